"""Baking a library of assets: a CSM and an AO-baked mesh per mesh file, and a manifest.

Output folder layout::

    out/manifest.json          this run: parameters, executor, every asset's entry
    out/csm/<name>.csm         the asset's Coherent Shadow Map (reproducible bytes)
    out/meshes/<name>.ply      the mesh with per-vertex AO and bent normals (or .glb)
    out/records/<name>.json    the asset's record, written last: the mark that it is done

Only the driver writes, each file atomically (temporary file, then rename),
the record after the outputs it lists; so an interrupted or killed run
leaves complete files or none, and a rerun trusts an asset only when its
record holds the same key (source hash, parameters, code) and every output
it lists is present with the recorded SHA-256. A run removes the temporary
files a killed run left once they are an hour old (``STALE_SECONDS``): a
younger one may be the write in progress of another bake into this folder.
An earlier run's manifest is removed before this run bakes anything: a run
killed outright (SIGKILL) leaves none, not one describing replaced outputs.
"""
from __future__ import annotations

import hashlib
import json
import re
import time
import unicodedata
from pathlib import Path

from .._files import write_bytes_atomic
from .._version import __version__
from .assets import bake_asset, other_code, output_names, side_files
from .params import AssetParams, asset_key, code_digest
from .records import differences, done, drop_manifest, other_bake, sha256_file, store
from .runner import (STALE_SECONDS, _TEMPORARY, check_executor, close_executor, executor_info,
                     open_executor, sweep_temporaries)

__all__ = ["bake_assets", "find_assets", "MANIFEST_SCHEMA"]

MANIFEST_SCHEMA = "pyshadow-bake-assets/1"


def _mesh_suffixes() -> set:
    import trimesh

    return {"." + f.lower() for f in trimesh.available_formats()}


def _reader_suffix(path: Path) -> str:
    """The extension that tells the mesh reader a file's format: the last one, or the last two for a
    compressed file (``.tar.gz``, ``.ply.bz2``: its archive's, or the format of the mesh it holds)."""
    last = path.suffix.lower()
    return "".join(path.suffixes[-2:]).lower() if last in (".gz", ".bz2") and len(path.suffixes) > 1 else last


def find_assets(sources) -> tuple[list, list]:
    """The mesh files of ``sources`` and the files passed over.

    Parameters
    ----------
    sources : str, path-like, or list of them
        A folder (its files whose extension trimesh reads, not its
        subfolders, hidden files or other files), or mesh files (every one
        is an asset, whatever its extension).

    Returns
    -------
    assets : list of (name, pathlib.Path)
        Sorted by path. ``name`` (output file stem) is the file's stem
        (NFC-composed) with characters other than letters and digits of any
        script, ``.``, ``_`` and ``-`` replaced by ``_`` (``Stühle`` and
        ``椅子`` stay, ``a b`` is ``a_b``); stems that collide (``a.obj``
        and ``a.ply``) get their extension appended (``a_obj``, ``a_ply``).
        A stem shaped like an atomic write's temporary file
        (``.a.<12 hex>.tmp``), whose outputs every run would remove as a
        killed run's leftovers, gets a leading ``_``.
    ignored : list of str
        Files of a folder that are not meshes.

    Raises
    ------
    FileNotFoundError
        A source that does not exist.
    """
    if isinstance(sources, (str, Path)) or hasattr(sources, "__fspath__"):
        sources = [sources]
    suffixes = _mesh_suffixes()
    files, ignored = [], []
    for s in sources:
        p = Path(s).expanduser()
        if p.is_dir():
            for f in sorted(p.iterdir()):
                if f.is_file() and not f.name.startswith(".") and {f.suffix.lower(), _reader_suffix(f)} & suffixes:
                    files.append(f)
                elif not f.name.startswith(".") and not f.is_dir():    # also a broken link, a FIFO
                    ignored.append(str(f))
        elif p.is_file():
            files.append(p)
        elif p.exists():                # a FIFO or device: reading it could block forever
            raise ValueError(f"not a mesh file (nor a folder): {p}")
        else:
            raise FileNotFoundError(f"no such mesh file or folder: {p}")
    seen = {}                           # one file named twice (src/a.obj, src/../src/a.obj) is one asset
    for f in files:
        seen.setdefault(f.parent.resolve() / f.name, f)
    files = sorted(seen.values())
    # letters and digits of any script (a name in ASCII letters only made every CJK stem of one length the same
    # name, '__', and a clash that refused the whole bake), composed: macOS spells 'é' as 'e' and an accent
    stems = [re.sub(r"[^\w.-]", "_", unicodedata.normalize("NFC", f.stem)) or "mesh" for f in files]
    stems = ["_" + s if _TEMPORARY.match(f"{s}.json") else s for s in stems]    # else swept away as a temporary
    lower = [s.lower() for s in stems]
    names = [s if lower.count(s.lower()) == 1 else f"{s}_{f.suffix.lstrip('.').lower()}"
             for s, f in zip(stems, files)]
    if len(set(n.lower() for n in names)) != len(names):
        same = sorted(f"{n} ({f})" for n, f in zip(names, files) if [m.lower() for m in names].count(n.lower()) > 1)
        raise ValueError(f"assets with the same name: {', '.join(same)}; rename the files")
    return list(zip(names, files)), ignored


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except OSError:
        return 0


def _source_sha256(path, side: dict) -> str:
    """SHA-256 of a mesh file, and of its side files where it has any (a changed buffer is a changed asset).

    ``path`` and the values of ``side`` (``uri`` -> file) are paths, or the files' bytes as read for the bake:
    the same digest from either.
    """
    def sha(x):
        return hashlib.sha256(x).hexdigest() if isinstance(x, bytes) else sha256_file(x)

    digest = sha(path)
    if not side:
        return digest
    spec = {"file": digest, "side": {uri: sha(p) for uri, p in sorted(side.items())}}
    return hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()


def _failed(name: str, path: Path, key, error: str) -> dict:
    return {"name": name, "source": str(path), "key": key, "status": "failed", "error": error}


def bake_assets(sources, out_dir, params: AssetParams | None = None, *, executor: str | None = None,
                workers: int | None = None, scheduler: str | None = None, threads: int | None = None,
                progress: bool = True,
                log=None) -> dict:
    """Bake a CSM and per-vertex AO for every mesh of ``sources`` into ``out_dir``.

    Parameters
    ----------
    sources : str, path-like, or list of them
        A folder of meshes or mesh files (:func:`find_assets`).
    out_dir : str or path-like
        Output folder (created); layout in :mod:`pyshadow.bake.library`.
    params : AssetParams, optional
        The same for every asset; default ``AssetParams()``.
    executor : {'dask', 'process', 'serial'}, optional
        Where tasks run (:func:`pyshadow.bake.runner.open_executor`); default
        Dask when installed (a ``LocalCluster`` of ``workers`` processes, or
        the cluster of ``scheduler``), else a process pool.
    workers : int, optional
        Local worker processes (default: the machine's cores); ignored with
        'serial' (one task at a time in this process).
    scheduler : str, optional
        Address or scheduler file of an existing Dask cluster.
    threads : int, optional
        OpenCL CPU threads per local worker (default: cores // workers).
    progress : bool
        A progress bar over the assets to bake.
    log : callable, optional
        ``log(str)`` for notes (default: print nothing).

    Returns
    -------
    dict
        The manifest (also written to ``out_dir/manifest.json``): ``schema``,
        ``params``, ``code`` (digest of the kernels), ``executor``,
        ``seconds``, ``summary`` (counts of ``baked``, ``skipped``,
        ``failed``, ``interrupted``), ``ignored`` files and ``assets``: per
        asset its record (:func:`pyshadow.bake.assets.bake_asset`) with
        ``source``, ``outputs`` (relative path -> ``sha256``, ``bytes``) and
        ``action`` ('baked', 'skipped' (done before, unchanged), 'failed' or
        'interrupted').

    Raises
    ------
    TypeError
        ``params`` not an :class:`AssetParams`, before anything is written.
    ValueError
        ``executor``, ``workers``, ``scheduler`` or ``threads`` that
        :func:`pyshadow.bake.runner.open_executor` refuses, before anything
        is written (also when every asset is done).

    Notes
    -----
    Rerunning with the same sources and parameters bakes nothing; a
    changed, new, failed or damaged asset (an output missing or altered,
    or a record that does not list exactly its outputs) is baked again;
    a ``.gltf`` also when a buffer or image file it names has changed
    (they travel with it: :func:`pyshadow.bake.assets.side_files`).
    A failed asset (unreadable, empty, not a mesh) is reported in the
    manifest and does not stop the others; so is one baked by a worker
    that runs other pyshadow code than this process (a Dask cluster's
    worker with another version: kept under this code's key, its outputs
    would pass for this code's in every rerun). On
    ``KeyboardInterrupt`` (while tasks run, or while the executor shuts
    down) the tasks are cancelled, this run's temporary files removed and the
    manifest written (the assets not finished marked 'interrupted') before
    the interrupt propagates.
    """
    from tqdm.auto import tqdm

    t_start = time.perf_counter()
    log = log or (lambda msg: None)
    params = params if params is not None else AssetParams()
    if not isinstance(params, AssetParams):     # a dict: AssetParams.from_dict(d)
        raise TypeError(f"params must be an AssetParams (or None), got {type(params).__name__}")
    check_executor(executor, workers, scheduler, threads)      # refused now, also when every asset is done
    out = Path(out_dir).expanduser()
    for sub in ("", "csm", "meshes", "records"):
        if (out / sub).exists() and not (out / sub).is_dir():
            raise FileExistsError(f"{out / sub} is a file, where the bake needs a folder")
        (out / sub).mkdir(parents=True, exist_ok=True)
    if (out / "manifest.json").exists() and not (out / "manifest.json").is_file():     # found now, not after the bake
        raise FileExistsError(f"{out / 'manifest.json'} is not a file, and the manifest is written there")
    for p in sweep_temporaries(out, STALE_SECONDS):
        log(f"removed a temporary file of an interrupted run: {p}")
    assets, ignored = find_assets(sources)
    code = code_digest()
    entries, todo, sides = {}, [], {}
    replaced = {}                       # how the parameters of an earlier bake's assets differ -> count
    # every source and every earlier output is hashed: minutes for a large library, silent before (shown after 1 s)
    for name, path in tqdm(assets, unit="asset", desc="checking", delay=1.0, leave=False, disable=not progress):
        try:
            sides[name] = side_files(path)      # a .gltf's buffers: they go to the worker with it
            key = asset_key(_source_sha256(path, sides[name]), params, code)
        except OSError as e:
            entries[name] = dict(_failed(name, path, None, f"{type(e).__name__}: {e}"), action="failed")
            continue
        rec = done(out, f"records/{name}.json", key)
        # trusted only when it lists exactly this asset's outputs, under its name (a hand-edited record may
        # list none, or files elsewhere: ../x, /abs)
        outputs = set(output_names(name, params).values())
        if rec is not None and rec.get("name") == name and set(rec["outputs"]) == outputs:
            entries[name] = dict(rec, source=str(path), action="skipped")     # this run's file (it may have moved)
            continue
        todo.append((name, path, key))
        other = other_bake(out, f"records/{name}.json", key)
        if other is not None and other.get("params") != params.to_dict():
            why = ", ".join(differences(other.get("params"), params.to_dict())) or "unrecorded ones"
            replaced[why] = replaced.get(why, 0) + 1
    # largest first: the long tasks start early and the short ones fill in the tail (LPT order)
    todo.sort(key=lambda t: (-_size(t[1]) - sum(map(_size, sides[t[0]].values())), t[0]))
    log(f"{len(assets)} assets: {len(todo)} to bake, {len(entries)} done or unreadable")
    if replaced:                        # baked over without a word: stopped part way, a folder of two bakes
        log(f"note: {out} holds {sum(replaced.values())} assets baked with other parameters, which this run "
            f"bakes again over (another -o keeps them): " + "; ".join(
                f"{n} with {why}" for why, n in sorted(replaced.items(), key=lambda i: -i[1])))

    def tasks():
        for name, path, key in todo:
            try:
                data = path.read_bytes()
                side = {uri: p.read_bytes() for uri, p in sides[name].items()}
            except OSError as e:
                entries[name] = dict(_failed(name, path, key, f"{type(e).__name__}: {e}"), action="failed")
                bar.update(1)           # else the bar ended short of its total
                continue
            # the key of the bytes baked: a file changed since the scan was stored under its old content's key,
            # and a rerun with that content back took the outputs of the other for it
            key = asset_key(_source_sha256(data, side), params, code)
            args = (name, _reader_suffix(path), data, params.to_dict(), key)
            yield (name, path, key), args + ((side,) if side else ())

    ex = None
    drop_manifest(out)                  # an earlier run's: it would describe the assets this run replaces
    bar = tqdm(total=len(todo), unit="asset", desc="baking", disable=not progress or not todo)
    try:
        if todo:
            ex = open_executor(executor, workers, scheduler, threads)
            for (name, path, key), res, err in ex.run(bake_asset, tasks()):
                if err is not None:         # the task itself failed (e.g. its worker died again and again)
                    entries[name] = dict(_failed(name, path, key, f"{type(err).__name__}: {err}"), action="failed")
                else:
                    try:
                        entries[name] = _store(out, path, res, code)
                    except OSError as e:    # unwritable, disk full: this asset failed, the others go on
                        entries[name] = dict(_failed(name, path, key, f"writing its outputs: {type(e).__name__}: "
                                                                      f"{e}"), action="failed")
                bar.update(1)
                bar.set_postfix_str(f"{name}: {entries[name]['action']}")
    finally:
        bar.close()
        stopped = close_executor(ex)        # a Ctrl-C while it closes: raised once the manifest is written
        for p in sweep_temporaries(out, STALE_SECONDS):
            log(f"removed a temporary file: {p}")
        for name, path, key in todo:
            entries.setdefault(name, dict(_failed(name, path, key, "interrupted before it finished"),
                                          action="interrupted"))
        manifest = _manifest(params, code, ex, executor, ignored, entries, time.perf_counter() - t_start)
        write_bytes_atomic(out / "manifest.json", json.dumps(manifest, indent=1, sort_keys=True).encode())
        if stopped is not None:
            raise stopped
    return manifest


def _store(out: Path, path: Path, res: dict, code: str) -> dict:
    """Write a finished task's outputs, then its record; returns its manifest entry.

    Outputs of a worker that ran other code than ``code`` (another pyshadow on a Dask cluster's worker)
    are not written: stored under this code's key, a rerun would keep them as this code's.
    """
    rec = dict(res["record"], source=str(path))
    worker_code = rec.pop("code", None)
    if rec["status"] != "baked":
        return dict(rec, action="failed")
    why = other_code(worker_code, code, rec.get("worker"))
    if why is not None:
        return dict(_failed(rec["name"], path, rec["key"], why), worker=rec.get("worker"), action="failed")
    return dict(store(out, f"records/{rec['name']}.json", rec, res["files"]), action="baked")


def _manifest(params, code, ex, executor, ignored, entries, seconds) -> dict:
    actions = [e["action"] for e in entries.values()]
    return {
        "schema": MANIFEST_SCHEMA,
        "pyshadow": __version__,
        "code": code,
        "params": params.to_dict(),
        "executor": executor_info(ex, executor),
        "seconds": seconds,
        "summary": {a: actions.count(a) for a in ("baked", "skipped", "failed", "interrupted")},
        "ignored": ignored,
        "assets": [entries[k] for k in sorted(entries)],
    }

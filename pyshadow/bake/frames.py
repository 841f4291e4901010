"""Rendering every frame of a scene's rigid motion: AO images as EXR and PNG.

The driver builds (or loads from the CSM cache) each caster's CSM once,
writes it to ``out/csm/`` and sends the scene to every worker once, as
plain data: mesh arrays and CSM file bytes. A worker builds its scene from
them the first time and keeps it; each task renders a chunk of frames
(``set_transform`` per body, then :meth:`pyshadow.Scene.render`) and
returns the image files' bytes, which the driver writes atomically::

    out/exr/frame_0000.exr     AO, linear float32 (one channel "Y")
    out/png/frame_0000.png     AO, sRGB 8-bit
    out/csm/<body>.csm         the casters' CSMs (reproducible bytes)
    out/records/frame_0000.json  the frame's done mark (key, output hashes, the bake's parameters)
    out/manifest.json          written last; an earlier run's is removed first

Frame numbers have 4 digits, or the last frame's digits where a motion has
more than 10,000 frames (``frame_00000`` ... ``frame_10000``), so that the
names sort in frame order. A folder holds one bake's frames: a bake with
other parameters (or another motion, scene or code) renders over the
finished frames of an earlier one and logs how many and what differs.
"""
from __future__ import annotations

import hashlib
import json
import math
import numbers
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from .._files import write_bytes_atomic
from .._validate import check_int
from .._version import __version__
from .assets import csm_file_bytes, other_code
from .motion import _check as _check_motion
from .params import code_digest
from .records import differences, done, drop_manifest, other_bake, store
from .runner import (STALE_SECONDS, _TEMPORARY, check_executor, close_executor, executor_info,
                     open_executor, sweep_temporaries)

__all__ = ["bake_frames", "scene_payload", "render_chunk", "FRAMES_SCHEMA"]

FRAMES_SCHEMA = "pyshadow-bake-frames/1"
_SCENES: dict = {}          # per worker process: payload key -> (Scene, Camera)


def scene_payload(parts, camera, *, ground, render: dict, csm_for) -> dict:
    """The scene as plain data a worker can rebuild it from.

    Parameters
    ----------
    parts : list of (name, trimesh.Trimesh, casts)
    camera : pyshadow.Camera
    ground : float or None
        Ground plane height.
    render : dict
        ``samples``, ``lookup``, ``denoise`` of :meth:`pyshadow.Scene.render`.
    csm_for : callable
        ``csm_for(name, mesh) -> CoherentShadowMap`` for each caster.

    Returns
    -------
    dict
        ``key`` (SHA-256 of everything else), ``parts`` (``name``,
        ``casts``, ``vertices`` float64 (V, 3), ``faces`` int64 (T, 3),
        ``csm`` file bytes or None), ``camera``, ``ground``, ``render``.
    """
    out, h = [], hashlib.sha256()
    for name, mesh, casts in parts:
        v = np.ascontiguousarray(mesh.vertices, np.float64)
        f = np.ascontiguousarray(mesh.faces, np.int64)
        csm = csm_file_bytes(csm_for(name, mesh)) if casts else None
        out.append({"name": name, "casts": bool(casts), "vertices": v, "faces": f, "csm": csm})
        # a name from a file name that is no UTF-8 (os.fsdecode: 'caf\udce9') hashes as its bytes
        for b in (name.encode("utf-8", "surrogateescape"), bytes([bool(casts)]), v.tobytes(), f.tobytes(),
                  csm or b""):          # np.bool_ too
            h.update(hashlib.sha256(b).digest())
    cam = _camera_dict(camera)
    ground = None if ground is None else float(ground) + 0.0     # one key for 0, 0.0 and -0.0: one plane
    h.update(json.dumps({"camera": cam, "ground": ground, "render": render}, sort_keys=True).encode())
    return {"key": h.hexdigest(), "parts": out, "camera": cam, "ground": ground, "render": render}


def _camera_dict(camera) -> dict:
    return {"eye": camera.eye.tolist(), "target": camera.target.tolist(), "up": camera.up.tolist(),
            "fov_y": float(camera.fov_y), "width": camera.width, "height": camera.height}


def _scene(payload):
    """This worker's scene and camera of ``payload`` (built on first use, then kept)."""
    key = payload["key"]
    if key not in _SCENES:
        import trimesh

        from ..camera import Camera
        from ..csm import CoherentShadowMap
        from ..scene import Scene

        scene = Scene(ground=payload["ground"])
        with tempfile.TemporaryDirectory(prefix="pyshadow-bake-") as d:
            for i, part in enumerate(payload["parts"]):
                mesh = trimesh.Trimesh(part["vertices"], part["faces"], process=False)
                if part["casts"]:
                    p = Path(d) / f"{i}.csm"
                    p.write_bytes(part["csm"])
                    scene.add(CoherentShadowMap.load(p, mmap=False), np.eye(4), mesh=mesh)
                else:
                    scene.add(mesh, np.eye(4), casts=False)
        c = payload["camera"]
        camera = Camera(c["eye"], c["target"], up=c["up"], fov_y=c["fov_y"], width=c["width"],
                        height=c["height"])
        _SCENES.clear()                 # one scene per worker at a time bounds its memory
        _SCENES[key] = (scene, camera)
    return _SCENES[key]


def render_chunk(frames, transforms, payload) -> list:
    """Render frames of the payload's scene (the task of :func:`bake_frames`).

    Parameters
    ----------
    frames : list of int
        Frame numbers.
    transforms : ndarray, float64, shape (len(frames), N, 4, 4)
    payload : dict
        :func:`scene_payload`.

    Returns
    -------
    list of dict
        Per frame: ``frame``, ``files`` (``exr/frame_NNNN.exr`` and
        ``png/frame_NNNN.png`` -> bytes; the driver names them with the
        motion's digits), ``seconds`` (render),
        ``ao_mean`` (over covered pixels), ``worker``, ``code``
        (:func:`pyshadow.bake.params.code_digest` of the code that rendered
        it, which the driver compares with its own); for a frame that
        failed (e.g. a render refused for that frame's placement) only
        ``frame``, ``error`` ('Type: message') and ``worker``: the chunk's
        other frames are rendered as they would be alone.
    """
    import socket

    from ..io import write_image
    from ..sampling import Sampling
    from .params import code_digest as worker_code

    scene, camera = _scene(payload)
    code = worker_code()
    r = payload["render"]
    results = []
    worker = f"{socket.gethostname()}:{os.getpid()}"
    for f, T in zip(frames, transforms):
        t0 = time.perf_counter()
        try:                            # one frame's failure is its own, not its chunk's (each sets every body)
            for i, M in enumerate(T):
                scene.set_transform(i, M)
            frame = scene.render(camera, sampling=Sampling(r["samples"]), lookup=r["lookup"],
                                 denoise=r["denoise"])
            seconds = time.perf_counter() - t0
            files = {}
            with tempfile.TemporaryDirectory(prefix="pyshadow-bake-") as d:
                for kind in ("exr", "png"):
                    p = Path(d) / f"frame.{kind}"
                    write_image(p, frame.ao)
                    files[f"{kind}/frame_{f:04d}.{kind}"] = p.read_bytes()
        except Exception as e:
            results.append({"frame": int(f), "error": f"{type(e).__name__}: {e}", "worker": worker})
            continue
        covered = frame.object_id >= 0
        results.append({"frame": int(f), "files": files, "seconds": seconds,
                        "ao_mean": float(frame.ao[covered].mean()) if covered.any() else None,
                        "worker": worker, "code": code})
    return results


def _check_parts(parts) -> None:
    """Raise for a body whose name cannot be its CSM's file stem in ``out/csm/``.

    TypeError for a name that is no str; ValueError for an empty one, one
    with a path separator or NUL (``../x`` would be written outside
    ``out/csm/``) or one shaped like an atomic write's temporary file
    (removed again at the end of the run), and for two casters of different meshes named alike up
    to case: their CSMs would be one file (the second replacing the first;
    on a case-insensitive file system also ``A`` and ``a``). Bodies that
    share one mesh may share its name.
    """
    seps = {"\0", os.sep} | ({os.altsep} if os.altsep else set())
    seen = {}                           # lower-case name -> (index, mesh) of the first caster
    for i, part in enumerate(parts):
        # else 'not enough values to unpack', or "'str' object has no attribute 'vertices'" from the CSM build
        if not isinstance(part, (tuple, list)) or len(part) != 3:
            raise TypeError(f"parts[{i}] must be a (name, mesh, casts) triple, got {type(part).__name__} "
                            f"{str(part)[:60]}")
        name, mesh, casts = part
        if not (hasattr(mesh, "vertices") and hasattr(mesh, "faces")):
            raise TypeError(f"parts[{i}]: the mesh must be a trimesh.Trimesh, got {type(mesh).__name__}")
        if not isinstance(name, str):
            raise TypeError(f"parts[{i}]: the name must be a str, got {name!r}")
        if not name or any(c in name for c in seps) or _TEMPORARY.match(f"{name}.csm"):
            raise ValueError(f"parts[{i}]: the name {name!r} cannot be a file name (csm/<name>.csm): it is "
                             f"empty, holds a path separator or NUL, or is shaped like a temporary file "
                             f"(.x.<12 hex>.tmp) that a run removes")
        if not casts:
            continue
        j, other = seen.setdefault(name.lower(), (i, mesh))
        if other is not mesh and not (np.array_equal(other.vertices, mesh.vertices)
                                      and np.array_equal(other.faces, mesh.faces)):
            raise ValueError(f"parts[{j}] and parts[{i}] are different meshes named {parts[j][0]!r} and "
                             f"{name!r}: their CSMs would be one file, csm/{name}.csm; rename one")


def _frame_stem(f: int, frames: int) -> str:
    """The file stem of frame ``f`` of a motion of ``frames`` frames: ``frame_`` and the number, zero-padded
    to 4 digits, or to the last frame's digits where it has more (``frame_10000`` sorted between
    ``frame_1000`` and ``frame_1001``: a 10,001-frame motion read as one sequence by file name, as a glob or
    ``ls`` gives it, jumped from frame 1000 to 10000)."""
    return f"frame_{f:0{max(4, len(str(frames - 1)))}d}"


def _frame_files(stem: str) -> set:
    """The outputs of the frame of file stem ``stem`` (relative paths): a done record must list these, no
    other files (a hand-edited one listing none, or files elsewhere, proves nothing about them)."""
    return {f"{kind}/{stem}.{kind}" for kind in ("exr", "png")}


def _frame_key(payload_key: str, T: np.ndarray, code: str) -> str:
    h = hashlib.sha256(payload_key.encode())
    h.update(np.ascontiguousarray(T, "<f8").tobytes())
    h.update(code.encode())
    return h.hexdigest()


def bake_frames(out_dir, parts, camera, transforms, *, ground=0.0, samples: int = 36, lookup: str = "nearest",
                denoise=None, csm_for=None, chunk: int = 4, executor=None, workers=None, scheduler=None,
                threads=None, progress: bool = True, log=None) -> dict:
    """Render every frame of a rigid motion to ``out_dir`` (layout in :mod:`pyshadow.bake.frames`).

    Parameters
    ----------
    out_dir : str or path-like
        Created if missing.
    parts : list of (name, trimesh.Trimesh, casts)
        The scene's bodies, in the order of the motion's bodies.
    camera : pyshadow.Camera
    transforms : ndarray, shape (F, N, 4, 4)
        Per-frame object-to-world transforms (:func:`pyshadow.bake.read_motion`).
    ground : float or None
        Ground plane height, finite (None: no ground).
    samples, lookup, denoise :
        As :meth:`pyshadow.Scene.render` (``Sampling(samples)``).
    csm_for : callable, optional
        ``csm_for(name, mesh) -> CoherentShadowMap``; default: build with
        the default parameters.
    chunk : int
        Frames per task (bounds a task's memory: ``chunk`` frames of images).
    executor, workers, scheduler, threads, progress, log :
        As :func:`pyshadow.bake.bake_assets`.

    Returns
    -------
    dict
        The manifest (also ``out_dir/manifest.json``): ``schema``,
        ``frames`` (per frame ``frame``, ``action`` 'rendered', 'skipped',
        'failed' or 'interrupted', ``outputs``, ``seconds``, ``error``; a
        frame a worker of other pyshadow code rendered is 'failed', not
        stored: under this code's key a rerun would keep it; so is one
        whose files could not be written, the others go on; the frames of
        a task that failed whole, e.g. its worker died, are each tried
        again alone, so that only the frame at fault fails),
        ``summary``, ``seconds`` (wall), ``frames_per_minute``, ``csm``
        (file per caster), ``executor``.

    Raises
    ------
    ValueError
        ``transforms`` of the wrong shape or without frames, one of them
        not finite or not rigid (the message names the frame and body),
        ``chunk`` not a positive int, ``ground`` not a finite number,
        ``samples``, ``lookup`` or ``denoise`` not one ``Scene.render``
        takes, executor arguments that
        :func:`pyshadow.bake.runner.open_executor` refuses, or a part's name that cannot be its CSM's file name (or the
        same as another caster's of a different mesh): before any CSM is
        built.
    TypeError
        ``transforms`` not real numbers, ``samples`` not an int, a part
        not a (name, mesh, casts) triple, its name not a str or its mesh
        not a mesh, ``camera`` not a :class:`pyshadow.Camera`.
    KeyboardInterrupt
        After the manifest is written (the frames not finished marked
        'interrupted'), also for one that lands while the executor shuts
        down or while the CSMs are built or written: then every frame is
        'interrupted' (its ``key`` None before the scene is known), ``csm``
        lists the CSM files this run wrote and ``scene`` is None until
        every CSM is built. So the manifest always describes this run,
        never an earlier one's outputs that this run may have replaced.
        Another exception raised while preparing or rendering leaves the
        same manifest before it propagates.
    """
    from tqdm.auto import tqdm

    t_start = time.perf_counter()
    log = log or (lambda msg: None)
    T = np.asarray(transforms)
    if T.ndim != 4 or T.shape[1:] != (len(parts), 4, 4) or len(T) < 1:
        raise ValueError(f"transforms must have shape (frames, {len(parts)}, 4, 4) for {len(parts)} bodies, "
                         f"at least one frame, got {T.shape}")
    T, _ = _check_motion(T, None, "transforms")     # real numbers, each finite and rigid (as Scene.set_transform)
    _check_parts(parts)
    from ..camera import Camera

    if not isinstance(camera, Camera):  # else an AttributeError from writing the manifest, the earlier one gone
        raise TypeError(f"camera must be a pyshadow.Camera, got {type(camera).__name__}")
    try:
        chunk = check_int(chunk, "chunk", 1)
    except (TypeError, ValueError):     # not 2.5 (a slice of floats), nor "3"; one error type, as documented
        raise ValueError(f"chunk must be a positive int, got {chunk!r}") from None
    if ground is not None and (isinstance(ground, bool) or not isinstance(ground, numbers.Real)
                               or not math.isfinite(ground)):
        raise ValueError(f"ground must be a finite number or None, got {ground!r}")
    if ground is not None:              # np.float32 is no JSON; 0 and -0.0 draw the plane of 0.0 but had other
        ground = float(ground) + 0.0    # keys (the scene's key holds JSON "0"): a rerun rendered every frame again
    _check_render(samples, lookup, denoise)
    check_executor(executor, workers, scheduler, threads)      # refused now, not after the CSMs are built
    out = Path(out_dir).expanduser()
    out.mkdir(parents=True, exist_ok=True)
    sweep_temporaries(out, STALE_SECONDS)
    if csm_for is None:
        from ..csm import CoherentShadowMap
        from ..views import ViewSet

        def csm_for(name, mesh):
            # 8,192 maps: seconds to minutes per caster, silent before (the CLI's cache shows its own bar)
            return CoherentShadowMap.build(mesh, ViewSet.zigzag(64, 128), progress=progress)

    render = {"samples": int(samples), "lookup": lookup, "denoise": denoise}
    code = code_digest()
    payload, csm_files, keys, entries, todo = None, {}, {}, {}, []
    ex = bar = prepare = None
    t0 = time.perf_counter()
    drop_manifest(out)                      # an earlier run's: it would describe the frames this run replaces
    try:                                    # a Ctrl-C from here on, even while the CSMs are built: manifest written
        payload = scene_payload(parts, camera, ground=ground, csm_for=csm_for, render=render)
        for part in payload["parts"]:
            if part["csm"] is not None:
                rel = f"csm/{part['name']}.csm"
                (out / "csm").mkdir(exist_ok=True)
                write_bytes_atomic(out / rel, part["csm"])
                csm_files[part["name"]] = rel
        prepare = time.perf_counter() - t0
        # every earlier frame's files are hashed: a long motion's rerun was silent for minutes (shown after 1 s)
        bake = {"scene": payload["key"], "render": render, "camera": payload["camera"], "ground": ground,
                "code": code}           # in each record: what a later bake into this folder tells apart
        replaced = {}                   # how another bake's finished frames differ from this one's -> count
        for f in tqdm(range(len(T)), unit="frame", desc="checking", delay=1.0, leave=False, disable=not progress):
            keys[f] = _frame_key(payload["key"], T[f], code)
            stem = _frame_stem(f, len(T))
            rec = done(out, f"records/{stem}.json", keys[f])
            if rec is not None and rec.get("frame") == f and set(rec["outputs"]) == _frame_files(stem):
                rec.pop("bake", None)
                entries[f] = dict(rec, action="skipped")
                continue
            todo.append(f)
            other = other_bake(out, f"records/{stem}.json", keys[f])
            if other is not None:
                why = _how_other(other.get("bake"), bake)
                replaced[why] = replaced.get(why, 0) + 1
        log(f"{len(T)} frames: {len(todo)} to render")
        _note_replaced(out, replaced, log)
        _note_past_frames(out, len(T), log)
        tasks = [(todo[i:i + chunk], T[todo[i:i + chunk]]) for i in range(0, len(todo), int(chunk))]
        bar = tqdm(total=len(todo), unit="frame", desc="rendering", disable=not progress or not todo)
        if todo:
            ex = open_executor(executor, workers, scheduler, threads)
            alone = []                  # frames of a chunk that failed whole (its worker died): each again, alone
            for batch in (tasks, None):
                if batch is None:       # else every frame of the chunk failed with the one that killed its worker
                    batch = [([f], T[[f]]) for f in alone]
                for frames, res, err in ex.run(render_chunk, ((tuple(fs), (fs, Tc)) for fs, Tc in batch),
                                                shared=payload):
                    if err is not None and len(frames) > 1 and batch is tasks:
                        alone.extend(frames)
                        continue
                    for f in frames if err is not None else ():
                        entries[f] = {"frame": f, "key": keys[f], "status": "failed", "action": "failed",
                                      "error": f"{type(err).__name__}: {err}"}
                    for r in res if err is None else ():
                        entries[r["frame"]] = _finished(out, r, keys[r["frame"]], bake, len(T))
                    bar.update(len(frames))
                if not alone:
                    break
    finally:
        if bar is not None:
            bar.close()
        stopped = close_executor(ex)        # a Ctrl-C while it closes: raised once the manifest is written
        sweep_temporaries(out, STALE_SECONDS)
        for f in range(len(T)):             # not rendered, nor found done, in this run
            entries.setdefault(f, {"frame": f, "key": keys.get(f), "status": "failed", "action": "interrupted",
                                   "error": "interrupted before it finished"})
        wall = time.perf_counter() - t_start
        prepare = time.perf_counter() - t0 if prepare is None else prepare     # stopped while preparing
        actions = [e["action"] for e in entries.values()]
        rendered = actions.count("rendered")
        manifest = {
            "schema": FRAMES_SCHEMA, "pyshadow": __version__, "code": code,
            "scene": payload["key"] if payload is not None else None, "render": render,
            "camera": _camera_dict(camera), "ground": ground, "csm": csm_files,
            "executor": executor_info(ex, executor),
            "seconds": wall, "prepare_seconds": prepare,
            "frames_per_minute": 60.0 * rendered / (wall - prepare) if rendered and wall > prepare else None,
            "summary": {a: actions.count(a) for a in ("rendered", "skipped", "failed", "interrupted")},
            "frames": [entries[f] for f in sorted(entries)],
        }
        write_bytes_atomic(out / "manifest.json", json.dumps(manifest, indent=1, sort_keys=True).encode())
        if stopped is not None:
            raise stopped
    return manifest


def _finished(out: Path, r: dict, key: str, bake: dict, frames: int) -> dict:
    """The manifest entry of frame result ``r`` (of :func:`render_chunk`) of a motion of ``frames`` frames:
    its files and record (with ``bake``, the parameters of this bake) stored when it rendered with this
    bake's ``code``."""
    f = r["frame"]
    failed = {"frame": f, "key": key, "status": "failed", "action": "failed"}
    if r.get("error") is not None:      # this frame alone failed
        return dict(failed, error=r["error"])
    why = other_code(r.get("code"), bake["code"], r["worker"])
    if why is not None:                 # under this code's key it would be skipped for good
        return dict(failed, error=why, worker=r["worker"])
    rec = {"frame": f, "key": key, "status": "baked", "seconds": r["seconds"], "ao_mean": r["ao_mean"],
           "worker": r["worker"], "bake": bake}
    stem = _frame_stem(f, frames)       # the worker names its files by the frame alone
    files = {f"{Path(rel).parent}/{stem}{Path(rel).suffix}": data for rel, data in r["files"].items()}
    try:                                # unwritable, disk full: this frame failed, the others go on
        rec = store(out, f"records/{stem}.json", rec, files)
    except OSError as e:
        return dict(failed, error=f"writing its outputs: {type(e).__name__}: {e}")
    rec.pop("bake")                     # the manifest has them once
    return dict(rec, action="rendered")


def _how_other(there, here: dict) -> str:
    """How the earlier bake whose record holds ``there`` (its ``bake``) differs from this one's ``here``."""
    if not isinstance(there, dict):
        return "its parameters not recorded (an older pyshadow's bake)"
    diff = differences(there.get("render"), here["render"]) + differences(there.get("camera"), here["camera"])
    diff += differences(there, here, ["ground"])
    if diff:
        return ", ".join(diff)
    if there.get("scene") != here["scene"]:
        return "other bodies or CSMs (meshes, names, --maps, --resolution, --depth-bits)"
    return "other pyshadow code" if there.get("code") != here["code"] else "another motion"


def _note_replaced(out: Path, replaced: dict, log) -> None:
    """Log that this run renders over ``out``'s finished frames of another bake (``replaced``: how it
    differs -> frames): they were replaced without a word, and a run stopped part way left a folder of
    two bakes' frames under one sequence of names."""
    if replaced:
        log(f"note: {out} holds {sum(replaced.values())} finished frames of another bake, which this run "
            f"renders over (another -o keeps them): " + "; ".join(f"{n} with {why}" for why, n in
                                                               sorted(replaced.items(), key=lambda i: -i[1])))


def _note_past_frames(out: Path, frames: int, log) -> None:
    """Log the frames an earlier run left in ``out`` past this motion's ``frames`` (a longer motion's, of other
    parameters): they stay, outside this run's manifest, but a tool reading ``png/frame_%04d.png`` as one
    sequence took them for this motion's last frames."""
    stems = [p.stem for p in (out / "records").glob("frame_*.json") if p.stem[6:].isdigit()]
    past = sorted(int(s[6:]) for s in stems if int(s[6:]) >= frames)
    if past:
        log(f"note: {out} also holds {len(past)} frames of an earlier run past this motion's {frames} "
            f"(frame {past[0]} to {past[-1]}), not in this run's manifest: remove them (exr/, png/, records/) "
            f"before reading the folder's images as one sequence")
    # a motion of more than 10,000 frames names them with more digits: frame_00000 is not frame_0000
    other = sorted(s for s in stems if int(s[6:]) < frames and s != _frame_stem(int(s[6:]), frames))
    if other:
        log(f"note: {out} also holds {len(other)} frames of an earlier run of another length, named with "
            f"{len(other[0]) - 6} digits ({other[0]} ...), not this run's ({_frame_stem(0, frames)} ...): remove "
            f"them (exr/, png/, records/) before reading the folder's images as one sequence")


def _check_render(samples, lookup, denoise) -> None:
    """The render options of :func:`bake_frames` as :meth:`pyshadow.Scene.render` checks them, but before
    the CSMs are built (not each frame failing after): TypeError or ValueError naming the option."""
    from ..render import DENOISERS
    from ..sampling import Sampling
    from .._validate import check_lookup

    Sampling(samples)                   # an int in 1 .. MAX_SAMPLES (2.5 was cut to 2, "3" read as 3)
    check_lookup(lookup)
    if denoise is not None and denoise not in DENOISERS:
        raise ValueError(f"denoise must be None, 'bilateral', 'separable' or 'box', got {denoise!r}")


def auto_camera(parts, transforms, *, width=640, height=480, fov_y=40.0):
    """A camera that frames every body in every frame, from the front (+z), above and to the right."""
    from ..camera import Camera

    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for b, (name, mesh, casts) in enumerate(parts):
        v = np.asarray(mesh.vertices)
        for T in transforms[:, b]:
            w = v @ T[:3, :3].T + T[:3, 3]
            lo, hi = np.minimum(lo, w.min(axis=0)), np.maximum(hi, w.max(axis=0))
    target = 0.5 * (lo + hi)
    radius = 0.5 * float(np.linalg.norm(hi - lo))
    half = math.radians(fov_y) / 2.0
    half = min(half, math.atan(math.tan(half) * width / height))
    view = np.array([0.35, 0.55, 1.0])
    eye = target + 1.08 * radius / math.sin(half) * view / np.linalg.norm(view)
    return Camera(eye, target, fov_y=fov_y, width=width, height=height)

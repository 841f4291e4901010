"""The ``pyshadow-bake`` command line: ``assets``, ``frames`` and ``motion``.

Usage::

    pyshadow-bake assets MESHES_DIR -o baked/              # Dask LocalCluster, one worker per core
    pyshadow-bake assets a.obj b.ply -o baked/ --scheduler tcp://host:8786
    pyshadow-bake frames -o frames/ --frames 60            # the bundled scene, turning
    pyshadow-bake frames -o frames/ --mesh a.obj --mesh b.obj --motion motion.npz
    pyshadow-bake frames -o frames/ --camera camera.json     # {"eye": [x, y, z], "target": [x, y, z], ...}
    pyshadow-bake motion motion.npz --frames 60            # the bundled scene's motion (4 bodies), as a file

Exit status: 0 when every asset or frame is done, 1 when one failed, 2 on
bad arguments, 130 when interrupted (Ctrl-C), 128 + the signal's number when
stopped by SIGTERM or SIGHUP (143, 129: ``kill``, ``timeout``, a job
scheduler, a closed terminal), which are handled as Ctrl-C is: the workers
stopped, the manifest written.
"""
from __future__ import annotations

import argparse
import math
import signal
import sys
import threading
import warnings
from pathlib import Path

from .._files import writable_folder
from ..bench.config import _int_range, _maps, _positive_float, _size
from ..sampling import MAX_SAMPLES
from .params import AssetParams
from .runner import EXECUTORS, check_executor


def _finite_float(text: str) -> float:
    """argparse type: a finite number (``nan`` and ``inf`` are errors, as a value that is not a number)."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return v


def _check_out(ap, out) -> None:
    """Create the output folder ``out`` and probe that a file can be written there.

    Parameters
    ----------
    ap : argparse.ArgumentParser
        Reports a folder that is a file, lies under a file or cannot be
        created or written to as a usage error (exit status 2).
    out : str or path-like
        The ``-o`` folder (``~`` expanded, as the bake does).
    """
    out = Path(out).expanduser()
    try:
        writable_folder(out, ".pyshadow-bake-")
    except ValueError as e:
        ap.error(f"-o {out}: {e}")


def _executor_options(p):
    g = p.add_argument_group("where it runs")
    g.add_argument("--executor", choices=EXECUTORS, default=None,
                   help="dask (default when dask.distributed is installed: a LocalCluster, or the cluster of "
                        "--scheduler), process (a local process pool) or serial (this process)")
    g.add_argument("--workers", type=_int_range(1, 4096, "--workers"), default=None,
                   help="local worker processes (default: the machine's cores; each gets cores/workers "
                        "OpenCL CPU threads); not with --executor serial")
    g.add_argument("--scheduler", metavar="ADDRESS",
                   help="an existing Dask scheduler (tcp://host:8786) or its scheduler file")
    g.add_argument("--quiet", action="store_true", help="no progress bar or notes on stderr")


def _csm_options(p, maps="64x128"):
    g = p.add_argument_group("CSM")
    g.add_argument("--maps", type=_maps, default=_maps(maps), metavar="THETAxPHI",
                   help=f"zigzag view set (default {maps})")
    g.add_argument("--resolution", type=_int_range(8, 4096, "--resolution"), default=128,
                   help="texels per map side (default 128)")
    g.add_argument("--depth-bits", type=int, choices=(16, 32), default=16,
                   help="depth precision of the CSM: 16 (default) or 32 bits a texel")
    g.add_argument("--lookup", choices=("nearest", "vote"), default="nearest",
                   help="CSM lookup of the AO rays (default nearest)")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``pyshadow-bake``."""
    ap = argparse.ArgumentParser(prog="pyshadow-bake",
                                 description="Batch baking with pyshadow: CSMs and per-vertex AO for a "
                                             "library of meshes, or every frame of a scene's motion, on "
                                             "this machine or a Dask cluster.")
    sub = ap.add_subparsers(dest="command", required=True)
    a = sub.add_parser("assets", help="a CSM and an AO-baked mesh per mesh file, and a manifest")
    a.add_argument("sources", nargs="+", metavar="MESH_OR_DIR",
                   help="mesh files, or folders (their files with a mesh extension)")
    a.add_argument("-o", "--out", required=True, metavar="DIR", help="output folder")
    _csm_options(a)
    a.add_argument("--samples", type=_int_range(1, MAX_SAMPLES, "--samples"), default=64,
                   help="AO samples per vertex (default 64)")
    a.add_argument("--ground", action="store_true", help="bake with a ground plane under each asset")
    a.add_argument("--fill-holes", action="store_true", help="close the meshes' holes first")
    a.add_argument("--format", choices=("ply", "glb"), default="ply", help="output mesh format")
    a.add_argument("--max-error", type=_positive_float, metavar="E",
                   help="choose each asset's maps and resolution: the smallest CSM whose visibility "
                        "disagreement with Embree, predicted by the error model and then checked, "
                        "is at most E (e.g. 0.01)")
    _executor_options(a)
    f = sub.add_parser("frames", help="AO images (EXR and PNG) of every frame of a rigid motion")
    f.add_argument("-o", "--out", required=True, metavar="DIR", help="output folder")
    f.add_argument("--mesh", action="append", metavar="PATH",
                   help="a body of the scene (repeatable; all cast shadows); default: the bundled scene")
    f.add_argument("--motion", metavar="FILE",
                   help="per-frame transforms (.npz or .json, pyshadow.bake.motion), matched to the bodies by "
                        "the file's names where they are the bodies' (--mesh file stems) in another order, else "
                        "in order; required with --mesh, default for the bundled scene: its bodies turning "
                        "(pyshadow-bake motion)")
    f.add_argument("--frames", type=_int_range(1, 1_000_000, "--frames"), default=None,
                   help="frames of the bundled scene's default motion (default 60; not with --motion, whose "
                        "file gives the frames)")
    f.add_argument("--size", type=_size, default=None, metavar="WxH",
                   help="image size (default: the --camera file's width and height, else 640x480)")
    f.add_argument("--camera", metavar="FILE",
                   help="the camera, a JSON object: eye, target (world xyz), optionally up (default [0, 1, 0]), "
                        "fov_y (degrees, default 45), width and height, as a frames manifest's \"camera\" holds "
                        "them; default: the bundled scene's camera, or one framing every --mesh in every frame")
    f.add_argument("--samples", type=_int_range(1, MAX_SAMPLES, "--samples"), default=36,
                   help="AO samples per pixel (default 36)")
    f.add_argument("--denoise", choices=("bilateral", "separable", "box"), default=None)
    # either, not both: '--no-ground --ground 0.5' (or '--no-cache --cache-dir D') dropped one of them silently
    gr = f.add_mutually_exclusive_group()
    gr.add_argument("--ground", type=_finite_float, default=0.0, metavar="Y", help="ground plane height (default 0)")
    gr.add_argument("--no-ground", action="store_true", help="no ground plane")
    f.add_argument("--chunk", type=_int_range(1, 10_000, "--chunk"), default=4, help="frames per task (default 4)")
    ca = f.add_mutually_exclusive_group()
    ca.add_argument("--cache-dir", metavar="DIR",
                    help="CSM cache (default $PYSHADOW_CACHE or the user cache folder)")
    ca.add_argument("--no-cache", action="store_true", help="build the CSMs, do not cache them")
    _csm_options(f)
    _executor_options(f)
    m = sub.add_parser("motion", help="write the bundled scene's default motion as a motion file")
    m.add_argument("path", help="output .npz or .json")
    m.add_argument("--frames", type=_int_range(1, 1_000_000, "--frames"), default=60)
    return ap


def _log(quiet):
    return (lambda msg: None) if quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))


def _assets(args) -> int:
    from .library import bake_assets

    params = AssetParams(theta=args.maps[0], phi=args.maps[1], resolution=args.resolution,
                         depth_bits=args.depth_bits, samples=args.samples, lookup=args.lookup,
                         ground=args.ground, fill_holes=args.fill_holes, mesh_format=args.format,
                         max_error=args.max_error)
    m = bake_assets(args.sources, args.out, params, executor=args.executor, workers=args.workers,
                    scheduler=args.scheduler, progress=not args.quiet, log=_log(args.quiet))
    print(assets_table(m))
    return 1 if m["summary"]["failed"] or m["summary"]["interrupted"] else 0


def assets_table(m: dict) -> str:
    """The assets manifest as a text table (what ``pyshadow-bake assets`` prints)."""
    rows = [("asset", "action", "vertices", "maps", "CSM MB", "ratio", "AO mean", "seconds", "error")]
    for e in m["assets"]:
        c = e.get("csm", {})
        rows.append((e["name"], e["action"], str(e.get("mesh", {}).get("vertices", "")),
                     f"{c['maps']}@{c['resolution']}" if c else "",
                     f"{c['bytes'] / 1e6:.2f}" if c else "", f"{c['ratio']:.1f}" if c else "",
                     f"{e['ao']['mean']:.3f}" if "ao" in e else "",
                     f"{e['timings']['total_s']:.2f}" if e.get("timings") else "",
                     (e.get("error") or "")[:60]))
    w = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w[i]) for i, c in enumerate(r)).rstrip() for r in rows]
    s, ex = m["summary"], m["executor"]
    lines.append(f"{s['baked']} baked, {s['skipped']} skipped (done), {s['failed']} failed, "
                 f"{s['interrupted']} interrupted in {m['seconds']:.1f} s on {ex['kind']} "
                 f"({ex['workers'] or 0} workers)")
    return "\n".join(lines)


def _bodies_in_order(T, names, parts, source: str, have: str, log):
    """The motion's (F, N, 4, 4) transforms ``T`` in the order of ``parts``: by position, or by name where the
    motion file's ``names`` are the parts' names in another order (each body was moved by another's)."""
    want = [p[0] for p in parts]
    if T.shape[1] != len(parts):
        raise ValueError(f"{source} moves {T.shape[1]} bodies, {have} {len(parts)} ({', '.join(want)})")
    if names is None or names == want or sorted(names) != sorted(want) or len(set(want)) != len(want):
        return T
    log(f"{source} lists its bodies as {names}: matched to {want} by name")
    return T[:, [names.index(n) for n in want]]


#: Keys of a --camera file: pyshadow.Camera's arguments (a frames manifest's "camera" entry holds them all).
_CAMERA_KEYS = ("eye", "target", "up", "fov_y", "width", "height")


def read_camera(path, size=None):
    """The :class:`pyshadow.Camera` of a ``--camera`` JSON file.

    Parameters
    ----------
    path : str or path-like
        A JSON object with ``eye`` and ``target`` (world positions, 3 numbers each) and optionally ``up``
        (default ``[0, 1, 0]``), ``fov_y`` (vertical field of view in degrees, default 45), ``width`` and
        ``height`` (pixels): the keys of a frames manifest's ``"camera"`` entry.
    size : tuple of two ints, optional
        ``(width, height)`` from ``--size``; default the file's, else 640x480.

    Raises
    ------
    ValueError
        Not a JSON object of those keys (the message names the file), values :class:`pyshadow.Camera` refuses,
        or a width and height that differ from ``size``.
    """
    import json

    from ..camera import Camera

    try:
        with open(Path(path).expanduser(), encoding="utf-8") as f:
            c = json.load(f)
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise ValueError(f"--camera {path}: not a JSON file ({e})") from None
    if not isinstance(c, dict) or not {"eye", "target"} <= c.keys() or not c.keys() <= set(_CAMERA_KEYS):
        got = sorted(c) if isinstance(c, dict) else type(c).__name__
        raise ValueError(f"--camera {path}: expected a JSON object with eye and target, and optionally up, fov_y, "
                         f"width and height (got {got})")
    own = (c.get("width", 640), c.get("height", 480))
    if size is not None and ("width" in c or "height" in c) and tuple(size) != own:
        raise ValueError(f"--camera {path} is {own[0]}x{own[1]} pixels and --size {size[0]}x{size[1]}: "
                         "give the size in one of them")
    W, H = own if size is None else size
    try:
        return Camera(c["eye"], c["target"], up=c.get("up", (0.0, 1.0, 0.0)), fov_y=c.get("fov_y", 45.0),
                      width=W, height=H)
    except (ValueError, TypeError) as e:
        raise ValueError(f"--camera {path}: {e}") from None


def _frames(args) -> int:
    import numpy as np

    from ..cache import CSMCache, default_cache_dir
    from ..camera import Camera
    from ..views import ViewSet
    from .frames import auto_camera, bake_frames
    from .motion import default_motion, read_motion

    log = _log(args.quiet)
    camera = None if args.camera is None else read_camera(args.camera, args.size)
    W, H = (camera.width, camera.height) if camera is not None else args.size or (640, 480)
    if args.motion is not None and args.frames is not None:       # else ignored: every frame of the file rendered
        raise ValueError(f"--frames {args.frames} sets the length of the bundled scene's default motion; "
                         f"--motion {args.motion} gives the frames itself (write fewer to it to render fewer)")
    if args.mesh:
        from ..bench.scenes import _load_meshes

        if args.motion is None:
            raise ValueError("--mesh needs --motion: the per-frame transforms of the meshes")
        parts = [(name, mesh, True) for name, mesh in _load_meshes(args.mesh)]
        T = _bodies_in_order(*read_motion(args.motion), parts, f"--motion {args.motion}", "--mesh gives", log)
        camera = camera or auto_camera(parts, T, width=W, height=H)
    else:
        from ..data import default_parts

        parts = [(n, m, c) for n, m, _, c in default_parts()]
        T = _bodies_in_order(*(read_motion(args.motion) if args.motion else default_motion(args.frames or 60)), parts,
                             f"--motion {args.motion}", "the bundled scene has", log)
        camera = camera or Camera([2.4, 2.1, 4.8], [0.8, 0.5, 0.0], fov_y=45.0, width=W, height=H)
    cache = CSMCache(None if args.no_cache else (args.cache_dir or default_cache_dir()), log=log)
    views = ViewSet.zigzag(*args.maps)

    def csm_for(name, mesh):
        return cache.csm(name, mesh, views, args.resolution, args.depth_bits, progress=not args.quiet)[0]

    m = bake_frames(args.out, parts, camera, np.asarray(T), ground=None if args.no_ground else args.ground,
                    samples=args.samples, lookup=args.lookup, denoise=args.denoise, csm_for=csm_for,
                    chunk=args.chunk, executor=args.executor, workers=args.workers, scheduler=args.scheduler,
                    progress=not args.quiet, log=log)
    s, ex = m["summary"], m["executor"]
    fpm = f"{m['frames_per_minute']:.1f} frames/min" if m["frames_per_minute"] else "nothing rendered"
    print(f"{len(m['frames'])} frames ({W}x{H}, {args.samples} samples) in {args.out}: {s['rendered']} rendered, "
          f"{s['skipped']} skipped (done), {s['failed']} failed, {s['interrupted']} interrupted; {fpm} "
          f"({m['seconds']:.1f} s, {m['prepare_seconds']:.1f} s of it the CSMs) on {ex['kind']} "
          f"({ex['workers'] or 0} workers)")
    bad = [e for e in m["frames"] if e.get("status") == "failed" and e.get("error")]
    if bad:                             # else the reason was only in the manifest (with --quiet, nowhere on screen)
        print(f"frame {bad[0]['frame']} failed: {bad[0]['error']} ({len(bad)} with an error; each one's in "
              f"{Path(args.out) / 'manifest.json'})")
    return 1 if s["failed"] or s["interrupted"] else 0


def _stop_on_signals(caught: list) -> dict:
    """Make SIGTERM and SIGHUP raise KeyboardInterrupt, as Ctrl-C does, appending their number to ``caught``;
    returns the handlers replaced: only default ones (``nohup`` ignores SIGHUP, which stays ignored), and none
    outside the main thread, where no handler can be set.

    Their default action ends the process at once: no manifest, and the workers of a process pool left
    running, orphaned, holding the command's output pipes open (``timeout 60 pyshadow-bake ... | tee``
    never returned).
    """
    if threading.current_thread() is not threading.main_thread():
        return {}

    def stop(signum, frame):
        caught.append(signum)
        raise KeyboardInterrupt(signal.Signals(signum).name)

    sigs = [getattr(signal, n) for n in ("SIGTERM", "SIGHUP") if hasattr(signal, n)]
    return {s: signal.signal(s, stop) for s in sigs if signal.getsignal(s) is signal.SIG_DFL}


def main(argv=None) -> int:
    """Entry point of ``pyshadow-bake``; returns the exit status."""
    ap = build_parser()
    args = ap.parse_args(argv)
    if args.command in ("assets", "frames"):
        if args.executor == "serial" and args.workers not in (None, 1):     # else ran on 1, without a word
            ap.error(f"--workers {args.workers}: the serial executor runs one task at a time in this process; "
                     f"for {args.workers} workers use --executor process or dask")
        try:                            # before the output folder is made
            check_executor(args.executor, args.workers, args.scheduler)
        except ValueError as e:
            ap.error(str(e))
        _check_out(ap, args.out)
    caught = []
    replaced = _stop_on_signals(caught)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")       # mesh cleanup notes go to the manifest
            if args.command == "assets":
                return _assets(args)
            if args.command == "frames":
                return _frames(args)
            from .motion import default_motion, write_motion

            T, names = default_motion(args.frames)
            write_motion(args.path, T, names)
            print(f"wrote {args.path}: {T.shape[0]} frames of {T.shape[1]} bodies ({', '.join(names)})")
            return 0
    except KeyboardInterrupt:
        print("interrupted: finished outputs are kept, nothing half-written; rerun to continue", file=sys.stderr)
        return 128 + caught[0] if caught else 130
    except (ValueError, FileNotFoundError, ImportError) as e:
        ap.error(str(e))
    except OSError as e:                # an output that cannot be written, a folder that cannot be read
        print(f"pyshadow-bake: error: {e}", file=sys.stderr)
        return 1
    finally:
        for sig, handler in replaced.items():
            signal.signal(sig, handler)
    return 2


if __name__ == "__main__":           # pragma: no cover
    sys.exit(main())

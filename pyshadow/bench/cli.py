"""The ``pyshadow-bench`` command line: options, the run it chooses, the files and stdout it writes."""
from __future__ import annotations

import argparse
import gc
import json
import os
import sys
from pathlib import Path

from .._files import link_target, writable_folder, write_bytes_atomic
from ..cache import CSMCache, default_cache_dir
from .answer import answer_text, run_max_error
from .common import _PROGRESS, UsageError, _Log, drop_earlier_record
from .config import (PRESETS, SWEEP_GRIDS, Config, _int_range, _maps, _positive_float,
                     _size)
from .lit import sky_lighting
from .methods import METHODS, methods_table, parse_methods, positive_distance, selected_methods
from .report import format_table, pareto_plot, sweep_markdown
from .scenes import SceneFactory, _load_meshes
from .single import run_main
from .sweep import _answer, run_sweep

#: Cube-map face resolution of --method cubemap and cubemap-horizon without --probe-resolution.
PROBE_RESOLUTION = 128


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``pyshadow-bench``."""
    from pyshadow import STRATEGIES

    ap = argparse.ArgumentParser(
        prog="pyshadow-bench",
        description="Ambient occlusion from Coherent Shadow Maps on a bundled scene (or your "
                    "meshes), timed and measured against the Embree ray tracer on the identical "
                    "rays and against a converged Embree reference.",
        epilog="Defaults: zigzag 64x128 maps of 128^2 texels, 16-bit depth, 640x480, 36 samples, "
               "1024-sample reference (< 3 min on 2 CPU cores, most of it the first CSM build and "
               "the reference). --quick: 32x64 maps, 320x240, 512-sample reference (< 1 min). "
               "The sweep's full grid takes about 8 minutes cold on 2 CPU cores; --max-error E "
               "alone answers from a model in seconds once the CSMs and reference are cached. "
               "See benchmarks/README.md.")
    mode = ap.add_argument_group("what to run")
    mode.add_argument("--quick", action="store_true",
                      help="smaller settings: 32x64 maps, 320x240, 512-sample reference")
    mode.add_argument("--sweep", action="store_true",
                      help="run the speed/accuracy trade study instead of the single benchmark; "
                           "writes sweep.json, sweep.md, pareto.png")
    mode.add_argument("--sweep-grid", choices=sorted(SWEEP_GRIDS), default=None,
                      help="rows of the sweep (default: 'quick' with --quick, else 'full'; "
                           "'tiny' is for tests)")
    mode.add_argument("--max-error", type=_positive_float, metavar="E",
                      help="answer the fastest configuration with AO RMSE <= E (vs the converged "
                           "reference). Alone: from a model of noise, bias and frame time fitted "
                           "to a few renders of the base CSMs (samples x filter none/bilateral), "
                           "then verified by rendering the choice; writes max_error.json, runs no "
                           "sweep and reads no earlier sweep.json. With --sweep: the fastest row "
                           "of the new sweep")
    mode.add_argument("--frame-budget", type=_positive_float, metavar="SECONDS",
                      help="the other direction: the configuration (samples x filter on the base "
                           "CSMs) with the least predicted AO RMSE that renders within SECONDS a "
                           "frame, from the same model, verified by timing it; writes frame_budget.json")
    mode.add_argument("--mesh", action="append", metavar="PATH",
                      help="use this mesh instead of the default bodies (repeatable); each is "
                           "scaled to bounding radius 1 and stood on the ground, side by side")
    io = ap.add_argument_group("output")
    io.add_argument("--out", type=_folder, default="pyshadow-bench-out", metavar="DIR",
                    help="output directory (default ./pyshadow-bench-out)")
    io.add_argument("--json", action="store_true",
                    help="print results.json (sweep.json with --sweep, max_error.json with "
                         "--max-error alone) on stdout and nothing else; the table goes to stderr")
    io.add_argument("--quiet", action="store_true", help="no progress messages on stderr")
    io.add_argument("--cache-dir", type=_folder, metavar="DIR",
                    help="CSM and reference cache (default $PYSHADOW_CACHE, else "
                         "the user cache directory of 'pyshadow')")
    io.add_argument("--no-cache", action="store_true", help="neither read nor write the cache")
    lit = ap.add_argument_group("lighting (single benchmark)")
    lit.add_argument("--sky", metavar="clear|overcast|FILE",
                     help="also render the scene lit ('bent' mode) by the clear sky with its sun, "
                          "the overcast sky, or an HDR environment map FILE (its sun extracted), "
                          "with the CSMs and with Embree on the same directions; writes radiance.exr "
                          "and lit.png and a 'lighting' entry in results.json")
    lit.add_argument("--normals", choices=("flat", "smooth"),
                     help="shading normals of the lit frames (--sky), both backends alike: 'flat' the "
                          "faces' (default; the kernels' one-pass transfer and sampled sky), 'smooth' "
                          "vertex normals interpolated, creases kept sharp (pyshadow.shading_normals; "
                          "no facet bands, but 'transfer' and 'sampled' take the host route)")
    lit.add_argument("--exposure", type=_positive_float, metavar="S",
                     help="tone-mapping exposure of lit.png (default: the 99th percentile of the "
                          "lit pixels' luminance maps to 0.8)")
    lit.add_argument("--light", metavar="sun|sun:AZ,EL|point|point:X,Y,Z",
                     help="also measure one light's hard shadows: the CSM (one-texel, vote) against "
                          "the classic shadow map at equal memory and at 1024^2, on identical rays "
                          "against Embree, with the time per frame while a body moves; writes "
                          "shadow.png and a 'light' entry (pyshadow/bench/light.py)")
    meth = ap.add_argument_group("methods")
    meth.add_argument("--method", type=parse_methods, action="append", metavar="|".join(METHODS),
                      help="also measure these AO methods on the same pixels (repeatable or "
                           "comma-separated): a 'methods' entry in results.json and a methods table "
                           "(pyshadow/bench/methods.py); with --sweep, each method at the grid's sample "
                           "counts on the sweep's axes (pyshadow/bench/method_sweep.py)")
    meth.add_argument("--ao-distance", type=positive_distance, metavar="D",
                      help="D of the distance-limited AO the methods are also measured on (world "
                           "units; default: the mean bounding radius of the casters)")
    meth.add_argument("--probe-resolution", type=_int_range(16, 2048, "--probe-resolution"),
                      metavar="R", help="cube-map face resolution of --method cubemap and cubemap-horizon "
                                        f"(default {PROBE_RESOLUTION}; with --sweep, R/2, R and 2R)")
    knobs = ap.add_argument_group("settings (override the preset; for tests and power users)")
    knobs.add_argument("--maps", type=_maps, metavar="TxP", help="zigzag map grid theta x phi")
    knobs.add_argument("--resolution", type=_int_range(2, 4096, "--resolution"), metavar="R",
                       help="CSM texels per side")
    knobs.add_argument("--depth-bits", type=int, choices=(16, 32), help="stored depth precision")
    knobs.add_argument("--size", type=_size, metavar="WxH", help="image size")
    knobs.add_argument("--samples", type=_int_range(1, 4096, "--samples"), metavar="N",
                       help="AO samples per pixel")
    knobs.add_argument("--reference-samples", type=_int_range(1, 65536, "--reference-samples"),
                       metavar="N", help="samples per pixel of the converged Embree reference")
    knobs.add_argument("--filter", choices=("none", "bilateral", "separable", "box"), default="none",
                       help="AO filter of the single benchmark (default none)")
    knobs.add_argument("--filtered-lookup", action="store_true",
                       help="filtered CSM lookups: 4 maps x 4 texels a ray (Scene.visible(..., lookup='vote'))")
    knobs.add_argument("--strategy", choices=STRATEGIES, default="hammersley",
                       help="sampling strategy (default hammersley)")
    knobs.add_argument("--seed", type=_int_range(0, 2**31 - 1, "--seed"), default=0)
    knobs.add_argument("--patterns", type=_int_range(1, 65536, "--patterns"), default=256,
                       help="precomputed sample patterns (default 256)")
    knobs.add_argument("--repeats", type=_int_range(1, 100, "--repeats"), metavar="N",
                       help="timed runs (median) after a warm-up")
    knobs.add_argument("--threads", type=_int_range(1, 1024, "--threads"), default=os.cpu_count() or 1,
                       metavar="N", help="Embree threads (default: all cores)")
    return ap


def _folder(text: str) -> str:
    """argparse type of a folder path: the text as given; an empty one (which would mean the
    current folder, or for --cache-dir the default cache) is refused."""
    if not text:
        raise argparse.ArgumentTypeError("expected a folder path, got an empty string")
    return text


def _outputs(args, answer_mode: bool) -> list:
    """The names of the files the run will write into ``--out``."""
    if args.sweep:
        return ["pareto.png", "sweep.md", "sweep.json"]
    if answer_mode:
        return ["max_error.json" if args.frame_budget is None else "frame_budget.json"]
    return (["ao.png", "reference.png", "difference.png", "ao.exr", "reference.exr", "converged.exr"]
            + (["radiance.exr", "lit.png"] if args.sky is not None else [])
            + (["shadow.png"] if args.light is not None else []) + ["results.json"])


def _check_out(ap, out: Path, names=()):
    """Create ``out`` and probe that it is writable, and that none of the output ``names`` there is
    something other than a file a write can replace (a folder, say); a parser error (exit 2) otherwise."""
    try:
        writable_folder(out, ".pyshadow-bench-")
    except ValueError as e:
        ap.error(f"--out {out}: {e}")
    except OSError as e:        # its look-up of the folder (a name too long for the file system: ENAMETOOLONG)
        ap.error(f"--out {out}: cannot write there ({e.strerror or e})")
    for name in names:
        p = out / name
        if p.exists() and not p.is_file():
            ap.error(f"--out {out}: {name} exists there and is not a regular file, which the run would replace")
        if p.is_symlink():              # written through the link
            try:
                into = link_target(p).parent
            except OSError:
                ap.error(f"--out {out}: {name} is a symbolic link that leads back to itself")
            if not into.is_dir():
                ap.error(f"--out {out}: {name} is a symbolic link to {os.readlink(p)}, in a folder that does not "
                         "exist")


def _emit(obj, path: Path | None, as_json: bool):
    """Write ``obj`` as JSON to ``path`` (atomically; None: no file) and, with ``as_json``, to stdout."""
    text = json.dumps(obj, indent=2, allow_nan=False)
    if path is not None:
        write_bytes_atomic(path, (text + "\n").encode())
    if as_json:
        sys.stdout.write(text + "\n")
        sys.stdout.flush()


#: Exit status after Ctrl-C (SIGINT): 128 + 2, as a shell reports a command SIGINT ended.
EXIT_INTERRUPTED = 130
#: Exit status when the reader of stdout has gone (a closed pipe): 128 + 13, as for SIGPIPE.
EXIT_BROKEN_PIPE = 141
#: Exit status when the run cannot finish for a file system error (an output the full disk cannot hold).
EXIT_OS_ERROR = 1


def main(argv=None) -> int:
    """Run ``pyshadow-bench`` with the arguments ``argv`` (default ``sys.argv[1:]``).

    Ctrl-C (``KeyboardInterrupt``) at any point ends the run with the one
    line "pyshadow-bench: interrupted" on stderr and status
    :data:`EXIT_INTERRUPTED`. Every output file is written atomically
    (a temporary file renamed over the target), so an interrupted run leaves
    no partly written file: each output is either complete or not there (or
    still the previous run's). The record (results.json, sweep.json) is
    written last, and an earlier one is removed before the run's first other
    output is written: a record present describes the files beside it.
    An output that cannot be written (the disk full, say) ends the run alike:
    one line "pyshadow-bench: error: ..." with the reason and the output
    file (none named for stdout), status :data:`EXIT_OS_ERROR`; the record
    is there only if it was written before (stdout fails after it).

    Returns
    -------
    int
        0 on success, :data:`EXIT_INTERRUPTED` after Ctrl-C,
        :data:`EXIT_OS_ERROR` after a file system error; argument
        errors exit with status 2 (``SystemExit``).
    """
    try:
        return _run(argv)
    except BrokenPipeError:
        # the reader of stdout left (``pyshadow-bench --json | head``): end without a traceback (the
        # files written so far stay); stdout goes to the null device, so the final flush raises nothing
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except OSError as e:
        # an output the folder cannot take after the run's work (ENOSPC, EIO, EDQUOT: --out was writable at
        # the start); the message names the file. Each output is atomic and the record comes last, as above
        sys.stderr.write(f"pyshadow-bench: error: cannot finish the run: {e}\n")
        sys.stderr.flush()
        return EXIT_OS_ERROR
    except KeyboardInterrupt:
        # leaving this clause frees the interrupted run's objects; one that Ctrl-C caught half
        # built (pyopencl's kernel cache, say) may fail in its __del__: not worth a traceback
        hook, sys.unraisablehook = sys.unraisablehook, _ignore_unraisable
    try:
        gc.collect()
    finally:
        sys.unraisablehook = hook
    sys.stderr.write("pyshadow-bench: interrupted\n")
    sys.stderr.flush()
    return EXIT_INTERRUPTED


def _ignore_unraisable(unraisable) -> None:
    """A ``sys.unraisablehook`` that drops the error (while an interrupted run is freed)."""


def _run(argv) -> int:
    """The run of :func:`main`, which adds the Ctrl-C handling."""
    ap = build_parser()
    args = ap.parse_args(argv)
    log = _Log(args.quiet)
    out = Path(args.out).expanduser().absolute()     # the records name their files from any folder
    args.out = str(out)

    if args.sweep_grid is not None and not args.sweep:
        ap.error("--sweep-grid needs --sweep")
    if args.no_cache and args.cache_dir is not None:
        ap.error("--cache-dir: --no-cache neither reads nor writes a cache; give one of the two")
    meshes = None
    if args.mesh:
        try:
            meshes = _load_meshes(args.mesh)
        except ValueError as e:
            ap.error(str(e))
    if args.frame_budget is not None and (args.sweep or args.max_error is not None):
        ap.error("--frame-budget answers alone: not with --sweep or --max-error")
    answer_mode = (args.max_error is not None and not args.sweep) or args.frame_budget is not None
    if answer_mode and args.filter != "none":
        ap.error("--filter: --max-error and --frame-budget choose the filter themselves (none or bilateral)")
    lighting = None
    if args.sky is not None:
        if args.sweep or answer_mode:
            ap.error("--sky is for the single benchmark, not --sweep, --max-error or --frame-budget")
        try:
            lighting = sky_lighting(args.sky)
        except (OSError, ValueError) as e:
            ap.error(f"--sky {args.sky}: not 'clear', 'overcast' or a readable HDR environment map ({e})")
    elif args.exposure is not None or args.normals is not None:
        ap.error(f"{'--exposure' if args.exposure is not None else '--normals'} needs --sky")
    args.normals = args.normals or "flat"
    if args.light is not None:
        if args.sweep or answer_mode:
            ap.error("--light is for the single benchmark, not --sweep, --max-error or --frame-budget")
        from .light import parse_light

        try:
            args.light = parse_light(args.light)
        except ValueError as e:
            ap.error(str(e))
    if (args.method or args.ao_distance is not None) and answer_mode:
        ap.error("--method and --ao-distance are for the single benchmark and --sweep, not --max-error "
                 "or --frame-budget")
    if args.ao_distance is not None and not args.method:
        ap.error("--ao-distance needs --method")
    probes = {"cubemap", "cubemap-horizon"} & set(selected_methods(args.method or []))
    if args.probe_resolution is not None and not probes:
        ap.error("--probe-resolution needs --method cubemap or cubemap-horizon (the methods with probes)")
    if args.probe_resolution is None:
        args.probe_resolution = PROBE_RESOLUTION

    preset = PRESETS["quick" if args.quick else "default"]
    explicit = [k for k in ("maps", "resolution", "depth_bits", "size", "samples",
                            "reference_samples", "repeats") if getattr(args, k) is not None]
    for k, v in preset.items():
        if getattr(args, k) is None:
            setattr(args, k, v)
    # 'custom' when a setting differs from the preset's (a value given equal to it is the preset's),
    # the sampling's (strategy, seed, patterns: they move every AO figure) included
    custom = [k for k, v in preset.items() if getattr(args, k) != v]       # (maps and size: tuples both)
    custom += [k for k in ("filter", "filtered_lookup", "strategy", "seed", "patterns")
               if getattr(args, k) != ap.get_default(k)]
    args.mode = ("quick" if args.quick else "default") if not custom else "custom"
    if args.sweep:
        args.mode = "sweep"
        if args.sweep_grid is None:
            args.sweep_grid = "quick" if args.quick else "full"
        if "repeats" not in explicit:
            args.repeats = 3
    elif answer_mode:
        args.mode = "max-error" if args.frame_budget is None else "frame-budget"
        if "repeats" not in explicit:
            args.repeats = 3          # renders per model configuration: 1 untimed, 2 timed
    cfg = Config(tuple(args.maps), args.resolution, args.depth_bits, args.samples,
                 None if args.filter == "none" else args.filter, bool(args.filtered_lookup))
    if args.method:                 # vtk-ssao's window holds the image: refused here, not after the run
        from types import SimpleNamespace

        from .method_sweep import check_camera
        try:
            check_camera(selected_methods(args.method), SimpleNamespace(width=args.size[0], height=args.size[1]),
                         () if args.sweep else (args.samples,))
        except UsageError as e:
            ap.error(str(e))
    if args.cache_dir and Path(args.cache_dir).expanduser().exists() \
            and not Path(args.cache_dir).expanduser().is_dir():     # was: a warning, then a run with no cache
        ap.error(f"--cache-dir {args.cache_dir}: exists and is not a directory")
    _check_out(ap, out, _outputs(args, answer_mode))      # after every argument check: no folder made for none

    if args.no_cache:
        cache_root = None
    elif args.cache_dir:
        cache_root = Path(args.cache_dir).expanduser()
    else:
        cache_root = default_cache_dir()
    cache = CSMCache(cache_root, log)
    progress = _PROGRESS["on"] = not args.quiet
    factory = SceneFactory(meshes, tuple(args.size), cache, progress)
    log(f"pyshadow-bench: {factory.description}; cache "
        f"{cache_root if cache_root is not None else 'off'}; output {out}")

    if args.sweep:
        sw = run_sweep(args, cfg, factory, cache, log)
        if args.max_error is not None:
            sw["max_error"] = _answer(sw, args.max_error)
        drop_earlier_record(out / "sweep.json")          # written last, below
        pareto_plot(sw, out / "pareto.png", args.max_error)
        write_bytes_atomic(out / "sweep.md", sweep_markdown(sw).encode())
        _emit(sw, out / "sweep.json", args.json)
        print(sweep_markdown(sw), file=sys.stderr if args.json else sys.stdout)
        return 0

    if answer_mode:
        rec = run_max_error(args, cfg, factory, cache, log)
        _emit(rec, out / ("max_error.json" if args.frame_budget is None else "frame_budget.json"), args.json)
        print(answer_text(rec), file=sys.stderr if args.json else sys.stdout)
        return 0

    try:
        result = run_main(args, cfg, factory, cache, log, lighting)
    except UsageError as e:                 # raised before any output is written
        ap.error(str(e))
    result["files"]["results.json"] = str(out / "results.json")
    _emit(result, out / "results.json", args.json)
    print(format_table(result), file=sys.stderr if args.json else sys.stdout)
    if "methods" in result:
        print(methods_table(result["methods"]), file=sys.stderr if args.json else sys.stdout)
    return 0

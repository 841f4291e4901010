"""Helpers shared by the benchmark scripts: meshes, timing, device name, JSON output."""
from __future__ import annotations

import argparse
import json
import math
import platform
import statistics
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MESH_HELP = ("a mesh bundled with pyshadow by name (pyshadow.data.MESHES, e.g. teapot.obj) "
             "or a mesh file (default: %(default)s)")


def load_mesh(spec, fill_holes: bool = False):
    """A mesh by file path, or by the name of a mesh bundled with pyshadow.

    An existing file wins; otherwise ``spec`` names an entry of
    ``pyshadow.data.MESHES`` (``"stanford-bunny.obj"``, ``"fandisk"``, ...),
    loaded bit-identically to its original file by ``pyshadow.data.mesh``.
    """
    import pyshadow

    if not Path(spec).is_file():
        try:
            return pyshadow.data.mesh(str(spec), fill_holes=fill_holes)
        except ValueError:
            pass                    # not a bundled name: let load_mesh report the path
    return pyshadow.load_mesh(spec, fill_holes=fill_holes)


def parse_grid(ap, text: str, option: str = "--maps", least: int = 1) -> tuple:
    """``(a, b)`` of ``"AxB"`` (two integers >= ``least``) by pyshadow-bench's own parser
    (``pyshadow.bench.config._pair``), else ``ap.error`` naming ``option`` (exit status 2)."""
    from pyshadow.bench.config import _pair

    try:
        return _pair(str(text), option, least, 1 << 20)
    except argparse.ArgumentTypeError as e:
        ap.error(str(e))


def parse_ints(ap, text: str, option: str, least: int = 1, even: bool = False) -> list:
    """The integers of a comma-separated list (at least one, each >= ``least``, even with ``even``),
    else ``ap.error`` naming ``option`` (exit status 2)."""
    try:
        out = [int(x) for x in str(text).split(",") if x.strip()]
    except ValueError:
        out = []
    if not out or min(out) < least or (even and any(x % 2 for x in out)):
        ap.error(f"{option} must be a comma-separated list of {'even ' if even else ''}integers >= {least}, "
                 f"got {text!r}")
    return out


def check_counts(ap, args, *names: str, least: int = 1, most: int | None = None) -> None:
    """``ap.error`` (exit status 2) unless every integer option ``names`` (attribute names) is >= ``least``
    (and <= ``most``: e.g. 4096 texels, the most a CSM's side takes)."""
    for name in names:
        value = getattr(args, name)
        if value < least:
            ap.error(f"--{name.replace('_', '-')} must be >= {least}, got {value}")
        if most is not None and value > most:
            ap.error(f"--{name.replace('_', '-')} must be <= {most}, got {value}")


def check_positive(ap, args, *names: str) -> None:
    """``ap.error`` (exit status 2) unless every number option ``names`` (attribute names) is finite and > 0."""
    for name in names:
        value = getattr(args, name)
        if not (math.isfinite(value) and value > 0):
            ap.error(f"--{name.replace('_', '-')} must be a finite number > 0, got {value}")


def check_meshes(ap, option: str, specs, files: bool = True) -> None:
    """``ap.error`` (exit status 2) unless every mesh of ``specs`` is a bundled mesh's name (``pyshadow.data``)
    or, with ``files``, an existing file (what :func:`load_mesh` takes)."""
    from pyshadow.data import MESHES, _mesh_name

    for spec in specs:
        if files and Path(spec).is_file():
            continue
        try:
            _mesh_name(spec)
        except ValueError:
            ap.error(f"{option}: {spec!r} is {'no mesh file and ' if files else ''}no bundled mesh "
                     f"(one of {', '.join(MESHES)})")


def check_file(ap, option: str, path) -> None:
    """``ap.error`` (exit status 2) unless ``path`` is an existing file (an input read after the work)."""
    if not Path(path).is_file():
        ap.error(f"{option}: no file {str(path)!r}")


def check_out_file(ap, option: str, path, make: bool = False) -> None:
    """``ap.error`` (exit status 2) unless ``path`` can be written: its folder exists (``make``: or can be made,
    and is made) and takes a file, and ``path`` is not a folder. Run before the work, so that its result is not
    lost at the end."""
    path = Path(path)
    if path.is_dir():
        ap.error(f"{option} {path}: is a folder, not a file")
    if not make and not path.absolute().parent.is_dir():
        ap.error(f"{option} {path}: no folder {str(path.absolute().parent)!r} to write into")
    check_out_folder(ap, option, path.absolute().parent, of=path)


def check_out_folder(ap, option: str, folder, of=None) -> None:
    """``ap.error`` (exit status 2) unless ``folder`` is (or can be made) a folder a file can be written into."""
    from pyshadow._files import writable_folder

    try:
        writable_folder(folder, ".pyshadow-bench-")
    except (ValueError, OSError) as e:
        where = f"{folder}" if of is None else f"{of}: {folder}"
        ap.error(f"{option} {where}: {e if isinstance(e, ValueError) else e.strerror or e}")


def median_time(fn, repeats: int = 3, warmup: int = 1):
    """Run ``fn`` ``warmup`` times untimed, then ``repeats`` times; return (median s, all)."""
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), times


def environment() -> dict:
    import pyshadow
    from pyshadow.bench.common import package_versions

    info = pyshadow.device_info()
    return {
        "device": info["name"],
        "platform": info["platform"],
        "device_type": info["type"],
        "compute_units": info["compute_units"],
        "lanes": info["lanes"],
        "lanes_reason": info["lanes_reason"],
        "python": sys.version.split()[0],
        "machine": platform.machine(),
        "pyshadow": pyshadow.__version__,
        "packages": package_versions(),
    }


def emit(result: dict, as_json: bool):
    if as_json:
        print(json.dumps(result, indent=2))

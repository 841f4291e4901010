"""Helpers shared by the benchmark scripts: meshes, timing, device name, JSON output."""
from __future__ import annotations

import argparse
import json
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


def check_counts(ap, args, *names: str, least: int = 1) -> None:
    """``ap.error`` (exit status 2) unless every integer option ``names`` (attribute names) is >= ``least``."""
    for name in names:
        value = getattr(args, name)
        if value < least:
            ap.error(f"--{name.replace('_', '-')} must be >= {least}, got {value}")


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

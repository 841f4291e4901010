"""Helpers every part of pyshadow-bench uses: progress on stderr, figure records, environment,
and the check of AO arrays read back from the cache."""
from __future__ import annotations

import math
import os
import platform
import sys

import numpy as np


class _Log:
    """Progress and information on stderr (stdout carries only the result)."""

    def __init__(self, quiet: bool = False):
        self.quiet = quiet

    def __call__(self, msg: str):
        if not self.quiet:
            print(msg, file=sys.stderr, flush=True)


_PROGRESS = {"on": True}      # --quiet turns progress bars off


class UsageError(Exception):
    """An option value found unusable once the scene exists (``--light`` inside a caster, say).

    Raised before the run writes any output; the command line reports it
    as an argparse error (``error: ...``, exit status 2).
    """


def _bar(total, desc, unit="it"):
    """A tqdm bar on stderr, shown only on a terminal (and not with --quiet)."""
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr,
                disable=None if _PROGRESS["on"] else True, leave=False)


def _fig(value, unit: str, label: str) -> dict:
    """A figure record ``{"value", "unit", "label"}``; NumPy scalars become Python ones, nan/inf None."""
    if isinstance(value, (np.floating, np.integer)):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        value = None
    return {"value": value, "unit": unit, "label": label}


def _num(x, fmt: str, scale: float = 1.0) -> str:
    """``x * scale`` formatted with ``fmt``; "n/a" for a missing figure (None: nan or inf in results.json).

    Every table and markdown of pyshadow-bench prints a figure through this.
    """
    return "n/a" if x is None else format(x if scale == 1.0 else x * scale, fmt)


def drop_earlier_record(path) -> None:
    """Remove ``path``, an earlier run's record (results.json, sweep.json), if it is there.

    A run calls this before it writes its first output into the folder and
    writes its own record last. Each output is written atomically, but not
    the set: otherwise a run interrupted (Ctrl-C) or failing between two
    outputs would leave its new images beside an earlier record describing
    other ones. So a record present always describes the files beside it.
    """
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


def ao_defect(a, n: int) -> str | None:
    """Why ``a`` cannot be the AO of ``n`` pixels, or None when it can.

    AO is a fraction of unoccluded directions: a finite value in [0, 1] per
    pixel, one dimension of length ``n``.

    Parameters
    ----------
    a : ndarray
        The array to check.
    n : int
        The number of pixels it should hold.

    Returns
    -------
    str or None
        A short reason (wrong shape, values not finite, values outside
        [0, 1]); None when ``a`` is a possible AO array.
    """
    a = np.asarray(a)
    if a.shape != (n,):
        return f"shape {a.shape}, expected ({n},)"
    bad = int(np.count_nonzero(~np.isfinite(a)))
    if bad:
        return f"{bad} of {n} values are not finite"
    out = int(np.count_nonzero((a < 0.0) | (a > 1.0)))
    if out:
        return f"{out} of {n} values are outside [0, 1] (min {float(a.min()):.6g}, max {float(a.max()):.6g})"
    return None


def cached_ao(cache, key: str, n: int, log=None):
    """The AO of ``n`` pixels cached under ``key``, or None when absent or impossible.

    :meth:`pyshadow.cache.CSMCache.array` checks the file (zip, checksum),
    not what it holds: an array that is not a possible AO of ``n`` pixels
    (:func:`ao_defect`: wrong shape, non-finite values, values outside
    [0, 1]) is treated like a missing one, so the caller recomputes it and
    its :meth:`~pyshadow.cache.CSMCache.put_array` replaces the file.

    Parameters
    ----------
    cache : pyshadow.cache.CSMCache
        The cache (disabled: always None).
    key : str
        The array's cache key.
    n : int
        The number of pixels the AO should have.
    log : callable, optional
        ``log(message)`` receives a one-line note when a cached array is
        refused; None: no note.

    Returns
    -------
    ndarray, shape (n,), float32, or None
    """
    a = cache.array(key)
    if a is None:
        return None
    why = ao_defect(a, n)
    if why is None:
        return a
    if log is not None:
        log(f"cache: reference/{key[:40]}.npz is not a possible AO of {n} pixels ({why}); "
            "recomputing it")
    return None


#: the distributions whose versions can move a figure (the answers of the mesh loader, of Embree, of PoCL)
PACKAGES = ("numpy", "scipy", "trimesh", "embreex", "pyopencl", "pocl-binary-distribution")


def package_versions() -> dict:
    """``{distribution: version or None}`` of :data:`PACKAGES` (None: not installed as a distribution)."""
    from importlib.metadata import PackageNotFoundError, version

    out = {}
    for name in PACKAGES:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = None
    return out


def environment(threads: int) -> dict:
    """Device and software the figures were measured on."""
    import pyshadow

    info = pyshadow.device_info()
    packages = package_versions()
    return {"device": info["name"], "platform": info["platform"], "device_type": info["type"],
            "compute_units": info["compute_units"], "cpu_count": os.cpu_count(),
            "embree_threads": threads, "embreex": packages["embreex"],
            "python": sys.version.split()[0], "machine": platform.machine(),
            "pyshadow": pyshadow.__version__, "packages": packages}

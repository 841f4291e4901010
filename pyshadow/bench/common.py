"""Helpers every part of pyshadow-bench uses: progress on stderr, figure records, environment."""
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


def environment(threads: int) -> dict:
    """Device and software the figures were measured on."""
    import pyshadow

    info = pyshadow.device_info()
    try:
        from importlib.metadata import version

        embreex_version = version("embreex")
    except Exception:                          # not installed as a distribution
        embreex_version = None
    return {"device": info["name"], "platform": info["platform"], "device_type": info["type"],
            "compute_units": info["compute_units"], "cpu_count": os.cpu_count(),
            "embree_threads": threads, "embreex": embreex_version,
            "python": sys.version.split()[0], "machine": platform.machine(),
            "pyshadow": pyshadow.__version__}

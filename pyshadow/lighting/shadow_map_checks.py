"""Argument checks of :mod:`pyshadow.lighting.shadow_map` (its PCF size and biases).

Kept apart so that the shadow map's module stays within the project's size limit; the names are
imported there (``pyshadow.lighting.shadow_map.PCF_SIZES`` etc. as before). The resolution's check stays
there: it reads that module's ``MAX_RESOLUTION`` (which a caller may lower).
"""
from __future__ import annotations

import math

import numpy as np

from .._validate import FLOAT32_MAX

__all__ = ["PCF_SIZES"]

PCF_SIZES = (1, 3, 5, 7)


def _check_pcf(pcf) -> int:
    if isinstance(pcf, bool) or not isinstance(pcf, (int, np.integer)) or int(pcf) not in PCF_SIZES:
        raise ValueError(f"pcf must be one of {PCF_SIZES} (an odd kernel size), got {pcf!r}")
    return int(pcf)


def _check_bias(bias, name="bias"):
    if bias is None:
        return None
    try:
        b = float(bias) if not isinstance(bias, (bool, np.bool_)) else math.nan      # True is no distance
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a finite number >= 0 (world units) or None, got {bias!r}") from None
    if not (np.isfinite(b) and 0 <= b <= FLOAT32_MAX):
        raise ValueError(f"{name} must be a finite number >= 0 (world units) or None, got {bias!r}"
                         + (f" (beyond float32's range, {FLOAT32_MAX:.3g}: the kernel reads it as float32)"
                            if b > FLOAT32_MAX else ""))
    return b

"""Input checks of the lighting package: each names the argument and the limit."""
from __future__ import annotations

import math
import sys
from contextlib import contextmanager

import numpy as np

from .._validate import check_int, flag  # noqa: F401  (flag: this package's name for it)

__all__ = ["radiance_array", "unit_direction", "unit_rows", "positive", "in_range", "MAX_RADIANCE", "MAX_SH",
           "sh_coefficients", "bounded_sh", "check_seed", "light_tuple", "rgb_channels", "flag"]

#: Largest radiance a map may hold: below it a map's integrals, SH coefficients (at most 0.631 * 4 pi
#: times it) and SH irradiance (at most some 250 times it) stay finite in float64.
MAX_RADIANCE = sys.float_info.max / 1024
#: Largest |SH coefficient| accepted: the SH irradiance (at most 31 times it) and the transfer sums
#: (at most 17 times it) stay finite. A map within MAX_RADIANCE has coefficients below it.
MAX_SH = sys.float_info.max / 64


def radiance_array(a, name: str, mask=None) -> np.ndarray:
    """An (H, W, 3) array of finite, non-negative radiance as float64 (a copy).

    ``mask`` (H, W) bool, if given, selects the texels that belong to the map;
    the others are not checked and are set to 0.
    """
    arr = np.asarray(a)
    if arr.ndim != 3 or arr.shape[2] != 3:
        raise ValueError(f"{name}: expected an RGB image of shape (H, W, 3) (got shape {arr.shape})")
    if arr.shape[0] < 1 or arr.shape[1] < 1:
        raise ValueError(f"{name}: the image is empty (shape {arr.shape})")
    if not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise TypeError(f"{name}: expected a float array (got dtype {arr.dtype})")
    out = np.array(arr, dtype=np.float64)
    if mask is not None:
        out[~mask] = 0.0
    if out.size and out.min() >= 0.0 and out.max() <= MAX_RADIANCE:       # (NaN fails both): all good
        return out
    bad = [(np.isnan(out), "NaN"), (np.isinf(out), "infinite"), (out < 0, "negative"),
           (out > MAX_RADIANCE, f"above {MAX_RADIANCE:.4g} (the map's integrals would overflow float64)")]
    for hit, what in bad:
        n = int(hit.any(axis=2).sum())
        if n:
            i, j = np.argwhere(hit.any(axis=2))[0]
            raise ValueError(f"{name}: {n} texel(s) are {what}, first at row {i}, column {j} "
                             f"(value {tuple(arr[i, j].tolist())}); radiance must be finite and >= 0")
    return out


def bounded_sh(L: np.ndarray, name: str) -> np.ndarray:
    """``L`` (finite float64) unchanged; ValueError naming ``name`` where |L| exceeds :data:`MAX_SH`."""
    if L.size and np.abs(L).max() > MAX_SH:
        raise ValueError(f"{name}: |coefficient| up to {np.abs(L).max():.4g}; SH coefficients beyond "
                         f"{MAX_SH:.4g} overflow the irradiance in float64")
    return L


def sh_coefficients(x, name: str, what: str) -> np.ndarray:
    """(9, 3) SH coefficients as float64 (a copy): real numbers, finite, within :data:`MAX_SH`."""
    L = np.array(_floats(x, name, f"{what} of shape (9, 3)"), dtype=np.float64)
    if L.shape != (9, 3):
        raise ValueError(f"{name}: expected {what} of shape (9, 3) (got shape {L.shape})")
    if not np.isfinite(L).all():
        raise ValueError(f"{name}: SH coefficients must be finite")
    return bounded_sh(L, name)


def check_seed(seed) -> int:
    """A random seed: an int >= 0 (NumPy's generators refuse negative ones with no name)."""
    try:
        return check_int(seed, "seed", 0)
    except (TypeError, ValueError):     # one error type for every bad seed, as the constructor documents
        raise ValueError(f"seed: expected an int >= 0 (got {seed!r})") from None


def light_tuple(lights) -> tuple:
    """``lights`` (an iterable of point, spot, disc or rectangle lights) as a tuple."""
    from .area import LIGHT_TYPES

    try:
        out = tuple(lights)
    except TypeError:
        out = None
    if out is None or not all(isinstance(x, LIGHT_TYPES) for x in out):
        one = " in a sequence (one light: lights=[light])" if isinstance(lights, LIGHT_TYPES) else ""
        raise TypeError(f"lights: expected point, spot, disc or rectangle lights{one} (got {lights!r})")
    return out


def rgb_channels(path) -> None:
    """ValueError naming ``path`` where its first three channels are not R, G, B (an EXR of Z, or Y/RY/BY)."""
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    if inp is None:                                  # read_image has read it: cannot happen
        return
    try:
        names = tuple(inp.spec().channelnames)
    finally:
        inp.close()
    base = tuple(n.rsplit(".", 1)[-1].upper() for n in names)
    if base[:3] != ("R", "G", "B") or base[3:] not in ((), ("A",)):
        raise ValueError(f"{path}: an environment map needs channels R, G, B (and A) (got {', '.join(names)})")


def unit_direction(d, name: str, tol: float = 1e-6) -> np.ndarray:
    """A unit 3-vector as float64; zero, non-finite or non-unit vectors raise ValueError. ``tol`` is widened
    to the rounding of a low-precision float input (:func:`_unit_tol`)."""
    v = _floats(d, name, "a 3-vector")
    tol = _unit_tol(d, tol)
    if v.shape != (3,):
        raise ValueError(f"{name}: expected a 3-vector (got shape {v.shape})")
    if not np.isfinite(v).all():
        raise ValueError(f"{name}: not finite (got {v.tolist()})")
    n = float(np.linalg.norm(v))
    if n == 0.0:
        raise ValueError(f"{name}: zero vector; expected a unit vector")
    if abs(n - 1.0) > tol:
        raise ValueError(f"{name}: not a unit vector (length {n:.9g}, allowed 1 +- {tol:g})")
    return v / n


def unit_rows(a, name: str, tol: float = 1e-6) -> np.ndarray:
    """An (N, 3) (or (3,)) array of unit vectors as float64 (N, 3); ``tol`` as in :func:`unit_direction`."""
    v = _floats(a, name, "rows of 3 numbers, shape (N, 3) or (3,)")
    tol = _unit_tol(a, tol)
    v2 = v.reshape(1, 3) if v.shape == (3,) else v
    if v2.ndim != 2 or v2.shape[1] != 3:
        raise ValueError(f"{name}: expected shape (N, 3) or (3,) (got shape {v.shape})")
    if not np.isfinite(v2).all():
        raise ValueError(f"{name}: {int((~np.isfinite(v2)).any(axis=1).sum())} rows are not finite")
    dev = np.abs(np.linalg.norm(v2, axis=1) - 1.0)
    if len(dev) and dev.max() > tol:
        k = int(np.argmax(dev))
        raise ValueError(f"{name}: {int((dev > tol).sum())} rows are not unit vectors (row {k} has "
                         f"length {np.linalg.norm(v2[k]):.9g}, allowed 1 +- {tol:g})")
    return v2


def _unit_tol(x, tol: float) -> float:
    """``tol``, or 4 machine epsilons of ``x``'s float dtype where more: a float16 unit vector's length is 1 only
    to its rounding (a float16 [0.48, 0.8, 0.36] has length 0.99987; it was refused at 1 +- 1e-6)."""
    dt = getattr(x, "dtype", None)
    if dt is not None and np.issubdtype(dt, np.floating):
        return max(tol, 4.0 * float(np.finfo(dt).eps))
    return tol


def _floats(x, name: str, what: str) -> np.ndarray:
    """``x`` as a float64 array; ValueError naming ``name`` where it holds what is no number: text ("0.5"
    was parsed as 0.5), bools (read as 0 and 1), complex numbers (NumPy would drop their imaginary part
    with a ComplexWarning) or a ragged list."""
    try:
        a = np.asarray(x)
        if a.dtype.kind not in "iufO" or (a.dtype.kind == "O" and any(map(_not_a_number, a.ravel()))):
            raise TypeError
        return np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected {what} (got {x!r})") from None


def _not_a_number(x) -> bool:
    """True for what ``float`` reads but is no number here: text, bools, complex numbers, arrays of one value
    (older NumPy read ``[2.0]`` as 2.0, warning at most)."""
    return isinstance(x, (str, bytes, bool, np.bool_)) or np.iscomplexobj(x) or np.ndim(x) > 0


def _number(x, name: str) -> float:
    """``x`` as a float; TypeError naming ``name`` for what is no real number (a bool: True is no latitude,
    exposure or radius; text: "2.5" was parsed; a complex number: its imaginary part was dropped; an array
    of more than one value; None)."""
    try:
        if _not_a_number(x):
            raise TypeError
        return float(x)
    except (TypeError, ValueError):
        raise TypeError(f"{name}: must be a number (got {x!r})") from None


def positive(x, name: str) -> float:
    v = _number(x, name)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name}: must be a finite number > 0 (got {x!r})")
    return v


def in_range(x, name: str, lo: float, hi: float) -> float:
    """``x`` as a finite float in [lo, hi]; an unbounded ``hi`` (inf) says "a finite number >= lo" (not
    "[lo, inf]", which inf itself seemed to satisfy)."""
    v = _number(x, name)
    if not (math.isfinite(v) and lo <= v <= hi):
        if hi == math.inf:
            raise ValueError(f"{name}: must be a finite number >= {lo:g} (got {x!r})")
        raise ValueError(f"{name}: must lie in [{lo:g}, {hi:g}] (got {x!r})")
    return v


@contextmanager
def straddle_advice(owner: str):
    """Inside the block, the visibility's advice "pass straddle='embree'" (a keyword the caller's function
    does not take) names ``owner``'s instead: "pass Lighting(straddle='embree')"."""
    try:
        yield
    except ValueError as e:
        if "pass straddle='embree'" not in str(e):
            raise
        raise ValueError(str(e).replace("pass straddle='embree'", f"pass {owner}(straddle='embree')")) from None

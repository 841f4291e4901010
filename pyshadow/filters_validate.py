"""Argument checks and limits shared by :mod:`pyshadow.filters` and its NumPy mirrors.

Internal to the filters: :mod:`pyshadow.filters` (the device wrappers) and
:mod:`pyshadow.filters_reference` (the ``*_reference`` functions) validate
their arguments through the same functions here, so that both accept and
reject exactly the same inputs with the same messages. The public limits
(``MAX_RADIUS``, ...) and :func:`low_res_shape` are re-exported by
:mod:`pyshadow.filters`; the array conventions (shapes, dtypes, units, the
depth and normal frames) are stated once in its module docstring.

Every checker returns float32 C-contiguous copies of the arrays it was given
and the parameters as Python ``int``/``float``; an invalid argument raises
``ValueError`` (``TypeError`` for a wrong type) that quotes the value.
"""
from __future__ import annotations

import math
import numbers

import numpy as np

from ._validate import FLOAT32_MAX

__all__ = [
    "MAX_RADIUS",
    "MAX_UPSAMPLE_RADIUS",
    "UPSAMPLE_SCALES",
    "UPSAMPLE_MIN_WEIGHT",
    "low_res_shape",
    "check_flag",
    "bilateral_inputs",
    "box_inputs",
    "upsample_inputs",
]

#: Largest window radius of :func:`pyshadow.filters.bilateral` (a 65 x 65 window).
MAX_RADIUS = 32
#: Largest number of low-res taps per side of :func:`pyshadow.filters.upsample`.
MAX_UPSAMPLE_RADIUS = 8
#: Resolution ratios :func:`pyshadow.filters.upsample` supports.
UPSAMPLE_SCALES = (2, 4)
#: Total weight below which :func:`pyshadow.filters.upsample` falls back to the closest-depth tap.
UPSAMPLE_MIN_WEIGHT = 1e-6

_NORMAL_TOL = 1e-2
#: Largest ``|n . n - 1|`` (float32) of a normal used as it is; ten times what rounding a unit vector to
#: float32 leaves (3.6e-7), so G-buffer normals pass unchanged. Normals further off (up to ``_NORMAL_TOL``)
#: are scaled to unit length: the filters' cosine ``n_p . n_q`` of two equal normals of length 0.995 was
#: 0.990, and the edge-aware box changed 145 of 231 pixels by up to 0.064.
_UNIT_BAND = 4e-6
_MIN_DEPTH = float(np.finfo(np.float32).tiny)


def _float_array(name: str, a, ndim: int, in_float32: bool = False) -> np.ndarray:
    """``a`` as a float32 C-contiguous array of ``ndim`` dimensions; with ``in_float32``, finite values
    beyond float32's range (which the cast would turn into infinities) are refused."""
    a = np.asarray(a)
    if not np.issubdtype(a.dtype, np.floating):
        raise TypeError(f"{name} must be a float array, got dtype {a.dtype}")
    if a.ndim != ndim:
        raise ValueError(f"{name} must have {ndim} dimensions (expected {ndim} vs got {a.ndim}, "
                         f"shape {a.shape})")
    if in_float32 and a.dtype.itemsize > 4 and a.size:     # finite values the cast would make +-inf
        big = np.isfinite(a) & (np.abs(a) > FLOAT32_MAX)
        if big.any():
            i = np.unravel_index(int(np.argmax(big)), a.shape)
            raise ValueError(f"{name} holds {int(big.sum())} finite value(s) beyond float32's range "
                             f"(|x| > {FLOAT32_MAX:.3g}; the filters compute in float32), first at "
                             f"{tuple(int(k) for k in i)}: {float(a[i])!r}")
    return np.ascontiguousarray(a, dtype=np.float32)


def _squared_lengths(normal: np.ndarray) -> np.ndarray:
    """``n . n`` of every normal of ``normal`` (H, W, 3) float32, in float32 (inf or NaN where not finite)."""
    with np.errstate(over="ignore", invalid="ignore"):
        return np.einsum("ijk,ijk->ij", normal, normal)


def _unit_normals(normal: np.ndarray, s: np.ndarray, surf: np.ndarray) -> np.ndarray:
    """``normal`` with every normal where ``surf`` whose squared length ``s`` is off 1 by more than
    ``_UNIT_BAND`` scaled to unit length (in float64, then rounded to float32); the others as they are.
    A new array where any is scaled (never the caller's)."""
    off = surf & ~(np.abs(s - 1.0) <= _UNIT_BAND)
    if not off.any():
        return normal
    n = normal[off].astype(np.float64)
    normal = normal.copy()
    normal[off] = n / np.linalg.norm(n, axis=1, keepdims=True)
    return normal


def _normals_clearly_unit(s: np.ndarray, surf: np.ndarray) -> bool:
    """Whether every normal (squared lengths ``s``, :func:`_squared_lengths`) where ``surf`` is finite
    and of unit length well within ``_NORMAL_TOL``, by float32 squared lengths: a quick screen that accepts only
    what the exact float64 test of :func:`_check_guide` accepts (its margin, 1e-4
    on the squared length, is far above float32 rounding), so that test -- and its
    message -- runs only when a normal is near or beyond the tolerance or not finite
    (NaN and inf fall outside the band; background normals may be anything). The
    exact test took 20 of the 24 ms that :func:`upsample_inputs` spent on a
    640x480 G-buffer; the screen takes 1 to 2."""
    lo, hi = (1.0 - _NORMAL_TOL) ** 2 + 1e-4, (1.0 + _NORMAL_TOL) ** 2 - 1e-4
    return bool((((s >= lo) & (s <= hi)) | ~surf).all())


def _check_guide(depth, normal) -> tuple[np.ndarray, np.ndarray]:
    """Validate the G-buffer guide; return float32 C-contiguous copies, the surface normals off unit
    length by more than float32 rounding scaled to unit length (:func:`_unit_normals`)."""
    depth = _float_array("depth", depth, 2, in_float32=True)       # else a surface became background
    normal = _float_array("normal", normal, 3)
    H, W = depth.shape
    if H < 1 or W < 1:
        raise ValueError(f"depth is empty (shape {depth.shape})")
    if H * W * 3 >= 2**31:
        raise ValueError(f"image of {H}x{W} pixels is too large (int32 indexing)")
    if normal.shape != (H, W, 3):
        raise ValueError(f"normal must have shape (H, W, 3) = {(H, W, 3)} to match depth "
                         f"(expected {(H, W, 3)} vs got {normal.shape})")
    if np.isnan(depth).any():
        raise ValueError(f"depth holds {int(np.isnan(depth).sum())} NaN value(s); "
                         "use +inf for background")
    bad = ~(depth >= _MIN_DEPTH)      # subnormal depths could flush to 0 on the device
    if bad.any():
        raise ValueError(f"depth must be > 0 (at least {_MIN_DEPTH:.3g}) or +inf (background), "
                         f"got {int(bad.sum())} value(s) below that or -inf, "
                         f"e.g. {float(depth[bad][0])!r}")
    surf = np.isfinite(depth)
    s = _squared_lengths(normal)
    if _normals_clearly_unit(s, surf):
        return depth, _unit_normals(normal, s, surf)
    n = normal[surf]
    if not np.isfinite(n).all():
        raise ValueError("normal holds non-finite values at pixels with finite depth")
    if len(n):
        err = np.abs(np.linalg.norm(n.astype(np.float64), axis=1) - 1.0)
        if err.max() > _NORMAL_TOL:
            raise ValueError(f"normal must be unit length where depth is finite: "
                             f"{int((err > _NORMAL_TOL).sum())} normal(s) are off by more than "
                             f"{_NORMAL_TOL} (worst length error {err.max():.3g})")
    return depth, _unit_normals(normal, s, surf)


def _check_values(name: str, img: np.ndarray, surf: np.ndarray):
    """``img`` must be finite wherever ``surf`` is True."""
    bad = surf & ~np.isfinite(img)
    if bad.any():
        y, x = np.argwhere(bad)[0]
        raise ValueError(f"{name} holds {int(bad.sum())} NaN/inf value(s) at pixels with finite "
                         f"depth, first at (row {y}, col {x}): {float(img[y, x])!r}")


def _check_ao(ao, depth: np.ndarray) -> np.ndarray:
    ao = _float_array("ao", ao, 2, in_float32=True)     # else 1e300 was refused as "NaN/inf"
    if ao.shape != depth.shape:
        raise ValueError(f"ao and depth must have the same shape "
                         f"(expected {depth.shape} vs got {ao.shape})")
    _check_values("ao", ao, np.isfinite(depth))
    return ao


def _int_in(name: str, v, lo: int, hi: int) -> int:
    if isinstance(v, bool) or not isinstance(v, numbers.Integral):
        raise TypeError(f"{name} must be an int, got {v!r}")
    if not lo <= int(v) <= hi:
        raise ValueError(f"{name} must be in {lo}..{hi}, got {int(v)}")
    return int(v)


def _positive(name: str, v) -> float:
    if isinstance(v, bool) or not isinstance(v, numbers.Real):
        raise TypeError(f"{name} must be a number, got {v!r}")
    v = float(v)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be finite and > 0, got {v!r}")
    return v


def _bilateral_params(radius, sigma_spatial, sigma_depth, sigma_normal):
    ss = _positive("sigma_spatial", sigma_spatial)
    sz = _positive("sigma_depth", sigma_depth)
    sn = _positive("sigma_normal", sigma_normal)
    if radius is None:                  # (ss capped: 2 ss overflows to inf, whose ceil raised OverflowError)
        radius = min(MAX_RADIUS, math.ceil(2.0 * min(ss, MAX_RADIUS)))
    radius = _int_in("radius", radius, 0, MAX_RADIUS)
    return radius, ss, sz, sn


def check_flag(name: str, v) -> bool:
    if not isinstance(v, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool, got {v!r}")
    return bool(v)


def _box_params(size, depth_threshold, normal_threshold):
    size = _int_in("size", size, 1, 2 * MAX_RADIUS + 1)
    if size % 2 == 0:
        raise ValueError(f"size must be odd (a window centred on the pixel), got {size}")
    dt = _positive("depth_threshold", depth_threshold)
    if isinstance(normal_threshold, bool) or not isinstance(normal_threshold, numbers.Real):
        raise TypeError(f"normal_threshold must be a number, got {normal_threshold!r}")
    nt = float(normal_threshold)
    if not -1.0 <= nt < 1.0:
        raise ValueError(f"normal_threshold must be in [-1, 1) (a cosine), got {nt!r}")
    return size, dt, nt


def low_res_shape(shape, scale: int) -> tuple[int, int]:
    """Shape ``(ceil(H/scale), ceil(W/scale))`` of the AO image :func:`upsample` expects."""
    H, W = shape
    return (-(-int(H) // scale), -(-int(W) // scale))


def _upsample_params(ao_low, depth, scale, radius, sigma_spatial, sigma_depth, sigma_normal,
                     fill):
    ao_low = _float_array("ao_low", ao_low, 2, in_float32=True)
    H, W = depth.shape
    if scale is None:
        fits = [s for s in UPSAMPLE_SCALES if low_res_shape((H, W), s) == ao_low.shape]
        if not fits:
            raise ValueError(
                f"ao_low of shape {ao_low.shape} is not a 1/2 or 1/4 resolution image of "
                f"{(H, W)} (expected {low_res_shape((H, W), 2)} or {low_res_shape((H, W), 4)} "
                f"vs got {ao_low.shape})")
        if len(fits) > 1:
            raise ValueError(f"the scale of ao_low {ao_low.shape} for a {(H, W)} image is "
                             f"ambiguous (2 or 4); pass scale")
        scale = fits[0]
    if isinstance(scale, bool) or not isinstance(scale, numbers.Integral) \
            or int(scale) not in UPSAMPLE_SCALES:
        raise ValueError(f"scale must be one of {UPSAMPLE_SCALES}, got {scale!r}")
    scale = int(scale)
    want = low_res_shape((H, W), scale)
    if ao_low.shape != want:
        raise ValueError(f"ao_low must have shape (ceil(H/{scale}), ceil(W/{scale})) for a "
                         f"{(H, W)} image (expected {want} vs got {ao_low.shape})")
    radius = _int_in("radius", radius, 1, MAX_UPSAMPLE_RADIUS)
    ss = _positive("sigma_spatial", 0.5 * scale if sigma_spatial is None else sigma_spatial)
    sz = _positive("sigma_depth", sigma_depth)
    sn = _positive("sigma_normal", sigma_normal)
    if isinstance(fill, bool) or not isinstance(fill, numbers.Real) or not math.isfinite(fill):
        raise ValueError(f"fill must be a finite number, got {fill!r}")
    if abs(float(fill)) > FLOAT32_MAX:
        raise ValueError(f"fill must lie within float32's range (|fill| <= {FLOAT32_MAX:.3g}), got {fill!r}")
    _check_values("ao_low", ao_low, np.isfinite(depth[::scale, ::scale]))
    return ao_low, scale, radius, ss, sz, sn, float(fill)


# --------------------------------------------------------------------------
# One check per filter, shared by the wrapper and its reference
# --------------------------------------------------------------------------
def bilateral_inputs(ao, depth, normal, radius, sigma_spatial, sigma_depth, sigma_normal):
    """Validate the arguments of :func:`pyshadow.filters.bilateral`.

    Parameters
    ----------
    ao, depth, normal, radius, sigma_spatial, sigma_depth, sigma_normal
        As :func:`pyshadow.filters.bilateral` takes them.

    Returns
    -------
    ao : ndarray, shape (H, W), float32
    depth : ndarray, shape (H, W), float32
        World units along each pixel's ray, ``+inf`` on background.
    normal : ndarray, shape (H, W, 3), float32
        Unit world-space normals.
    radius : int
        Window radius in pixels, 0 .. ``MAX_RADIUS`` (the default rule applied).
    ss, sz, sn : float
        ``sigma_spatial`` (pixels), ``sigma_depth`` (relative depth) and
        ``sigma_normal`` (``1 - n_p . n_q``), each finite and > 0.
    """
    depth, normal = _check_guide(depth, normal)
    ao = _check_ao(ao, depth)
    radius, ss, sz, sn = _bilateral_params(radius, sigma_spatial, sigma_depth, sigma_normal)
    return ao, depth, normal, radius, ss, sz, sn


def box_inputs(ao, depth, normal, size, depth_threshold, normal_threshold):
    """Validate the arguments of :func:`pyshadow.filters.edge_aware_box`.

    Returns
    -------
    ao, depth, normal : ndarray, float32
        Shapes (H, W), (H, W), (H, W, 3), as :func:`bilateral_inputs`.
    size : int
        Odd window side in pixels, 1 .. ``2 MAX_RADIUS + 1``.
    dt : float
        Relative depth threshold, > 0.
    nt : float
        Cosine threshold, in [-1, 1).
    """
    depth, normal = _check_guide(depth, normal)
    ao = _check_ao(ao, depth)
    size, dt, nt = _box_params(size, depth_threshold, normal_threshold)
    return ao, depth, normal, size, dt, nt


def upsample_inputs(ao_low, depth, normal, scale, radius, sigma_spatial, sigma_depth,
                    sigma_normal, fill):
    """Validate the arguments of :func:`pyshadow.filters.upsample`.

    Returns
    -------
    ao_low : ndarray, shape (ceil(H/scale), ceil(W/scale)), float32
    depth : ndarray, shape (H, W), float32
    normal : ndarray, shape (H, W, 3), float32
    scale : int
        2 or 4 (inferred from the shapes where ``scale`` is None).
    radius : int
        Low-res taps per side, 1 .. ``MAX_UPSAMPLE_RADIUS``.
    ss, sz, sn : float
        ``sigma_spatial`` in full-res pixels (``scale / 2`` where None),
        ``sigma_depth``, ``sigma_normal``.
    fill : float
    """
    depth, normal = _check_guide(depth, normal)
    ao_low, scale, radius, ss, sz, sn, fill = _upsample_params(
        ao_low, depth, scale, radius, sigma_spatial, sigma_depth, sigma_normal, fill)
    return ao_low, depth, normal, scale, radius, ss, sz, sn, fill

"""Edge-aware filtering and upsampling of a screen-space AO image.

Stage "bilateral filter" of the pipeline (DESIGN.md, "Filtering"): the AO
image computed with few samples per pixel is noisy; these filters average it
over neighbours that lie on the same surface, which they recognise from the
G-buffer (depth and normal) rather than from the noisy AO itself (seed 002,
section 4.5). The kernels are in ``kernels/filters.cl``; every one has a
NumPy reference here (``*_reference``, float64, small images only).

Conventions shared by every function of this module
----------------------------------------------------
* Images are ``(H, W)`` arrays, row 0 at the top; pixel ``(y, x)`` is row
  ``y``, column ``x``.
* ``ao`` : float (H, W), AO in [0, 1] (1 = fully open, DESIGN.md). Any finite
  value is filtered alike; NaN/inf are rejected where the depth is finite.
* ``depth`` : float (H, W), distance from the eye along the pixel's ray in
  world units (as :func:`pyshadow.render_gbuffer` returns it), ``> 0``
  (at least the smallest normal float32, 1.2e-38);
  ``+inf`` marks background (no surface). NaN, ``-inf`` and values ``<= 0``
  are rejected.
* ``normal`` : float (H, W, 3), unit world-space normals (within 1e-2 of unit
  length wherever the depth is finite; anything, e.g. zeros, on background).
* Background pixels never contribute to a neighbour and keep their input value
  in the output (:func:`upsample` writes ``fill`` there instead).
* Windows are cut at the image border: taps outside the image are dropped,
  nothing is mirrored or repeated.
* The depth term uses the **relative** depth difference
  ``|z_q - z_p| / z_p``, so results do not change when the scene and camera are
  scaled together (millimetres or kilometres alike); ``sigma_depth`` and
  ``depth_threshold`` are fractions of the centre pixel's depth.
* The normal term uses ``max(0, 1 - n_p . n_q)``: 0 on the same plane, 1 at a
  right angle, 2 for opposite normals.
* Computation is in float32 on the device; outputs are float32 (H, W).

Functions validate every argument before anything is launched; an invalid one
raises ``ValueError`` (``TypeError`` for a wrong type) that quotes the value.
"""
from __future__ import annotations

import math
import numbers

import numpy as np
import pyopencl as cl

from . import _cl

__all__ = [
    "bilateral",
    "edge_aware_box",
    "upsample",
    "bilateral_reference",
    "separable_reference",
    "edge_aware_box_reference",
    "upsample_reference",
    "low_res_shape",
    "MAX_RADIUS",
    "MAX_UPSAMPLE_RADIUS",
    "UPSAMPLE_SCALES",
    "UPSAMPLE_MIN_WEIGHT",
]

#: Largest window radius of :func:`bilateral` (a 65 x 65 window).
MAX_RADIUS = 32
#: Largest number of low-res taps per side of :func:`upsample`.
MAX_UPSAMPLE_RADIUS = 8
#: Resolution ratios :func:`upsample` supports.
UPSAMPLE_SCALES = (2, 4)
#: Total weight below which :func:`upsample` falls back to the closest-depth tap.
UPSAMPLE_MIN_WEIGHT = 1e-6

_NORMAL_TOL = 1e-2
_MIN_DEPTH = float(np.finfo(np.float32).tiny)
# inverse sigmas go to the device clamped to this range, so that no product in
# the weight is 0 * inf (see kernels/filters.cl); it changes no weight that
# float32 can tell apart from 0 or 1 for sigmas in [1e-18, 1e30]
_INV_SIGMA_RANGE = (1e-30, 1e18)


# --------------------------------------------------------------------------
# Validation
# --------------------------------------------------------------------------
def _float_array(name: str, a, ndim: int) -> np.ndarray:
    a = np.asarray(a)
    if not np.issubdtype(a.dtype, np.floating):
        raise TypeError(f"{name} must be a float array, got dtype {a.dtype}")
    if a.ndim != ndim:
        raise ValueError(f"{name} must have {ndim} dimensions (expected {ndim} vs got {a.ndim}, "
                         f"shape {a.shape})")
    return np.ascontiguousarray(a, dtype=np.float32)


def _check_guide(depth, normal) -> tuple[np.ndarray, np.ndarray]:
    """Validate the G-buffer guide; return float32 C-contiguous copies."""
    depth = _float_array("depth", depth, 2)
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
    n = normal[surf]
    if not np.isfinite(n).all():
        raise ValueError("normal holds non-finite values at pixels with finite depth")
    if len(n):
        err = np.abs(np.linalg.norm(n.astype(np.float64), axis=1) - 1.0)
        if err.max() > _NORMAL_TOL:
            raise ValueError(f"normal must be unit length where depth is finite: "
                             f"{int((err > _NORMAL_TOL).sum())} normal(s) are off by more than "
                             f"{_NORMAL_TOL} (worst length error {err.max():.3g})")
    return depth, normal


def _check_values(name: str, img: np.ndarray, surf: np.ndarray):
    """``img`` must be finite wherever ``surf`` is True."""
    bad = surf & ~np.isfinite(img)
    if bad.any():
        y, x = np.argwhere(bad)[0]
        raise ValueError(f"{name} holds {int(bad.sum())} NaN/inf value(s) at pixels with finite "
                         f"depth, first at (row {y}, col {x}): {float(img[y, x])!r}")


def _check_ao(ao, depth: np.ndarray) -> np.ndarray:
    ao = _float_array("ao", ao, 2)
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
    if radius is None:
        radius = min(MAX_RADIUS, math.ceil(2.0 * ss))
    radius = _int_in("radius", radius, 0, MAX_RADIUS)
    return radius, ss, sz, sn


def _check_flag(name: str, v) -> bool:
    if not isinstance(v, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool, got {v!r}")
    return bool(v)


def _inv(sigma: float) -> np.float32:
    return np.float32(min(max(1.0 / sigma, _INV_SIGMA_RANGE[0]), _INV_SIGMA_RANGE[1]))


def _launch(kernel, W: int, H: int, *args):
    kernel(_cl.queue(), (W, H), None, *args)


# --------------------------------------------------------------------------
# Bilateral filter
# --------------------------------------------------------------------------
def bilateral(ao, depth, normal, radius=None, sigma_spatial=2.0, sigma_depth=0.02,
              sigma_normal=0.2, *, separable=False) -> np.ndarray:
    """Joint bilateral filter of an AO image guided by depth and normal.

    ``out_p = 1/W_p sum_q G(|p - q|, sigma_spatial) G(|z_q - z_p| / z_p, sigma_depth)
    G(max(0, 1 - n_p . n_q), sigma_normal) ao_q`` over the square window
    ``|q_x - p_x| <= radius``, ``|q_y - p_y| <= radius`` (cut at the image
    border, background taps dropped), ``W_p`` the sum of the weights and
    ``G(x, s) = exp(-x^2 / (2 s^2))``.

    Parameters
    ----------
    ao : ndarray, shape (H, W), float
        AO image; must be finite where ``depth`` is finite.
    depth : ndarray, shape (H, W), float
        Distance along each pixel's ray (world units), ``+inf`` on background.
    normal : ndarray, shape (H, W, 3), float
        Unit world-space normals.
    radius : int, optional
        Window radius in pixels, 0 .. 32 (0 returns ``ao`` unchanged).
        None: ``min(32, ceil(2 * sigma_spatial))`` -- 4 for the default sigma
        (a 9 x 9 window), which keeps every tap with a spatial weight above
        ``exp(-2) = 0.135``.
    sigma_spatial : float, optional
        Spatial standard deviation in pixels (default 2: smooths the noise of
        a few dozen AO samples per pixel while staying below typical contact
        shadow widths).
    sigma_depth : float, optional
        Standard deviation of the relative depth difference (default 0.02:
        a neighbour 2 % nearer or farther keeps 61 % of its weight, one 10 %
        away keeps 4e-6 -- a depth step of a tenth of the distance is an edge).
    sigma_normal : float, optional
        Standard deviation of ``1 - n_p . n_q`` (default 0.2: 25 degrees keeps
        90 %, 45 degrees 35 %, a right angle 4e-6).
    separable : bool, optional
        Filter each row with the 1-D window ``|q_x - p_x| <= radius``, then
        each column of that result with ``|q_y - p_y| <= radius``. Both passes
        weigh each tap by the guide of the centre pixel against the tap's
        guide; costs ``2(2r+1)`` instead of ``(2r+1)^2`` taps per pixel, an
        approximation of the 2-D filter (exact only where all weights but the
        spatial ones are 1).

    Returns
    -------
    out : ndarray, shape (H, W), float32
        Filtered AO; background pixels hold their ``ao`` value unchanged.

    Raises
    ------
    TypeError
        Non-float images, non-integer radius, non-numeric sigma.
    ValueError
        Mismatched shapes, invalid depth/normal (see the module docstring),
        NaN/inf in ``ao`` where depth is finite, radius outside 0 .. 32,
        a sigma that is not finite and > 0. Nothing is launched then.

    Notes
    -----
    Seed 002, section 3.1.5, eq. 3.6-3.8: the bilateral filter of [PKTD08],
    with its range term ``G_sigma_r(I_p - I_q)`` replaced by depth and normal
    terms of the G-buffer as in the seed's section 4.5 (a *joint* bilateral
    filter). The Gaussian normalisation ``1 / (2 pi sigma^2)`` of eq. 3.8
    cancels in ``1/W_p`` and is left out. The centre tap weighs exactly 1.
    The separable form is the seed's future work (section 5.3; [PKTD08]).

    Examples
    --------
    >>> d = np.full((4, 5), 3.0, np.float32)
    >>> n = np.zeros((4, 5, 3), np.float32); n[..., 2] = 1
    >>> bilateral(np.full((4, 5), 0.25, np.float32), d, n).tolist()[0][:2]
    [0.25, 0.25]
    """
    depth, normal = _check_guide(depth, normal)
    ao = _check_ao(ao, depth)
    radius, ss, sz, sn = _bilateral_params(radius, sigma_spatial, sigma_depth, sigma_normal)
    _check_flag("separable", separable)
    H, W = depth.shape
    if radius == 0:
        return ao.copy()
    q = _cl.queue()
    ao_b, z_b, n_b = _cl.to_device(ao), _cl.to_device(depth), _cl.to_device(normal)
    out_b = _cl.empty(4 * H * W)
    consts = (np.int32(W), np.int32(H), _inv(ss), _inv(sz), _inv(sn))
    defines = {"RADIUS": radius}
    if separable:
        tmp_b = _cl.empty(4 * H * W)
        _launch(_cl.kernel("filters.cl", "bilateral_rows", defines), W, H,
                ao_b, z_b, n_b, *consts, tmp_b)
        _launch(_cl.kernel("filters.cl", "bilateral_cols", defines), W, H,
                tmp_b, z_b, n_b, *consts, out_b)
    else:
        _launch(_cl.kernel("filters.cl", "bilateral_2d", defines), W, H,
                ao_b, z_b, n_b, *consts, out_b)
    out = np.empty((H, W), np.float32)
    cl.enqueue_copy(q, out, out_b)
    return out


# --------------------------------------------------------------------------
# Edge-aware box filter (seed 002, section 4.5)
# --------------------------------------------------------------------------
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


def edge_aware_box(ao, depth, normal, size=7, depth_threshold=0.02,
                   normal_threshold=0.9) -> np.ndarray:
    """Edge-aware box filter: the mean over the neighbours on the same surface.

    ``out_p`` is the plain mean of ``ao_q`` over the pixels ``q`` of the
    ``size x size`` window centred on ``p`` (cut at the image border) with
    finite depth, ``|z_q - z_p| / z_p < depth_threshold`` and
    ``n_p . n_q > normal_threshold``; ``p`` itself always counts.

    Parameters
    ----------
    ao : ndarray, shape (H, W), float
    depth : ndarray, shape (H, W), float
        ``+inf`` on background.
    normal : ndarray, shape (H, W, 3), float
        Unit normals.
    size : int, optional
        Window side, odd, 1 .. 65 (default 7, the seed's mask).
    depth_threshold : float, optional
        Largest relative depth difference (exclusive) of a counted neighbour,
        > 0 (default 0.02, the bilateral filter's ``sigma_depth``: the seed's
        ``|dz| < 0.01`` in depth-buffer units, made scale-free).
    normal_threshold : float, optional
        Smallest cosine (exclusive) between the normals of a counted
        neighbour and the centre, in [-1, 1) (default 0.9: up to 25.8 degrees).

    Returns
    -------
    out : ndarray, shape (H, W), float32
        Background pixels hold their ``ao`` value unchanged.

    Raises
    ------
    TypeError, ValueError
        As :func:`bilateral`; also an even or out-of-range ``size``,
        ``depth_threshold <= 0`` and ``normal_threshold`` outside [-1, 1).

    Notes
    -----
    Seed 002, section 4.5, Listing 4.15 (a 7 x 7 low-pass filter that adds a
    neighbour only when its depth and hashed normal are close to the centre's).
    Here the depth test is relative and the normal test uses the true normals'
    cosine instead of a hash.

    Examples
    --------
    >>> d = np.full((3, 3), 2.0, np.float32)
    >>> n = np.zeros((3, 3, 3), np.float32); n[..., 1] = 1
    >>> float(edge_aware_box(np.eye(3, dtype=np.float32), d, n, size=3)[1, 1])
    0.3333333432674408
    """
    depth, normal = _check_guide(depth, normal)
    ao = _check_ao(ao, depth)
    size, dt, nt = _box_params(size, depth_threshold, normal_threshold)
    H, W = depth.shape
    q = _cl.queue()
    ao_b, z_b, n_b = _cl.to_device(ao), _cl.to_device(depth), _cl.to_device(normal)
    out_b = _cl.empty(4 * H * W)
    k = _cl.kernel("filters.cl", "edge_aware_box", {"HALF": size // 2})
    _launch(k, W, H, ao_b, z_b, n_b, np.int32(W), np.int32(H), np.float32(dt), np.float32(nt),
            out_b)
    out = np.empty((H, W), np.float32)
    cl.enqueue_copy(q, out, out_b)
    return out


# --------------------------------------------------------------------------
# Joint bilateral upsampling
# --------------------------------------------------------------------------
def low_res_shape(shape, scale: int) -> tuple[int, int]:
    """Shape ``(ceil(H/scale), ceil(W/scale))`` of the AO image :func:`upsample` expects."""
    H, W = shape
    return (-(-int(H) // scale), -(-int(W) // scale))


def _upsample_params(ao_low, depth, scale, radius, sigma_spatial, sigma_depth, sigma_normal,
                     fill):
    ao_low = _float_array("ao_low", ao_low, 2)
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
    _check_values("ao_low", ao_low, np.isfinite(depth[::scale, ::scale]))
    return ao_low, scale, radius, ss, sz, sn, float(fill)


def upsample(ao_low, depth, normal, scale=None, radius=2, sigma_spatial=None, sigma_depth=0.02,
             sigma_normal=0.2, *, fill=1.0) -> np.ndarray:
    """Joint bilateral upsampling of a low-resolution AO image (Kopf et al. 2007).

    Sampling convention: low-res pixel ``(i, j)`` holds the AO of full-res
    pixel ``(scale*i, scale*j)`` -- the top-left pixel of the
    ``scale x scale`` block it stands for, not the block's centre. Compute it
    with the G-buffer subsampled as ``depth[::scale, ::scale]``,
    ``normal[::scale, ::scale]``; this function reads the guide of each
    low-res sample from the full-res ``depth``/``normal`` at that pixel.

    Full-res pixel ``p = (y, x)``, ``i0 = y // scale``, ``j0 = x // scale``,
    uses the low-res taps ``q = (i, j)`` with
    ``i0 - radius + 1 <= i <= i0 + radius`` and likewise ``j`` (``2 radius``
    per side, cut at the low-res border), background taps dropped, weight
    ``G(|p - (scale i, scale j)|, sigma_spatial) G(|z_q - z_p| / z_p,
    sigma_depth) G(max(0, 1 - n_p . n_q), sigma_normal)`` with
    ``G(x, s) = exp(-x^2 / (2 s^2))``, and returns the weighted mean. Where
    the total weight is below ``UPSAMPLE_MIN_WEIGHT`` = 1e-6 (no tap lies on
    p's surface, e.g. a thin object seen only at full resolution), it returns
    the tap whose depth is closest to ``z_p`` (ties: the spatially nearest,
    then the first in row-major order).

    Parameters
    ----------
    ao_low : ndarray, shape (ceil(H/scale), ceil(W/scale)), float
        Low-res AO; must be finite where its sample pixel has finite depth.
    depth : ndarray, shape (H, W), float
        Full-res distance along each pixel's ray, ``+inf`` on background.
    normal : ndarray, shape (H, W, 3), float
        Full-res unit normals.
    scale : {2, 4}, optional
        Resolution ratio. None: inferred from the shapes (an error when both
        fit, which happens only for images of at most 2 x 2 pixels).
    radius : int, optional
        Low-res taps per side, 1 .. 8 (default 2: 4 x 4 taps, the footprint
        of bicubic interpolation, so a pixel whose two nearest samples per
        axis lie on another surface can still find its own; 1 gives the
        2 x 2 bilinear footprint).
    sigma_spatial : float, optional
        Spatial standard deviation in full-res pixels. None: ``scale / 2``
        (half a low-res pixel, Kopf et al.'s choice): a pixel halfway between
        two samples weighs both by 0.61, the next ones out by at most 0.011,
        so the result interpolates rather than blurs.
    sigma_depth : float, optional
        Standard deviation of the relative depth difference (default 0.02).
    sigma_normal : float, optional
        Standard deviation of ``1 - n_p . n_q`` (default 0.2).
    fill : float, optional
        Value of background output pixels and of surface pixels with no
        surface tap at all (default 1, unoccluded: the neutral value for the
        multiplicative blending of seed 002, eq. 4.11).

    Returns
    -------
    out : ndarray, shape (H, W), float32

    Raises
    ------
    TypeError, ValueError
        As :func:`bilateral`; also ``ao_low`` of the wrong shape, a scale
        other than 2 or 4, radius outside 1 .. 8, a non-finite ``fill``.

    Notes
    -----
    With the top-left sampling convention the last ``(H - 1) % scale`` rows
    (and ``(W - 1) % scale`` columns) lie beyond the last sample row (column)
    and are extrapolated as a weighted mean of the samples before them;
    compute AO at full resolution there if that matters.

    Joint bilateral upsampling: J. Kopf, M. Cohen, D. Lischinski,
    M. Uyttendaele, "Joint Bilateral Upsampling", SIGGRAPH 2007; named as
    future work in DESIGN.md "Filtering". The range term is the same depth
    and normal term as :func:`bilateral` (seed 002, eq. 3.6 with section
    4.5's geometric edges).

    Examples
    --------
    >>> d = np.full((6, 8), 4.0, np.float32)
    >>> n = np.zeros((6, 8, 3), np.float32); n[..., 0] = 1
    >>> upsample(np.full((3, 4), 0.5, np.float32), d, n).shape
    (6, 8)
    """
    depth, normal = _check_guide(depth, normal)
    ao_low, scale, radius, ss, sz, sn, fill = _upsample_params(
        ao_low, depth, scale, radius, sigma_spatial, sigma_depth, sigma_normal, fill)
    H, W = depth.shape
    Hl, Wl = ao_low.shape
    q = _cl.queue()
    lo_b, z_b, n_b = _cl.to_device(ao_low), _cl.to_device(depth), _cl.to_device(normal)
    out_b = _cl.empty(4 * H * W)
    k = _cl.kernel("filters.cl", "upsample_joint_bilateral",
                   {"SCALE": scale, "RADIUS": radius, "MIN_WEIGHT": UPSAMPLE_MIN_WEIGHT})
    _launch(k, W, H, lo_b, z_b, n_b, np.int32(W), np.int32(H), np.int32(Wl), np.int32(Hl),
            _inv(ss), _inv(sz), _inv(sn), np.float32(fill), out_b)
    out = np.empty((H, W), np.float32)
    cl.enqueue_copy(q, out, out_b)
    return out


# --------------------------------------------------------------------------
# NumPy references (float64, small images only)
# --------------------------------------------------------------------------
def _shifted(a: np.ndarray, dy: int, dx: int, outside) -> np.ndarray:
    """``s[y, x] = a[y + dy, x + dx]``, or ``outside`` where that is off the image."""
    H, W = a.shape[:2]
    s = np.full_like(a, outside)
    if abs(dy) >= H or abs(dx) >= W:
        return s
    ys, yd = slice(max(dy, 0), H + min(dy, 0)), slice(max(-dy, 0), H + min(-dy, 0))
    xs, xd = slice(max(dx, 0), W + min(dx, 0)), slice(max(-dx, 0), W + min(-dx, 0))
    s[yd, xd] = a[ys, xs]
    return s


def _weights(dist2, zp, zq, np_, nq, ss, sz, sn):
    """Tap weights (float64) of the module docstring; 0 where zq is background."""
    with np.errstate(invalid="ignore", over="ignore"):
        rel = np.abs(zq - zp) / zp
        m = np.maximum(0.0, 1.0 - np.sum(np_ * nq, axis=-1))
        w = np.exp(-0.5 * (dist2 / ss**2 + (rel / sz) ** 2 + (m / sn) ** 2))
    return np.where(np.isfinite(zq), w, 0.0)


def _filter_offsets(ao, depth, normal, offsets, weight_fn):
    """``sum_q w ao_q / sum_q w`` over ``offsets`` (centre weight 1), background kept."""
    a, z, n = ao.astype(np.float64), depth.astype(np.float64), normal.astype(np.float64)
    num, den = a.copy(), np.ones_like(a)
    for dy, dx in offsets:
        zq = _shifted(z, dy, dx, np.inf)
        w = weight_fn(dy, dx, z, zq, n, _shifted(n, dy, dx, 0.0))
        num += w * np.nan_to_num(_shifted(a, dy, dx, 0.0))
        den += w
    out = np.where(np.isfinite(z), num / den, a)
    return out.astype(np.float32)


def bilateral_reference(ao, depth, normal, radius=None, sigma_spatial=2.0, sigma_depth=0.02,
                        sigma_normal=0.2, *, separable=False) -> np.ndarray:
    """NumPy version of :func:`bilateral` (same rules, float64 arithmetic).

    Sums over every window offset ``(dy, dx) != (0, 0)`` with whole-image
    array operations; off-image taps act as background.
    ``separable=True`` calls :func:`separable_reference`.
    """
    if _check_flag("separable", separable):
        return separable_reference(ao, depth, normal, radius, sigma_spatial, sigma_depth,
                                   sigma_normal)
    depth, normal = _check_guide(depth, normal)
    ao = _check_ao(ao, depth)
    r, ss, sz, sn = _bilateral_params(radius, sigma_spatial, sigma_depth, sigma_normal)
    offsets = [(dy, dx) for dy in range(-r, r + 1) for dx in range(-r, r + 1) if (dy, dx) != (0, 0)]
    return _filter_offsets(
        ao, depth, normal, offsets,
        lambda dy, dx, zp, zq, np_, nq: _weights(dy * dy + dx * dx, zp, zq, np_, nq, ss, sz, sn))


def separable_reference(ao, depth, normal, radius=None, sigma_spatial=2.0, sigma_depth=0.02,
                        sigma_normal=0.2) -> np.ndarray:
    """NumPy version of ``bilateral(..., separable=True)``: rows, then columns.

    The row pass's float32 result feeds the column pass, as on the device.
    """
    depth, normal = _check_guide(depth, normal)
    ao = _check_ao(ao, depth)
    r, ss, sz, sn = _bilateral_params(radius, sigma_spatial, sigma_depth, sigma_normal)

    def weight(dy, dx, zp, zq, np_, nq):
        return _weights(dy * dy + dx * dx, zp, zq, np_, nq, ss, sz, sn)

    ks = [k for k in range(-r, r + 1) if k != 0]
    rows = _filter_offsets(ao, depth, normal, [(0, k) for k in ks], weight)
    return _filter_offsets(rows, depth, normal, [(k, 0) for k in ks], weight)


def edge_aware_box_reference(ao, depth, normal, size=7, depth_threshold=0.02,
                             normal_threshold=0.9) -> np.ndarray:
    """NumPy version of :func:`edge_aware_box` (same rules, float64 arithmetic)."""
    depth, normal = _check_guide(depth, normal)
    ao = _check_ao(ao, depth)
    size, dt, nt = _box_params(size, depth_threshold, normal_threshold)
    h = size // 2

    def counted(dy, dx, zp, zq, np_, nq):
        with np.errstate(invalid="ignore"):
            same = (np.abs(zq - zp) / zp < dt) & (np.sum(np_ * nq, axis=-1) > nt)
        return (same & np.isfinite(zq)).astype(np.float64)

    offsets = [(dy, dx) for dy in range(-h, h + 1) for dx in range(-h, h + 1) if (dy, dx) != (0, 0)]
    return _filter_offsets(ao, depth, normal, offsets, counted)


def upsample_reference(ao_low, depth, normal, scale=None, radius=2, sigma_spatial=None,
                       sigma_depth=0.02, sigma_normal=0.2, *, fill=1.0) -> np.ndarray:
    """NumPy version of :func:`upsample`: a loop over pixels and their taps.

    Weights in float64; the fallback's depth distance ``|z_q - z_p|`` is
    computed in float32, as on the device, so that ties are the same ties.
    """
    depth, normal = _check_guide(depth, normal)
    ao_low, s, r, ss, sz, sn, fill = _upsample_params(
        ao_low, depth, scale, radius, sigma_spatial, sigma_depth, sigma_normal, fill)
    H, W = depth.shape
    Hl, Wl = ao_low.shape
    out = np.full((H, W), fill, np.float64)
    for y in range(H):
        for x in range(W):
            zp = depth[y, x]
            if not np.isfinite(zp):
                continue
            num = den = 0.0
            best, best_key = fill, (np.inf, np.inf)
            for i in range(max(y // s - r + 1, 0), min(y // s + r, Hl - 1) + 1):
                for j in range(max(x // s - r + 1, 0), min(x // s + r, Wl - 1) + 1):
                    zq = depth[s * i, s * j]
                    if not np.isfinite(zq):
                        continue
                    d2 = (s * i - y) ** 2 + (s * j - x) ** 2
                    w = float(_weights(d2, float(zp), float(zq), normal[y, x].astype(np.float64),
                                       normal[s * i, s * j].astype(np.float64), ss, sz, sn))
                    num += w * float(ao_low[i, j])
                    den += w
                    key = (float(np.abs(zq - zp)), d2)      # float32 subtraction
                    if key < best_key:
                        best, best_key = float(ao_low[i, j]), key
            out[y, x] = num / den if den >= UPSAMPLE_MIN_WEIGHT else best
    return out.astype(np.float32)

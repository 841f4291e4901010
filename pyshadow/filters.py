"""Edge-aware filtering and upsampling of a screen-space AO image.

Stage "bilateral filter" of the pipeline (README.md, the table of stages): the AO
image computed with few samples per pixel is noisy; these filters average it
over neighbours that lie on the same surface, which they recognise from the
G-buffer (depth and normal) rather than from the noisy AO itself (seed 002,
section 4.5). The kernels are in ``kernels/filters.cl``; every one has a
NumPy reference (``*_reference``, float64, small images only) in
:mod:`pyshadow.filters_reference`, re-exported here. Both validate their
arguments through :mod:`pyshadow.filters_validate`.

Conventions shared by every function of this module
----------------------------------------------------
* Images are ``(H, W)`` arrays, row 0 at the top; pixel ``(y, x)`` is row
  ``y``, column ``x``.
* ``ao`` : float (H, W), AO in [0, 1] (1 = fully open, as everywhere). Any finite
  value is filtered alike; NaN/inf are rejected where the depth is finite.
* ``depth`` : float (H, W), distance from the eye along the pixel's ray in
  world units (as :func:`pyshadow.render_gbuffer` returns it), ``> 0``
  (at least the smallest normal float32, 1.2e-38);
  ``+inf`` marks background (no surface). NaN, ``-inf`` and values ``<= 0``
  are rejected.
* ``normal`` : float (H, W, 3), unit world-space normals (within 1e-2 of unit
  length wherever the depth is finite, and scaled to unit length where off it by
  more than float32 rounding; anything, e.g. zeros, on background).
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
* Computation is in float32 on the device; outputs are float32 (H, W). The
  means are summed as differences from the centre pixel's value (in
  :func:`upsample`, from the first surface tap's), so a constant image comes
  out unchanged, bit for bit.

Functions validate every argument before anything is launched; an invalid one
raises ``ValueError`` (``TypeError`` for a wrong type) that quotes the value.
"""
from __future__ import annotations

import numpy as np
import pyopencl as cl

from . import _cl
from ._compat import keyword_only
from .filters_reference import (
    bilateral_reference,
    edge_aware_box_reference,
    separable_reference,
    upsample_reference,
)
from .filters_validate import (
    MAX_RADIUS,
    MAX_UPSAMPLE_RADIUS,
    UPSAMPLE_MIN_WEIGHT,
    UPSAMPLE_SCALES,
    bilateral_inputs,
    box_inputs,
    check_flag,
    low_res_shape,
    upsample_inputs,
)

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

# inverse sigmas go to the device clamped to this range, so that no product in
# the weight is 0 * inf (see kernels/filters.cl); it changes no weight that
# float32 can tell apart from 0 or 1 for sigmas in [1e-18, 1e30]
_INV_SIGMA_RANGE = (1e-30, 1e18)
#: the range terms' default sigmas of bilateral and upsample (relative depth, 1 - n.n); pyshadow.ao_pass reads them
SIGMA_DEPTH, SIGMA_NORMAL = 0.02, 0.2


def _inv(sigma: float) -> np.float32:
    return np.float32(min(max(1.0 / sigma, _INV_SIGMA_RANGE[0]), _INV_SIGMA_RANGE[1]))


def _planes(normal: np.ndarray) -> np.ndarray:
    """(H, W, 3) normals -> (3, H, W), one contiguous plane per component (the
    lane kernels read the normals of consecutive pixels as whole vectors)."""
    return np.ascontiguousarray(np.moveaxis(normal, -1, 0))


def _run_passes(names, defines: dict, image: np.ndarray, guides, scalars, size) -> np.ndarray:
    """Run the ``filters.cl`` kernels ``names`` in turn over the 2-D range ``size(lanes)``.

    Every kernel takes ``(src, *guides, *scalars, dst)``: the first reads
    ``image`` (float32, any 2-D shape the kernel expects), each later one the
    float32 (H, W) output of the one before; all read the float32 arrays
    ``guides``, the first of them the full-res depth (H, W). The kernels
    are built with ``LANES`` = :func:`pyshadow._cl.lanes` and launched over
    ``size(LANES)`` work-items (see the kernels' comment), local size None.

    Returns
    -------
    ndarray, shape (H, W), float32
        The output of the last kernel.
    """
    H, W = guides[0].shape
    q = _cl.queue()
    lanes = _cl.lanes()
    defines = {**defines, "LANES": lanes}
    src_b = _cl.to_device(image)
    guide_b = [_cl.to_device(g) for g in guides]
    for name in names:
        dst_b = _cl.empty(4 * H * W)
        _cl.kernel("filters.cl", name, defines)(q, size(lanes), None, src_b, *guide_b, *scalars,
                                                 dst_b)
        src_b = dst_b
    out = np.empty((H, W), np.float32)
    cl.enqueue_copy(q, out, src_b)
    return out


def _value_scale(image: np.ndarray, surf: np.ndarray, fill: float = 0.0) -> float:
    """A power of two that brings the largest ``|value|`` of ``image`` where ``surf`` (and ``|fill|``)
    down to ``2**100`` (1.3e30); where the values are all below ``2**-100`` (7.9e-31, but not all 0),
    one that brings them up (their largest, or ``|fill|`` if larger, to ``2**100``; at most ``2**126``);
    1 otherwise.

    The kernels sum up to 65 x 65 weighted taps in float32: values beyond about
    8e34 overflowed there to inf (an edge-aware box over values of 1e37: 84 of
    240 pixels inf, every pixel for values of 3e38) although their mean is
    finite; values near float32's smallest made subnormal products that kept
    few bits (an upsampling of values of 2**-141 .. 2**-140 came out up to 12
    subnormal ulps, 3 %, off the reference; of values of 2**-149 .. 2**-148,
    0 at 28 of 231 pixels). A weighted mean scales with its values, and a power of
    two changes no significand: the filter of the scaled image, scaled back, is
    the filter's answer (values below ``2**-126 / scale`` become subnormal and keep
    fewer bits).
    """
    values = float(np.max(np.abs(image), where=surf, initial=0.0))
    top = max(values, abs(fill))
    if top > 2.0 ** 100:
        return float(2.0 ** (100 - np.ceil(np.log2(top))))
    if 0.0 < values < 2.0 ** -100:
        return float(2.0 ** min(126.0, 100 - np.ceil(np.log2(top))))
    return 1.0


def _scaled(image: np.ndarray, scale: float, surf: np.ndarray) -> np.ndarray:
    """``image`` times ``scale`` where ``surf``, 0 elsewhere (background is never read, and a value
    there must not overflow when tiny surface values scale up); ``image`` itself for ``scale = 1``."""
    return image if scale == 1.0 else np.where(surf, image, np.float32(0.0)) * np.float32(scale)


def _unscale(out: np.ndarray, scale: float, background: np.ndarray, kept) -> np.ndarray:
    """``out / scale``, with ``kept`` (the unscaled input or ``fill``) restored where ``background``."""
    if scale != 1.0:
        out = out / np.float32(scale)
        out[background] = kept[background] if isinstance(kept, np.ndarray) else kept
    return out


def _row_range(W: int, H: int):
    """The range of the bilateral and box kernels: LANES pixels of a row a work-item."""
    return lambda lanes: (-(-W // lanes), H)


# --------------------------------------------------------------------------
# Bilateral filter
# --------------------------------------------------------------------------
@keyword_only("pyshadow.bilateral", old=4)
def bilateral(ao, depth, normal, *, radius=None, sigma_spatial=2.0, sigma_depth=SIGMA_DEPTH,
              sigma_normal=SIGMA_NORMAL, separable=False) -> np.ndarray:
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
    ao, depth, normal, radius, ss, sz, sn = bilateral_inputs(
        ao, depth, normal, radius, sigma_spatial, sigma_depth, sigma_normal)
    check_flag("separable", separable)
    H, W = depth.shape
    if radius == 0:
        return ao.copy()
    passes = ("bilateral_rows", "bilateral_cols") if separable else ("bilateral_2d",)
    k = _value_scale(ao, np.isfinite(depth))
    out = _run_passes(passes, {"RADIUS": radius}, _scaled(ao, k, np.isfinite(depth)),
                      (depth, _planes(normal)),
                      (np.int32(W), np.int32(H), _inv(ss), _inv(sz), _inv(sn)), _row_range(W, H))
    return _unscale(out, k, ~np.isfinite(depth), ao)


# --------------------------------------------------------------------------
# Edge-aware box filter (seed 002, section 4.5)
# --------------------------------------------------------------------------
@keyword_only("pyshadow.edge_aware_box")
def edge_aware_box(ao, depth, normal, *, size=7, depth_threshold=0.02,
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
    >>> round(float(edge_aware_box(np.eye(3, dtype=np.float32), d, n, size=3)[1, 1]), 6)
    0.333333
    """
    ao, depth, normal, size, dt, nt = box_inputs(ao, depth, normal, size, depth_threshold,
                                                 normal_threshold)
    H, W = depth.shape
    with np.errstate(over="ignore"):    # a threshold beyond float32's range is +inf there, as in the reference
        dt32 = np.float32(dt)           # (the cast's RuntimeWarning was an error under -W error)
    k = _value_scale(ao, np.isfinite(depth))
    out = _run_passes(("edge_aware_box",), {"HALF": size // 2},
                      _scaled(ao, k, np.isfinite(depth)), (depth, _planes(normal)),
                      (np.int32(W), np.int32(H), dt32, np.float32(nt)), _row_range(W, H))
    return _unscale(out, k, ~np.isfinite(depth), ao)


# --------------------------------------------------------------------------
# Joint bilateral upsampling
# --------------------------------------------------------------------------
@keyword_only("pyshadow.upsample", old=5)
def upsample(ao_low, depth, normal, *, scale=None, radius=2, sigma_spatial=None, sigma_depth=SIGMA_DEPTH,
             sigma_normal=SIGMA_NORMAL, fill=1.0) -> np.ndarray:
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
    M. Uyttendaele, "Joint Bilateral Upsampling", SIGGRAPH 2007. The range term is the same depth
    and normal term as :func:`bilateral` (seed 002, eq. 3.6 with section
    4.5's geometric edges).

    Examples
    --------
    >>> d = np.full((6, 8), 4.0, np.float32)
    >>> n = np.zeros((6, 8, 3), np.float32); n[..., 0] = 1
    >>> upsample(np.full((3, 4), 0.5, np.float32), d, n).shape
    (6, 8)
    """
    ao_low, depth, normal, scale, radius, ss, sz, sn, fill = upsample_inputs(
        ao_low, depth, normal, scale, radius, sigma_spatial, sigma_depth, sigma_normal, fill)
    H, W = depth.shape
    Hl, Wl = ao_low.shape
    defines = {"SCALE": scale, "RADIUS": radius, "MIN_WEIGHT": UPSAMPLE_MIN_WEIGHT}
    # the guide at the samples, (Hl, Wl) and (3, Hl, Wl): the kernel reads its
    # taps for consecutive low-res columns as whole vectors
    guides = (depth, normal, np.ascontiguousarray(depth[::scale, ::scale]),
              _planes(normal[::scale, ::scale]))
    k = _value_scale(ao_low, np.isfinite(guides[2]), fill)
    out = _run_passes(("upsample_joint_bilateral",), defines,
                      _scaled(ao_low, k, np.isfinite(guides[2])), guides,
                      (np.int32(W), np.int32(H), np.int32(Wl), np.int32(Hl),
                       _inv(ss), _inv(sz), _inv(sn), np.float32(fill * k)),
                      lambda lanes: (scale * -(-Wl // lanes), H))
    return _unscale(out, k, ~np.isfinite(depth), np.float32(fill))

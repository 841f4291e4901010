"""NumPy mirrors of the CSM kernels: compression, footprint intervals, the segment search, the vote.

Small and float64 (or float32 where the kernel's roundings matter); the
kernels are tested against these bit for bit where the text says so.
"""
from __future__ import annotations

import numpy as np

from .._validate import check_int, check_rows, check_values, flag, real_scalar
from .build import check_depth_bits, footprint_scale
from .core import (DEFAULT_BIAS_TAN, DEFAULT_BIAS_TEXELS, DEPTH_Q, MISS16, PLANE_BIAS_TEXELS, front_margin,
                   query_indices, slope_slack)
from .surface_rule import SURFACE_LIFT_TEXELS

__all__ = ["compress_reference", "footprint_interval", "map_intervals", "miss_key", "second_bound", "second_slope",
           "segment_index_reference", "shadow_taps", "shadow_vote"]


def _depths(a, name):
    """Depth maps as float32: real numbers, each in [0, +inf] (+inf: no hit); ValueError or TypeError naming
    ``name`` (a negative depth or -inf wrapped around the 16-bit keys and was clamped to 0 at 32 bits,
    complex depths lost their imaginary part, strings were parsed)."""
    a = np.asarray(a)
    if a.dtype.kind not in "iuf":
        raise TypeError(f"{name} must hold real numbers (normalised depths), got dtype {a.dtype}")
    a = a.astype(np.float32)
    for bad, what in ((np.isnan(a), "NaN"), (a < 0, "negative")):
        n = int(np.count_nonzero(bad))
        if n:
            raise ValueError(f"{name}: {n} depths are {what} (depths lie in [0, 1]; +inf marks a ray with "
                             f"fewer hits), first at index {tuple(np.argwhere(bad)[0].tolist())}")
    return a


def _flags(a, name):
    """A bool array; TypeError naming ``name`` for any other dtype (the strings "False" and 0.5 were True)."""
    a = np.asarray(a)
    if a.dtype != bool:
        raise TypeError(f"{name} must be a bool array (render_depth(..., facing=True)), got dtype {a.dtype}")
    return a


def _keys_at_or_above(z, depth_bits):
    """Smallest depth key >= z (z >= 0, float32), as csm_common.h; int64."""
    z = np.asarray(z, np.float32)
    if depth_bits == 16:
        # float64 holds z * Q exactly (24 + 16 bits): its ceiling is the exact one
        return np.minimum(np.ceil(np.minimum(z, 1).astype(np.float64) * DEPTH_Q), DEPTH_Q).astype(np.int64)
    return np.maximum(z, np.float32(0)).view(np.uint32).astype(np.int64)


def _keys_below(z, depth_bits):
    """Largest depth key < z, -1 when there is none (the kernel's (uint)-1)."""
    k = _keys_at_or_above(z, depth_bits) - 1
    if depth_bits == 16:
        k = np.where(np.asarray(z, np.float32) > 1, DEPTH_Q, k)
    return k


def _texel_slope(z, margin, deeper):
    """``min(0.5 (gx + gy), margin)`` per texel of one map's layer ``z`` (R, R) float32: ``gx`` the larger
    step to a left or right neighbour with a surface (nearer: ``z - zn``, ``deeper``: ``zn - z``, at least 0),
    ``gy`` the same over rows; ``margin`` where an axis has no such neighbour."""
    f = np.float32
    z = np.asarray(z, f)
    pad = np.pad(z, 1, constant_values=np.inf)

    def axis(a, b):
        with np.errstate(invalid="ignore"):
            da = np.where(np.isfinite(a), np.maximum((a - z) if deeper else (z - a), f(0)), f(-1))
            db = np.where(np.isfinite(b), np.maximum((b - z) if deeper else (z - b), f(0)), f(-1))
        return np.maximum(da, db).astype(f)

    gx = axis(pad[1:-1, :-2], pad[1:-1, 2:])
    gy = axis(pad[:-2, 1:-1], pad[2:, 1:-1])
    with np.errstate(invalid="ignore"):
        s = np.minimum((f(0.5) * (gx + gy)).astype(f), f(margin))
    return np.where((gx < 0) | (gy < 0), f(margin), s).astype(f)


def first_slope(z1, margin):
    """NumPy version of ``first_slope`` (csm.cl): how much deeper than z1 its surface goes in each texel.

    :func:`second_slope`'s rule with the step deeper, ``max(z1(neighbour) -
    z1, 0)``, over neighbours that have a first surface: where the ray runs
    through free space behind ``z1``, a map's interval ends this far behind
    it (:func:`compress_reference`).

    Parameters
    ----------
    z1 : ndarray, shape (R, R), float32
        One map's first depth layer (``+inf`` where a ray meets nothing).
    margin : float
        :func:`front_margin` (normalised depth): the cap.

    Returns
    -------
    ndarray, shape (R, R), float32
    """
    return _texel_slope(z1, margin, True)


def second_slope(z2, margin):
    """NumPy version of ``second_slope`` (csm.cl): how much nearer than z2 its surface comes in each texel.

    Parameters
    ----------
    z2 : ndarray, shape (R, R), float32
        One map's second depth layer (``+inf`` where a ray has no second hit).
    margin : float
        :func:`front_margin` (normalised depth): the cap.

    Returns
    -------
    ndarray, shape (R, R), float32
        ``min(0.5 (gx + gy), margin)``: ``gx`` the larger ``max(z2 -
        z2(neighbour), 0)`` over the texel's left and right neighbours that
        have a second surface, ``gy`` the same over the rows above and
        below; ``margin`` where an axis has no such neighbour. For a plane
        ``0.5 (gx + gy)`` is exactly its depth change from the texel's
        centre to its nearest corner. Meaningless where ``z2`` is ``+inf``.
    """
    return _texel_slope(z2, margin, False)


def second_bound(z1, z2, asked, margin, slack=None):
    """The upper end ``z2'`` of one map's interval where its ray meets two surfaces, float32 (csm.cl).

    Parameters
    ----------
    z1, z2 : ndarray, shape (R, R), float32
        The map's first and second depth layers.
    asked : bool or ndarray of bool, shape (R, R)
        Where the second surface is asked with a self-bias: it faces the
        light, or the mesh is open.
    margin : float
        :func:`front_margin` (normalised depth): the slope term's cap, and
        added where ``asked``.
    slack : float, optional
        :func:`slope_slack` by default.

    Returns
    -------
    ndarray, shape (R, R), float32
        ``max(z2 - m2, z1)`` with ``m2 = second_slope(z2, margin) + slack
        (+ margin where asked)``; meaningful where ``z2`` is finite.
    """
    f = np.float32
    z1, z2 = np.asarray(z1, f), np.asarray(z2, f)
    m2 = (second_slope(z2, margin) + f(slope_slack() if slack is None else slack)).astype(f)
    m2 = np.where(asked, (m2 + f(margin)).astype(f), m2).astype(f)
    with np.errstate(invalid="ignore"):
        return np.maximum((z2 - m2).astype(f), z1).astype(f)


def footprint_interval(z1, hic, c1, c2, c2_front, margin, scale):
    """NumPy version of ``footprint_keys`` (csm.cl) before the keys, float32.

    Parameters
    ----------
    z1, hic : ndarray, shape (T,), float32
        The centre's first depth and upper end ``z2'`` (finite).
    c1, c2 : ndarray, shape (T, 4), float32
        First and second depth at the texel's corners, corner-grid entries
        ``(row, col), (row, col+1), (row+1, col), (row+1, col+1)``, in the
        corner frame; ``+inf`` for none.
    c2_front : ndarray, shape (T, 4), bool
        The second corner surface is asked with a self-bias: it faces the
        light, or the mesh is open.
    margin : float
        :func:`front_margin` (normalised depth): a second corner surface
        that faces the light bounds the interval this far in front of it.
    scale : float
        :func:`footprint_scale` of ``R``.

    Returns
    -------
    lo, hi : ndarray, shape (T,), float32
        The footprint interval ``[lo, hi)``: ``lo`` is the largest of ``z1``
        and the corners' first depths below ``hic``; ``hi`` the smallest of
        ``hic`` and the corners' second depths above ``lo``. So ``z1 <= lo
        <= hi <= hic``; where no depth key lies in ``[lo, hi)`` the build
        keeps the centre's interval.
    """
    f = np.float32
    half = f(0.5)
    with np.errstate(invalid="ignore"):
        d1 = np.where(np.isfinite(c1), half - f(scale) * (half - c1), np.inf).astype(f)
        d2 = np.where(np.isfinite(c2), half - f(scale) * (half - c2), np.inf).astype(f)
        d2 = np.where(np.isfinite(d2) & c2_front, np.maximum(d2 - f(margin), d1), d2).astype(f)
    lo = np.maximum(z1, np.where(d1 < hic[:, None], d1, -np.inf).max(axis=1)).astype(f)
    hi = np.minimum(hic, np.where(np.isfinite(d2) & (d2 > lo[:, None]), d2, np.inf).min(axis=1)).astype(f)
    return lo, hi


def _interval_inputs(layers, front, rule, depth_bits, margin_depth, corners, corner_front, two_sided, open_air):
    """compress_reference's arguments checked and normalised (the same errors, in the same order)."""
    if not (real_scalar(rule) and rule in (2, 3)):
        raise ValueError(f"rule must be 2 or 3, got {rule!r}")
    check_depth_bits(depth_bits)
    layers = _depths(layers, "layers")
    front = _flags(front, "front")
    if layers.ndim != 4 or layers.shape[2] != layers.shape[3] or 0 in layers.shape:
        raise ValueError(f"layers must have shape (D, L, R, R) with D, L, R >= 1, got {layers.shape}")
    D, L, R = layers.shape[0], layers.shape[1], layers.shape[2]
    if corners is not None:
        if corner_front is None:
            raise ValueError("corner_front must be given with corners (the corner maps' facing flags)")
        corners, corner_front = _depths(corners, "corners"), _flags(corner_front, "corner_front")
        if corners.shape[:2] != (D, L) or corners.shape[2:] != (R + 1, R + 1) or corner_front.shape != corners.shape:
            raise ValueError(f"corners and corner_front must have shape {(D, L, R + 1, R + 1)}, got "
                             f"{corners.shape} and {corner_front.shape}")
    if L < rule:
        raise ValueError(f"rule {rule} needs {rule} layers, got {L}")
    if front.shape != layers.shape:
        raise ValueError(f"front has shape {front.shape}, layers {layers.shape}")
    if margin_depth is None:
        margin = front_margin(R)
    elif real_scalar(margin_depth) and np.float32(margin_depth) >= 0 and np.isfinite(np.float32(margin_depth)):
        margin = np.float32(margin_depth)
    else:       # NaN was cast to a key with a RuntimeWarning; a negative margin moved z2' behind z2
        raise ValueError(f"margin_depth must be a finite number >= 0 (normalised depth), got {margin_depth!r}")
    two_sided, open_air = flag(two_sided, "two_sided"), flag(open_air, "open_air")
    return layers, front, rule, depth_bits, margin, corners, corner_front, two_sided, open_air


def miss_key(depth_bits: int) -> int:
    """The depth key of a texel that sees nothing: 16-bit ``MISS16``, or the bits of float32 +inf at 32 bits."""
    return MISS16 if depth_bits == 16 else int(np.float32(np.inf).view(np.uint32))


def _intervals(layers, front, rule, depth_bits, margin, corners, corner_front, two_sided, open_air):
    """Each map's keys per texel, in view-set order: (lo, hi2, hi3), int64 (R*R,) each (checked inputs)."""
    D, R = layers.shape[0], layers.shape[2]
    miss = miss_key(depth_bits)
    for i in range(D):
        z1, z2 = layers[i, 0].ravel(), layers[i, 1].ravel()
        hit, two = np.isfinite(z1), np.isfinite(z2)
        mlo = np.where(hit, _keys_at_or_above(np.where(hit, z1, 0), depth_bits), miss)
        front2 = front[i, 1].ravel()
        z2b = second_bound(layers[i, 0], layers[i, 1], front[i, 1] | two_sided, margin).ravel()
        air = two & (two_sided | ~front[i, 0].ravel() | (open_air & front2))       # free space behind z1
        with np.errstate(invalid="ignore"):
            z1s = (layers[i, 0] + first_slope(layers[i, 0], margin)).astype(np.float32).ravel()
        z2b = np.where(air, np.minimum(z2b, z1s), z2b)
        k2 = _keys_below(np.where(two, z2b, 0), depth_bits)
        mhi2 = np.where(two & (k2 >= mlo), k2, mlo)   # hit once, or no key below the bound: {z1}
        if corners is not None:
            c1, c2, cf = (np.stack([a[i, layer, r:r + R, c:c + R].ravel() for r in (0, 1) for c in (0, 1)], 1)
                          for a, layer in ((corners, 0), (corners, 1), (corner_front, 1)))
            use = hit & two
            flo, fhi = footprint_interval(np.where(use, z1, 0), np.where(use, z2b, 1), c1, c2, cf | two_sided, margin,
                                          footprint_scale(R))
            klo = _keys_at_or_above(flo, depth_bits)
            khi = _keys_below(fhi, depth_bits)
            use &= khi >= klo
            mlo = np.where(use, klo, mlo)
            mhi2 = np.where(use, khi, mhi2)
        mhi3 = mhi2
        if rule == 3:
            z3 = layers[i, 2].ravel()
            z3m = z3 - margin
            re_enter = two & ~air & ~front2 & np.isfinite(z3) & (z3m > z2)
            mhi3 = np.where(re_enter, np.maximum(_keys_below(np.where(re_enter, z3m, 0), depth_bits), mhi2),
                            mhi2)
        yield mlo, mhi2, mhi3


def map_intervals(layers, front, rule: int = 2, depth_bits: int = 16, margin_depth=None, corners=None,
                  corner_front=None, two_sided: bool = False, open_air: bool = False):
    """The interval of every map and texel that :func:`compress_reference` joins into runs.

    Takes the arguments of :func:`compress_reference` (and raises its errors
    at the call). Returns an iterator over the maps in view-set order, each
    item ``(lo, hi2, hi3)``: int64 arrays of shape (R*R,) of depth keys (the
    16-bit depth ``k``, or a float32's bits at 32 bits). A run of maps can
    share one stored depth at a texel while ``max(lo) <= min(hi3)`` over its
    maps; ``lo`` is the miss key (:func:`miss_key`) where the texel sees nothing.
    """
    return _intervals(*_interval_inputs(layers, front, rule, depth_bits, margin_depth, corners, corner_front,
                                        two_sided, open_air))


def compress_reference(layers, front, rule: int = 2, depth_bits: int = 16, margin_depth=None,
                       corners=None, corner_front=None, two_sided: bool = False, open_air: bool = False):
    """NumPy version of the compression kernel: greedy runs per texel, in map order.

    Parameters
    ----------
    layers : ndarray, shape (D, L, R, R), float32
        Depth layers in view-set order (:func:`pyshadow.render_depth` with
        ``L >= rule``): normalised depths in [0, 1], ``+inf`` where a ray
        has fewer hits.
    front : ndarray, shape (D, L, R, R), bool
        Which layers face the light (``render_depth(..., facing=True)``).
        Where the first surface does not, or ``two_sided``, or
        ``open_air`` and the second one is ``front``, the ray runs through
        free space behind ``z1`` (a room's wall seen from outside, a bowl's
        hollow): the interval also ends :func:`first_slope` behind ``z1``,
        and ``rule=3`` keeps ``[z1, z2)`` there.
    rule : {2, 3}
        Interval rule, as ``layers`` of :meth:`CoherentShadowMap.build`.
    depth_bits : {16, 32}
    margin_depth : float, optional
        The margin in front of a surface asked with a self-bias (normalised
        depth), on top of z2's slope term (:func:`second_bound`); default
        :func:`front_margin` of ``R``, as the build uses.
    corners, corner_front : ndarray, shape (D, L, R+1, R+1), optional
        The footprint build's corner maps (:func:`footprint_corners`);
        given, each map's interval is narrowed as in
        ``CoherentShadowMap.build(..., footprint=True)``.
    two_sided : bool, optional
        Every second surface is asked, as ``CoherentShadowMap.build(...,
        two_sided=True)``.
    open_air : bool, optional
        The mesh is mostly open (:func:`pyshadow.csm.exposure.open_sheet`
        of the faces marked in ``front``): the build's ``OPEN_AIR``.

    Returns
    -------
    offsets : ndarray, shape (R*R + 1,), int64
    iend : ndarray, shape (S,), int64
    depth : ndarray, shape (S,), uint16 or float32
        The arrays of :meth:`CoherentShadowMap.build` for the same maps,
        bit for bit.

    Raises
    ------
    TypeError
        Depths that are no real numbers, facing flags that are not bool,
        ``two_sided`` not True or False.
    ValueError
        Shapes that do not match, depths that are NaN or negative, a
        ``margin_depth`` that is not a finite number >= 0, ``corners``
        without ``corner_front``.
    """
    args = _interval_inputs(layers, front, rule, depth_bits, margin_depth, corners, corner_front, two_sided,
                            open_air)
    layers, depth_bits = args[0], args[3]
    D, R = layers.shape[0], layers.shape[2]
    miss = miss_key(depth_bits)
    T = R * R
    lo = hi2 = hi3 = np.zeros(T, np.int64)
    started = False
    emitted = []                                    # (texels, i_end, stored values) per emission

    def value(lo, hi2, hi3):
        hi = np.where(lo <= hi2, hi2, hi3)
        if depth_bits == 16:
            return ((lo + hi) >> 1).astype(np.uint16)
        a = lo.astype(np.uint32).view(np.float32)
        b = hi.astype(np.uint32).view(np.float32)
        with np.errstate(invalid="ignore"):
            m = (a + (b - a) * np.float32(0.5)).view(np.uint32).astype(np.int64)
        m = np.where(lo == miss, lo, np.clip(m, lo, hi))
        return m.astype(np.uint32).view(np.float32)

    for i, (mlo, mhi2, mhi3) in enumerate(_intervals(*args)):
        if started:
            nlo, nhi3 = np.maximum(lo, mlo), np.minimum(hi3, mhi3)
            join = nlo <= nhi3
            out = np.flatnonzero(~join)
            emitted.append((out, i - 1, value(lo[out], hi2[out], hi3[out])))
            lo = np.where(join, nlo, mlo)
            hi2 = np.where(join, np.minimum(hi2, mhi2), mhi2)
            hi3 = np.where(join, nhi3, mhi3)
        else:
            lo, hi2, hi3, started = mlo, mhi2, mhi3, True
    emitted.append((np.arange(T), D - 1, value(lo, hi2, hi3)))
    texel = np.concatenate([e[0] for e in emitted])
    iend = np.concatenate([np.full(len(e[0]), e[1], np.int64) for e in emitted])
    depth = np.concatenate([e[2] for e in emitted])
    order = np.lexsort((iend, texel))
    offsets = np.zeros(T + 1, np.int64)
    np.cumsum(np.bincount(texel, minlength=T), out=offsets[1:])
    return offsets, iend[order], depth[order]


def segment_index_reference(csm, map_index, rows, cols) -> np.ndarray:
    """NumPy version of :meth:`segment_index` (searchsorted per texel), int64 (N,) for the N broadcast
    queries; the indices are checked as there (:func:`pyshadow.csm.core.query_indices`)."""
    m, r, c, _ = query_indices(csm, map_index, rows, cols)
    t = r * csm.resolution + c
    out = np.empty(len(m), np.int64)
    for i, (tt, mm) in enumerate(zip(t, m)):
        a, b = int(csm.offsets[tt]), int(csm.offsets[tt + 1])
        out[i] = a + np.searchsorted(csm.iend[a:b], mm, side="left")
    return out


def _tan_to_axis(v, axis):
    """tan of the angle between unit rows ``v`` and ``axis``, its cosine clamped to [1e-3, 1] (``bias_v``)."""
    c = np.clip(np.einsum("ij,ij->i", v, axis), 1e-3, 1.0)
    return np.sqrt(np.maximum(1.0 - c * c, 0.0)) / c


def _lift(normals, rows, B, R):
    """The surface rule's lift of each row in the maps with bases ``B`` (normalised units), for a bias
    given by the caller (no self-bias texels: with the default bias the receiver's plane applies instead)."""
    sd = np.einsum("ij,ij->i", normals, B[:, 2])
    lt = np.abs(np.einsum("ij,ij->i", normals, B[:, 0])) + np.abs(np.einsum("ij,ij->i", normals, B[:, 1]))
    h = SURFACE_LIFT_TEXELS * lt * (2.0 / R)
    return np.where(rows & (sd > 0), h, 0.0)


def _plane_slopes(normals, B, shift, R):
    """The receiver's plane in maps with bases ``B``: its depth grows by ``(pu dx + pv dy + pe) / R``
    (normalised depth) at ``(dx, dy)`` texels from the texel point, whose offset from the point is
    ``shift`` (normalised units; zero but for finite rays). The normal's cosine to the axis is clamped to
    [1e-3, 1] (``map_frame_v``)."""
    od = np.clip(np.einsum("ij,ij->i", normals, B[:, 2]), 1e-3, 1.0)
    pu = np.einsum("ij,ij->i", normals, B[:, 0]) / od
    pv = np.einsum("ij,ij->i", normals, B[:, 1]) / od
    pe = -(pu * np.einsum("ij,ij->i", shift, B[:, 0]) + pv * np.einsum("ij,ij->i", shift, B[:, 1])) * (0.5 * R)
    return pu, pv, pe


def shadow_vote(csm, pn, wn, maps, map_weights, *, quantum: float, texels: int = 1,
                self_=True, bias: float | None = None, bias_texels: float = DEFAULT_BIAS_TEXELS,
                normals=None, lift=None, texel_points=None, beyond=None) -> np.ndarray:
    """Weighted shadowing vote of a CSM's taps for points and directions in its frame (NumPy).

    The rule of the visibility kernel (``instance16``) for one caster, in
    float64: each point is asked in the maps ``maps[:, m]`` with weights
    ``map_weights[:, m]``, at the texel holding it (``texels=1``) or at the
    four texels around it with bilinear weights of the texel centres, border
    texels repeated (``texels=4``); a tap votes "shadowed" when the point's
    depth exceeds the stored depth plus the bias.

    Parameters
    ----------
    csm : CoherentShadowMap
    pn, wn : ndarray, shape (N, 3)
        Points in the CSM's normalised frame (its bounding sphere centred at
        the origin with radius 1) and unit directions in its frame.
    maps, map_weights : ndarray, shape (N, M)
        Map indices (int) and their weights.
    quantum : float
        Depth quantum plus rounding slack, normalised depth units.
    texels : {1, 4}
    self_ : bool or ndarray of bool, shape (N,)
        Where the point may lie on this caster, the self-bias
        ``quantum + (bias_texels + DEFAULT_BIAS_TAN * tan a) / R`` applies
        (``a`` the angle between direction and map axis); elsewhere ``quantum``.
    bias : float, optional
        One fixed bias for every tap instead.
    bias_texels : float, optional
    normals : ndarray, shape (N, 3), optional
        Unit surface normals in the CSM's frame, for the surface rule
        (:mod:`pyshadow.csm.surface_rule`) of the rows where ``lift`` is True:
        with the default bias (``bias`` None) each tap's bias follows the
        plane through the point with its normal (the receiver's plane), else
        the point is lifted off the surface.
    lift : ndarray of bool, shape (N,), optional
        The rows of the surface rule (default: none).
    texel_points : ndarray, shape (N, 3), optional
        Where each point's texel is taken, normalised frame (default ``pn``;
        a point before its chord through the caster: the chord's midpoint,
        :func:`pyshadow.visibility.mirror.caster_occludes`).
    beyond : ndarray of bool, shape (N,), optional
        Rows of points outside the caster's sphere on none of its surfaces
        (:func:`pyshadow.visibility.mirror.caster_occludes`): asked with the
        depth 2, behind every stored one (default: none).

    Returns
    -------
    ndarray, shape (N,), float64
        The summed weights of the shadowing taps; the caster shadows a ray
        where this exceeds one half.

    Raises
    ------
    TypeError
        ``texels`` not an int, ``maps`` not integers.
    ValueError
        Rows that are not finite or not (N, 3), ``maps`` outside the view
        set or of another shape than ``map_weights`` (N, M), a quantum or
        bias that is not a finite number, ``lift`` not a bool (N,) array.
    """
    R, D = csm.resolution, csm.maps
    # global keys texel * D + i_end are sorted: one searchsorted finds every segment
    keys = (np.repeat(np.arange(R * R), np.diff(np.asarray(csm.offsets, dtype=np.int64))) * D
            + np.asarray(csm.iend, dtype=np.int64))
    depths = np.asarray(csm.depth)
    vote = np.zeros(len(pn))
    for k, tex, _, _, depth, b, inside, weight in shadow_taps(
            csm.views, R, pn, wn, maps, map_weights, quantum=quantum, texels=texels, self_=self_, bias=bias,
            bias_texels=bias_texels, normals=normals, lift=lift, texel_points=texel_points, beyond=beyond):
        seg = np.searchsorted(keys, np.where(inside, tex, 0) * D + k)
        z = csm.stored_to_depth(depths[np.minimum(seg, len(keys) - 1)])
        vote += weight * (inside & (depth > z + b))
    return vote


def shadow_taps(views, R, pn, wn, maps, map_weights, *, quantum: float, texels: int = 1, self_=True,
                bias: float | None = None, bias_texels: float = DEFAULT_BIAS_TEXELS, normals=None, lift=None,
                texel_points=None, beyond=None):
    """The taps of :func:`shadow_vote`, one at a time, whatever answers them.

    Yields, per map column and texel tap, ``(k, tex, col, row, depth, b,
    inside, weight)``: map index (N,), texel index ``row * R + col`` and its
    column and row (N,) int64, the asked point's normalised depth in map
    ``k`` (N,), the bias (N,) or scalar, whether the point lies in the map's
    square, and the tap's weight (map weight times bilinear weight). A tap
    votes "shadowed" where ``inside`` and the depth exceeds the first
    surface's depth along the texel's centre ray plus ``b``: the stored
    depth in :func:`shadow_vote`, a traced ray in
    :mod:`pyshadow.csm.error_model`. The texel is that of ``texel_points``
    where given (the depth stays that of ``pn``). Rows ``beyond`` (bool (N,),
    optional: points outside the caster's sphere on none of its surfaces,
    :func:`pyshadow.visibility.mirror.caster_occludes`) take the depth 2,
    behind every stored one, so every surface of the texel shadows them.
    """
    if check_int(texels, "texels", 1, 4) == 4:      # texel offsets and their bilinear weights (tx, ty)
        taps = [(0, 0, lambda tx, ty: (1 - tx) * (1 - ty)), (0, 1, lambda tx, ty: tx * (1 - ty)),
                (1, 0, lambda tx, ty: (1 - tx) * ty), (1, 1, lambda tx, ty: tx * ty)]
    elif texels == 1:
        taps = [(0, 0, lambda tx, ty: 1.0)]
    else:
        raise ValueError(f"texels must be 1 or 4, got {texels!r}")
    lift = _check_taps(len(views), pn, wn, maps, map_weights, quantum, bias, bias_texels, normals, lift,
                       texel_points)
    # the receiver's plane (rows `lift` with the default bias): each tap's tolerance is that of the plane
    # through the point with its normal, at the tap's texel centre; the other rows are lifted instead
    plane = normals is not None and bias is None
    for m in range(maps.shape[1]):
        k = maps[:, m]
        B = views.bases[k]
        pt = pn if texel_points is None else texel_points
        if normals is None or plane:
            q, qt = pn, pt
        else:
            h = _lift(normals, lift, B, R)[:, None] * normals
            q, qt = pn + h, pt + h
        depth = (1.0 - np.einsum("ij,ij->i", q, B[:, 2])) * 0.5
        if beyond is not None:
            depth = np.where(beyond, 2.0, depth)
        fx = (np.einsum("ij,ij->i", qt, B[:, 0]) + 1.0) * 0.5 * R
        fy = (np.einsum("ij,ij->i", qt, B[:, 1]) + 1.0) * 0.5 * R
        inside = (depth > 0) & (fx >= 0) & (fx < R) & (fy >= 0) & (fy < R)
        if bias is None:
            tan_a = _tan_to_axis(wn, B[:, 2])
            b = np.where(self_, quantum + (bias_texels + DEFAULT_BIAS_TAN * tan_a) / R, quantum)
        else:
            b = float(bias)
        if plane:
            pu, pv, pe = _plane_slopes(normals, B, q - qt, R)
            base = quantum + (PLANE_BIAS_TEXELS + DEFAULT_BIAS_TAN * tan_a) / R
        gx, gy = (fx - 0.5, fy - 0.5) if texels == 4 else (fx, fy)
        x0, y0 = np.floor(gx), np.floor(gy)
        tx, ty = gx - x0, gy - y0
        for dy, dx, weight in taps:
            col = np.clip(x0.astype(np.int64) + dx, 0, R - 1)
            row = np.clip(y0.astype(np.int64) + dy, 0, R - 1)
            bt = b
            if plane:       # the plane's depth at the tap's centre (cx - fx, cy - fy texels from the point)
                rise = (pu * (x0 + dx + 0.5 - fx) + pv * (y0 + dy + 0.5 - fy) + pe) / R
                bt = np.where(lift, np.maximum(base - rise, quantum), b)
            yield k, row * R + col, col, row, depth, bt, inside, map_weights[:, m] * weight(tx, ty)


def _check_taps(D, pn, wn, maps, map_weights, quantum, bias, bias_texels, normals, lift, texel_points):
    """The checks of :func:`shadow_taps`' arguments (no copy): finite (N, 3) rows, map indices (N, M) of
    the ``D`` maps with weights of the same shape, finite numbers; ``lift`` as a bool (N,) array (None:
    no row). A map index -1 was read as the last map, NaN points were cast to texels with a
    RuntimeWarning, a NaN quantum or bias answered every tap "lit", and ``normals`` with a bias but no
    ``lift`` failed in ``None & bool``."""
    n = len(check_rows(pn, "pn"))
    for a, name in ((pn, "pn"), (wn, "wn"), (normals, "normals"), (texel_points, "texel_points")):
        if a is not None:
            check_values(check_rows(a, name, n), name)
    maps, w = np.asarray(maps), np.asarray(map_weights)
    if maps.dtype.kind not in "iu":
        raise TypeError(f"maps must be integer map indices, got dtype {maps.dtype}")
    if maps.ndim != 2 or len(maps) != n or w.shape != maps.shape:
        raise ValueError(f"maps and map_weights must have shape (N, M) with N = {n} (the points), got "
                         f"{maps.shape} and {w.shape}")
    if maps.size and not (maps.min() >= 0 and maps.max() < D):
        raise ValueError(f"maps must lie in 0 .. {D - 1} (the view set's maps), got {maps.min()} .. {maps.max()}")
    if w.dtype.kind not in "iuf" or not np.isfinite(w).all():
        raise ValueError(f"map_weights must be finite real numbers, got dtype {w.dtype}")
    for x, name in ((quantum, "quantum"), (bias, "bias"), (bias_texels, "bias_texels")):
        if x is not None and not (real_scalar(x) and np.isfinite(x)):
            raise ValueError(f"{name} must be a finite number, got {x!r}")
    if lift is None:
        return np.zeros(n, bool)
    lift = np.asarray(lift)
    if lift.dtype != bool or lift.shape != (n,):
        raise ValueError(f"lift must be a bool array of shape ({n},), got dtype {lift.dtype}, shape {lift.shape}")
    return lift

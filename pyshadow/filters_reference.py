"""NumPy mirrors of the edge-aware AO filters of :mod:`pyshadow.filters`.

One ``*_reference`` function per device filter, same signature, same
validation (:mod:`pyshadow.filters_validate`) and same rules (the module
docstring of :mod:`pyshadow.filters`: images ``(H, W)`` with row 0 at the
top, depth in world units along each pixel's ray with ``+inf`` on background,
unit world-space normals ``(H, W, 3)``, windows cut at the image border),
computed in float64 with whole-image array operations (a per-pixel loop for
:func:`upsample_reference`) and returned as float32 ``(H, W)``. Slow: for the
tests on small images only. All four are re-exported by
:mod:`pyshadow.filters`.
"""
from __future__ import annotations

import numpy as np

from ._compat import keyword_only
from .filters_validate import (
    UPSAMPLE_MIN_WEIGHT,
    bilateral_inputs,
    box_inputs,
    check_flag,
    upsample_inputs,
)

__all__ = [
    "bilateral_reference",
    "separable_reference",
    "edge_aware_box_reference",
    "upsample_reference",
]


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
    """Tap weights (float64) of the module docstring; 0 where zq is background.

    ``ss ** 2`` in float64 (a Python float's raised OverflowError beyond
    ``ss = 1.3e154``, and its 0 below ``1e-162`` ZeroDivisionError): a tap
    at distance 0 has spatial term 0 at every sigma, any other one inf
    where ``ss ** 2`` underflows.
    """
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        rel = np.abs(zq - zp) / zp
        m = np.maximum(0.0, 1.0 - np.sum(np_ * nq, axis=-1))
        d = np.where(dist2 > 0, dist2 / np.float64(ss) ** 2, 0.0)
        w = np.exp(-0.5 * (d + (rel / sz) ** 2 + (m / sn) ** 2))
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


@keyword_only("pyshadow.filters.bilateral_reference", old=4)
def bilateral_reference(ao, depth, normal, *, radius=None, sigma_spatial=2.0, sigma_depth=0.02,
                        sigma_normal=0.2, separable=False) -> np.ndarray:
    """NumPy version of :func:`bilateral` (same rules, float64 arithmetic).

    Sums over every window offset ``(dy, dx) != (0, 0)`` with whole-image
    array operations; off-image taps act as background.
    ``separable=True`` calls :func:`separable_reference`.
    """
    if check_flag("separable", separable):
        return separable_reference(ao, depth, normal, radius=radius, sigma_spatial=sigma_spatial,
                                   sigma_depth=sigma_depth, sigma_normal=sigma_normal)
    ao, depth, normal, r, ss, sz, sn = bilateral_inputs(ao, depth, normal, radius, sigma_spatial,
                                                        sigma_depth, sigma_normal)
    offsets = [(dy, dx) for dy in range(-r, r + 1) for dx in range(-r, r + 1) if (dy, dx) != (0, 0)]
    return _filter_offsets(
        ao, depth, normal, offsets,
        lambda dy, dx, zp, zq, np_, nq: _weights(dy * dy + dx * dx, zp, zq, np_, nq, ss, sz, sn))


@keyword_only("pyshadow.filters.separable_reference")
def separable_reference(ao, depth, normal, *, radius=None, sigma_spatial=2.0, sigma_depth=0.02,
                        sigma_normal=0.2) -> np.ndarray:
    """NumPy version of ``bilateral(..., separable=True)``: rows, then columns.

    The row pass's float32 result feeds the column pass, as on the device.
    """
    ao, depth, normal, r, ss, sz, sn = bilateral_inputs(ao, depth, normal, radius, sigma_spatial,
                                                        sigma_depth, sigma_normal)

    def weight(dy, dx, zp, zq, np_, nq):
        return _weights(dy * dy + dx * dx, zp, zq, np_, nq, ss, sz, sn)

    ks = [k for k in range(-r, r + 1) if k != 0]
    rows = _filter_offsets(ao, depth, normal, [(0, k) for k in ks], weight)
    return _filter_offsets(rows, depth, normal, [(k, 0) for k in ks], weight)


@keyword_only("pyshadow.filters.edge_aware_box_reference")
def edge_aware_box_reference(ao, depth, normal, *, size=7, depth_threshold=0.02,
                             normal_threshold=0.9) -> np.ndarray:
    """NumPy version of :func:`edge_aware_box` (same rules; the mean in float64).

    Which neighbours count is decided in float32 as on the device: the
    quotient ``|z_q - z_p| / z_p`` against ``float32(depth_threshold)`` and
    the dot product ``(x x' + y y') + z z'`` against
    ``float32(normal_threshold)``. Decided in float64, a neighbour within
    float32 rounding of a threshold could count here and not there (433 of
    400,000 depth pairs near the default 0.02, 17,632 of 400,000 normal
    pairs near 0.9: a 1 x 2 image gave 0.5 here, 0 on the device).
    """
    ao, depth, normal, size, dt, nt = box_inputs(ao, depth, normal, size, depth_threshold,
                                                 normal_threshold)
    h = size // 2

    def counted(dy, dx, zp, zq, np_, nq):
        zp, zq = zp.astype(np.float32), zq.astype(np.float32)
        p, q = np_.astype(np.float32), nq.astype(np.float32)
        with np.errstate(all="ignore"):         # background taps (inf, any normal) are dropped below
            dot = (p[..., 0] * q[..., 0] + p[..., 1] * q[..., 1]) + p[..., 2] * q[..., 2]
            same = (np.abs(zq - zp) / zp < np.float32(dt)) & (dot > np.float32(nt))
        return (same & np.isfinite(zq)).astype(np.float64)

    offsets = [(dy, dx) for dy in range(-h, h + 1) for dx in range(-h, h + 1) if (dy, dx) != (0, 0)]
    return _filter_offsets(ao, depth, normal, offsets, counted)


@keyword_only("pyshadow.filters.upsample_reference", old=5)
def upsample_reference(ao_low, depth, normal, *, scale=None, radius=2, sigma_spatial=None,
                       sigma_depth=0.02, sigma_normal=0.2, fill=1.0) -> np.ndarray:
    """NumPy version of :func:`upsample`: a loop over pixels and their taps.

    Weights in float64; the fallback's depth distance ``|z_q - z_p|`` is
    computed in float32, as on the device, so that ties are the same ties.
    """
    ao_low, depth, normal, s, r, ss, sz, sn, fill = upsample_inputs(
        ao_low, depth, normal, scale, radius, sigma_spatial, sigma_depth, sigma_normal, fill)
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

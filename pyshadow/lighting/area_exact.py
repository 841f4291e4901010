"""Exact unshadowed irradiance of the disc and rectangle area lights, with horizon clipping.

The irradiance at a point ``p`` with unit normal ``n`` from a uniform
Lambertian light of radiance ``L`` is ``E_0 = L G`` with the geometric factor

    G = integral over the light of max(n . l, 0) max(-n_L . l, 0) / d^2 dA      (sr)

(``l`` the unit direction from ``p`` to the light point, ``d`` its distance).
The part of the light below the point's tangent plane (``n . (y - p) < 0``)
contributes nothing; for a point in front of the light (``(p - c) . n_L > 0``)
the light's cosine is positive everywhere. ``G`` is the cosine-weighted
solid angle of the light clipped against that plane. By Stokes' theorem the
vector ``integral l dw`` over a region of directions equals ``1/2`` times the
loop integral of ``x x dx / |x|^2`` along the region's boundary curve ``x(s)``
(relative to ``p``; any curve that projects onto the boundary), so

    G = 1/2 * | loop integral of n . (x x dx) / |x|^2 |

along the clipped light's outline; walking the outline counter-clockwise
about ``n_L`` (as seen from the front) gives the negative value.

* Straight edge from ``a`` to ``b``: ``theta n . (a x b) / |a x b|`` with
  ``theta = atan2(|a x b|, a . b)`` the angle it subtends (Lambert's polygon
  formula). The rectangle is clipped by Sutherland-Hodgman against the
  plane ``n . x >= 0``; the clipping edge lies in a plane through ``p``, so it
  adds its signed subtended angle.
* Disc rim ``x(phi) = c - p + R (cos phi e_1 + sin phi e_2)``: the integrand is
  ``(A_0 + C cos psi + S sin psi) / (B_0 + B_m cos psi)`` in ``psi = phi - phi_0``,
  a rational trigonometric function with a closed-form antiderivative
  (``atan`` of ``k tan(psi / 2)``, ``psi`` and ``log(B_0 + B_m cos psi)``), written
  here in forms without cancellation when ``B_m -> 0`` (points near the axis or
  far away). The arc above the tangent plane is closed by the chord along it.

Everything is relative to the light's centre (points far from the origin keep
their digits relative to the light's size) and float64. Accuracy (against
closed forms, a polar quadrature and bracketing polygons): about ``1e-14``
relative within a few sizes ``R`` of the light; at distance ``d`` the
rectangle's edge sum loses up to ``eps d / R`` divided by the receiver's cosine
(its edges' cross products are taken with the edge vectors in the light's own
coordinates; against the point-light limit at oblique angles: ``8e-10`` at
``d = 1e6 R``, ``1e-8`` at ``1e7 R``, where :data:`FAR_RECT` now hands it to the point limit, off by
about ``(R / d)^2``, from about ``1e5 R`` for a square; the disc none); where the receiver's
plane cuts a far light, the clipped part is within ``4e-9`` of the whole
light's value at ``d = 1e7 R`` (rectangle and disc; the disc's chord is also
taken in the light's coordinates); at ``h = 1e-3 R`` beside the light, values
``1e-9`` of the largest agree to ``1e-8`` relative, the references' own
spread. Near the light it stays exact (``G -> pi`` for a receiver facing the
light just in front of it within its extent).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["unshadowed_factor"]

#: Points per vectorised block (the rectangle keeps (M, 8, 3) arrays).
BLOCK = 1 << 16
#: A rectangle not cut by the receiver's plane takes the point limit ``A cos cos / d^2``, off by about
#: ``(D / d)^2`` (``D`` its half-diagonal), rather than the edge sum, off by about ``eps d / S`` (``S`` its
#: shorter half-edge), where ``(D / d)^2 S / d`` is below this (float64's eps: where the two errors meet).
FAR_RECT = float(np.finfo(np.float64).eps)


def _frame(nl):
    """Unit ``e1, e2`` with ``e1 x e2 = nl``."""
    a = np.array([1.0, 0.0, 0.0]) if abs(nl[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    e1 = np.cross(nl, a)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(nl, e1)


def _edge_sum(a, e, n):
    """Sum over edges a -> a + e (M, J, 3) of ``theta n . (a x b) / |a x b|`` (M,); zero-length edges add 0.

    ``a x b = a x e`` with the edge ``e`` given as a difference of the light's own coordinates (the light's
    size, not the distance, sets its rounding): ``a x b`` of two vectors of length ``d`` loses ``eps d / R``
    of its ``d R`` size, which the four edges' cancelling sum turned into ``eps (d / R)^2`` (a 1 cm light
    10 km away at an angle was up to 6e-4 off, at 100 km 3.5e-2)."""
    cr = np.cross(a, e)
    s = np.linalg.norm(cr, axis=-1)
    theta = np.arctan2(s, np.einsum("mjk,mjk->mj", a, a) + np.einsum("mjk,mjk->mj", a, e))
    t = np.divide(np.einsum("mjk,mk->mj", cr, n), s, out=np.zeros_like(s), where=s > 0)
    return (theta * t).sum(axis=1)


def _rect(light, q, n):
    """Geometric factor of a rectangle for offsets ``q = p - c`` (M, 3) and unit normals (M, 3)."""
    u, v = light.u, light.v
    corners = np.stack([u + v, v - u, -u - v, u - v])            # counter-clockwise about u x v
    edges = np.roll(corners, -1, axis=0) - corners                # in the light's coordinates (_edge_sum)
    x = corners[None] - q[:, None, :]                             # (M, 4, 3), relative to p
    s = np.einsum("mjk,mk->mj", x, n)                             # height above the tangent plane
    whole = (s >= 0).all(axis=1)
    out = np.zeros(len(q))
    # far away the edge sum's eps d / |shorter edge| exceeds the point limit's (half-diagonal / d)^2: there
    # A cos cos / d^2 at the centre (a 1e-20 m light 1 m away was black, 1e-12 m 7e-3 off, a 1e-3 x 1e-150 sliver 0)
    d = np.linalg.norm(q, axis=1)
    diag, short = math.sqrt(u @ u + v @ v), min(math.sqrt(u @ u), math.sqrt(v @ v))
    far = whole & ((diag / d) ** 2 * (short / d) < FAR_RECT)
    if far.any():
        lq = q[far] / d[far][:, None]                             # unit, from the light's centre to p
        out[far] = light.area * np.maximum(-np.einsum("mk,mk->m", n[far], lq), 0.0) \
            * np.maximum(lq @ light.normal, 0.0) / d[far] ** 2
    near = whole & ~far
    out[near] = -0.5 * _edge_sum(x[near], np.broadcast_to(edges, x[near].shape), n[near])     # nothing clipped
    cut = np.flatnonzero(~whole & (s > 0).any(axis=1))
    if len(cut):
        out[cut] = _clipped(corners, edges, q[cut], s[cut], n[cut])
    return out


def _clipped(corners, edges, q, s, n):
    """Lambert's sum over the quadrilateral ``corners`` (4, 3) (relative to its centre, ``edges`` from each to
    the next) seen from offsets ``q`` (M, 3), clipped to the heights ``s >= 0`` (M, 4) (Sutherland-Hodgman)."""
    s1 = np.roll(s, -1, axis=1)
    keep = s >= 0
    cross = keep != (s1 >= 0)
    t = np.divide(s, s - s1, out=np.zeros_like(s), where=cross)
    x = np.broadcast_to(corners, (len(q), 4, 3))
    xi = x + t[..., None] * edges                                 # the edge's crossing of the plane
    cand = np.stack([x, xi], axis=2).reshape(len(q), 8, 3)        # Sutherland-Hodgman: vertex, crossing
    ok = np.stack([keep, cross], axis=2).reshape(len(x), 8)
    order = np.argsort(~ok, axis=1, kind="stable")                # kept ones first, in order
    cand = np.take_along_axis(cand, order[..., None], axis=1)
    m = ok.sum(axis=1)
    j = np.arange(8)
    nxt = np.where(j[None, :] + 1 < m[:, None], j[None, :] + 1, 0)
    b = np.take_along_axis(cand, nxt[..., None], axis=1)
    used = (j[None, :] < m[:, None])[..., None]
    a = np.where(used, cand - q[:, None, :], 0.0)                 # relative to p
    e = np.where(used, b - cand, 0.0)                             # the clipped outline's edges, light coordinates
    return -0.5 * _edge_sum(a, e, n)


def _ratio(num, y):
    """``num * log1p(y) / y`` (1 at ``y = 0``)."""
    f = np.divide(np.log1p(y), y, out=np.ones_like(y), where=y != 0)
    return num * f


def _disc(light, q, n):
    """Geometric factor of a disc for offsets ``q = p - c`` (M, 3) and unit normals (M, 3).

    With ``e_1 x e_2 = n_L``, ``g = n x (c - p)``, ``h`` the height and ``q_i`` the foot's offset:
    ``n . (x x x') = A_0 + A_1 cos phi + A_2 sin phi``, ``A_0 = R^2 n . n_L``, ``(A_1, A_2) = R (g . e_2,
    -g . e_1)``; ``|x|^2 = B_0 + B_m cos(phi - phi_0)``, ``B_0 = h^2 + |q_i|^2 + R^2``, ``B_m = 2 R |q_i|``,
    ``phi_0`` the direction of ``-q_i``. Over ``psi``: ``J_0 = int d psi / |x|^2 = 2 / W [theta + atan z]``
    (``theta = psi / 2``, ``W = sqrt(B_0^2 - B_m^2)``, ``k = sqrt((B_0 - B_m) / (B_0 + B_m))``,
    ``z = (k - 1) sin theta cos theta / (cos^2 theta + k sin^2 theta)``: continuous in ``theta``),
    ``K_1 = int cos psi / |x|^2 = (psi - B_0 J_0) / B_m``, ``K_2 = int sin psi / |x|^2 = -log |x|^2 / B_m``,
    each evaluated with ``B_m`` divided out.
    """
    r = light.radius
    nl = light.normal
    e1, e2 = _frame(nl)
    cp = -q                                                       # c - p
    h = q @ nl
    qi = q - h[:, None] * nl                                      # the foot's in-plane offset
    rq = np.linalg.norm(qi, axis=1)
    b0 = h * h + rq * rq + r * r
    bm = 2.0 * r * rq
    lo = h * h + (rq - r) ** 2                                    # B0 - Bm: nearest rim point, squared
    hi = h * h + (rq + r) ** 2                                    # B0 + Bm
    w = np.sqrt(lo * hi)
    k = np.sqrt(lo / hi)
    kappa = 2.0 / (np.sqrt(hi) * (np.sqrt(hi) + np.sqrt(lo)))   # (1 - k) / Bm
    phi0 = np.arctan2(cp @ e2, cp @ e1)
    g = np.cross(n, cp)
    a0 = r * r * (n @ nl)
    a1, a2 = r * (g @ e2), -r * (g @ e1)
    c = a1 * np.cos(phi0) + a2 * np.sin(phi0)
    s = -a1 * np.sin(phi0) + a2 * np.cos(phi0)
    # the rim's height above the tangent plane: s0 + sm cos(phi - phin)
    s0 = np.einsum("mk,mk->m", n, cp)
    ne1, ne2 = n @ e1, n @ e2
    sm = r * np.hypot(ne1, ne2)
    phin = np.arctan2(ne2, ne1)
    full = s0 >= sm
    cut = ~full & (s0 > -sm)
    out = np.zeros(len(q))
    # whole rim: the sine term integrates to 0 over a period
    f = full
    out[f] = 2.0 * np.pi * (a0[f] - c[f] * bm[f] / (b0[f] + w[f])) / w[f]
    if cut.any():
        i = np.flatnonzero(cut)
        gam = np.arccos(np.clip(-s0[i] / sm[i], -1.0, 1.0))
        p1 = phin[i] - gam
        psi1 = p1 - phi0[i]
        th = np.stack([psi1 / 2.0, psi1 / 2.0 + gam])             # (2, m): half-angles at both ends
        sn, cs = np.sin(th), np.cos(th)
        den = cs * cs + k[i] * sn * sn
        zb = -kappa[i] * sn * cs / den                            # z / Bm, z = (k - 1) sin cos / den
        z = zb * bm[i]
        at = np.where(z != 0, np.arctan(z) / np.where(z != 0, z, 1.0), 1.0) * zb   # atan(z) / Bm
        datz = (at[1] - at[0]) * bm[i]
        j0 = 2.0 / w[i] * (gam + datz)
        k1 = -2.0 * gam * bm[i] / (w[i] * (b0[i] + w[i])) - 2.0 * b0[i] / w[i] * (at[1] - at[0])
        xs = cp[i] + r * (np.cos(p1)[:, None] * e1 + np.sin(p1)[:, None] * e2)
        xe = cp[i] + r * (np.cos(p1 + 2 * gam)[:, None] * e1 + np.sin(p1 + 2 * gam)[:, None] * e2)
        d1 = np.einsum("mk,mk->m", xs, xs)
        dcos = -2.0 * np.sin(psi1 + gam) * np.sin(gam)            # cos(psi2) - cos(psi1)
        k2 = -_ratio(dcos / d1, bm[i] * dcos / d1)
        # xs - xe in the light's coordinates (xe x xs = xe x (xs - xe): no digits lost to the distance)
        ch = 2.0 * r * np.sin(gam)[:, None] * (np.sin(p1 + gam)[:, None] * e1 - np.cos(p1 + gam)[:, None] * e2)
        chord = np.arctan2(np.einsum("mk,mk->m", np.cross(xe, ch), n[i]),
                           np.einsum("mk,mk->m", xe, xe) + np.einsum("mk,mk->m", xe, ch))
        out[i] = a0[i] * j0 + c[i] * k1 + s[i] * k2 + chord
    return -0.5 * out


def unshadowed_factor(light, points, normals) -> np.ndarray:
    """Geometric factor ``G`` of a disc or rectangle light at surface points, (N,) float64, sr.

    ``E_0 = L G`` is the exact unshadowed irradiance (module docstring): the
    light's part below the point's tangent plane is clipped off; points on or
    behind the light's plane get 0.

    Parameters
    ----------
    light : DiscLight or RectLight
    points : ndarray, shape (N, 3), float64
        World positions.
    normals : ndarray, shape (N, 3), float64
        World unit normals (not checked here: :func:`pyshadow.lighting.area.area_light_radiance` checks).

    Returns
    -------
    ndarray, shape (N,), float64
        ``G`` in sr, in ``[0, pi]``.
    """
    from .area import DiscLight      # at call time: area imports this module

    p = np.asarray(points, np.float64).reshape(-1, 3)
    n = np.asarray(normals, np.float64).reshape(-1, 3)
    out = np.zeros(len(p))
    fn = _disc if isinstance(light, DiscLight) else _rect
    for lo in range(0, len(p), BLOCK):
        q = p[lo:lo + BLOCK] - light.position
        front = np.flatnonzero(q @ light.normal > 0)
        if len(front):
            out[lo + front] = np.maximum(fn(light, q[front], n[lo:lo + BLOCK][front]), 0.0)
    return out

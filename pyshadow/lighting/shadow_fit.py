"""The orthographic shadow map's fit (:mod:`pyshadow.lighting.shadow_map`): the light's frame, the rectangle of
the casters' world bounding spheres seen along the light, and the split of casters lying far apart across the
light into maps of their own.

One map over casters far apart spends its texels on the empty space between them: a 1 m box on the ground with
a second box 1 km away got texels of 0.53 m at 1024^2, and 6.0 % of 23,595 points around the first box
differed from Embree (0.004 % without the second box; 0.5 % at 100 m, 0.08 % at 10 m; sun 40 degrees up).
So the casters are cut by a line across the light (along the map's u or v axis) in a gap that no caster's
rectangle crosses, where the gap spans over, and the casters on one side of it under, 1 / ``SPLIT_RATIO`` of
the whole's extent across the line (the cut leaving the least on its larger side first; not a row of a field
of bodies, their gaps narrow: its texels along the line would not shrink), into at most ``MAX_PARTS`` maps of
R x R texels each (fewer where more than ``MAX_TEXELS`` in all: :func:`part_limit`), every one fitted to its
own casters (four houses at the corners of a square: two cuts, then four maps). A point is looked up in the
map of the cell (of those lines) it lies in: no caster of another cell projects into it, so the hard answer
is that of a map over its own group alone; a PCF tap across a cut is lit, as off a map. Casters within
``SPLIT_RATIO`` of each other (a scene of 1 m bodies a few metres apart, a field of them) keep one map, as
before, at the price of sorting their rectangles when the map is rendered (unless they span under
``SPLIT_RATIO`` times their smallest sphere's diameter). Casters scattered evenly over a wide region (no line
leaves a small group) keep one map, coarse over each: cascaded maps would be needed.
"""
from __future__ import annotations

import math

import numpy as np

from ..scene_arrays import scene_arrays

__all__ = ["SPLIT_RATIO", "MAX_PARTS", "MAX_TEXELS", "part_limit", "split_casters", "cell_points", "far_axis"]

SPLIT_RATIO = 8.0       # a cut where its gap spans over, its smaller side under, 1 / this of the whole across it
MAX_PARTS = 8           # maps of one directional light at most (each R x R float32) ...
MAX_TEXELS = 2 ** 26    # ... and at most this many texels in all (256 MB), but 2 maps (4 at 4096^2, 2 at 8192^2)
SPHERE_SLACK = 1e-6     # the casters' radii grown by this fraction (float32 rasterisation)


def _light_frame(direction):
    """Orthonormal (u, v, d) with d = -direction (the light's travel direction)."""
    d = -np.asarray(direction, np.float64)
    u = np.cross(np.eye(3)[int(np.argmin(np.abs(d)))], d)
    u /= np.linalg.norm(u)
    return u, np.cross(d, u), d


def _ortho_frame(scene, casters, direction, R):
    """The orthographic map's affine world-to-texel map ``q = A (p - origin) + b`` (float64), the kernel's
    frame (float32) and the texel size: the rectangle of the casters' spheres seen along the light."""
    u, v, d = _light_frame(direction)
    arr = scene_arrays(scene)
    c, r = arr["world_centre"][casters], arr["world_radius"][casters] * (1 + SPHERE_SLACK)
    origin = c.mean(axis=0) if len(casters) else np.zeros(3)
    rel = c - origin
    if len(casters):
        lo = np.array([(rel @ u - r).min(), (rel @ v - r).min(), (rel @ d - r).min()])
        hi = np.array([(rel @ u + r).max(), (rel @ v + r).max()])
    else:
        lo, hi = -np.ones(3), np.ones(2)
    tu, tv = (hi - lo[:2]) / R
    A = np.stack([u / tu, v / tv, d])
    b = np.array([-lo[0] / tu - 0.5, -lo[1] / tv - 0.5, -lo[2]])
    frame = np.concatenate([A[0], [b[0]], A[1], [b[1]], A[2], [b[2]], [tu, tv]]).astype(np.float32)
    return A, b, origin, frame, float(max(tu, tv))


def part_limit(resolution: int) -> int:
    """The most maps a directional light's map is split into at ``resolution`` texels per side: ``MAX_PARTS``,
    fewer where they would hold over ``MAX_TEXELS`` texels in all, but 2."""
    return max(2, min(MAX_PARTS, MAX_TEXELS // int(resolution) ** 2))


def _best_cut(lo, hi, ratio):
    """The best cut across u or v between the rectangles ``lo``, ``hi`` (K, 2) (module docstring): (score, axis,
    cut line midway across its gap, mask of the rectangles before it), or None where no line qualifies."""
    best = None
    for a in (0, 1):
        order = np.argsort(lo[:, a], kind="stable")
        sl, reach = lo[order, a], np.maximum.accumulate(hi[order, a])
        gap = sl[1:] - reach[:-1]
        k = np.flatnonzero(gap > 0)
        before = reach[k] - sl[0]                                   # the sides' extents along the axis
        after = np.maximum.accumulate(hi[order[::-1], a])[::-1][k + 1] - sl[k + 1]
        whole = reach[-1] - sl[0]
        small, large = np.minimum(before, after), np.maximum(before, after)
        ok = np.flatnonzero((whole > ratio * small) & (gap[k] > whole / ratio))
        if len(ok):
            j = ok[int(np.argmin(large[ok]))]                       # the most even of them
            if best is None or whole / large[j] > best[0]:
                mask = np.zeros(len(lo), bool)
                mask[order[:k[j] + 1]] = True
                best = (float(whole / large[j]), a, float(sl[k[j] + 1] - 0.5 * gap[k[j]]), mask)
    return best


def split_casters(centres, radii, direction, max_parts=MAX_PARTS, ratio=SPLIT_RATIO):
    """The casters' groups of a directional light's maps (module docstring).

    Parameters
    ----------
    centres : ndarray, shape (K, 3), float64
        The casters' world bounding sphere centres.
    radii : ndarray, shape (K,), float64
        Their radii, world units.
    direction : ndarray, shape (3,), float64
        Unit direction towards the light.
    max_parts, ratio : int, float
        ``MAX_PARTS``, ``SPLIT_RATIO``.

    Returns
    -------
    axes : ndarray, shape (2, 3), float64
        The map's world unit axes u, v across the light.
    groups : list of (ndarray of int, ndarray (2,), ndarray (2,))
        Each group's caster numbers (into ``centres``) and its cell: the half-open rectangle
        ``lo <= (p . u, p . v) < hi`` of world points ``p`` (world units; +-inf unbounded). The cells
        tile the plane; one group (every caster, the whole plane) where no cut is made.
    """
    u, v, _ = _light_frame(direction)
    uv = np.stack([centres @ u, centres @ v], axis=1)
    r = radii[:, None] * (1 + SPHERE_SLACK)
    lo, hi = uv - r, uv + r
    groups = [(np.arange(len(centres)), np.full(2, -np.inf), np.full(2, np.inf))]
    if not len(centres) or float((hi.max(axis=0) - lo.min(axis=0)).max()) < 2.0 * ratio * float(r.min()):
        return np.stack([u, v]), groups     # no side can span that little: each holds a sphere
    while len(groups) < max_parts:
        best = None
        for i, (k, _, _) in enumerate(groups):
            cut = _best_cut(lo[k], hi[k], ratio) if len(k) > 1 else None
            if cut is not None and (best is None or cut[0] > best[0][0]):
                best = (cut, i)
        if best is None:
            break
        (_, a, t, left), i = best
        k, clo, chi = groups.pop(i)
        lhi, rlo = chi.copy(), clo.copy()
        lhi[a] = rlo[a] = t
        groups[i:i] = [(k[left], clo, lhi), (k[~left], rlo, chi)]
    return np.stack([u, v]), groups


def cell_points(points, axes, cells):
    """The rows of ``points`` (N, 3) float64 world in each cell (``split_casters``'s (lo, hi) pairs):
    a list of int index arrays, one per cell."""
    uv = points @ axes.T
    return [np.flatnonzero(((uv >= lo) & (uv < hi)).all(axis=1)) for lo, hi in cells]


def far_axis(scene, position, resolution: int, far_texels: float):
    """A point light whose casters' cone spans under ``far_texels`` texels at ``resolution``
    (:mod:`pyshadow.lighting.shadow_map`'s ``FAR_TEXELS``, its module docstring): (unit direction towards it
    along the cone's axis, the casters' mean centre); else None."""
    from .local import _sphere_cone

    arr = scene_arrays(scene)
    casters = np.flatnonzero(arr["casts"])
    c, r = arr["world_centre"][casters], arr["world_radius"][casters] * (1 + 1e-6)
    cone, half = _sphere_cone(position, c, r)
    if not (len(casters) and half < 0.5 and resolution * math.tan(half) < far_texels):
        return None
    return -cone[2], c.mean(axis=0)

"""A bounding volume hierarchy over the casters' bounding spheres, for scenes of many instances.

Without it every query visits every caster instance's bounding sphere, so a
query among 10,000 instances costs 10,000 sphere tests whatever it can meet.
With it the kernels (``INSTANCE_BVH``, ``kernels/batch.h``) walk a tree of
boxes: a node is entered when the ray of any open query of a work-item's
batch meets its box, so a batch's cost follows the casters its rays can
reach. The tree only decides which instances are asked; each is still asked
through its sphere test and its CSM exactly as without the tree, so answers
are bit-identical (an OR over the same instances, in another order).

Where the uniform grid over the spheres is balanced (:mod:`.grid`; casters
spread evenly, as over a ground plane) the kernels walk that instead; the
tree serves the other scenes (dense clusters, many casters wider than a
cell): :func:`pyshadow.visibility.csm.instance_accel` chooses.

Build (vectorised, no Python loop over instances): instances sorted by the
30-bit Morton code of their sphere centres, leaves of :data:`LEAF` instances
in that order, then each level pairs neighbouring nodes of the level below
until one root is left. Boxes are the spheres' boxes, rounded outward to
float32.
"""
from __future__ import annotations

import numpy as np

from .._cl.tables import BVH_NODE

__all__ = ["BVH_MIN_INSTANCES", "LEAF", "STACK", "instance_bvh", "box_pad"]

#: Scenes with fewer casters loop over all of them (the tree's code is not compiled).
BVH_MIN_INSTANCES = 16
#: Instances per leaf.
LEAF = 4
#: The kernel's traversal stack (``BVH_STACK``): enough for any depth the build makes.
STACK = 48


def _morton(c: np.ndarray) -> np.ndarray:
    """30-bit Morton codes of points (N, 3), quantised over their bounding box."""
    lo, hi = c.min(axis=0), c.max(axis=0)
    with np.errstate(over="ignore"):
        span = hi - lo
    if not np.isfinite(span).all():     # a box wider than float64 (centres near +-1.8e308): by halves (the
        # codes only order the leaves: the tree's boxes, hence its answers, do not depend on them)
        c, lo, hi = c * 0.5, lo * 0.5, hi * 0.5
        span = hi - lo
    q = ((c - lo) / np.where(hi > lo, span, 1.0) * 1023.0).astype(np.uint32)
    code = np.zeros(len(c), np.uint32)
    for bit in range(10):
        for axis in range(3):
            code |= ((q[:, axis] >> bit) & 1) << (3 * bit + (2 - axis))
    return code


def _outward(lo: np.ndarray, hi: np.ndarray):
    with np.errstate(over="ignore"):    # beyond float32: +-inf, or its largest value on the inner side
        lo32, hi32 = lo.astype(np.float32), hi.astype(np.float32)
    lo32 = np.where(lo32 > lo, np.nextafter(lo32, np.float32(-np.inf)), lo32)
    hi32 = np.where(hi32 < hi, np.nextafter(hi32, np.float32(np.inf)), hi32)
    return lo32, hi32


def spheres(centres, radii, name: str):
    """Validated spheres of :func:`instance_bvh` and :func:`.grid.instance_grid`: float64 ``(N, 3)`` centres,
    ``(N,)`` radii, N >= 1, all finite and the radii >= 0 (a NaN or infinite sphere was silently left out of
    every cell of the grid and made the tree's boxes NaN: the caster was never asked)."""
    c, r = np.asarray(centres), np.asarray(radii)
    for a, what in ((c, "centres"), (r, "radii")):
        if a.dtype.kind not in "iuf":   # complex lost its imaginary part, bools and digit strings passed
            raise TypeError(f"{name}: {what} must be real numbers, got dtype {a.dtype}")
    if c.ndim != 2 or c.shape[1] != 3:  # ((3, 4) was read as 4 centres)
        raise ValueError(f"{name}: centres must have shape (N, 3), got {c.shape}")
    c, r = c.astype(np.float64), r.astype(np.float64).reshape(-1)
    n = len(c)
    if n < 1 or len(r) != n or np.ndim(radii) > 1:
        raise ValueError(f"{name}: {n} centres and radii of shape {np.shape(radii)}: expected N >= 1 and shape (N,)")
    bad = ~(np.isfinite(c).all(axis=1) & np.isfinite(r) & (r >= 0))
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"{name}: sphere {i} (of {int(bad.sum())} bad) has centre {c[i].tolist()}, radius {r[i]}: "
                         f"centres must be finite, radii finite and >= 0")
    return c, r


def instance_bvh(centres, radii):
    """The tree over spheres (anchor-relative centres, radii) as the kernels read it.

    Parameters
    ----------
    centres : ndarray, shape (N, 3)
    radii : ndarray, shape (N,)
        N >= 1.

    Returns
    -------
    nodes : ndarray of BVH_NODE, root first
        Inner node: ``a``, ``b`` its children (``b == a`` when it has one);
        leaf: instances ``order[a : a - b]``.
    order : ndarray, int32, shape (N,)
        Instance indices in leaf order.
    depth : int
        Levels of the tree (the traversal stack needs ``depth - 1`` slots).
    """
    c, r = spheres(centres, radii, "instance_bvh")
    n = len(c)
    order = np.argsort(_morton(c), kind="stable").astype(np.int32)
    with np.errstate(over="ignore"):    # beyond float64: -inf / +inf, still the outward bound
        lo, hi = c[order] - r[order, None], c[order] + r[order, None]
    starts = np.arange(0, n, LEAF)
    levels = [{"lo": np.minimum.reduceat(lo, starts), "hi": np.maximum.reduceat(hi, starts),
               "a": starts.astype(np.int32), "b": -np.diff(np.append(starts, n)).astype(np.int32)}]
    while len(levels[-1]["a"]) > 1:
        below = levels[-1]
        m = len(below["a"])
        left = np.arange(0, m, 2)
        right = np.minimum(left + 1, m - 1)
        levels.append({"lo": np.minimum(below["lo"][left], below["lo"][right]),
                       "hi": np.maximum(below["hi"][left], below["hi"][right]),
                       "a": left.astype(np.int32), "b": right.astype(np.int32)})
    # root first: level k's nodes start after all the levels above it
    sizes = [len(lv["a"]) for lv in levels]
    first = np.cumsum([0] + sizes[::-1])[:-1][::-1]         # first node index of each level
    nodes = np.zeros(sum(sizes), BVH_NODE)
    for k, lv in enumerate(levels):
        s = slice(first[k], first[k] + sizes[k])
        nodes["lo"][s], nodes["hi"][s] = _outward(lv["lo"], lv["hi"])
        if k == 0:
            nodes["a"][s], nodes["b"][s] = lv["a"], lv["b"]
        else:
            nodes["a"][s], nodes["b"][s] = first[k - 1] + lv["a"], first[k - 1] + lv["b"]
    if len(levels) > STACK:
        raise ValueError(f"instance_bvh: {len(levels)} levels exceed the kernel's stack of {STACK}")
    return nodes, order, len(levels)


def box_pad(points_extent: float, boxes_extent: float) -> float:
    """Margin (world units) the kernel adds around every box before its slab test.

    A ray that meets a sphere passes through its box at least this far
    inside every face, so the float32 rounding of the slab test (relative
    1.2e-7 of the coordinates involved) can never cull it:
    ``1e-5 * (largest |coordinate| of the points + of the boxes)``.
    """
    return 1e-5 * (float(points_extent) + float(boxes_extent))

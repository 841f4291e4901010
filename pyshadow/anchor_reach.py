"""How far from its anchor each query point may lie: its reach among the scene's casters.

The device reads query points relative to an anchor in float32, which rounds
a coordinate at distance ``d`` from it by up to ``d 2**-24``. Against a
caster ``c`` of world radius ``r_c`` that loss stays below the 16-bit depth
quantum of its CSM (``2 r_c / 65534``) while ``d <= 512 r_c``
(:data:`pyshadow.scene_arrays.ANCHOR_REACH_RADII`); and it stays within the
rounding every ray from ``p`` already carries to ``c`` -- float32 rounds the
unit direction (and the caster's place and the point in its frame) by
``2**-24`` too, which misplaces the ray at ``c`` by about its distance
``|c - p| - r_c`` there -- while ``d`` is at most that distance. So a point
may be asked relative to an anchor ``a`` where ``|p - a|`` (its largest
coordinate) is at most

    reach(p) = min over casters c of max(512 r_c, s (|c - p| - r_c))

(world units; ``s``: :data:`DISTANCE_SHARE`): only casters near ``p``, and
tiny beside its distance from the anchor, bring it down, and it is never
below ``512 r_min`` (the rule of one reach for the whole scene, which made a
single 1 mm caster split every query over a 60 m scene into thousands of
anchors, each a kernel launch with the instance tables rebuilt).

What the second term costs: nothing measurable on AO rays or points near
casters (280,000 rays over scenes with 1 mm and 1 cm casters, at 1e4 from
the origin, on a 1 km floor: not one answer changed); on rays aimed at the
edges of a 1 mm caster from 100 m (1e5 of its radii), where the ray's own
rounding is already 1 % of its size, an anchor at the full reach about
triples the rays that disagree with an exact test (Embree 25 -> 78 of 20,000,
the kernel 41 -> 100; at a tenth of the reach 28 and 48).

:func:`reach_bound` gives a lower bound of ``reach(p)`` without visiting
every (point, caster) pair: the casters are bucketed by radius (powers of
two, :func:`caster_buckets`), and a bucket is asked (nearest centre, a
k-d tree) only for the points farther from their anchor than 512 radii of
its smallest caster -- the others cannot fall below their reach by it.
The points beyond it are grouped by cubes of a power-of-two side up to
twice that bound (:func:`pyshadow.scene_arrays.cube_groups`), each asked
relative to its centre: within the bound of each point in every coordinate.
"""
from __future__ import annotations

import numpy as np

__all__ = ["caster_buckets", "reach_bound", "run_starts", "DISTANCE_SHARE"]

#: The share ``s`` of a point's distance to a caster's sphere that its distance to its anchor may reach
#: (module docstring): 1 lets the anchor's rounding match the one its rays carry to that caster. Smaller
#: shares cost anchors: 20,000 points over a 60 m scene with a 1 mm caster make 64 groups at 1, 743 at
#: 1/4, 5,366 at 1/16 (0.38, 2.6 and 18 s of AO; 17,079 groups by 512 radii of that caster alone).
DISTANCE_SHARE = 1.0


def caster_buckets(centres, radii) -> list:
    """The casters bucketed by radius, for :func:`reach_bound`.

    Parameters
    ----------
    centres : ndarray, shape (C, 3), float64
        World bounding-sphere centres of the casters.
    radii : ndarray, shape (C,), float64
        Their world radii (> 0).

    Returns
    -------
    list of dict
        One bucket per power of two of the radii, smallest first:
        ``rmin``, ``rmax`` (its smallest and largest radius), ``centres``
        (its centres) and ``tree`` (a k-d tree of them, made at first use).
    """
    r = np.asarray(radii, np.float64)
    c = np.asarray(centres, np.float64).reshape(len(r), 3)
    exp = np.frexp(r)[1]
    out = []
    for e in np.unique(exp):
        k = np.flatnonzero(exp == e)
        out.append({"rmin": float(r[k].min()), "rmax": float(r[k].max()), "centres": c[k], "tree": None})
    return out


def run_starts(a) -> np.ndarray:
    """(N,) bool: True at each row of ``a`` (N, K) that differs from the row before it (the first row too): the
    starts of its runs of equal rows (-0.0 equal to 0.0, a NaN equal to nothing)."""
    start = np.ones(len(a), bool)
    if len(a) > 1:
        np.not_equal(a[1:, 0], a[:-1, 0], out=start[1:])
        for c in range(1, a.shape[1]):
            start[1:] |= a[1:, c] != a[:-1, c]
    return start


def reach_bound(points, extent, buckets, radii: float) -> np.ndarray:
    """A lower bound of ``reach(p)`` (module docstring) at each point, world units.

    Parameters
    ----------
    points : ndarray, shape (N, 3), float64
        World points.
    extent : ndarray, shape (N,), float64
        Their largest |coordinate| relative to their anchor: a bucket is asked
        only for the points whose extent exceeds its ``radii`` x ``rmin``.
    buckets : list
        :func:`caster_buckets` of the scene's casters.
    radii : float
        The reach in caster radii (:data:`pyshadow.scene_arrays.ANCHOR_REACH_RADII`).

    Returns
    -------
    ndarray, shape (N,), float64
        At most ``reach(p)`` where that is below the point's extent (the points
        that need an anchor of their own), and at least about half of it (a
        bucket's radii lie within a factor of two); elsewhere it may exceed
        ``reach(p)``, both then at least the extent (a bucket not asked, the
        point within ``radii`` radii of its smallest caster, brings nothing
        below it). ``+inf`` where no bucket was asked or none has a caster
        near enough to bring the point below its extent. Where it is finite it
        is at least ``radii`` x the smallest radius.
    """
    from scipy.spatial import cKDTree

    start = run_starts(points)      # rays from one point come as runs of equal rows (its AO directions): one ask a run
    if not start.all():
        return reach_bound(points[start], extent[start], buckets, radii)[np.cumsum(start) - 1]
    out = np.full(len(points), np.inf)
    for b in buckets:
        floor = radii * b["rmin"]
        rows = np.flatnonzero(extent > floor)
        if not len(rows):
            continue
        if b["tree"] is None:
            b["tree"] = cKDTree(b["centres"])
        # farther than extent / share + rmax, a caster cannot bring a point below its extent
        top = float(extent[rows].max()) / DISTANCE_SHARE + b["rmax"]
        dist = b["tree"].query(points[rows], distance_upper_bound=top, workers=-1)[0]     # (each point on its own)
        out[rows] = np.minimum(out[rows], np.maximum(floor, DISTANCE_SHARE * (dist - b["rmax"])))
    return out

"""Finite shadow rays: ``visible(..., max_distance=...)`` and what a CSM can answer of them.

A shadow ray towards a light at distance ``t`` from the point is the segment
``p + s w``, ``0 <= s <= t`` (``w`` unit): occluders beyond ``t`` do not
count. Per caster, with its world bounding sphere (the kernels' radius,
grown by 1e-6) met by the ray over ``[t0, t1]``:

* ``t0 >= t`` (the sphere lies wholly beyond the end): the caster is culled;
* ``t1 <= t`` (it ends before the end): it is answered as for an infinite ray
  -- the segment then holds every point of the caster the ray can meet, so
  the two answers agree (``LIGHTING.md``, "What a CSM can and cannot do");
* ``t0 < t < t1``, i.e. the end ``p + t w`` lies inside (or on) the sphere:
  a CSM cannot answer. Its maps store each occluder's depth only up to its
  compression interval (any depth in ``[z1, z2)``), not where along the ray
  the occluder lies, so whether it is before or beyond the end is unknown.
  Such rays ("straddling" rays) are refused with a ``ValueError`` naming the
  instance (``straddle="error"``, the default), or answered -- those rays
  only -- by Embree on the casters' meshes (``straddle="embree"``; every
  caster needs its mesh, else the same error). Nothing is launched before
  the check.

The kernel tells the first two cases apart by the midpoint of the chord:
the caster counts where ``(c - p).w < t``. For a ray that does not end inside
the sphere this is exactly the case split above, and it stays far from its
float32 rounding boundary except for rays that only graze the sphere.

The ground plane ``y = ground`` blocks a finite ray only where the segment
crosses it: from a point on or above it (within the kernels' tolerance of
1e-5 of the scene's largest radius) going down to an end strictly below it,
or from a point below it going up to an end strictly above it. A light
exactly in the plane is therefore not hidden by the plane.

Every backend applies these rules (the kernel under ``FINITE_RAYS=1``, the
NumPy mirror in float64, Embree with ``tfar``); ``max_distance=None`` (or
``+inf`` for a ray) is the unbounded ray of before, bit-identical and as
fast: the kernel is compiled without the length test then.
"""
from __future__ import annotations

import numpy as np

from ..scene_arrays import scene_arrays

__all__ = ["STRADDLE", "check_max_distance", "check_straddle", "unit_directions", "straddling",
           "ground_blocks", "answer_finite"]

#: What to do with rays that end inside a caster's bounding sphere.
STRADDLE = ("error", "embree")


def check_max_distance(max_distance, n: int):
    """Validate ``max_distance`` for ``n`` rays.

    Parameters
    ----------
    max_distance : None, float or array_like, shape (N,)
        Length of each ray, world units: > 0 and not NaN; ``inf`` is the
        unbounded ray.
    n : int

    Returns
    -------
    ndarray, shape (N,), float64, or None
        A new array (None passes through).
    """
    if max_distance is None:
        return None
    try:
        t = np.asarray(max_distance, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"max_distance must be a number or an array of N numbers, got {max_distance!r}") from None
    if t.ndim > 1 or (t.ndim == 1 and len(t) != n):
        raise ValueError(f"max_distance must be a number or have shape ({n},), got shape {t.shape}")
    t = np.array(np.broadcast_to(t, (n,)))
    bad = np.isnan(t) | ~(t > 0)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"max_distance must be > 0 (inf: unbounded), got {t[i]} for ray {i} "
                         f"({int(bad.sum())} bad)")
    return t


def check_straddle(straddle) -> str:
    """Validate ``straddle`` (one of :data:`STRADDLE`)."""
    if straddle not in STRADDLE:
        raise ValueError(f"straddle must be one of {STRADDLE}, got {straddle!r}")
    return straddle


def unit_directions(w) -> np.ndarray:
    """Non-zero (N, 3) directions -> float64 unit rows (scaled by a power of two first, as the kernel)."""
    w = np.asarray(w, dtype=np.float64).reshape(-1, 3)
    if len(w) == 0:
        return w.copy()
    sq = np.einsum("ij,ij->i", w, w)
    if not ((sq > 1e-30) & (sq < 1e30)).all():      # squares would lose digits: rescale first (exact)
        w = np.ldexp(w, -np.frexp(np.abs(w).max(axis=1, keepdims=True))[1])
        sq = np.einsum("ij,ij->i", w, w)
    return w / np.sqrt(sq)[:, None]


def straddling(scene, points, directions, tmax):
    """Rays that end inside (or on) a caster's bounding sphere: those a CSM cannot answer.

    Parameters
    ----------
    scene : pyshadow.Scene
    points : ndarray, shape (N, 3)
        World ray origins.
    directions : ndarray, shape (N, 3)
        World unit directions (:func:`unit_directions`).
    tmax : ndarray, shape (N,)
        Ray lengths, world units (``inf`` never straddles).

    Returns
    -------
    rows : ndarray of int, shape (K,)
        The straddling rays, ascending.
    instances : ndarray of int, shape (K,)
        For each, the id of a caster instance whose sphere holds its end
        (the lowest such id).
    """
    arr = scene_arrays(scene)
    casters = np.flatnonzero(arr["casts"])
    fin = np.flatnonzero(np.isfinite(tmax))
    if not len(casters) or not len(fin):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    ends = np.asarray(points, np.float64)[fin] + tmax[fin, None] * directions[fin]
    centres = arr["world_centre"][casters]
    radii = arr["world_radius"][casters] * (1 + 1e-6)      # the kernels' radius
    owner = np.full(len(fin), -1, np.int64)
    if len(casters) <= 32:
        for k in range(len(casters) - 1, -1, -1):          # lowest id wins
            d = ends - centres[k]
            owner[np.einsum("ij,ij->i", d, d) <= radii[k] ** 2] = casters[k]
    else:
        from scipy.spatial import cKDTree

        hits = cKDTree(ends).query_ball_point(centres, radii)
        for k in range(len(casters) - 1, -1, -1):
            owner[np.asarray(hits[k], np.int64)] = casters[k]
    inside = owner >= 0
    return fin[inside], owner[inside]


def ground_blocks(h, wy, tmax, eps) -> np.ndarray:
    """The ground rule of a ray (float64): ``h`` the height above the plane, ``wy`` the
    unit direction's y, ``tmax`` the lengths (None: unbounded), ``eps`` the plane's tolerance."""
    if tmax is None:
        return ((h >= -eps) & (wy < 0)) | ((h < -eps) & (wy > 0))
    with np.errstate(invalid="ignore"):
        e = h + tmax * wy
    return ((h >= -eps) & (wy < 0) & (e < 0)) | ((h < -eps) & (wy > 0) & (e > 0))


def answer_finite(scene, points, directions, tmax, straddle, answer) -> np.ndarray:
    """Finite rays by a CSM backend: refuse or reroute the straddling ones, ``answer()`` the rest.

    Parameters
    ----------
    scene : pyshadow.Scene
    points, directions : ndarray, shape (N, 3)
        World origins and unit directions (float64).
    tmax : ndarray, shape (N,)
        Validated lengths (:func:`check_max_distance`).
    straddle : {'error', 'embree'}
    answer : callable
        ``answer()`` -> (N,) bool, the backend's answer for every ray (its
        rows for the straddling rays are replaced).

    Returns
    -------
    ndarray, shape (N,), bool
    """
    check_straddle(straddle)
    rows, inst = straddling(scene, points, directions, tmax)
    if len(rows):
        meshes = all(scene.instances[i].mesh is not None for i in np.flatnonzero(scene_arrays(scene)["casts"]))
        if straddle == "error" or not meshes:
            i, j = int(rows[0]), int(inst[0])
            c, r = scene.instances[j].world_sphere()
            why = ("pass straddle='embree' to answer those rays by ray tracing" if straddle == "error" else
                   "straddle='embree' needs every caster's mesh (Scene.add(csm, mesh=...))")
            raise ValueError(f"ray {i} (and {len(rows) - 1} more) ends inside the bounding sphere of caster "
                             f"instance {j} (centre {np.round(np.asarray(c), 6).tolist()}, radius {float(r):.6g}): "
                             f"a CSM stores occluder depths only up to its compression intervals, so it cannot "
                             f"tell whether that caster lies before or beyond the ray's end; move the light "
                             f"outside the sphere, or {why}")
    vis = answer()
    if len(rows):
        from .. import embree

        vis[rows] = embree.visible(scene, points[rows], directions[rows], max_distance=tmax[rows])
    return vis

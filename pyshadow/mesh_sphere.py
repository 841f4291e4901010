"""trimesh's ``minimum_nsphere``, the same centre and radius bit for bit, without its two slow steps.

:func:`pyshadow.mesh.bounding_sphere` fits a mesh's frame with trimesh's ``minimum_nsphere``. On a mesh of
10^6 faces that spent seconds repairing the hull mesh it builds (winding, inversion, volume) only to read the
hull's vertices, and, where those lie near one sphere but not on it (a scanned stone, a noisy ball), it
measured every vertex of the furthest-site Voronoi diagram against every hull vertex: O(n^2), 111 s for a hull
of 40,962 vertices (benchmarks/README.md, bigsphere). Here the hull's vertices are made as trimesh makes them,
less the repair, which moves no vertex, and the Voronoi vertex of smallest radius is found with a lower bound
per vertex (its distance to the sites whose regions hold it, which are the farthest) that rules the others out
before their radii are measured, as trimesh measures them. trimesh's own path is taken wherever these
shortcuts could differ from it (no valid hull face, coordinates not finite). The answers per mesh are kept for
its content as it is (:class:`pyshadow.mesh_kept.MeshKept`): trimesh kept the hull on the mesh itself.
"""
from __future__ import annotations

import functools
import itertools

import numpy as np
import trimesh
from scipy import spatial
from trimesh.nsphere import fit_nsphere

from .mesh_kept import MeshKept

__all__ = ["hull_points", "minimum_nsphere", "kept_per_mesh"]

_SPHERES = MeshKept()           # mesh -> (centre, radius) of bounding_sphere, for its content as it is
_LOOP_BYTES = 4e9               # trimesh's: beyond this estimate of cdist's bytes it loops over the vertices


def hull_points(points: np.ndarray) -> np.ndarray:
    """The corners of ``trimesh.convex.convex_hull(points)``, without the repair of its faces.

    Parameters
    ----------
    points : ndarray, shape (n, 3), float64
        Any unit.

    Returns
    -------
    ndarray, shape (h, 3), float64
        The hull's corners that bound a face of nonzero area, merged within ``trimesh.tol.merge``: the vertices
        of trimesh's hull mesh. Its repair (each face wound outwards, its normals, its volume) takes seconds at
        10^6 points and moves no corner, so it is left out; where qhull gives no face of nonzero area, the
        corners are trimesh's own (its repair decides there).
    """
    xyz = np.asarray(points, dtype=np.float64)
    try:                                        # the options trimesh gives qhull, then its joggled retry
        qh = spatial.ConvexHull(xyz, qhull_options="Qt QbB Pp")
    except trimesh.convex.QhullError:
        qh = spatial.ConvexHull(xyz, qhull_options="QJ")
    corner_ids = np.sort(qh.vertices)           # the corners in input order, simplices renumbered onto them
    renumber = np.zeros(len(qh.points), dtype=np.int64)
    renumber[corner_ids] = np.arange(len(corner_ids))
    corners, tris = qh.points[corner_ids], renumber[qh.simplices]
    _, has_area = trimesh.util.unitize(trimesh.triangles.cross(corners[tris]), check_valid=True)
    if not has_area.any():
        return np.asarray(trimesh.convex.convex_hull(xyz).vertices)
    # trimesh merges the corners of the faces with area; the winding it repairs afterwards moves none
    merged = trimesh.Trimesh(vertices=corners, faces=tris[has_area], process=True, validate=False)
    return np.asarray(merged.vertices)


def _sites_bound(voronoi, points: np.ndarray) -> np.ndarray:
    """Per Voronoi vertex, the largest squared distance to a site whose region holds it, less a relative 1e-9:
    at most its largest squared distance to any site however that is rounded (-inf: no region holds it)."""
    regions = [voronoi.regions[r] for r in voronoi.point_region]
    lengths = np.fromiter(map(len, regions), np.int64, len(regions))
    vertex = np.fromiter(itertools.chain.from_iterable(regions), np.int64, int(lengths.sum()))
    site = np.repeat(np.arange(len(regions)), lengths)
    keep = vertex >= 0                          # -1: the vertex at infinity
    vertex, site = vertex[keep], site[keep]
    bound = np.full(len(voronoi.vertices), -np.inf)
    np.maximum.at(bound, vertex, ((points[site] - voronoi.vertices[vertex]) ** 2).sum(axis=1))
    return bound * (1.0 - 1e-9)


def _smallest_vertex(voronoi, points: np.ndarray):
    """``(i, r2)``: trimesh's ``radii_2.argmin()`` and ``radii_2[i]``, the largest squared distance from each
    Voronoi vertex to the points, rounded as trimesh rounds it (``cdist``, or its loop beyond 4 GB); measured
    only for the vertices whose lower bound is not above the smallest radius measured so far."""
    vertices = voronoi.vertices
    if len(vertices) * len(points) * 9 > _LOOP_BYTES:      # trimesh's loop instead of cdist

        def radii(rows):
            return np.array([((points - v) ** 2).sum(axis=1).max() for v in rows])
    else:

        def radii(rows):
            return spatial.distance.cdist(rows, points, metric="sqeuclidean").max(axis=1)
    if not (len(vertices) and np.isfinite(vertices).all() and np.isfinite(points).all()):
        r2 = radii(vertices)                    # as trimesh (a NaN is its argmin; none: its ValueError)
        i = int(r2.argmin())
        return i, r2[i]
    bound = _sites_bound(voronoi, points)
    order = np.argsort(bound, kind="stable")
    batch = max(1, min(64, (1 << 24) // max(1, len(points))))
    best, best_i, at = np.inf, len(vertices), 0
    while at < len(order) and not bound[order[at]] > best:
        rows = order[at:at + batch]
        rows = rows[~(bound[rows] > best)]
        for i, r2 in zip(rows.tolist(), radii(vertices[rows])):
            if r2 < best or (r2 == best and i < best_i):           # argmin: the first of equal ones
                best, best_i = r2, i
        at += batch
    return best_i, best


def minimum_nsphere(points: np.ndarray):
    """``trimesh.nsphere.minimum_nsphere`` of the points (or of a mesh with these vertices), bit for bit.

    Parameters
    ----------
    points : ndarray, shape (n, 3), float64
        Any unit.

    Returns
    -------
    centre : ndarray, shape (3,), float64
    radius : float
        The sphere trimesh gives: its least-squares sphere where the hull's corners lie on one (fit error below
        1e-6), else the furthest-site Voronoi vertex of smallest radius unless that is larger than the
        least-squares sphere's. Its errors are raised. ``tests/test_bigsphere_equal.py`` compares the two.
    """
    with np.errstate(all="ignore"):
        corners = hull_points(points)
        low = corners.min(axis=0)               # the corners in a box of least side 1, as trimesh fits them
        side = np.ptp(corners, axis=0).min()
        unit = (corners - low) / side
        ls_centre, _, ls_error = fit_nsphere(unit)
        ls_radius = (((unit - ls_centre) ** 2).sum(axis=1).max() ** 0.5) * side
        ls_centre = ls_centre * side + low
        if ls_error < 1e-6:                     # on one sphere: no Voronoi diagram (qhull would fail)
            return ls_centre, ls_radius
        diagram = spatial.Voronoi(unit, furthest_site=True)
        best, r2 = _smallest_vertex(diagram, unit)
        radius = np.sqrt(r2) * side
        if radius > ls_radius:
            return ls_centre, ls_radius
        return diagram.vertices[best] * side + low, radius


def kept_per_mesh(sphere):
    """``sphere(mesh)`` (:func:`pyshadow.mesh.bounding_sphere`) kept per mesh for its content as it is: its
    qhull calls take seconds on a mesh of 10^6 faces, which a build, its error model and a scene ask again."""

    @functools.wraps(sphere)
    def kept(mesh):
        if not isinstance(mesh, trimesh.Trimesh):
            return sphere(mesh)
        got, stamp = _SPHERES.get(mesh), hash(mesh)
        if got is None:
            got = sphere(mesh)
            if hash(mesh) == stamp:             # not changed meanwhile
                _SPHERES[mesh] = got
        return np.array(got[0], dtype=np.float64), got[1]
    return kept

"""How far :mod:`pyshadow.embree` moves a ray's ends off the surfaces they lie on (world units).

A ray leaving a surface starts moved along itself by :func:`surface_epsilon`, so that the float32 ray
tracer does not meet the surface it leaves; a finite ray that ends on a surface (a light standing on a
table, a disc light lying on a face) ends as much before its end (:func:`end_epsilon`), so that the
surface it ends on does not hide it: with the end exactly on the face, rounding hid 71 % of the points a
point light at the centre of a box's lid lights.
"""
from __future__ import annotations

import numpy as np

from ._validate import float32_exact

__all__ = ["ray_epsilon", "surface_epsilon", "end_epsilon", "body_size", "sphere_size", "off_own_surface",
           "off_crossed_planes", "point_surfaces", "occluded_again"]


#: :func:`sphere_size`'s bound: a point's body size is at most this many times the radius of (and the
#: distance to) the nearest small caster; scenes whose casters differ in size by less keep their lifts.
NEAR_SIZES = 64.0


def ray_epsilon(scale) -> np.ndarray:
    """Offset along a ray that safely leaves a surface at coordinates of size ``scale``.

    64 float32 ulps of ``scale`` clipped to ``[1.2e-38, 2**127]`` (float32's normal range): large enough
    to step over the intersection error of a float32 ray tracer, small against any feature.
    """
    # beyond 2**127 (float32's last binade: up to its largest number, and inf) the same spacing, 2**104
    scale = np.minimum(np.maximum(np.abs(np.asarray(scale, dtype=np.float64)), float(np.finfo(np.float32).tiny)),
                       2.0 ** 127)
    return 64.0 * np.spacing(scale.astype(np.float32)).astype(np.float64)


def body_size(scene, points) -> np.ndarray:
    """(N,) the radius (world units) of the caster each point's rays may leave, for its lift.

    The largest world bounding-sphere radius of the casters whose sphere holds the point (to 1e-6 of
    that radius), else that of the caster whose sphere lies nearest, but at most :data:`NEAR_SIZES` times
    the radius of, and the distance to, any caster (:func:`sphere_size`); the scene's largest radius
    (:meth:`pyshadow.Scene.scale`) where every instance has one radius or there is no caster. With the
    scene's largest radius for every point, a 1 cm box beside a 1 km one was lifted over by its own rays
    (the ground's Embree AO around it 0.9998 instead of 0.913); with the largest holding radius alone, a
    1 cm box on a 100 m floor mesh was (the rays of its side facing a second box 5 mm away started 1.4 mm
    out: Embree's AO there 0.236 instead of 0.294).
    """
    from .scene_arrays import scene_arrays

    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not scene.instances:
        return np.full(len(P), scene.scale())
    arr = scene_arrays(scene)
    r_all = arr["world_radius"][arr["live"]]        # (not those removed)
    c, r = arr["world_centre"][arr["casts"]], arr["world_radius"][arr["casts"]]
    if not len(r) or r_all.min() == r_all.max():
        return np.full(len(P), scene.scale())
    return sphere_size(P, c, r)


def sphere_size(points, centres, radii) -> np.ndarray:
    """(N,) :func:`body_size`'s rule among the spheres ``centres`` (M, 3), ``radii`` (M,), M >= 1: the
    largest radius of the spheres holding each point (to 1e-6 of that radius), else the nearest sphere's;
    at most :data:`NEAR_SIZES` times the least over the spheres of ``max(radius, gap)`` (``gap``: the
    point's distance to the sphere, 0 inside), so that a lift of 2e-5 of it stays within 1/780 of the size
    of, and the distance to, a small caster beside or on a large one.

    Many spheres and points: the points are taken a cell of a grid at a time, each among the spheres that
    can decide its answer (the same values: every sphere left out is farther than one kept, for every point
    of the cell). Over all spheres at once, the lifts of 100,000 points among 2,000 bodies took 40 s (now
    1.1 s), far longer than tracing their rays."""
    if len(radii) > _DENSE_SPHERES and len(points) > _CELL_POINTS:
        return _sphere_size_cells(points, centres, radii)
    return _sphere_size_dense(points, centres, radii)


#: :func:`sphere_size` over every sphere at once up to this many spheres; by grid cells of about
#: ``_CELL_POINTS`` points beyond
_DENSE_SPHERES, _CELL_POINTS = 64, 64


def _sphere_size_cells(P, c, r) -> np.ndarray:
    """:func:`sphere_size` of points ``P`` (N, 3) a grid cell at a time, each cell among the spheres (``c``
    (M, 3), ``r`` (M,)) that may hold one of its points or give one its nearest sphere or least
    ``max(radius, gap)``: bounds of each sphere's distances over the cell's box (its points' bounding box)
    leave out the others, with a margin of 1e-9 of the distances (float64 rounds them to 1e-16). The
    spheres kept stay in their order (the first of equally near ones, as :func:`numpy.argmin` takes)."""
    out = np.empty(len(P))
    lo, hi = P.min(axis=0), P.max(axis=0)
    g = int(np.clip(np.cbrt(len(P) / _CELL_POINTS), 1, 64))
    with np.errstate(invalid="ignore", divide="ignore"):        # a flat extent: one cell across it
        cell = np.clip(np.nan_to_num((P - lo) / (hi - lo) * g), 0, g - 1).astype(np.int64)
    key = (cell[:, 0] * g + cell[:, 1]) * g + cell[:, 2]
    order = np.argsort(key, kind="stable")
    cuts = np.flatnonzero(np.diff(key[order])) + 1
    rr = r * (1.0 + 1e-6)
    for rows in np.split(order, cuts):
        Q = P[rows]
        b0, b1 = Q.min(axis=0), Q.max(axis=0)
        dmin = np.linalg.norm(np.maximum(np.maximum(b0 - c, c - b1), 0.0), axis=1)
        dmax = np.linalg.norm(np.maximum(np.abs(c - b0), np.abs(c - b1)), axis=1)
        slack = 1e-9 * (dmax + r)
        gap_lo, gap_hi = dmin - rr, dmax - rr
        near_hi = np.maximum(gap_hi, r).min()
        keep = ((gap_lo <= slack) | (gap_lo <= gap_hi.min() + slack + 1e-9 * abs(gap_hi.min()))
                | (np.maximum(gap_lo, r) <= near_hi * (1.0 + 1e-9) + slack))
        k = np.flatnonzero(keep)
        out[rows] = _sphere_size_dense(Q, c[k], r[k])
    return out


def _sphere_size_dense(P, c, r) -> np.ndarray:
    """:func:`sphere_size` over every sphere at once."""
    out = np.empty(len(P))
    step = max(1, (1 << 22) // len(r))          # at most 4 M point-sphere pairs at a time
    for s in range(0, len(P), step):
        gap = np.linalg.norm(P[s:s + step, None, :] - c[None], axis=2) - r * (1.0 + 1e-6)     # < 0: inside
        inside = gap <= 0.0
        held = np.where(inside, r, 0.0).max(axis=1)
        near = np.maximum(gap, r).min(axis=1)      # the finest scale of the casters around the point
        out[s:s + step] = np.minimum(np.where(inside.any(axis=1), held, r[np.argmin(gap, axis=1)]),
                                     NEAR_SIZES * near)
    return out


def surface_epsilon(scene, points=None, anchor=None, *, float32_points=True):
    """Offset that lifts a ray origin off a surface, world units.

    2e-5 of the radius of the body a point's rays leave (:func:`body_size`; of the scene's largest
    instance without ``points``), and at least 64 float32 ulps (:func:`ray_epsilon`) of the
    coordinates Embree sees: relative to the casters' anchor (:func:`caster_scene`; or ``anchor``), those
    of each point when ``points`` (world, (N, 3)) are given -- a float (N,) array then -- else of the
    farthest caster, a float. Far from the anchor a float32 ray tracer's intersection error grows with the
    coordinates, not with the bodies' size: with many bodies spread over a large scene a fixed offset let
    rays restart behind their own surface. A point float32 holds exactly is lifted at least 4 float32
    spacings of its own coordinates (up to 0.87 of one off its surface, were it a float32 point), unless
    ``float32_points`` is False (points that are no surface's float32 samples: :func:`end_epsilon`'s ends,
    where a light at x = 1e7 + 2 stopped its rays 4 units short of it; :mod:`pyshadow.embree`'s points given
    as float64, whose coordinates float32 may hold by chance: the corner of a box at (1e7, 1e7 + 1, 1e7)
    resting on another was lifted 4 units, through the box above it, AO 1 against the exact 0.219).
    """
    anchor = scene.anchor() if anchor is None else anchor
    if points is None:
        floor = 2e-5 * scene.scale()
        extent = max([np.linalg.norm(inst.world_sphere()[0] - anchor) + inst.world_sphere()[1]
                      for inst in scene.instances if inst.casts] or [scene.scale()])
        return float(max(floor, ray_epsilon(extent)))
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    size = body_size(scene, P)
    eps = np.maximum(2e-5 * size, ray_epsilon(np.maximum(np.abs(P - anchor).max(axis=1), size)))
    # float32 points at x = 1e3: 209 of 600 outward rays hit their sphere
    if not float32_points:
        return eps
    own = 4.0 * np.spacing(np.abs(P).max(axis=1).astype(np.float32))
    return np.where(float32_exact(P).all(axis=1), np.maximum(eps, own), eps)


def end_epsilon(scene, points, directions, tmax, anchor=None) -> np.ndarray:
    """(N,) how far before its end ``points + tmax * directions`` each finite ray (world (N, 3) float64,
    unit directions, lengths (N,)) stops; 0 for an unbounded ray.

    2e-5 of the radius of the smallest caster whose bounding sphere holds the end (the body a light on a
    surface stands on: :func:`surface_epsilon`'s lift, taken from that body, not from the scene's largest,
    which beside a body of radius 1000 stopped a lamp's rays 2 cm short, before a plate 1 cm over it), at
    most :data:`NEAR_SIZES` times the radius of, and the distance to, any caster (as :func:`sphere_size`: a
    lamp on a 1 km floor mesh 3 mm beside a 1 cm box had its rays stopped 14 mm short, and lit every point
    behind the box), and at least 16 float32 spacings (a quarter of :func:`ray_epsilon`) of the end's
    coordinates relative to ``anchor`` (default the scene's) or of the length: the rounding of a float32 ray
    tracer's hit there.
    """
    out = np.zeros(len(points))
    fin = np.flatnonzero(np.isfinite(tmax))
    if len(fin):
        anchor = scene.anchor() if anchor is None else anchor
        with np.errstate(over="ignore", invalid="ignore"):
            ends = points[fin] + tmax[fin, None] * directions[fin]
            size = np.maximum(np.abs(ends - anchor).max(axis=1), tmax[fin])
        ok = np.flatnonzero(np.isfinite(size))
        out[fin[ok]] = np.maximum(0.25 * ray_epsilon(size[ok]), 2e-5 * _smallest_sphere(scene, ends[ok]))
    return out


def _smallest_sphere(scene, p) -> np.ndarray:
    """(N,) radius of the smallest caster's world bounding sphere holding each point ``p`` (N, 3); 0 for none."""
    from scipy.spatial import cKDTree

    from .scene_arrays import scene_arrays

    arr = scene_arrays(scene)
    c, r = arr["world_centre"][arr["casts"]], arr["world_radius"][arr["casts"]]
    out = np.full(len(p), np.inf)
    if len(c) and len(p):
        hits = cKDTree(p).query_ball_point(c, r) if len(c) > 32 else None
        for k in np.argsort(-r):                # the smaller spheres last: theirs kept
            inside = (np.asarray(hits[k], np.int64) if hits is not None
                      else np.flatnonzero(np.einsum("ij,ij->i", p - c[k], p - c[k]) <= r[k] ** 2))
            out[inside] = r[k]
        held = np.flatnonzero(np.isfinite(out))
        out[held] = np.minimum(out[held], _near_bound(p[held], c, r))
    return np.where(np.isinf(out), 0.0, out)


def _near_bound(points, centres, radii) -> np.ndarray:
    """(N,) :data:`NEAR_SIZES` times the least over the spheres (M >= 1) of ``max(radius, gap)`` (``gap``:
    each point's distance to the sphere): :func:`sphere_size`'s bound."""
    out = np.empty(len(points))
    step = max(1, (1 << 22) // len(radii))      # at most 4 M point-sphere pairs at a time
    for s in range(0, len(points), step):
        gap = np.linalg.norm(points[s:s + step, None, :] - centres[None], axis=2) - radii * (1.0 + 1e-6)
        out[s:s + step] = NEAR_SIZES * np.maximum(gap, radii).min(axis=1)
    return out


def off_own_surface(rays, rel, w, eps, tfar, occ, ends=None) -> np.ndarray:
    """``occ`` (N,) of :func:`pyshadow.embree.visible`'s rays, with each ray whose first hit is a triangle
    whose plane holds its own point (within its lift) traced again from the point lifted off that plane,
    and each whose first hit lies in the plane of its end (the surface a light stands on) answered open.

    ``rays`` is the :class:`pyshadow.embree.EmbreeScene`; ``rel`` the points relative to its anchor, ``w``
    their unit directions, ``eps`` (N,) their lifts, ``tfar`` (N,) or None the lengths from the lifted
    origins ``rel + eps w``; ``ends`` None or the ends (N, 3) (relative, not finite for unbounded rays) and
    how far before them the rays stop (N,) (:func:`end_epsilon`). A ray meets a plane holding its point
    (its end) only there, so such a hit is float32's rounding: lifted along itself only, a ray leaving its
    surface at a grazing angle stayed within it, and the surface (that triangle or a coplanar neighbour) hid
    it (25-61 % of the rays 0.01 degrees above a plate turned by 30-77 degrees; none unturned), and so hid
    a light standing on a turned plate (a ray's first hit: nothing lies before it). Again from ``rel + eps
    w`` moved ``eps`` off that plane, to the side the ray leaves (behind it for a ray into the surface, as a
    steep one starts); up to three planes (a point on an edge or a corner). Rays stopped elsewhere keep
    their answer.
    """
    occ = occ.copy()
    rows = np.flatnonzero(occ)
    lift = np.zeros((len(rows), 3))
    for k in range(4):
        if not len(rows):
            break
        _, prim, _ = rays.intersect(rel[rows] + eps[rows, None] * w[rows] + lift, w[rows],
                                    None if tfar is None else tfar[rows])
        if k:                       # traced again: its new first hit decides
            occ[rows] = prim >= 0
        if ends is not None:        # the plane the light stands on
            with np.errstate(invalid="ignore"):
                occ[rows[_holding_normals(rays, prim, ends[0][rows], ends[1][rows]).any(axis=1)]] = False
        n = _holding_normals(rays, prim, rel[rows], eps[rows]) if k < 3 else np.zeros((len(rows), 3))
        own = n.any(axis=1) & occ[rows]
        side = np.where(np.einsum("ij,ij->i", n, w[rows]) < 0.0, -1.0, 1.0)
        lift = (lift + (eps[rows] * side)[:, None] * n)[own]
        rows = rows[own]
    return occ


def _holding_normals(rays, prim, points, tol) -> np.ndarray:
    """(N, 3) the unit normal of each hit triangle ``prim`` (N,) of ``rays`` whose plane lies within ``tol``
    (N,) of its point ``points`` (N, 3) (both relative to the scene's anchor, world units); 0 for a triangle
    farther, a miss or no area."""
    u = rays.unit
    tri = rays.triangles[np.maximum(prim, 0)].astype(np.float64)     # Embree's, in its units (exact)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = np.linalg.norm(n, axis=1)
    n /= np.where(area > 0.0, area, 1.0)[:, None]
    held = (prim >= 0) & (area > 0.0) & (np.abs(np.einsum("ij,ij->i", points * u - tri[:, 0], n)) <= tol * u)
    return np.where(held[:, None], n, 0.0)


def off_crossed_planes(rays, origins, w, surface=None, moved=None) -> np.ndarray:
    """(N,) first-hit distances (inf: a miss) of AO rays from the lifted ``origins`` (N, 3) along ``w``
    (N, 3), both relative to the anchor of ``rays`` (:class:`pyshadow.embree.EmbreeScene`), with each ray
    whose first hit is a triangle whose plane holds its origin traced again from the origin moved off that
    plane; up to three planes (an origin on an edge or a corner).

    An origin lifted along its normal stays in the plane of a face perpendicular to that normal: a point on
    the ground (or a lid) at the foot of a wall. A ray meets a plane holding its origin only there, so such
    a hit is float32's rounding: every AO ray of such a point was hidden by the wall at t = 0 (AO 0 at the
    foot of a box's side instead of 0.5). "Holds" is within 8 float32 spacings of the larger of the
    origin's and the triangle's coordinates (Embree's units), far below the lift off the point's own
    surface (:func:`surface_epsilon`, at least 64); the move is :func:`ray_epsilon` of the same, to the side
    of the plane the point's own surface lies on where ``surface`` tells it (:func:`_surface_side`: inside
    a room of walls without thickness), else to the side the ray leaves (beside a solid, whose inside
    hides the rays into it). Origins are taken as the float32 numbers Embree traces.

    First, with ``surface``, the origins of a point whose lift crossed a face of a body touching it (a box's
    corner resting on another's face, lifted along its vertex normal into the other) are moved out of that
    body, in front of that face (:func:`_off_touching`); ``moved``, a list, then gets the array of those
    points.

    ``surface``: None, or the points' :func:`point_surfaces` followed by each ray's point (N,) int.
    """
    u = rays.unit
    t, prim, _ = rays.intersect(origins, w)
    o = np.asarray(origins, dtype=np.float32).astype(np.float64) * u       # Embree's units (exact)
    w = np.asarray(w, dtype=np.float64)
    if surface is not None:         # origins lifted into a body touching their point: out of it first
        o, t, prim, pts = _off_touching(rays, origins, o, w, t, prim, surface)
        if moved is not None:
            moved.append(pts)
    rows = np.flatnonzero(prim >= 0)
    prim = prim[rows]
    for _ in range(3):
        if not len(rows):
            break
        tri = rays.triangles[prim].astype(np.float64)
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        area = np.linalg.norm(n, axis=1)
        n /= np.where(area > 0.0, area, 1.0)[:, None]
        size = np.maximum(np.abs(o[rows]).max(axis=1), np.abs(tri).max(axis=(1, 2)))
        held = (area > 0.0) & (np.abs(np.einsum("ij,ij->i", o[rows] - tri[:, 0], n)) <= 0.125 * ray_epsilon(size))
        rows, n, step = rows[held], n[held], ray_epsilon(size[held])
        side = np.where(np.einsum("ij,ij->i", n, w[rows]) < 0.0, -1.0, 1.0)
        if surface is not None and len(rows):
            own = _surface_side(rays, o[rows], n, step, *(a[surface[3][rows]] for a in surface[:3]))
            side = np.where(own != 0.0, own, side)
        o[rows] += (step * side)[:, None] * n
        t[rows], prim, _ = rays.intersect(o[rows] / u, w[rows])
        rows, prim = rows[prim >= 0], prim[prim >= 0]
    return t


def _off_touching(rays, origins, o, w, t, prim, surface):
    """``o``, ``t``, ``prim`` of :func:`off_crossed_planes`' rays with the origins of each point whose lift
    crossed a face of a body touching it (a ray's first hit the back of a face whose plane lies between the
    point and its origin: :func:`_lifted_through`) moved in front of that plane by
    :func:`ray_epsilon` of the coordinates, and those rays traced again; up to three planes, none facing
    one already crossed (the face the body beyond touches back with); and the points moved."""
    u = rays.unit
    point = surface[3]
    done, used = np.zeros(0, np.int64), np.zeros((0, 3, 3))     # the points moved, the normals they crossed
    rows = np.flatnonzero(prim >= 0)
    for j in range(3):
        tri = rays.triangles[prim[rows]].astype(np.float64)
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        area = np.linalg.norm(n, axis=1)
        n /= np.where(area > 0.0, area, 1.0)[:, None]
        gap = np.einsum("ij,ij->i", o[rows] - tri[:, 0], n)
        bad = (area > 0.0) & _lifted_through(rays, origins, rows, tri, n, gap, w, surface)
        if j and bad.any():             # not back through a plane crossed before
            at = np.minimum(np.searchsorted(done, point[rows]), len(done) - 1)
            bad &= ~((done[at] == point[rows]) & (np.einsum("ij,ikj->ik", n, used[at]) < -0.999).any(axis=1))
        if not bad.any():
            break
        k = np.flatnonzero(bad)
        pts, first = np.unique(point[rows[k]], return_index=True)     # one plane a point: its first ray's
        k = k[first]
        size = np.maximum(np.abs(o[rows[k]]).max(axis=1), np.abs(tri[k]).max(axis=(1, 2)))
        shift = (ray_epsilon(size) - gap[k])[:, None] * n[k]
        new = np.union1d(done, pts)
        grown = np.zeros((len(new), 3, 3))
        grown[np.searchsorted(new, done)] = used
        grown[np.searchsorted(new, pts), j] = n[k]
        done, used = new, grown
        moved = np.flatnonzero(np.isin(point, pts))
        o[moved] += shift[np.searchsorted(pts, point[moved])]
        t[moved], prim[moved], _ = rays.intersect(o[moved] / u, w[moved])
        rows = moved[prim[moved] >= 0]          # the others' first hits are as they were
    return o, t, prim, done


def occluded_again(rays, origins, w, occ, surface) -> np.ndarray:
    """``occ`` (N,) of AO rays from the lifted ``origins`` (N, 3) along ``w`` (N, 3) (Embree's occlusion,
    relative to the anchor of ``rays``), with the hidden rays traced again by :func:`off_crossed_planes`
    (``surface`` as there), and every ray of a point whose origins it moved out of a body touching the
    point traced again from there too: the open ones as well (from below a sheet a box stands on, the rays
    down met nothing; from above, the sheet).
    """
    occ = occ.copy()
    rows, moved = np.flatnonzero(occ), []
    occ[rows] = np.isfinite(off_crossed_planes(rays, origins[rows], w[rows], (*surface[:3], surface[3][rows]),
                                               moved))
    pts = moved[0] if moved else np.zeros(0, np.int64)
    if len(pts):
        rows = np.flatnonzero(np.isin(surface[3], pts))
        occ[rows] = np.isfinite(off_crossed_planes(rays, origins[rows], w[rows], (*surface[:3], surface[3][rows])))
    return occ


def _lifted_through(rays, origins, rows, tri, n, gap, w, surface) -> np.ndarray:
    """(len(rows),) whether each ray ``rows`` of :func:`off_crossed_planes` met the back of a triangle ``tri``
    (Embree's units, unit normal ``n``) whose plane its point's lift crossed: the point (its origin moved
    back along its normal) lies on or in front of the plane, and the origin behind it (``gap``: its signed
    distance), both beyond 8 float32 spacings of the coordinates (the tolerance of a plane holding the
    origin). Such an origin was lifted into the body behind that face, one touching the point's surface
    there (a box's corner resting on another's face, whose vertex normal points down into it): from inside,
    every ray met that body (AO 0 where the open directions gave 0.19-0.22). A plane the lift runs along
    (the side of a box over a point of the face it rests on, nearer than the lift) is not crossed. False for
    all without ``surface``."""
    if surface is None or not len(rows):
        return np.zeros(len(rows), bool)
    u = rays.unit
    k = surface[3][rows]
    lift = surface[1][k] * u
    p = np.asarray(origins, dtype=np.float64)[rows] * u - lift[:, None] * surface[0][k]
    tol = 0.125 * ray_epsilon(np.maximum(np.abs(p).max(axis=1), np.abs(tri).max(axis=(1, 2))))
    at = np.einsum("ij,ij->i", p - tri[:, 0], n)
    return (at >= -tol) & (gap < -tol) & (at - gap >= tol) & (np.einsum("ij,ij->i", w[rows], n) > 0.0)


def point_surfaces(scene, points, normals, lifts):
    """``surface`` of :func:`off_crossed_planes` for AO points (N, 3, world) lifted ``lifts`` (N,) along their
    unit ``normals`` (N, 3): those two and whether each point lies on the scene's ground plane (within
    :func:`pyshadow.contact.ground_tolerance`)."""
    from .contact import ground_tolerance

    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    on = (np.zeros(len(P), bool) if scene.ground is None
          else np.abs(P[:, 1] - scene.ground) <= ground_tolerance(scene))
    return np.asarray(normals, dtype=np.float64), np.asarray(lifts, dtype=np.float64), on


def _surface_side(rays, o, n, step, normals, lifts, on_ground) -> np.ndarray:
    """(N,) the side (+1: along ``n``, -1: against it, 0: both or neither) of the planes ``n`` (N, 3) holding
    the origins ``o`` (N, 3, Embree's units) on which the surface the origins were lifted off lies: a
    triangle met by a ray from ``o`` moved ``step`` (N,) to that side, back along the point's normal
    ``normals`` (N, 3) as far as twice its lift ``lifts`` (N,, world units); both sides for a point on the
    ground plane (``on_ground`` (N,) bool: the plane extends under the wall and beside it)."""
    u = rays.unit
    d = -np.asarray(normals, dtype=np.float64)
    hit = [rays.occluded((o + (s * step)[:, None] * n) / u, d, 2.0 * lifts) | on_ground for s in (1.0, -1.0)]
    return np.where(hit[0] == hit[1], 0.0, np.where(hit[0], 1.0, -1.0))

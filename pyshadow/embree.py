"""Ground truth from Embree (through embreex): the same quantities by ray tracing.

Everything pyshadow computes from rasterised or compressed visibility is
measured against these functions. Ray origins that continue from a hit are
moved along the ray by a scale-aware epsilon (a multiple of the float32
spacing at the size of the coordinates), never by a fixed constant.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import trimesh

from ._compat import keyword_only
from ._embree_checks import (check_frame, check_item, check_threads, float32_rays, prepare_inputs, scene_state,
                             traced_in_chunks)
from ._embree_lift import (ray_epsilon, surface_epsilon, end_epsilon, off_crossed_planes, off_own_surface,
                           occluded_again, point_surfaces)
from ._validate import check_both, check_indices, check_values, flag, kernel_rows, unit_normals
from .contact import ground_tolerance
from .mesh import bounding_sphere, check_mesh, float32_unit, load_mesh
from .scene_arrays import ANCHOR_REACH_RADII, anchor_groups
from .views import ViewSet

__all__ = ["EmbreeScene", "EmbreeTracer", "caster_scene", "depth_layers", "gbuffer", "ground_occludes",
           "ray_epsilon", "visible", "ambient_occlusion", "render", "surface_epsilon"]


class EmbreeScene:
    """An embreex scene of triangle soups with float64 helpers.

    Embree tests rays against triangles in float32, whose products of three
    coordinates overflow beyond about 7e12 and leave the normal range below
    about 2e-13: there rays pass through triangles. Triangles whose largest
    coordinate lies outside ``[2**-20, 2**20]`` are therefore given to Embree
    scaled by a power of two (:func:`pyshadow.mesh.float32_unit`, the
    attribute ``unit``), and so are the rays' origins and lengths; distances
    come back in the caller's units. A power of two changes no significand:
    the answers are those of the same scene at unit size, and within the band
    those of the coordinates as given, bit for bit.

    Parameters
    ----------
    triangles : ndarray, shape (T, 3, 3)
        Triangle corners, any units (converted to float32 for Embree).
    """

    def __init__(self, triangles):
        from embreex import rtcore_scene as rtcs
        from embreex.mesh_construction import TriangleMesh

        tri = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
        if not np.isfinite(tri).all():      # Embree would drop such triangles: rays pass through them
            raise ValueError(f"EmbreeScene: {int((~np.isfinite(tri).all(axis=(1, 2))).sum())} triangles have "
                             "corners that are not finite (NaN or inf)")
        # coordinates of any size: Embree sees them scaled by a power of two (1 near unit size)
        self.unit = float32_unit(np.abs(tri).max()) if len(tri) else 1.0
        tri = np.ascontiguousarray(tri * self.unit, dtype=np.float32)
        self.n_triangles, self.triangles = len(tri), tri        # (T, 3, 3) float32: Embree's, in its units
        self._scene = rtcs.EmbreeScene()
        if len(tri):
            TriangleMesh(self._scene, tri)

    def intersect(self, origins, directions, tfar=None):
        """Closest hits: (t float64 (N,) with inf for misses, primID int (N,), Ng (N,3))."""
        o, d, kw = self._rays(origins, directions, tfar)
        if len(o) == 0 or self.n_triangles == 0:
            n = len(o)
            return np.full(n, np.inf), np.full(n, -1, np.int32), np.zeros((n, 3))
        res = self._scene.run(o, d, output=1, **kw)
        prim = np.asarray(res["primID"], dtype=np.int64)
        t = np.where(prim >= 0, np.asarray(res["tfar"], dtype=np.float64), np.inf) / self.unit
        return t, prim, np.asarray(res["Ng"], dtype=np.float64) / self.unit ** 2

    def _rays(self, origins, directions, tfar):
        """float32 origins and directions and embreex's keywords (``dists``: ``tfar``), in Embree's units
        (scaled by :attr:`unit`, exact: a power of two); refused, named, where Embree would misread them
        (:func:`pyshadow._embree_checks.float32_rays`)."""
        return float32_rays(origins, directions, tfar, self.unit)

    def occluded(self, origins, directions, tfar=None) -> np.ndarray:
        """Any hit along each ray within ``tfar`` (default: unbounded); bool (N,)."""
        o, d, kw = self._rays(origins, directions, tfar)
        if len(o) == 0 or self.n_triangles == 0:
            return np.zeros(len(o), dtype=bool)
        res = self._scene.run(o, d, query="OCCLUDED", **kw)
        return np.asarray(res) >= 0


@keyword_only("pyshadow.embree.depth_layers", old=2)
def depth_layers(mesh, views: ViewSet, *, resolution: int = 128, layers: int = 2,
                 frame=None, facing: bool = False):
    """Depth layers of ``mesh`` by Embree rays through the texel centres.

    Same convention and output as :func:`pyshadow.render_depth`: rays start on
    the plane through ``d_k`` and run along ``-d_k``; depth is ``t/2``.
    Layer ``l+1`` is found by restarting the ray just behind the hit of
    layer ``l``.

    Returns
    -------
    depth : ndarray, shape (D, layers, R, R), float32
    front : ndarray, shape (D, layers, R, R), bool
        Only with ``facing=True``: the hit triangle's winding normal has a
        positive component along ``d_k``.
    """
    from .raster import texel_rays

    from ._validate import check_int

    R = check_int(resolution, "depth_layers: resolution", 1)
    layers = check_int(layers, "depth_layers: layers", 0)
    if not isinstance(mesh, trimesh.Trimesh):
        mesh = load_mesh(mesh)
    check_mesh(mesh, "depth_layers: mesh")
    centre, radius = check_frame(frame, "depth_layers: frame") if frame is not None else bounding_sphere(mesh)
    verts = (np.asarray(mesh.vertices, dtype=np.float64) - centre) / radius
    tri = verts[np.asarray(mesh.faces)]
    scene = EmbreeScene(tri)
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    out = np.full((len(views), layers, R, R), np.inf, dtype=np.float32)
    front = np.zeros(out.shape, bool)
    eps = float(ray_epsilon(2.0))
    for k, B in enumerate(views.bases):
        origins, direction = texel_rays(B, R)
        o = origins.reshape(-1, 3)
        dirs = np.broadcast_to(direction, o.shape)
        travelled = np.zeros(len(o))
        alive = np.arange(len(o))
        for layer in range(layers):
            if len(alive) == 0:
                break
            start = o[alive] + (travelled[alive])[:, None] * dirs[alive]
            t, prim, _ = scene.intersect(start, dirs[alive])
            hit = np.isfinite(t)
            alive = alive[hit]
            travelled[alive] += t[hit]
            out[k, layer].reshape(-1)[alive] = (travelled[alive] * 0.5).astype(np.float32)
            front[k, layer].reshape(-1)[alive] = normals[prim[hit]] @ B[2] > 0
            travelled[alive] += eps
    return (out, front) if facing else out


def gbuffer(items, camera) -> dict:
    """Primary-ray G-buffer by Embree: the same dict as :func:`pyshadow.render_gbuffer`.

    Rays start at the camera's eye; triangles are moved into eye-relative
    coordinates first (float64), so Embree's float32 stays precise for scenes
    far from the world origin.
    """
    from .gbuffer import check_transform, through_eye

    tris, obj, face = [], [], []
    for oid, item in enumerate(items):
        mesh, T = check_item(item, oid)     # as render_gbuffer: a NaN corner would drop its triangles, unseen
        T = check_transform(T, name=f"transform of item {oid}")
        w = np.asarray(mesh.vertices, dtype=np.float64) @ T[:3, :3].T + T[:3, 3]
        tris.append((w - camera.eye)[np.asarray(mesh.faces)])
        obj.append(np.full(len(mesh.faces), oid, np.int32))
        face.append(np.arange(len(mesh.faces)))
    tris = np.concatenate(tris) if tris else np.zeros((0, 3, 3))
    obj = np.concatenate(obj) if obj else np.zeros(0, np.int32)
    face = np.concatenate(face) if face else np.zeros(0, np.int64)
    # a triangle in a plane through the eye (the ground with the eye in it) is seen edge-on: no pixel, as in
    # render_gbuffer; traced from the eye it was met at t = 0 by every ray
    seen = ~through_eye(tris)
    tris, obj, face = tris[seen], obj[seen], face[seen]
    # rays start where they reach the triangles' bounding sphere (float64), triangles relative to its centre:
    # from a far eye, float32 coordinates relative to the eye would round corners by 6e-8 of the distance
    centre = 0.5 * (tris.min(axis=(0, 1)) + tris.max(axis=(0, 1))) if len(tris) else np.zeros(3)
    reach = float(np.sqrt(((tris - centre) ** 2).sum(axis=2).max())) if len(tris) else 0.0
    dirs = camera.ray_directions().reshape(-1, 3)
    skip = np.maximum(dirs @ centre - reach, 0.0)
    scene = EmbreeScene(tris - centre)
    t, prim, _ng = scene.intersect(skip[:, None] * dirs - centre, dirs)
    t = t + skip
    hit = prim >= 0
    p = np.where(hit, prim, 0)
    if not len(tris):           # no triangles: every pixel misses (one zero row for the lookups below)
        tris, obj, face = np.zeros((1, 3, 3)), np.zeros(1, np.int32), np.zeros(1, np.int64)
    tri = tris[p]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    n = np.where((np.einsum("ij,ij->i", n, dirs) > 0)[:, None], -n, n)
    H, W = camera.height, camera.width
    pos = camera.eye + np.where(hit, t, 0.0)[:, None] * dirs
    pos[~hit] = np.nan
    n[~hit] = 0.0
    return {
        "position": pos.reshape(H, W, 3).astype(np.float32),
        "normal": n.reshape(H, W, 3).astype(np.float32),
        "object_id": np.where(hit, obj[p], -1).reshape(H, W).astype(np.int32),
        "face": np.where(hit, face[p], -1).reshape(H, W).astype(np.int32),
        "depth": np.where(hit, t, np.inf).reshape(H, W).astype(np.float32),
    }


# ---------------------------------------------------------------------------
# scenes: visibility and ambient occlusion by ray tracing
# ---------------------------------------------------------------------------
def caster_scene(scene, anchor=None) -> tuple[EmbreeScene, np.ndarray]:
    """Embree scene of every caster of a :class:`pyshadow.Scene`, for rays of one's own.

    Parameters
    ----------
    scene : pyshadow.Scene
        Every instance added with ``casts=True`` must carry its mesh.
    anchor : array_like, shape (3,), optional
        World point to subtract (default: the scene's, :meth:`pyshadow.Scene.anchor`;
        :func:`pyshadow.scene_arrays.anchor_groups` gives others for points far from it).

    Returns
    -------
    rays : EmbreeScene
        The casters' triangles in world space minus ``anchor`` (float32 in
        Embree, so coordinates stay small wherever the scene is).
    anchor : ndarray, shape (3,), float64
        World point subtracted from the triangles: rays must be given
        relative to it.
    """
    anchor = scene.anchor() if anchor is None else np.asarray(anchor, np.float64)
    if anchor.shape != (3,) or not np.isfinite(anchor).all():
        raise ValueError(f"caster_scene: anchor must be 3 finite numbers, got {anchor.tolist()}")
    tris = []
    for i, inst in enumerate(scene.instances):
        if not inst.casts:
            continue
        if inst.mesh is None:
            raise ValueError(f"instance {i} was added as a CSM without its mesh: the reference "
                             "ray tracer needs the geometry (pass mesh= to Scene.add)")
        T = inst.transform
        w = np.asarray(inst.mesh.vertices, dtype=np.float64) @ T[:3, :3].T + T[:3, 3] - anchor
        tris.append(w[np.asarray(inst.mesh.faces)])
    return EmbreeScene(np.concatenate(tris) if tris else np.zeros((0, 3, 3))), anchor


def ground_occludes(scene, points, directions, anchor=None, tmax=None) -> np.ndarray:
    """The scene's ground plane, decided analytically as the visibility kernel does.

    Parameters
    ----------
    scene : pyshadow.Scene
    points : ndarray, shape (N, 3), float64
        Ray origins: world space, or relative to ``anchor`` when it is given.
    directions : ndarray, shape (N, 3)
        Ray directions (any length).
    anchor : ndarray, shape (3,), optional
        The anchor of :func:`caster_scene`.
    tmax : ndarray, shape (N,), optional
        Ray lengths (world units; the directions must then be unit): the
        plane blocks only segments that cross it
        (:mod:`pyshadow.visibility.finite`).

    Returns
    -------
    ndarray, shape (N,), bool
        True where the plane y = ``scene.ground`` blocks the ray: a point on or
        above it (within :func:`pyshadow.contact.ground_tolerance`) looking down, or
        a point below it looking up. All False without a ground plane.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    directions = np.asarray(directions).reshape(-1, 3)
    if scene.ground is None:
        return np.zeros(len(points), bool)
    level = scene.ground - (0.0 if anchor is None else anchor[1])
    from .visibility.finite import ground_blocks, ground_offsets

    offset = 0.0 if tmax is None else abs(level) if anchor is not None else ground_offsets(scene, points)
    return ground_blocks(points[:, 1] - level, directions[:, 1], tmax, ground_tolerance(scene), offset)


def _rays64(points, directions):
    """(N, 3) points and non-zero directions, finite, as float64: refused as the kernels refuse them."""
    p = kernel_rows(points, "points")
    w = kernel_rows(directions, "directions", len(p))
    check_both(p, "points", w, "directions")
    return np.asarray(p, np.float64), np.asarray(w, np.float64)


def visible(scene, points, directions, max_distance=None) -> np.ndarray:
    """Ground-truth :meth:`pyshadow.Scene.visible`: Embree occlusion rays.

    Each ray starts at the point moved by :func:`surface_epsilon` along its
    direction (so a point on a surface does not hit that surface) and runs
    to infinity, or with ``max_distance`` (float or (N,), world units, > 0)
    to the end ``p + max_distance w`` moved back as much (:func:`end_epsilon`:
    a light on a surface is not hidden by it); a ray that grazes the surface
    its point or its end lies on is not hidden by it either
    (:func:`pyshadow._embree_lift.off_own_surface`); the ground plane is tested
    analytically as in the kernel (:mod:`pyshadow.visibility.finite`).
    """
    from .visibility.finite import check_max_distance

    p, w = _rays64(points, directions)
    f32 = np.asarray(points).dtype == np.float32        # float32 surface samples: lifted off their rounding too
    w = unit_normals(w, len(p), "directions")       # any length: scaled first where |w|^2 leaves float64
    tmax = check_max_distance(max_distance, len(p))
    groups = anchor_groups(scene, p)
    if len(groups) > 1:         # points far apart: each group's rays relative to an anchor of its own
        out = np.empty(len(p), bool)
        for rows, a in groups:
            out[rows] = _visible(scene, p[rows], w[rows], None if tmax is None else tmax[rows], a, f32)
        return out
    return _visible(scene, p, w, tmax, groups[0][1], f32)


def _visible(scene, p, w, tmax, anchor, f32=True):
    """:func:`visible` of validated rows, relative to ``anchor`` (``f32``: the points were given as float32)."""
    rays, anchor = caster_scene(scene, anchor)
    rel = p - anchor
    occ = ground_occludes(scene, rel, w, anchor, tmax)
    todo = np.flatnonzero(~occ)
    if len(todo):
        eps = surface_epsilon(scene, p[todo], anchor, float32_points=f32)
        tfar = ends = None
        if tmax is not None:
            back = end_epsilon(scene, p[todo], w[todo], tmax[todo], anchor)
            tfar = np.maximum(tmax[todo] - eps - back, 0.0)
            tfar = np.where(tfar > np.finfo(np.float32).max, np.inf, tfar)     # beyond float32's range: unbounded
            with np.errstate(over="ignore", invalid="ignore"):      # unbounded rays: no end
                ends = (rel[todo] + tmax[todo, None] * w[todo], back)
        occ[todo] = rays.occluded(rel[todo] + eps[:, None] * w[todo], w[todo], tfar)
        # a ray stopped by the surface its point or its end lies on (grazing it): again, off that surface
        occ[todo] = off_own_surface(rays, rel[todo], w[todo], eps, tfar, occ[todo], ends)
    return ~occ


def ambient_occlusion(scene, points, normals, *args, sampling=None, return_bent_normals: bool = False,
                      indices=None, max_distance=None, obscurance=None, **old):
    """Ground-truth :meth:`pyshadow.Scene.ambient_occlusion` on the identical directions.

    The directions are :func:`pyshadow.sample_directions`' for ``sampling``
    (default ``Sampling()``) and ``indices`` (the ones the kernel traces);
    ray origins are lifted off the surface along the normal by
    :func:`surface_epsilon`, off a plane holding the lifted origin (a wall
    at the point's foot) where it hides the ray, and out of a body the lift
    entered (a box's corner resting on another's face)
    (:func:`pyshadow._embree_lift.off_crossed_planes`). Returns ``(N,)`` float32 AO (and ``(N, 3)``
    float32 bent normals with ``return_bent_normals=True``). The old
    positional ``samples, strategy, seed, patterns, bent_normals`` still work,
    with a DeprecationWarning.

    ``max_distance`` (float or (N,), world units, > 0) and ``obscurance``
    (``tau``, 1 / world units): distance AO, exact -- each ray contributes
    ``rho(L)`` of its first-hit distance ``L`` (Embree's closest hit from the
    lifted origin, or the ground plane's analytic distance):
    ``[L > max_distance]`` (distance-limited), ``1 - exp(-tau L)`` for
    ``L <= max_distance`` and 1 beyond (distance-weighted;
    :mod:`pyshadow.visibility.finite`). Bent normals weight each direction
    by its ``rho``.
    """
    from ._compat import legacy_sampling
    from .sampling import Sampling, ao_from_samples, sample_directions

    sampling, extra = legacy_sampling("embree.ambient_occlusion", args,
                                      ("samples", "strategy", "seed", "patterns", "bent_normals"), sampling,
                                      old, Sampling())
    bent_normals = flag(extra.get("bent_normals", return_bent_normals), "return_bent_normals")   # "False" was true

    p = kernel_rows(points, "points")
    f32, p = p.dtype == np.float32, np.asarray(p, np.float64)     # float32 points: lifted off their rounding too
    check_values(p, "points")
    n = unit_normals(normals, len(p))
    distance = max_distance is not None or obscurance is not None
    if distance:                        # checked before anything is launched
        from .visibility.finite import check_ao_options, check_max_distance

        tau = check_ao_options(obscurance, 1, "error")[0]
        tmax = check_max_distance(np.inf if max_distance is None else max_distance, len(p))
    idx = check_indices(indices, len(p))
    out = (np.empty(len(p), np.float32), np.empty((len(p), 3), np.float32))
    step = max(1, _CHUNK_RAYS // sampling.samples)     # points a chunk: all N S rays at once took 100 bytes a ray
    for rows, a in anchor_groups(scene, p):  # one group but where points lie far apart
        rays, a = caster_scene(scene, a)
        rows = np.arange(len(p)) if rows is None else rows
        for r in (rows[s:s + step] for s in range(0, len(rows), step)):
            dirs = sample_directions(n[r], sampling=sampling, indices=idx[r]).astype(np.float64)
            w = (_distance_weights(scene, rays, a, p[r], n[r], dirs, tmax[r], tau, f32) if distance
                 else ~_occluded_samples(scene, rays, a, p[r], n[r], dirs, f32))
            got = ao_from_samples(dirs, w, n[r], bent_normals)
            out[0][r], out[1][r] = got if bent_normals else (got, 0.0)
    return out if bent_normals else out[0]


_CHUNK_RAYS = 1 << 21   # AO rays a chunk of ambient_occlusion's points, and a call of Embree


def _occluded_samples(scene, rays, anchor, p, n, dirs, f32=True):
    """(N, S) bool: which of the AO sample rays ``dirs`` (N, S, 3) from ``p`` an occluder stops (``rays``:
    :func:`caster_scene` relative to ``anchor``)."""
    N, S = dirs.shape[:2]
    flat = dirs.reshape(-1, 3)
    # the ground is tested at the point itself, as the kernel does
    occ = ground_occludes(scene, np.repeat(p - anchor, S, axis=0), flat, anchor)
    lift = surface_epsilon(scene, p, anchor, float32_points=f32)
    origins, surf = np.repeat(p - anchor + lift[:, None] * n, S, axis=0), point_surfaces(scene, p, n, lift)
    todo = np.flatnonzero(~occ)
    chunk = _CHUNK_RAYS
    for s in range(0, len(todo), chunk):
        sel = todo[s:s + chunk]
        occ[sel] = rays.occluded(origins[sel], flat[sel])
        # hidden by a plane holding the origin (at a wall's foot), or lifted into a touching body: again
        occ[sel] = occluded_again(rays, origins[sel], flat[sel], occ[sel], (*surf, sel // S))
    return occ.reshape(N, S)


def _distance_weights(scene, rays, anchor, p, n, dirs, tmax, tau, f32=True):
    """:func:`ambient_occlusion`'s distance AO weights (N, S) from first-hit distances (float64), relative to
    ``anchor`` (``rays``: :func:`caster_scene` there)."""
    from .visibility.finite import obscurance_weight

    N, S = dirs.shape[:2]
    flat = dirs.reshape(-1, 3)
    L = np.full(N * S, np.inf)
    if scene.ground is not None:        # the plane's distance, by the rule of finite.ground_blocks
        h = np.repeat(p[:, 1] - scene.ground, S)
        wy = flat[:, 1].astype(np.float64)
        eps = ground_tolerance(scene)
        with np.errstate(divide="ignore", invalid="ignore"):
            down = (h >= -eps) & (wy < 0)
            up = (h < -eps) & (wy > 0)
            L = np.where(down, np.maximum(h, 0.0) / -wy, L)
            L = np.where(up, -h / wy, L)
    lift = surface_epsilon(scene, p, anchor, float32_points=f32)
    origins, surf = np.repeat(p - anchor + lift[:, None] * n, S, axis=0), point_surfaces(scene, p, n, lift)
    chunk = _CHUNK_RAYS
    for s in range(0, N * S, chunk):
        pt = np.arange(s, min(s + chunk, N * S)) // S       # the first hit, off planes holding the origin
        t = off_crossed_planes(rays, origins[s:s + chunk], flat[s:s + chunk], (*surf, pt))
        L[s:s + chunk] = np.minimum(L[s:s + chunk], t)
    return obscurance_weight(L, np.repeat(tmax, S), tau).reshape(N, S)


class EmbreeTracer:
    """Embree occlusion rays against a scene's casters, traced by a pool of threads.

    The rays are those of :func:`ambient_occlusion`, bit for bit: :meth:`prepare`
    lifts each origin off its surface along the normal by
    :func:`surface_epsilon`, expresses it relative to the casters' anchor
    (:func:`caster_scene`) and rounds origins and directions to float32 as
    :meth:`EmbreeScene.occluded` does; the ground plane is decided
    analytically at the point itself (:func:`ground_occludes`) and never
    traced. Given the directions of :func:`pyshadow.sample_directions`, the
    AO of ``~occluded`` averaged over each point's samples therefore equals
    :func:`ambient_occlusion`'s exactly, for any number of threads, but for a
    ray hidden by a plane holding its lifted origin (a point at the foot of a
    wall) or a point lifted into a body touching it, which :func:`ambient_occlusion`
    traces again (:func:`pyshadow._embree_lift.off_crossed_planes`) and the tracer, timed as
    Embree is, does not (the second trace doubled its time at 11 % of rays hidden).

    embreex releases the GIL while it traces, so :meth:`occluded` keeps
    ``threads`` cores busy: it splits a batch of rays into contiguous chunks
    (about four chunks per thread, each at least 4096 rays) traced
    concurrently.

    The constructor builds the Embree scene and traces one ray, so that
    Embree's BVH is committed before any timed call. Call :meth:`close` (or
    use the tracer as a context manager) to stop the threads.

    Parameters
    ----------
    scene : pyshadow.Scene
        Every caster must carry its mesh (``Scene.add(..., mesh=...)``);
        after a change to the scene :meth:`prepare` raises ValueError.
    threads : int
        Worker threads, >= 1 (e.g. ``os.cpu_count()``).

    Attributes
    ----------
    rays : EmbreeScene
        The casters' triangles relative to ``anchor``.
    anchor : ndarray, shape (3,), float64
        World point subtracted from every ray origin.
    eps : float
        :func:`surface_epsilon` of the scene, world units (the largest; :meth:`prepare` lifts each
        point by its own, as :func:`ambient_occlusion` does).
    threads : int
    """

    def __init__(self, scene, threads: int):
        self.threads = check_threads(threads)
        self.scene = scene
        self.rays, self.anchor, self._state = *caster_scene(scene), scene_state(scene)
        self.eps = surface_epsilon(scene)
        self.closed = False
        self.pool = ThreadPoolExecutor(self.threads)
        # first call commits Embree's BVH: keep it out of every timing
        self.rays.occluded(np.zeros((1, 3), np.float32), np.array([[0.0, 1.0, 0.0]], np.float32))

    def close(self):
        """Shut the thread pool down (waits for running calls); :meth:`occluded` then refuses rays."""
        self.closed = True
        self.pool.shutdown()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def occluded(self, o32, d32) -> np.ndarray:
        """Embree occlusion of rays, split over the thread pool.

        Parameters
        ----------
        o32, d32 : ndarray, shape (n, 3), float32
            Ray origins relative to :attr:`anchor` and directions, as
            :meth:`prepare` returns them (checked there: C-contiguous float32
            rays go to Embree unchecked, and a NaN one reads open). Rays run
            from the origin to infinity.

        Returns
        -------
        ndarray, shape (n,), bool
            True where a caster triangle blocks the ray.
        """
        if self.closed:
            raise RuntimeError("EmbreeTracer.occluded: the tracer is closed (close() or the end of its with block)")
        o32, d32 = np.asarray(o32), np.asarray(d32)     # lists too (no copy of an array)
        n = len(o32)
        if np.shape(o32) != (n, 3) or np.shape(d32) != (n, 3):    # chunks of shorter directions: read past their end
            raise ValueError(f"EmbreeTracer.occluded: origins and directions must both have shape (n, 3), got "
                             f"{np.shape(o32)} and {np.shape(d32)}")
        # rays as prepare() makes them go to Embree unchecked (the benchmarks time this path)
        raw = (self.rays.unit == 1.0 and self.rays.n_triangles and o32.dtype == d32.dtype == np.float32
               and o32.flags.c_contiguous and d32.flags.c_contiguous)

        def trace(s, e):
            o, d = o32[s:e], d32[s:e]
            return np.asarray(self.rays._scene.run(o, d, query="OCCLUDED")) >= 0 if raw else self.rays.occluded(o, d)

        return traced_in_chunks(self.pool, self.threads, n, trace)

    def prepare(self, points, normals, dirs32, samples: int):
        """The rays of ``samples`` directions per point, as :func:`ambient_occlusion` builds them.

        Parameters
        ----------
        points : ndarray, shape (n, 3), float64
            World points on surfaces.
        normals : ndarray, shape (n, 3), float64
            Their normals (world frame; any length, normalised as :func:`ambient_occlusion` does).
        dirs32 : ndarray, shape (n * samples, 3), float32
            Unit directions (finite, non-zero), point-major (the ``samples`` directions of
            point 0 first), e.g. :func:`pyshadow.sample_directions` reshaped.
        samples : int
            Directions per point.

        Returns
        -------
        ground : ndarray, shape (n * samples,), bool
            Rays the ground plane occludes (decided analytically, not
            traced); the caller fills in the others from :meth:`occluded`.
        todo : ndarray of int64, shape (m,)
            Indices (into ``ground``) of the rays to trace.
        origins, dirs : ndarray, shape (m, 3), float32
            Those rays, ready for :meth:`occluded`.
        """
        f32 = np.asarray(points).dtype == np.float32
        points, normals, dirs32, S = prepare_inputs(self, points, normals, dirs32, samples)
        if anchor_groups(self.scene, points)[0][0] is not None:      # not one group at the scene's anchor
            raise ValueError(f"EmbreeTracer: points lie beyond {ANCHOR_REACH_RADII:g} radii of a caster nearer to "
                             "them than the scene's anchor, where its one anchor loses float32 precision; "
                             "pyshadow.embree.ambient_occlusion asks them relative to anchors of their own")
        rel = points - self.anchor
        ground = ground_occludes(self.scene, np.repeat(rel, S, axis=0), dirs32, self.anchor)
        lift = surface_epsilon(self.scene, points, self.anchor, float32_points=f32)[:, None]   # ambient_occlusion's
        origins = np.repeat((rel + lift * normals).astype(np.float32), S, axis=0)
        todo = np.flatnonzero(~ground)
        return ground, todo, origins[todo], dirs32[todo]


def render(scene, camera, *args, sampling=None, ground_size=None, normals="flat", crease_angle=None, **old):
    """Ground-truth :meth:`pyshadow.Scene.render`: Embree primary rays, then Embree AO
    rays along the identical directions (pixel ``r*W + c`` uses the same pattern).

    :func:`pyshadow.render.render` with ``visibility="embree"`` on the
    G-buffer of :func:`gbuffer`; returns a :class:`pyshadow.render.Frame`.
    ``normals`` and ``crease_angle`` (default that of
    :mod:`pyshadow.shading_normals`) as in :func:`pyshadow.render.render`:
    with ``"smooth"`` the same shading normals and the same hemisphere rule.
    The old positional ``samples, strategy, seed, patterns`` still work, with a
    DeprecationWarning.
    """
    from ._compat import legacy_sampling
    from .render import render as render_frame
    from .sampling import Sampling

    sampling, _ = legacy_sampling("embree.render", args, ("samples", "strategy", "seed", "patterns"), sampling,
                                  old, Sampling())
    from .shading_normals import DEFAULT_CREASE_ANGLE

    items, _ = scene.draw_items(ground_size)
    return render_frame(scene, camera, visibility="embree", sampling=sampling, ground_size=ground_size,
                        gbuffer=gbuffer(items, camera), normals=normals,
                        crease_angle=DEFAULT_CREASE_ANGLE if crease_angle is None else crease_angle)
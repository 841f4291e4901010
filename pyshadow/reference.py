"""Ground truth from Embree (through embreex): the same quantities by ray tracing.

Everything pyshadow computes from rasterised or compressed visibility is
measured against these functions. Ray origins that continue from a hit are
moved along the ray by a scale-aware epsilon (a multiple of the float32
spacing at the size of the coordinates), never by a fixed constant.
"""
from __future__ import annotations

import numpy as np
import trimesh

from .mesh import bounding_sphere, load_mesh
from .views import ViewSet

__all__ = ["EmbreeScene", "depth_layers", "gbuffer", "ray_epsilon"]


def ray_epsilon(scale) -> np.ndarray:
    """Offset along a ray that safely leaves a surface at coordinates of size ``scale``.

    64 float32 ulps of ``max(scale, 1e-30)``: large enough to step over the
    intersection error of a float32 ray tracer, small against any feature.
    """
    scale = np.maximum(np.abs(np.asarray(scale, dtype=np.float64)), 1e-30)
    return 64.0 * np.spacing(scale.astype(np.float32)).astype(np.float64)


class EmbreeScene:
    """An embreex scene of triangle soups with float64 helpers.

    Parameters
    ----------
    triangles : ndarray, shape (T, 3, 3)
        World-space triangle corners (converted to float32 for Embree).
    """

    def __init__(self, triangles):
        from embreex import rtcore_scene as rtcs
        from embreex.mesh_construction import TriangleMesh

        tri = np.ascontiguousarray(triangles, dtype=np.float32).reshape(-1, 3, 3)
        self.n_triangles = len(tri)
        self._scene = rtcs.EmbreeScene()
        if len(tri):
            TriangleMesh(self._scene, tri)

    def intersect(self, origins, directions, tfar=None):
        """Closest hits: (t float64 (N,) with inf for misses, primID int (N,), Ng (N,3))."""
        o = np.ascontiguousarray(origins, dtype=np.float32).reshape(-1, 3)
        d = np.ascontiguousarray(directions, dtype=np.float32).reshape(-1, 3)
        if len(o) == 0 or self.n_triangles == 0:
            n = len(o)
            return np.full(n, np.inf), np.full(n, -1, np.int32), np.zeros((n, 3))
        kw = {}
        if tfar is not None:
            kw["dists"] = np.ascontiguousarray(np.broadcast_to(tfar, (len(o),)), dtype=np.float32)
        res = self._scene.run(o, d, output=1, **kw)
        prim = np.asarray(res["primID"], dtype=np.int64)
        t = np.where(prim >= 0, np.asarray(res["tfar"], dtype=np.float64), np.inf)
        return t, prim, np.asarray(res["Ng"], dtype=np.float64)

    def occluded(self, origins, directions, tfar=None) -> np.ndarray:
        """Any hit along each ray within ``tfar`` (default: unbounded); bool (N,)."""
        o = np.ascontiguousarray(origins, dtype=np.float32).reshape(-1, 3)
        d = np.ascontiguousarray(directions, dtype=np.float32).reshape(-1, 3)
        if len(o) == 0 or self.n_triangles == 0:
            return np.zeros(len(o), dtype=bool)
        kw = {}
        if tfar is not None:
            kw["dists"] = np.ascontiguousarray(np.broadcast_to(tfar, (len(o),)), dtype=np.float32)
        res = self._scene.run(o, d, query="OCCLUDED", **kw)
        return np.asarray(res) >= 0


def depth_layers(mesh, views: ViewSet, resolution: int = 128, layers: int = 2, *,
                 frame=None) -> np.ndarray:
    """Depth layers of ``mesh`` by Embree rays through the texel centres.

    Same convention and output as :func:`pyshadow.render_depth`: rays start on
    the plane through ``d_k`` and run along ``-d_k``; depth is ``t/2``.
    Layer ``l+1`` is found by restarting the ray just behind the hit of
    layer ``l``.

    Returns
    -------
    ndarray, shape (D, layers, R, R), float32
    """
    from .raster import texel_rays

    if not isinstance(mesh, trimesh.Trimesh):
        mesh = load_mesh(mesh)
    centre, radius = frame if frame is not None else bounding_sphere(mesh)
    verts = (np.asarray(mesh.vertices, dtype=np.float64) - centre) / radius
    scene = EmbreeScene(verts[np.asarray(mesh.faces)])
    R = int(resolution)
    out = np.full((len(views), layers, R, R), np.inf, dtype=np.float32)
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
            travelled[alive] += eps
    return out


def gbuffer(items, camera) -> dict:
    """Primary-ray G-buffer by Embree: the same dict as :func:`pyshadow.render_gbuffer`.

    Rays start at the camera's eye; triangles are moved into eye-relative
    coordinates first (float64), so Embree's float32 stays precise for scenes
    far from the world origin.
    """
    from .gbuffer import check_transform

    tris, obj, face = [], [], []
    for oid, (mesh, T) in enumerate(items):
        if not isinstance(mesh, trimesh.Trimesh):
            mesh = load_mesh(mesh)
        T = check_transform(T, name=f"transform of item {oid}")
        w = np.asarray(mesh.vertices, dtype=np.float64) @ T[:3, :3].T + T[:3, 3]
        tris.append((w - camera.eye)[np.asarray(mesh.faces)])
        obj.append(np.full(len(mesh.faces), oid, np.int32))
        face.append(np.arange(len(mesh.faces)))
    tris = np.concatenate(tris) if tris else np.zeros((0, 3, 3))
    obj = np.concatenate(obj) if obj else np.zeros(0, np.int32)
    face = np.concatenate(face) if face else np.zeros(0, np.int64)
    scene = EmbreeScene(tris)
    dirs = camera.ray_directions().reshape(-1, 3)
    t, prim, _ng = scene.intersect(np.zeros_like(dirs), dirs)
    hit = prim >= 0
    p = np.where(hit, prim, 0)
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

"""A point light's cube-face triangles for :mod:`pyshadow.lighting.shadow_map` (camera space, float64).

:func:`pyshadow.gbuffer.gbuffer_triangles` places a face's casters in its
camera space and clips them at a near plane 1e-6 of the farthest geometry
in view, refusing a triangle whose part nearer than that lies in view (a
G-buffer would show what lies behind it there). A shadow map needs no such
plane: a caster face within 1e-6 of the scene's size from the light (a
light just above a face) shadows everything behind it. :func:`face_triangles`
hands such triangles to the raster clipped in float64 to ``GUARD``
half-widths of the face's view and to ``NEAR_MIN`` of the farthest geometry
(their screen corners and inverse depths stay finite in float32), and every
other triangle as ``gbuffer_triangles`` does (clipped at its near plane), then,
where it reaches beyond :data:`pyshadow.gbuffer.GUARD_BAND` half-widths of the
view, clipped to that band as a G-buffer's (:func:`pyshadow.gbuffer.raster_triangles`):
a ground quad cut at the near plane keeps corners 1e-6 of the scene's size
from the light, whose float32 screen coordinates reach 1e7 texels, and the
raster's float32 edge functions there misplaced depths (up to 13 % off over
5 % of a box-on-the-ground's texels at 256^2, and texels left empty). A vertex in view nearer than the
G-buffer's near plane where no face near the light has an area in view (a lamp at a box's corner or at the
centre of a fan of triangles, whose faces it sees edge-on, or at a vertex no face uses) took the G-buffer's
route and met its refusal; the triangles are then given as where some are near.
"""
from __future__ import annotations

import numpy as np

__all__ = ["face_triangles", "GUARD", "NEAR_MIN"]

GUARD = 1.01            # the near triangles, clipped to this many half-widths of the view (texel centres: < 1)
NEAR_MIN = 2.0 ** -60   # ... and to this fraction of the farthest geometry from the light


def _has_area(poly) -> bool:
    """Does a camera-space polygon (z > 0) cover an area on the screen? Its fan's triangles span a volume
    with the eye (a polygon in a plane through the eye projects to a line)."""
    return any(np.linalg.det(np.stack([poly[0], poly[k], poly[k + 1]])) != 0 for k in range(1, len(poly) - 1))


def face_triangles(items, camera) -> np.ndarray:
    """Camera-space triangles of ``items`` for one 90 degree cube face, (M, 3, 3) float64.

    Parameters
    ----------
    items : list of (trimesh.Trimesh, ndarray (4, 4))
        The casters' meshes and world (or fitted cube) transforms.
    camera : pyshadow.Camera
        The face's camera (:func:`pyshadow.camera.axis_camera`) at the light.

    Returns
    -------
    ndarray, shape (M, 3, 3), float64
        Those of :func:`pyshadow.gbuffer.gbuffer_triangles` where no
        triangle's part nearer than its near plane lies in view; else the
        others clipped at that plane and those clipped to the view
        (module docstring).
    """
    from ..gbuffer import _clip_near, clip_polygon, gbuffer_triangles, raster_triangles

    cam = [(np.asarray(m.vertices, np.float64) @ T[:3, :3].T + T[:3, 3] - camera.eye) @ camera.rotation.T
           for m, T in items]
    tri = [c[np.asarray(m.faces)] for c, (m, _) in zip(cam, items)]
    tri = np.concatenate(tri).reshape(-1, 3, 3) if tri else np.zeros((0, 3, 3))
    cam = np.concatenate(cam).reshape(-1, 3) if cam else np.zeros((0, 3))
    far = float(np.abs(tri).max()) if len(tri) else 0.0
    near, z = max(1e-6 * far, 1e-30), tri[:, :, 2]
    view = [(np.array([0.0, 0.0, -1.0]), -max(NEAR_MIN * far, 1e-30))]     # first: every corner then has z > 0
    view += [(np.array(a, np.float64), 0.0) for a in ((1, 0, -GUARD), (-1, 0, -GUARD), (0, 1, -GUARD), (0, -1, -GUARD))]
    close, pieces = [], []
    for i in np.flatnonzero((z < near).any(axis=1) & (z > 0).any(axis=1)):
        poly = clip_polygon(list(tri[i]), view)
        part = clip_polygon(poly, [(np.array([0.0, 0.0, 1.0]), near)]) if poly else []
        if part and _has_area(part):
            close.append(i)
            pieces += [np.stack([poly[0], poly[k], poly[k + 1]]) for k in range(1, len(poly) - 1)]
    # a vertex in view nearer than the G-buffer's near plane (1e-6 of the farthest vertex in view, unreferenced ones
    # too) is refused there: a lamp at a box's corner (its faces there seen edge-on, none close) or at a vertex
    # no face uses. A shadow map's such vertex hides nothing: the triangles as when some are close
    c = cam[(cam[:, 2] > 0) & (cam[:, 2] < max(1e-6 * float(np.abs(cam).max(initial=0.0)), 1e-30))]
    if not close and not (np.abs(c[:, :2]) <= GUARD * c[:, 2:]).all(axis=1).any():
        return raster_triangles(gbuffer_triangles(items, camera)[0], camera)[0]
    rest = raster_triangles(_clip_near(np.delete(tri, close, axis=0), near)[0], camera)[0]
    return np.concatenate([rest, np.array(pieces).reshape(-1, 3, 3)])

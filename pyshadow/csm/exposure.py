"""Faces of an open mesh whose back is open to the outside (``two_sided='auto'`` of the build).

A CSM keeps a margin before a second surface ``z2`` where that surface faces
the light (:mod:`pyshadow.csm`): a point on it, asked with its self-bias,
must not see a stored depth within the bias. On a closed mesh the back of a
face is never asked: it lies inside the solid. On an open one it can be: the
inner floor of a box without a lid is the back of its bottom face, and a
point there, in the shadow of a wall, was reported lit where the map's
stored depth came within the bias of the floor (``two_sided=True`` keeps the
margin before every ``z2``, at 1.4-1.5x the bytes of the bundled open meshes).
Which faces need it follows from the geometry: those whose back side a ray
from outside can reach, that is, from whose back side a ray can leave the
mesh without meeting it again (:func:`exposed_back_faces`).
"""
from __future__ import annotations

import numpy as np

from .surface_rule import _fibonacci_sphere

__all__ = ["exposed_back_faces", "both_sided_faces", "is_auto", "EXPOSURE_DIRECTIONS"]

#: directions of the sphere tried from each face's back side (about half of
#: them lie in its back hemisphere)
EXPOSURE_DIRECTIONS = 64


def is_auto(two_sided) -> bool:
    """Whether ``two_sided`` is ``'auto'`` (a string compared only as a string: NumPy bools never are)."""
    return isinstance(two_sided, str) and two_sided == "auto"


def exposed_back_faces(mesh, frame, directions: int = EXPOSURE_DIRECTIONS) -> np.ndarray:
    """Faces whose back side (against their winding normal) a ray from outside the mesh can reach.

    From a point just behind each face's centroid, rays go out along the
    directions of a Fibonacci lattice that lie in the face's back hemisphere;
    a face is exposed when one of them meets no face of the mesh (Embree).
    On a closed mesh wound outwards none is. A face exposed only away from its
    centroid, or only through an opening narrower than the lattice's spacing
    (about 25 degrees at 64 directions) seen from its centroid, is not found.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    frame : (centre, radius)
        The normalised frame (world units) the rays are traced in: float32
        keeps its precision there whatever the mesh's size and position.
    directions : int, optional
        Lattice directions over the whole sphere.

    Returns
    -------
    ndarray, shape (F,), bool
        True where the face's back side is open to the outside; False for
        faces of zero area.
    """
    from ..embree import EmbreeScene, ray_epsilon

    centre, radius = frame
    tri = (np.asarray(mesh.triangles, dtype=np.float64) - np.asarray(centre, dtype=np.float64)) / float(radius)
    out = np.zeros(len(tri), bool)
    if len(tri) == 0:
        return out
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(n, axis=1)
    live = length > 0.0
    n[live] /= length[live, None]
    c = tri.mean(axis=1)
    # behind the face by more than the float32 intersection error at the frame's size (1)
    o = c - n * float(ray_epsilon(1.0)) * 4.0
    scene = EmbreeScene(tri)
    for d in _fibonacci_sphere(int(directions)):
        ask = np.flatnonzero(live & ~out & (n @ d < 0.0))
        if len(ask):
            out[ask] = ~scene.occluded(o[ask], np.broadcast_to(d, (len(ask), 3)))
    return out


def both_sided_faces(mesh, frame, layer_rule: int, two_sided="auto"):
    """The faces a build marks as facing the light from both sides, or None (none marked).

    What :meth:`pyshadow.CoherentShadowMap.build` passes to the rasteriser
    (``both_sides`` of :class:`pyshadow.raster.DepthRenderer`): with
    ``two_sided='auto'`` and ``layers=2`` the faces of
    :func:`exposed_back_faces`; otherwise none (``True`` keeps the margin
    before every ``z2`` in the fold instead; a closed mesh's backs are never
    asked). The NumPy mirror of a build is
    ``compress_reference(*render_depth(..., facing=True, both_sides=both_sided_faces(...)), ...)``.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    frame : (centre, radius)
        The CSM's normalised frame (``csm.centre``, ``csm.radius``).
    layer_rule : {2, 3}
    two_sided : {'auto', True, False}, optional

    Returns
    -------
    ndarray, shape (F,), bool, or None
    """
    return exposed_back_faces(mesh, frame) if is_auto(two_sided) and int(layer_rule) == 2 else None

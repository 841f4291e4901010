"""Data shipped inside pyshadow: the Stanford bunny and the default scene.

The bunny (Stanford Computer Graphics Laboratory scan, 69,451 faces, with its
holes) is stored as 16-bit fixed-point vertices over its bounding box (error
at most 1.2e-6 of a 0.156 extent) and int32 faces in a compressed NumPy
archive (no pickle). Nothing here touches the network or ``../shared``.
"""
from __future__ import annotations

from importlib.resources import files

import numpy as np
import trimesh

__all__ = ["bunny", "default_scene", "DEFAULT_PARTS"]

# name -> (what it is, whether it casts)
DEFAULT_PARTS = {
    "bunny": ("Stanford bunny, bounding radius 1, standing on the ground", True),
    "torus": ("torus, radii 0.55 / 0.22, leaning on the ground beside the bunny", True),
    "back_wall": ("wall behind the bodies (receives only)", False),
    "side_wall": ("wall to the left (receives only)", False),
}


def bunny() -> trimesh.Trimesh:
    """The bundled Stanford bunny (original coordinates, metres of the scan)."""
    from ..mesh import load_mesh

    with files(__name__).joinpath("stanford_bunny.npz").open("rb") as fh:
        data = np.load(fh, allow_pickle=False)
        q = data["vertices_q"].astype(np.float64)
        v = q / 65535.0 * float(data["extent"]) + data["origin"]
        faces = data["faces"].astype(np.int64)
    return load_mesh(trimesh.Trimesh(v, faces, process=False))


def _stand(mesh, T):
    """Lift transform ``T`` so the mesh's lowest point touches y = 0."""
    T = T.copy()
    T[1, 3] -= (np.asarray(mesh.vertices) @ T[:3, :3].T + T[:3, 3])[:, 1].min()
    return T


def _quad(corner, u, v):
    c = np.asarray(corner, float)
    u, v = np.asarray(u, float), np.asarray(v, float)
    return trimesh.Trimesh([c, c + u, c + u + v, c + v], [[0, 1, 2], [0, 2, 3]], process=False)


def default_parts():
    """The default scene's bodies: list of (name, mesh, 4x4 transform, casts)."""
    from ..mesh import bounding_sphere, load_mesh

    b = bunny()
    c, r = bounding_sphere(b)
    Tb = np.eye(4)
    Tb[:3, :3] /= r
    Tb[:3, 3] = -c / r
    Tb = _stand(b, Tb)
    torus = load_mesh(trimesh.creation.torus(major_radius=0.55, minor_radius=0.22,
                                             major_sections=64, minor_sections=24))
    Tt = trimesh.transformations.rotation_matrix(np.radians(55), [1, 0, 0.2])
    Tt[:3, 3] = [1.95, 0.0, 0.2]
    Tt = _stand(torus, Tt)
    back = _quad([-3.0, 0.0, -1.6], [7.0, 0.0, 0.0], [0.0, 3.5, 0.0])
    side = _quad([-1.7, 0.0, 3.0], [0.0, 0.0, -5.0], [0.0, 3.5, 0.0])
    # face the receivers' fronts towards the bodies
    side.invert()
    return [("bunny", b, Tb, True), ("torus", torus, Tt, True),
            ("back_wall", back, np.eye(4), False), ("side_wall", side, np.eye(4), False)]


def default_scene(*, views=None, resolution: int = 128, depth_bits: int = 16, layers="auto",
                  csm_for=None, width: int = 640, height: int = 480, progress: bool = False):
    """The bundled scene: bunny and torus on a ground plane, two walls, a camera.

    Parameters
    ----------
    views, resolution, depth_bits, layers :
        CSM options of the casters (see :meth:`pyshadow.CoherentShadowMap.build`);
        default views ``ViewSet.zigzag(64, 128)``.
    csm_for : callable, optional
        ``csm_for(name, mesh) -> CoherentShadowMap or None``; lets a caller
        supply cached CSMs (``None``: build).
    width, height : int
        Image size of the returned camera.

    Returns
    -------
    scene : pyshadow.Scene
        Ground plane ``y = 0``; instance ids in the order of
        :data:`DEFAULT_PARTS`.
    camera : pyshadow.Camera
    """
    from ..camera import Camera
    from ..csm import CoherentShadowMap
    from ..scene import Scene
    from ..views import ViewSet

    views = views if views is not None else ViewSet.zigzag(64, 128)
    scene = Scene(ground=0.0, views=views, resolution=resolution, depth_bits=depth_bits,
                  layers=layers, progress=progress)
    for name, mesh, T, casts in default_parts():
        if casts:
            csm = csm_for(name, mesh) if csm_for is not None else None
            if csm is None:
                csm = CoherentShadowMap.build(mesh, views, resolution, depth_bits, layers,
                                              progress=progress)
            scene.add(csm, T, mesh=mesh)
        else:
            scene.add(mesh, T, casts=False)
    camera = Camera([2.4, 2.1, 4.8], [0.8, 0.5, 0.0], fov_y=45.0, width=width, height=height)
    return scene, camera

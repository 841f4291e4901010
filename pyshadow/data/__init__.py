"""Data shipped inside pyshadow: the Stanford bunny, the default scene and test meshes.

The bunny (Stanford Computer Graphics Laboratory scan, 69,451 faces, with its
holes) is stored as 16-bit fixed-point vertices over its bounding box (error
at most 1.2e-6 of a 0.156 extent) and int32 faces in a compressed NumPy
archive (no pickle).

:func:`mesh` loads the real test meshes of the test suite and the benchmarks
(:data:`MESHES`: the Stanford bunny at full precision, the Utah teapot, Spot,
fandisk, Homer, a cow, Suzanne and two CAD parts). Each is its original file,
byte for byte, compressed with xz in ``meshes/``; ``meshes/README.md`` gives
every file's source and licence. Nothing here touches the network or any
folder outside the installed package.
"""
from __future__ import annotations

import io
import lzma
import os
from importlib.resources import files
from pathlib import Path

import numpy as np
import trimesh

__all__ = ["bunny", "default_scene", "DEFAULT_PARTS", "MESHES", "mesh", "mesh_bytes", "mesh_file"]

#: File names of the bundled test meshes (original names; see :func:`mesh`).
MESHES = ("cow.obj", "fandisk.obj", "featuretype.STL", "homer.obj", "spot.obj",
          "stanford-bunny.obj", "suzanne.ply", "teapot.obj", "torus.STL")

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


def _mesh_name(name) -> str:
    """The entry of :data:`MESHES` that ``name`` means (file name or stem, any case)."""
    if isinstance(name, str):
        key = name.strip().lower()
        for full in MESHES:
            if key in (full.lower(), full.rsplit(".", 1)[0].lower()):
                return full
    raise ValueError(f"no bundled mesh {name!r}; available: {', '.join(MESHES)} "
                     "(with or without the extension)")


def mesh_bytes(name: str) -> bytes:
    """The original file of a bundled test mesh, byte for byte (decompressed).

    Parameters
    ----------
    name : str
        An entry of :data:`MESHES`, with or without its extension, in any
        case (``"fandisk"``, ``"fandisk.obj"``, ``"torus.stl"``).

    Returns
    -------
    data : bytes
        The file as it was received (OBJ text, binary STL or ASCII PLY).

    Raises
    ------
    ValueError
        If ``name`` is not a bundled mesh; the message lists the available ones.
    """
    full = _mesh_name(name)
    packed = files(__name__).joinpath("meshes").joinpath(full + ".xz").read_bytes()
    return lzma.decompress(packed, format=lzma.FORMAT_XZ)


def mesh(name: str, fill_holes: bool = False) -> trimesh.Trimesh:
    """Load a bundled test mesh through :func:`pyshadow.load_mesh`.

    The arrays are bit-identical to ``pyshadow.load_mesh(path_of_original)``:
    the original file is decompressed in memory and parsed by trimesh with its
    own format, then cleaned by :func:`pyshadow.load_mesh`.

    Parameters
    ----------
    name : str
        An entry of :data:`MESHES`, with or without its extension, in any
        case: ``"stanford-bunny"``, ``"teapot.obj"``, ``"torus"``, ...
    fill_holes : bool, optional
        Passed to :func:`pyshadow.load_mesh` (close every boundary loop).

    Returns
    -------
    mesh : trimesh.Trimesh
        A new mesh on every call (float64 vertices, int64 faces).

    Raises
    ------
    ValueError
        If ``name`` is not a bundled mesh; the message lists the available ones.
    TypeError
        If ``fill_holes`` is not True or False.

    See Also
    --------
    bunny : the bunny of the default scene (16-bit quantised vertices, so not
        bit-identical to ``mesh("stanford-bunny")``).

    Examples
    --------
    >>> import pyshadow
    >>> m = pyshadow.data.mesh("fandisk")
    >>> m.faces.shape, bool(m.is_watertight)
    ((5750, 3), True)
    """
    from ..mesh import load_mesh

    full = _mesh_name(name)
    if full.lower().endswith(".ply"):           # as load_mesh reads the file: its concave quads tiled
        from ..mesh_files import _read_ply
        raw = _read_ply(None, mesh_bytes(full))
    else:
        raw = trimesh.load(io.BytesIO(mesh_bytes(full)), file_type=full.rsplit(".", 1)[1].lower(), process=False)
    return load_mesh(raw, fill_holes=fill_holes)


def mesh_file(name: str, folder) -> Path:
    """Write the original file of a bundled test mesh into ``folder``.

    For tools that want a path (``pyshadow-bench --mesh``, other programs).

    Parameters
    ----------
    name : str
        An entry of :data:`MESHES`, with or without its extension.
    folder : str or os.PathLike
        An existing folder; the file gets its original name (e.g.
        ``spot.obj``) and replaces any file of that name there.

    Returns
    -------
    path : pathlib.Path
        The written file; ``pyshadow.load_mesh(path)`` equals ``mesh(name)``.

    Raises
    ------
    ValueError
        If ``name`` is not a bundled mesh.
    """
    from .._files import write_bytes_atomic

    full = _mesh_name(name)
    path = Path(os.fspath(folder)) / full
    write_bytes_atomic(path, mesh_bytes(full))          # a failed write leaves an earlier file intact
    return path


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
    progress : bool
        Show the builders' progress bars for the CSMs built here.

    Returns
    -------
    scene : pyshadow.Scene
        Ground plane ``y = 0``; instance ids in the order of
        :data:`DEFAULT_PARTS`.
    camera : pyshadow.Camera

    Raises
    ------
    TypeError
        If ``csm_for`` is not callable, or returns what is not a
        :class:`pyshadow.CoherentShadowMap` or None.
    """
    from ..camera import Camera
    from ..csm import CoherentShadowMap
    from ..scene import Scene
    from ..views import ViewSet

    if csm_for is not None and not callable(csm_for):
        raise TypeError(f"csm_for must be a callable csm_for(name, mesh) or None, got {csm_for!r}")
    views = views if views is not None else ViewSet.zigzag(64, 128)
    scene = Scene(ground=0.0, views=views, resolution=resolution, depth_bits=depth_bits,
                  layers=layers, progress=progress)
    for name, mesh, T, casts in default_parts():
        if casts:
            csm = csm_for(name, mesh) if csm_for is not None else None
            if csm is not None and not isinstance(csm, CoherentShadowMap):    # was: "mesh= is only for CSMs"
                raise TypeError(f"csm_for({name!r}, mesh) must return a CoherentShadowMap or None, "
                                f"got {type(csm).__name__}")
            if csm is None:
                csm = CoherentShadowMap.build(mesh, views, resolution=resolution, depth_bits=depth_bits,
                                              layers=layers, progress=progress)
            scene.add(csm, T, mesh=mesh)
        else:
            scene.add(mesh, T, casts=False)
    camera = Camera([2.4, 2.1, 4.8], [0.8, 0.5, 0.0], fov_y=45.0, width=width, height=height)
    return scene, camera

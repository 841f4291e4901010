"""Meshes and scenes as pyvista objects, the camera on them, and a ground receiver.

Turns trimesh meshes and the instances of a :class:`pyshadow.Scene` into
``pv.PolyData`` with per-vertex scalars (AO, differences) in the object
frame, the instance transform going to the actor; points the camera of a
subplot at a region of world space; and builds the ground grid the examples
compute ground AO on. World units and frames are those of the scene (y up,
DESIGN.md).
"""
from __future__ import annotations

import numpy as np

from .plotter import _pv, _viewport_pixels

__all__ = [
    "mesh_to_polydata",
    "update_scalars",
    "scene_to_plotter",
    "look_at_bodies",
    "ground_grid",
]


def mesh_to_polydata(mesh, transform=None, scalars=None, name: str = "ao"):
    """A trimesh mesh as ``pv.PolyData`` with vertex normals and optional scalars.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        ``V`` vertices, ``T`` triangles.
    transform : array_like, shape (4, 4), optional
        Applied to points and normals (rigid with uniform scale, as in
        :meth:`pyshadow.Scene.add`); default identity (object frame).
    scalars : array_like, shape (V,) or (V, 3), optional
        Per-vertex values stored as point data ``name`` and made active.
    name : str, optional
        Name of the scalar array.

    Returns
    -------
    pyvista.PolyData
        Points float64 (V, 3); active point normals ``'Normals'`` float32
        (V, 3) -- the mesh's area-weighted vertex normals, so the mapper
        shades smoothly without filters between this object and the screen,
        and :func:`update_scalars` changes what is drawn.

    Raises
    ------
    TypeError
        ``mesh`` is not a trimesh.Trimesh.
    ValueError
        ``transform`` or ``scalars`` of the wrong shape.
    """
    import trimesh

    pv = _pv()
    if not isinstance(mesh, trimesh.Trimesh):
        raise TypeError(f"mesh_to_polydata: mesh must be a trimesh.Trimesh, got {type(mesh).__name__}")
    pts = np.asarray(mesh.vertices, dtype=np.float64)
    nrm = np.asarray(mesh.vertex_normals, dtype=np.float64)
    if transform is not None:
        T = np.asarray(transform, dtype=np.float64)
        if T.shape != (4, 4):
            raise ValueError(f"mesh_to_polydata: transform must have shape (4, 4), got {T.shape}")
        pts = pts @ T[:3, :3].T + T[:3, 3]
        nrm = nrm @ T[:3, :3].T
        nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    cells = np.hstack([np.full((len(faces), 1), 3, np.int64), faces]).reshape(-1)
    poly = pv.PolyData(pts, cells)
    poly.point_data["Normals"] = nrm.astype(np.float32)
    poly.point_data.active_normals_name = "Normals"
    if scalars is not None:
        update_scalars(poly, scalars, name)
    return poly


def update_scalars(poly, values, name: str = "ao"):
    """Replace (or add) per-vertex scalars ``name`` of ``poly`` and make them active.

    Parameters
    ----------
    poly : pyvista.PolyData
        ``V`` points.
    values : array_like, shape (V,) or (V, 3)
    name : str, optional

    Raises
    ------
    ValueError
        ``values`` does not have one row per point.
    """
    v = np.asarray(values)
    if v.ndim not in (1, 2) or len(v) != poly.n_points:
        raise ValueError(f"update_scalars: expected ({poly.n_points},) or ({poly.n_points}, k) "
                         f"values, got shape {v.shape}")
    poly.point_data[name] = v
    poly.point_data.active_scalars_name = name
    return poly


def scene_to_plotter(scene, plotter, scalars=None, *, name: str = "ao", cmap: str = "gray",
                     clim=(0.0, 1.0), ground: bool = True, ground_size: float | None = None,
                     color: str = "white", lighting: bool = True):
    """Add every instance of a :class:`pyshadow.Scene` that has a mesh to the active subplot.

    Parameters
    ----------
    scene : pyshadow.Scene
    plotter : pyvista.Plotter
    scalars : dict of int -> array_like, shape (V_i,), optional
        Per-vertex values of instance ``i`` (e.g. ``scene.vertex_ao(i)``);
        instances without an entry are drawn in ``color``.
    name, cmap, clim :
        Scalar array name, colour map and colour range (shared by all
        instances, so one colour bar describes them).
    ground : bool, optional
        Draw the scene's analytic ground plane as a flat quad
        (:meth:`Scene.ground_quad`) in ``color`` when it has one.
    ground_size : float, optional
        Side of that quad.
    color : str, optional
    lighting : bool, optional
        Shade with the plotter's lights; ``False`` draws the scalar colours
        exactly (an AO value then reads straight off the colour bar).

    Returns
    -------
    dict of int -> (pyvista.PolyData, pyvista.Actor)
        Per instance id; the polydata is in the object frame and the
        instance transform is the actor's ``user_matrix``: moving a body is
        ``actor.user_matrix = scene.transform(i)``, new AO is
        :func:`update_scalars` on the polydata. The ground quad, if drawn,
        is under key ``pyshadow.scene.GROUND_ID`` (-2).
    """
    from ..scene import GROUND_ID

    scalars = {} if scalars is None else dict(scalars)
    out = {}
    for i, inst in enumerate(scene.instances):
        if inst.mesh is None:
            continue
        values = scalars.get(i)
        poly = mesh_to_polydata(inst.mesh, scalars=values, name=name)
        if values is not None:
            actor = plotter.add_mesh(poly, scalars=name, cmap=cmap, clim=clim, lighting=lighting,
                                     show_scalar_bar=False)
        else:
            actor = plotter.add_mesh(poly, color=color, lighting=lighting, show_scalar_bar=False)
        actor.user_matrix = inst.transform
        out[i] = (poly, actor)
    if ground and scene.ground is not None:
        quad = mesh_to_polydata(scene.ground_quad(ground_size))
        out[GROUND_ID] = (quad, plotter.add_mesh(quad, color=color, lighting=lighting,
                                                 show_scalar_bar=False))
    return out


def look_at_bodies(plotter, centre, radius: float, direction=(0.55, 0.45, 1.0), *,
                   fill: float = 0.9):
    """Point the active subplot's camera at a sphere ``(centre, radius)`` from ``direction``.

    Parameters
    ----------
    plotter : pyvista.Plotter
    centre : array_like, shape (3,)
        World centre of the region to show.
    radius : float
        World radius of the region.
    direction : array_like, shape (3,), optional
        From the centre towards the camera (normalised here); y is up.
    fill : float, optional
        Share of the subplot's narrower side the sphere spans (a
        perspective camera with VTK's 30 degree view angle).
    """
    c = np.asarray(centre, dtype=np.float64).reshape(3)
    d = np.asarray(direction, dtype=np.float64).reshape(3)
    d = d / np.linalg.norm(d)
    w, h = _viewport_pixels(plotter)
    half = np.radians(30.0) / 2.0
    if w < h:                      # the horizontal field is the narrow one
        half = np.arctan(np.tan(half) * w / h)
    dist = radius / (np.sin(half) * float(fill))
    plotter.camera_position = [tuple(c + dist * d), tuple(c), (0.0, 1.0, 0.0)]
    plotter.renderer.ResetCameraClippingRange()


# ---------------------------------------------------------------------------
# scene layout for the examples
# ---------------------------------------------------------------------------
def ground_grid(centre=(0.0, 0.0), size: float = 6.0, divisions: int = 48,
                height: float = 0.0):
    """A square receiver mesh on the ground, normals up, for per-vertex ground AO.

    Parameters
    ----------
    centre : (float, float), optional
        World ``(x, z)`` of the square's centre.
    size : float, optional
        Side length.
    divisions : int, optional
        Quads per side (``(divisions + 1)**2`` vertices), 1 .. 2048.
    height : float, optional

    Returns
    -------
    trimesh.Trimesh
        Add it with ``scene.add(grid, casts=False)``.
    """
    import trimesh

    n = int(divisions)
    if not 1 <= n <= 2048:
        raise ValueError(f"ground_grid: divisions must be in 1..2048, got {divisions!r}")
    if not size > 0:
        raise ValueError(f"ground_grid: size must be positive, got {size}")
    s = np.linspace(-0.5, 0.5, n + 1) * float(size)
    z, x = np.meshgrid(s + float(centre[1]), s + float(centre[0]), indexing="ij")
    v = np.column_stack([x.reshape(-1), np.full(x.size, float(height)), z.reshape(-1)])
    i = np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]
    a, b, c, d = i, i + 1, i + n + 2, i + n + 1          # (r,c) (r,c+1) (r+1,c+1) (r+1,c)
    # x grows along a row, z along a column: (b - a) x (d - a) = x x z = -y, so wind a, d, c
    faces = np.concatenate([np.stack([a, d, c], -1).reshape(-1, 3),
                            np.stack([a, c, b], -1).reshape(-1, 3)])
    return trimesh.Trimesh(v, faces, process=False)

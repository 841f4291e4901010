"""Meshes and scenes as pyvista objects, the camera on them, and a ground receiver.

Turns trimesh meshes and the instances of a :class:`pyshadow.Scene` into
``pv.PolyData`` with per-vertex scalars (AO, differences) in the object
frame, the instance transform going to the actor; points the camera of a
subplot at a region of world space; and builds the ground grid the examples
compute ground AO on. World units and frames are those of the scene (y up,
:mod:`pyshadow`).
"""
from __future__ import annotations

import warnings

import numpy as np

from .plotter import _pv, _viewport_pixels

__all__ = [
    "mesh_to_polydata",
    "polydata_to_mesh",
    "point_values",
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
        Affine, invertible and finite; applied to the points, and its
        inverse transpose to the normals (so any scale, shear or mirror
        keeps them perpendicular to the surface); default identity (object
        frame).
    scalars : array_like, shape (V,) or (V, 3), optional
        Per-vertex values stored as point data ``name`` and made active.
    name : str, optional
        Name of the scalar array.

    Returns
    -------
    pyvista.PolyData
        Points float64 (V, 3), a copy of the mesh's vertices (editing one
        leaves the other alone); active point normals ``'Normals'`` float32
        (V, 3) -- the mesh's area-weighted vertex normals, so the mapper
        shades smoothly without filters between this object and the screen,
        and :func:`update_scalars` changes what is drawn.

    Raises
    ------
    TypeError
        ``mesh`` is not a trimesh.Trimesh.
    ValueError
        ``transform`` of the wrong shape, not finite, not affine or
        singular; ``scalars`` of the wrong shape; a mesh without vertices.
        ``scalars`` not real numbers raise TypeError.
    """
    import trimesh

    from .._validate import check_transform

    pv = _pv()
    if not isinstance(mesh, trimesh.Trimesh):
        raise TypeError(f"mesh_to_polydata: mesh must be a trimesh.Trimesh, got {type(mesh).__name__}")
    if len(mesh.vertices) == 0:
        raise ValueError("mesh_to_polydata: mesh has no vertices")
    pts = np.array(mesh.vertices, dtype=np.float64)     # a copy: VTK would share (and edit) the mesh's own
    extent = float(np.ptp(pts, axis=0).max())
    if 0.0 < extent < 2.0 ** -10:       # trimesh zeroes normals of faces below ~1e-12 (a 1e-6 sphere drew black):
        unit = float(2.0 ** -np.round(np.log2(extent)))         # a power of two changes no normal's bits
        nrm = trimesh.Trimesh(pts * unit, np.asarray(mesh.faces), process=False).vertex_normals
        nrm = np.asarray(nrm, dtype=np.float64)
    else:
        nrm = np.asarray(mesh.vertex_normals, dtype=np.float64)
    if transform is not None:
        T = check_transform(transform, name="mesh_to_polydata: transform")
        pts = pts @ T[:3, :3].T + T[:3, 3]
        N = np.linalg.inv(T[:3, :3]).T
        nrm = nrm @ (N / np.abs(N).max()).T              # scaled: no overflow for huge/tiny scales
        nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    cells = np.hstack([np.full((len(faces), 1), 3, np.int64), faces]).reshape(-1)
    poly = pv.PolyData(pts, cells)
    poly.point_data["Normals"] = nrm.astype(np.float32)
    poly.point_data.active_normals_name = "Normals"
    if scalars is not None:
        update_scalars(poly, scalars, name)
    return poly


def polydata_to_mesh(poly):
    """A pyvista mesh as a ``trimesh.Trimesh`` of its surface's triangles, the inverse of
    :func:`mesh_to_polydata` (:func:`pyshadow.load_mesh` and :meth:`pyshadow.Scene.add` take pyvista meshes
    through it).

    Parameters
    ----------
    poly : pyvista.DataSet
        A ``pv.PolyData`` (its polygons, triangulated by VTK; lines and vertices left out) or any other
        dataset (an ``UnstructuredGrid``, an ``ImageData``: its outer surface, ``extract_surface``), in
        the units and frame of its points.

    Returns
    -------
    trimesh.Trimesh
        Vertices float64 (V, 3), the dataset's points; faces int64 (T, 3); not processed (nothing merged or
        removed: :func:`pyshadow.load_mesh` cleans). Colours: a uint8 point (else cell) array ``'RGB'`` or
        ``'RGBA'`` (3 or 4 components, as VTK's PLY reader names a file's colours: ``pv.read``) becomes the
        mesh's vertex (face) colours, sRGB-encoded as a PLY's, which the lit render multiplies the albedo by
        (:mod:`pyshadow.materials`); ``Scene.add(pv.read("a.ply"))`` drew grey what ``Scene.add("a.ply")``
        drew in its colours. Other point and cell data (normals, scalars) are not read.
        Per-vertex results of the cleaned mesh go back onto the dataset's own points through
        :func:`point_values`.

    Raises
    ------
    TypeError
        ``poly`` is not a pyvista dataset (a ``pv.MultiBlock``: the message says how to merge it).
    ValueError
        It has no polygons to triangulate (points or lines only).
    """
    import trimesh

    pv = _pv()
    if not isinstance(poly, pv.DataSet):
        hint = " (merge its blocks first: blocks.combine())" if isinstance(poly, pv.MultiBlock) else ""
        raise TypeError(f"polydata_to_mesh: expected a pyvista dataset, got {type(poly).__name__}{hint}")
    with warnings.catch_warnings():     # pyvista's notices of defaults to change (0.49): the same surface
        warnings.simplefilter("ignore")
        surface = poly if isinstance(poly, pv.PolyData) else poly.extract_surface()
        tri = surface.triangulate()
    cells = np.asarray(tri.faces, dtype=np.int64)
    if cells.size == 0:
        raise ValueError(f"polydata_to_mesh: the {type(poly).__name__} has no polygons (points or lines only: "
                         "nothing casts a shadow)")
    faces = cells.reshape(-1, 4)
    if (faces[:, 0] != 3).any():        # (triangulate leaves only triangles)
        raise ValueError("polydata_to_mesh: VTK's triangulate left polygons that are not triangles")
    return trimesh.Trimesh(vertices=np.array(tri.points, dtype=np.float64), faces=faces[:, 1:], process=False,
                           **_colours(tri, len(faces)))


def _colours(tri, n_faces: int) -> dict:
    """``vertex_colors`` or ``face_colors`` (uint8 (V or T, 3 or 4)) of the triangulated dataset ``tri``: its point
    (else cell) array ``'RGB'`` or ``'RGBA'`` (uint8, 3 or 4 components); {} where it has none."""
    for data, key, n, first in ((tri.point_data, "vertex_colors", tri.n_points, 0),
                                (tri.cell_data, "face_colors", n_faces, tri.n_verts + tri.n_lines)):
        for name in ("RGBA", "RGB"):
            rgb = np.asarray(data[name]) if name in data else None      # cells: vertices, lines, then polygons
            if rgb is not None and rgb.dtype == np.uint8 and rgb.ndim == 2 and rgb.shape[1] == len(name) \
                    and len(rgb) >= first + n:
                return {key: rgb[first:first + n].copy()}
    return {}


def point_values(dataset, mesh, values):
    """Per-vertex values of ``mesh`` on the points of the pyvista dataset it was made from.

    :func:`pyshadow.load_mesh` (and so :meth:`pyshadow.Scene.add` of a pyvista mesh) merges coincident
    points (a ``pv.Cylinder``'s rims, ``pv.Cube(clean=False)``, ``compute_normals(split_vertices=True)``),
    drops points no polygon uses and keeps only a volume's outer surface, so
    :meth:`pyshadow.Scene.vertex_ao` answers one value per vertex of ``scene.instances[i].mesh``, not one
    per point of the dataset. Each point here takes the value of the vertex at its position: ``poly["ao"]
    = point_values(poly, scene.instances[i].mesh, scene.vertex_ao(i))``.

    Parameters
    ----------
    dataset : pyvista.DataSet
        ``N`` points, in the frame of ``mesh``'s vertices (the object frame: the frame the dataset was
        added in, not moved by the instance's transform).
    mesh : trimesh.Trimesh
        ``V`` vertices, e.g. ``scene.instances[i].mesh`` or ``pyshadow.load_mesh(dataset)``.
    values : array_like, shape (V,) or (V, k)
        Real numbers, one row per vertex of ``mesh`` (AO, bent normals).

    Returns
    -------
    ndarray, shape (N,) or (N, k)
        Floating point (float32 values stay float32, others become float64). A point takes the
        value of the vertex within ``1e-5`` of the mesh's extent of it (or the rounding
        :func:`pyshadow.load_mesh` merged it at, where larger); a point with none (inside a volume, on
        lines or vertex cells only) is NaN.

    Raises
    ------
    TypeError
        ``dataset`` not a pyvista dataset, ``mesh`` not a ``trimesh.Trimesh``, ``values`` not real numbers.
    ValueError
        ``values`` without one row per vertex of ``mesh``.
    """
    import trimesh
    from scipy.spatial import cKDTree

    from ..mesh import _merge_digits

    pv = _pv()
    if not isinstance(dataset, pv.DataSet):
        raise TypeError(f"point_values: dataset must be a pyvista dataset, got {type(dataset).__name__}")
    if not isinstance(mesh, trimesh.Trimesh):
        raise TypeError(f"point_values: mesh must be a trimesh.Trimesh, got {type(mesh).__name__}")
    v = np.asarray(values)
    if not (np.issubdtype(v.dtype, np.number) or v.dtype == bool) or v.dtype.kind == "c":
        raise TypeError(f"point_values: values must be real numbers, got {v.dtype}")
    verts = np.asarray(mesh.vertices, dtype=np.float64)
    if v.ndim not in (1, 2) or len(v) != len(verts):
        raise ValueError(f"point_values: values must have shape ({len(verts)},) or ({len(verts)}, k), one row "
                         f"per vertex of mesh, got {v.shape}")
    pts = np.asarray(dataset.points, dtype=np.float64).reshape(-1, 3)
    out = np.full((len(pts),) + v.shape[1:], np.nan, dtype=np.float32 if v.dtype == np.float32 else np.float64)
    if len(pts) and len(verts):
        digits = _merge_digits(verts)
        tol = max(1e-5 * float(np.ptp(verts, axis=0).max()), 2.0 * 10.0 ** -(8 if digits is None else digits))
        dist, k = cKDTree(verts).query(pts, distance_upper_bound=tol)      # a miss: dist inf
        hit = np.isfinite(dist)
        out[hit] = v[k[hit]]
    return out


def _surface_mesh(obj, who: str):
    """A pyvista mesh as :func:`pyshadow.load_mesh` takes it (:func:`polydata_to_mesh`); TypeError naming ``who``
    for anything else that is not a ``trimesh.Trimesh`` (which is returned as it is)."""
    import trimesh

    if isinstance(obj, trimesh.Trimesh):
        return obj
    if type(obj).__module__.split(".")[0] == "pyvista":
        return polydata_to_mesh(obj)
    raise TypeError(f"{who} must be a trimesh.Trimesh or a pyvista mesh, got {type(obj).__name__}")


def update_scalars(poly, values, name: str = "ao"):
    """Replace (or add) per-vertex scalars ``name`` of ``poly`` and make them active.

    Parameters
    ----------
    poly : pyvista.PolyData
        ``V`` points.
    values : array_like, shape (V,) or (V, 3)
        Copied (changing the caller's array later changes nothing drawn);
        float16 is stored as float32.
    name : str, optional

    Raises
    ------
    ValueError
        ``values`` does not have one row per point.
    TypeError
        ``values`` not real numbers (strings and None were drawn in the
        lowest colour, complex numbers as their real part).
    """
    v = np.array(values)                # a copy: pyvista keeps the array, later edits of values would show
    if not (np.issubdtype(v.dtype, np.number) or v.dtype == bool) or v.dtype.kind == "c":
        raise TypeError(f"update_scalars: values must be real numbers, got {v.dtype}")
    if v.dtype == np.float16:           # no VTK type for it: widened exactly
        v = v.astype(np.float32)
    if v.ndim not in (1, 2) or len(v) != poly.n_points:
        raise ValueError(f"update_scalars: expected ({poly.n_points},) or ({poly.n_points}, k) "
                         f"values, got shape {v.shape}")
    poly.point_data[name] = v
    poly.point_data.active_scalars_name = name
    return poly


def scene_to_plotter(scene, plotter, scalars=None, *, name: str = "ao", cmap: str = "gray",
                     clim=(0.0, 1.0), ground: bool = True, ground_size: float | None = None,
                     color: str = "white", lighting: bool = True, nan_color: str = "magenta"):
    """Add every instance of a :class:`pyshadow.Scene` that has a mesh to the active subplot.

    Parameters
    ----------
    scene : pyshadow.Scene
    plotter : pyvista.Plotter
    scalars : dict of int -> array_like, shape (V_i,), optional
        Per-vertex values of instance ``i`` (e.g. ``scene.vertex_ao(i)``);
        instances without an entry are drawn in ``color``. A key that is
        not the id of an instance with a mesh, or values of another shape
        (a column (V_i, 1) was drawn as its magnitude: -0.1 as +0.1),
        raise ValueError before anything is drawn.
    name, cmap, clim :
        Scalar array name, colour map and colour range (shared by all
        instances, so one colour bar describes them; ``clim`` finite with
        low < high). Values outside ``clim`` (infinities too) take the
        colour of its nearer end.
    ground : bool, optional
        Draw the scene's analytic ground plane as a flat quad
        (:meth:`Scene.ground_quad`) in ``color`` when it has one.
    ground_size : float, optional
        Side of that quad.
    color : str, optional
    lighting : bool, optional
        Shade with the plotter's lights; ``False`` draws the scalar colours
        exactly (an AO value then reads straight off the colour bar).
    nan_color : str, optional
        Colour of NaN values; default magenta, no colour of ``'gray'``
        (pyvista's own, dark grey, read as an AO of 0.66).

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
    from .images import _check_clim

    scalars = {} if scalars is None else dict(scalars)
    drawn = [i for i, inst in enumerate(scene.instances) if inst.mesh is not None]
    stray = [k for k in scalars if isinstance(k, (bool, np.bool_)) or k not in drawn]
    if stray:
        raise ValueError(f"scene_to_plotter: scalars has keys {stray!r} that are not ids of instances "
                         f"with a mesh (those are {drawn})")
    for k, v in scalars.items():
        V = len(scene.instances[k].mesh.vertices)
        if np.shape(v) != (V,):
            raise ValueError(f"scene_to_plotter: scalars[{k}] must have shape ({V},), got {np.shape(v)}")
    clim = _check_clim(clim, "scene_to_plotter")
    out = {}
    for i, inst in enumerate(scene.instances):
        if inst.mesh is None:
            continue
        values = scalars.get(i)
        poly = mesh_to_polydata(inst.mesh, scalars=values, name=name)
        if values is not None:
            actor = plotter.add_mesh(poly, scalars=name, cmap=cmap, clim=clim, lighting=lighting,
                                     nan_color=nan_color, show_scalar_bar=False)
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
        perspective camera with VTK's 30 degree view angle), > 0.

    Raises
    ------
    ValueError
        ``centre`` or ``direction`` not 3 finite numbers, ``direction``
        zero, ``radius`` or ``fill`` not finite and > 0.

    Notes
    -----
    The camera's up is +y; looking along y (from straight above or below)
    it is -z from above and +z from below, so x points right either way.
    """
    c = np.asarray(centre, dtype=np.float64).reshape(-1)
    d = np.asarray(direction, dtype=np.float64).reshape(-1)
    if c.shape != (3,) or not np.isfinite(c).all():
        raise ValueError(f"look_at_bodies: centre must be 3 finite numbers, got {centre!r}")
    if d.shape != (3,) or not np.isfinite(d).all() or not np.abs(d).max() > 0:
        raise ValueError(f"look_at_bodies: direction must be 3 finite numbers, not all 0, got {direction!r}")
    for key, value in (("radius", radius), ("fill", fill)):
        if not (np.isfinite(float(value)) and float(value) > 0):
            raise ValueError(f"look_at_bodies: {key} must be finite and > 0, got {value!r}")
    d = d / np.abs(d).max()
    d = d / np.linalg.norm(d)
    up = (0.0, 1.0, 0.0)
    if abs(d[1]) > 0.999999:           # looking along y: +y is no up; x to the right
        up = (0.0, 0.0, -1.0) if d[1] > 0 else (0.0, 0.0, 1.0)
    w, h = _viewport_pixels(plotter)
    half = np.radians(30.0) / 2.0
    if w < h:                      # the horizontal field is the narrow one
        half = np.arctan(np.tan(half) * w / h)
    dist = radius / (np.sin(half) * float(fill))
    plotter.camera_position = [tuple(c + dist * d), tuple(c), up]
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
        World ``(x, z)`` of the square's centre (exactly two numbers: a
        3-D point raises ValueError).
    size : float, optional
        Side length, finite and > 0.
    divisions : int, optional
        Quads per side (``(divisions + 1)**2`` vertices), 1 .. 2048.
    height : float, optional
        World ``y`` of the grid, finite.

    Returns
    -------
    trimesh.Trimesh
        Add it with ``scene.add(grid, casts=False)``.
    """
    import trimesh

    from .._validate import check_int

    n = check_int(divisions, "ground_grid: divisions", 1, 2048)
    cen = np.asarray(centre, dtype=np.float64).reshape(-1)
    if cen.shape != (2,) or not np.isfinite(cen).all():
        raise ValueError(f"ground_grid: centre must be the two finite numbers (x, z), got {centre!r}")
    size, height = float(size), float(height)
    if not (np.isfinite(size) and size > 0):
        raise ValueError(f"ground_grid: size must be finite and > 0, got {size}")
    if not np.isfinite(height):
        raise ValueError(f"ground_grid: height must be finite, got {height}")
    s = np.linspace(-0.5, 0.5, n + 1) * size
    z, x = np.meshgrid(s + cen[1], s + cen[0], indexing="ij")
    v = np.column_stack([x.reshape(-1), np.full(x.size, height), z.reshape(-1)])
    i = np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]
    a, b, c, d = i, i + 1, i + n + 2, i + n + 1          # (r,c) (r,c+1) (r+1,c+1) (r+1,c)
    # x grows along a row, z along a column: (b - a) x (d - a) = x x z = -y, so wind a, d, c
    faces = np.concatenate([np.stack([a, d, c], -1).reshape(-1, 3),
                            np.stack([a, c, b], -1).reshape(-1, 3)])
    return trimesh.Trimesh(v, faces, process=False)

"""pyshadow results as pyvista objects: meshes with AO, image panels, view sets.

Every example script under ``examples/`` draws through this module. It turns
trimesh meshes and :class:`pyshadow.Scene` instances into ``pv.PolyData``
with per-vertex scalars, shows 2-D arrays (AO images, depth maps, CSM texel
statistics) as flat image panels seen straight on, draws a :class:`ViewSet`
on the unit sphere coloured by compression order, and sets up plotters that
render on screen or off screen into a PNG.

pyvista (and VTK) are imported lazily, inside the functions that need them:
``import pyshadow.viz`` works where pyvista is missing or cannot render.

Off-screen rendering
--------------------
VTK's Linux wheels (9.4 and later) try an X window first and fall back to EGL.
Without a display, :func:`configure_offscreen` picks the fallback explicitly
(no failed X connection, no warning): ``VTK_DEFAULT_OPENGL_WINDOW`` is set to
``vtkEGLRenderWindow`` when the system has ``libEGL.so.1`` (Debian packages
``libegl1``, ``libegl-mesa0``, ``libgl1-mesa-dri``: Mesa's llvmpipe renders on
the CPU), else to ``vtkOSOpenGLRenderWindow`` when it has ``libOSMesa``
(``libosmesa6``). A value already in the environment is left alone.

Image conventions follow the arrays: a camera image (:meth:`Scene.render`,
:class:`pyshadow.Camera`) has row 0 at the top (``origin='upper'``); a depth
map or CSM texel grid has row 0 at the bottom, ``y = 2(r+0.5)/R - 1`` along
the map's ``v`` axis (``origin='lower'``, see :mod:`pyshadow.raster`).
"""
from __future__ import annotations

import ctypes.util
import os
import sys

import numpy as np

from .mesh import stand_on_ground  # noqa: F401  (placement helper, part of viz's API)

__all__ = [
    "BACKGROUND",
    "TEXT_COLOR",
    "configure_offscreen",
    "make_plotter",
    "finish",
    "save_screenshot",
    "font_size",
    "add_title",
    "update_title",
    "mesh_to_polydata",
    "update_scalars",
    "scene_to_plotter",
    "look_at_bodies",
    "image_panel",
    "colour_bar",
    "bent_normal_rgb",
    "view_set_points",
    "add_view_set",
    "segment_heatmap",
    "stand_on_ground",
    "ground_grid",
]

BACKGROUND = "#c9d3df"     # light blue-grey: differs from AO black (0) and white (1)
TEXT_COLOR = "black"


def _pv():
    """Import pyvista, with an error that says what is missing."""
    try:
        import pyvista as pv
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError(
            "pyshadow.viz needs pyvista (pip install pyvista); the rest of pyshadow works without it"
        ) from exc
    return pv


# ---------------------------------------------------------------------------
# plotters
# ---------------------------------------------------------------------------
def _has_display() -> bool:
    if sys.platform != "linux":
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def configure_offscreen() -> str:
    """Choose VTK's off-screen render window for this machine.

    Call before the first render window is created (:func:`make_plotter`
    does it for ``off_screen=True``).

    Returns
    -------
    str
        The render window class VTK will use: the value of
        ``VTK_DEFAULT_OPENGL_WINDOW`` if it was already set, ``'default'``
        where a display exists (or not on Linux; VTK's own choice), else
        ``'vtkEGLRenderWindow'`` or ``'vtkOSOpenGLRenderWindow'`` (now set in
        ``os.environ``).

    Raises
    ------
    RuntimeError
        On Linux without a display, EGL or OSMesa; the message names the
        system packages that provide them.
    """
    key = "VTK_DEFAULT_OPENGL_WINDOW"
    if os.environ.get(key):
        return os.environ[key]
    if _has_display():
        return "default"
    if ctypes.util.find_library("EGL"):
        os.environ[key] = "vtkEGLRenderWindow"
    elif ctypes.util.find_library("OSMesa"):
        os.environ[key] = "vtkOSOpenGLRenderWindow"
    else:
        raise RuntimeError(
            "off-screen rendering needs EGL or OSMesa and this machine has neither "
            "(no display either). On Debian/Ubuntu install libegl1 libegl-mesa0 "
            "libgl1-mesa-dri (or libosmesa6), or run under xvfb-run"
        )
    return os.environ[key]


def make_plotter(shape=(1, 1), window_size=(1024, 768), *, off_screen: bool = False,
                 groups=None, row_weights=None, col_weights=None, background: str = BACKGROUND):
    """A ``pv.Plotter`` on screen or off screen, with pyshadow's background.

    Parameters
    ----------
    shape : tuple of int, optional
        Subplot grid ``(rows, columns)``.
    window_size : tuple of int, optional
        ``(width, height)`` in pixels, each at least 16.
    off_screen : bool, optional
        Render without a window (for :func:`finish` with a screenshot);
        :func:`configure_offscreen` is called first.
    groups, row_weights, col_weights : optional
        Passed to ``pv.Plotter`` (merged subplots and relative sizes).
    background : str, optional
        Background colour of every subplot.

    Returns
    -------
    pyvista.Plotter

    Raises
    ------
    ValueError
        A window size that is not two integers >= 16.
    RuntimeError
        ``off_screen=False`` on Linux without a display (the message says to
        pass ``--screenshot``), or no off-screen backend (see
        :func:`configure_offscreen`).
    """
    size = tuple(int(v) for v in np.asarray(window_size).reshape(-1))
    if len(size) != 2 or min(size) < 16:
        raise ValueError(f"window_size must be (width, height) with both >= 16, got {window_size!r}")
    if off_screen:
        configure_offscreen()
    elif not _has_display():
        raise RuntimeError("no display ($DISPLAY is unset): pass --screenshot out.png to render "
                           "off screen into a file")
    pv = _pv()
    kw = {}
    if groups is not None:
        kw["groups"] = groups
    if row_weights is not None:
        kw["row_weights"] = row_weights
    if col_weights is not None:
        kw["col_weights"] = col_weights
    plotter = pv.Plotter(shape=tuple(shape), window_size=list(size), off_screen=bool(off_screen),
                         border=False, **kw)
    plotter.set_background(background, all_renderers=True)
    return plotter


def finish(plotter, screenshot=None, *, title: str = "pyshadow"):
    """Save ``plotter`` to a PNG and close it, or show it interactively.

    Parameters
    ----------
    plotter : pyvista.Plotter
    screenshot : str or os.PathLike, optional
        Output PNG path; its directory must exist. ``None``: open a window.
    title : str, optional
        Window title of the interactive window.

    Returns
    -------
    str or None
        The path written.
    """
    if screenshot is None:
        plotter.show(title=title)
        return None
    path = save_screenshot(plotter, screenshot)
    plotter.close()
    return path


def save_screenshot(plotter, path):
    """Render ``plotter`` now and write the image to the PNG ``path``; the plotter stays open.

    pyvista's ``Plotter.screenshot`` renders only before the first image,
    so frames of an animation must come through here.

    Returns
    -------
    str
        The path written.
    """
    path = os.fspath(path)
    parent = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(parent):
        raise FileNotFoundError(f"screenshot directory does not exist: {parent}")
    plotter.render()
    plotter.screenshot(path)
    return path


def _viewport_pixels(plotter) -> tuple[float, float]:
    x0, y0, x1, y1 = plotter.renderer.GetViewport()
    w, h = plotter.window_size
    return (x1 - x0) * w, (y1 - y0) * h


def font_size(plotter, text: str = "", scale: float = 1.0) -> int:
    """Font size for a title line in the active subplot.

    A 16th of the subplot's height (at most 22 pixels, at most a 20th of
    its width), smaller where ``text`` would not fit on one line, at least
    4. pyvista draws viewport text at twice this size in pixels.
    """
    w, h = _viewport_pixels(plotter)
    px = scale * min(h / 16.0, w / 20.0, 22.0)
    if text:
        px = min(px, 0.94 * w / (0.55 * len(text)))     # measured: about 0.5 em per character
    return int(max(4, np.floor(px / 2.0)))


def add_title(plotter, text: str, *, scale: float = 1.0, fit: str | None = None):
    """Write ``text`` centred along the top edge of the active subplot; returns the text actor.

    ``fit``: size the font for this (longer) text instead, so that titles of
    several panels come out the same size.
    """
    actor = plotter.add_text(text, position=(0.5, 0.985), viewport=True,
                             font_size=font_size(plotter, fit or text, scale), color=TEXT_COLOR)
    actor.prop.justification_horizontal = "center"
    actor.prop.justification_vertical = "top"
    return actor


def update_title(plotter, actor, text: str, *, scale: float = 1.0):
    """Change the text of a title from :func:`add_title`, resized to fit the active subplot."""
    actor.input = text
    actor.prop.font_size = 2 * font_size(plotter, text, scale)
    return actor


# ---------------------------------------------------------------------------
# meshes
# ---------------------------------------------------------------------------
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
    from .scene import GROUND_ID

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
# images
# ---------------------------------------------------------------------------
def image_panel(plotter, image, *, title: str | None = None, cmap: str = "gray", clim=None,
                mask=None, origin: str = "upper", log_scale: bool = False, name: str = "values",
                title_fit: str | None = None):
    """Show a 2-D array as an image in the active subplot, seen straight on.

    Parameters
    ----------
    plotter : pyvista.Plotter
    image : array_like, shape (H, W) numeric, or (H, W, 3) RGB
        Scalar images are colour-mapped; RGB images are shown as colours:
        ``uint8`` as is, floats in [0, 1] scaled to 0..255 (clipped).
    title : str, optional
        Text along the top edge of the subplot.
    title_fit : str, optional
        Size the title's font for this text (see :func:`add_title`).
    cmap : str, optional
        Colour map of a scalar image.
    clim : (float, float), optional
        Colour range; default the finite minimum and maximum.
    mask : array_like of bool, shape (H, W), optional
        Pixels to leave out (they show the background). Non-finite pixels
        of a scalar image are always left out.
    origin : {'upper', 'lower'}
        Where row 0 is drawn: at the top (camera images) or at the bottom
        (depth maps, CSM texel grids).
    log_scale : bool, optional
        Logarithmic colour mapping (positive values).
    name : str, optional
        Name of the cell array holding the pixel values.

    Returns
    -------
    pyvista.Actor or None
        ``None`` when every pixel is masked.

    Raises
    ------
    ValueError
        Wrong shape, unknown ``origin``, a mask of another shape.

    Notes
    -----
    Pixel ``(r, c)`` is the unit cell ``[c, c+1] x [y, y+1]`` of a
    ``pv.ImageData`` in the plane z = 0 (``y = H-1-r`` for ``origin='upper'``,
    ``y = r`` for ``'lower'``), drawn without lighting so colours are exact.
    The camera is parallel, looks down -z and fits the whole ``W x H``
    rectangle (masked pixels included) with room for the title.
    """
    pv = _pv()
    img = np.asarray(image)
    rgb = img.ndim == 3 and img.shape[2] == 3
    if not (img.ndim == 2 or rgb):
        raise ValueError(f"image_panel: image must have shape (H, W) or (H, W, 3), got {img.shape}")
    if origin not in ("upper", "lower"):
        raise ValueError(f"image_panel: origin must be 'upper' or 'lower', got {origin!r}")
    H, W = img.shape[:2]
    if H == 0 or W == 0:
        raise ValueError(f"image_panel: empty image of shape {img.shape}")
    keep = np.ones((H, W), bool)
    if mask is not None:
        m = np.asarray(mask, dtype=bool)
        if m.shape != (H, W):
            raise ValueError(f"image_panel: mask must have shape {(H, W)}, got {m.shape}")
        keep &= ~m
    if rgb:
        if img.dtype != np.uint8:
            img = np.round(np.clip(np.asarray(img, np.float64), 0.0, 1.0) * 255.0).astype(np.uint8)
    else:
        if not (np.issubdtype(img.dtype, np.number) or img.dtype == bool):
            raise ValueError(f"image_panel: image must be numeric, got {img.dtype}")
        img = np.asarray(img, dtype=np.float64)
        keep &= np.isfinite(img)
    if origin == "upper":
        img, keep = img[::-1], keep[::-1]
    grid = pv.ImageData(dimensions=(W + 1, H + 1, 1))
    grid.cell_data[name] = img.reshape(H * W, 3) if rgb else img.reshape(-1)
    actor = None
    if keep.any():
        shown = grid if keep.all() else grid.extract_cells(np.flatnonzero(keep.reshape(-1)))
        if rgb:
            actor = plotter.add_mesh(shown, scalars=name, rgb=True, lighting=False,
                                     show_scalar_bar=False)
        else:
            vals = img[keep]
            if clim is None:
                lo, hi = float(vals.min()), float(vals.max())
                clim = (lo, hi if hi > lo else lo + 1.0)
            actor = plotter.add_mesh(shown, scalars=name, cmap=cmap, clim=clim, lighting=False,
                                     log_scale=log_scale, show_scalar_bar=False)
    # straight-on parallel camera that fits the whole image below a title strip
    w, h = _viewport_pixels(plotter)
    aspect = w / h
    title_frac = 0.14 if title else 0.04
    half_h = max(0.5 * H, 0.5 * W / aspect) / (1.0 - title_frac)
    cx, cy = 0.5 * W, 0.5 * H + half_h * (title_frac - 0.02)
    dist = 2.0 * max(H, W)
    plotter.camera_position = [(cx, cy, dist), (cx, cy, 0.0), (0.0, 1.0, 0.0)]
    plotter.camera.parallel_projection = True
    plotter.camera.parallel_scale = half_h
    plotter.renderer.ResetCameraClippingRange()
    if title:
        add_title(plotter, title, fit=title_fit)
    return actor


def colour_bar(plotter, title: str, *, cmap: str = "gray", clim=(0.0, 1.0), n_labels: int = 5,
               fmt: str = "%.2f"):
    """A horizontal colour bar filling the active subplot (a strip under panels).

    Meshes and images drawn with the same ``cmap`` and ``clim`` share it.

    Parameters
    ----------
    plotter : pyvista.Plotter
    title : str
        Written under the bar, with the labels.
    cmap : str, optional
    clim : (float, float), optional
    n_labels : int, optional
    fmt : str, optional
        printf-style label format.

    Returns
    -------
    vtkScalarBarActor
    """
    w, h = _viewport_pixels(plotter)
    size = int(np.clip(round(min(h / 3.2, w / 30.0)), 6, 16))
    bar = plotter.add_scalar_bar(title=title, cmap=cmap, clim=tuple(float(v) for v in clim),
                                 n_labels=n_labels, fmt=fmt, vertical=False, position_x=0.1,
                                 position_y=0.04, width=0.8, height=0.92, color=TEXT_COLOR,
                                 title_font_size=size, label_font_size=size)
    bar.SetTextPositionToPrecedeScalarBar()      # labels under the bar, the title above it
    return bar


def bent_normal_rgb(bent, mask=None):
    """Bent normals as colours: ``(b + 1) / 2`` per channel.

    Parameters
    ----------
    bent : array_like, shape (H, W, 3)
        Unit vectors (world x, y, z -> red, green, blue).
    mask : array_like of bool, shape (H, W), optional
        Pixels without a surface; they become black (0).

    Returns
    -------
    ndarray, shape (H, W, 3), uint8
    """
    b = np.asarray(bent, dtype=np.float64)
    if b.ndim != 3 or b.shape[2] != 3:
        raise ValueError(f"bent_normal_rgb: bent must have shape (H, W, 3), got {b.shape}")
    rgb = np.round(np.clip((b + 1.0) * 0.5, 0.0, 1.0) * 255.0).astype(np.uint8)
    if mask is not None:
        rgb[np.asarray(mask, dtype=bool)] = 0
    return rgb


# ---------------------------------------------------------------------------
# view sets and CSMs
# ---------------------------------------------------------------------------
def view_set_points(views, radius: float = 1.0, *, path: bool = True):
    """The map directions of a view set on a sphere, ordered.

    Parameters
    ----------
    views : pyshadow.ViewSet
        ``D`` directions in compression order.
    radius : float, optional
        Sphere radius.
    path : bool, optional
        Also join consecutive directions by one polyline (the traversal).

    Returns
    -------
    pyvista.PolyData
        ``D`` points ``radius * d_k`` with one vertex cell each (and the
        polyline); point data ``'order'`` float64 ``k / (D - 1)`` in [0, 1]
        (0 for ``D = 1``) and ``'index'`` int64 ``k``.
    """
    from .views import ViewSet

    pv = _pv()
    if not isinstance(views, ViewSet):
        raise TypeError(f"view_set_points: views must be a pyshadow.ViewSet, got {type(views).__name__}")
    D = len(views)
    if D == 0:
        raise ValueError("view_set_points: the view set is empty")
    pts = np.asarray(views.directions, dtype=np.float64) * float(radius)
    verts = np.column_stack([np.ones(D, np.int64), np.arange(D)]).reshape(-1)
    kw = {"verts": verts}
    if path and D > 1:
        kw["lines"] = np.concatenate([[D], np.arange(D)]).astype(np.int64)
    poly = pv.PolyData(pts, **kw)
    poly.point_data["order"] = np.arange(D) / max(D - 1, 1)
    poly.point_data["index"] = np.arange(D, dtype=np.int64)
    poly.point_data.active_scalars_name = "order"
    return poly


def add_view_set(plotter, views, *, cmap: str = "turbo", sphere_color: str = "#e8e8e8",
                 path: bool = True):
    """Draw a view set on an opaque unit sphere in the active subplot.

    Points (rendered as small spheres sized to the subplot and the map
    count) and, with ``path``, the polyline of the traversal, both coloured
    by ``'order'`` of :func:`view_set_points` with ``cmap`` over [0, 1].

    Parameters
    ----------
    plotter : pyvista.Plotter
    views : pyshadow.ViewSet
    cmap : str, optional
        Colour map of the order, first map at 0.
    sphere_color : str, optional
    path : bool, optional

    Returns
    -------
    pyvista.Actor
        The actor of the points and path.
    """
    pv = _pv()
    plotter.add_mesh(pv.Sphere(radius=0.985, theta_resolution=48, phi_resolution=48),
                     color=sphere_color, smooth_shading=True)
    pts = view_set_points(views, path=path)
    w, h = _viewport_pixels(plotter)
    size = float(np.clip(0.45 * min(w, h) / np.sqrt(len(views)), 3.0, 14.0))
    return plotter.add_mesh(pts, scalars="order", cmap=cmap, clim=(0.0, 1.0), point_size=size,
                            render_points_as_spheres=True, line_width=max(1.0, size / 4.0),
                            show_scalar_bar=False)


def segment_heatmap(csm):
    """Segments per texel of a CSM, masked outside the object's silhouette.

    Parameters
    ----------
    csm : pyshadow.CoherentShadowMap
        ``R x R`` texels.

    Returns
    -------
    ndarray, shape (R, R), float64
        ``csm.texel_segment_counts()`` indexed ``[row, col]`` (row 0 at the
        bottom: ``origin='lower'`` in :func:`image_panel`), NaN where the
        texel's whole list is one miss segment -- no map sees the object
        through that texel. Texels hit in any map keep their count (>= 1).
    """
    from .csm import CoherentShadowMap

    if not isinstance(csm, CoherentShadowMap):
        raise TypeError(f"segment_heatmap: expected a CoherentShadowMap, got {type(csm).__name__}")
    counts = csm.texel_segment_counts()
    R = csm.resolution
    first = np.asarray(csm.offsets[:-1], dtype=np.int64).reshape(R, R)
    single = counts == 1
    miss = np.zeros((R, R), bool)
    if single.any():
        miss[single] = np.isinf(csm.stored_to_depth(np.asarray(csm.depth)[first[single]]))
    out = counts.astype(np.float64)
    out[single & miss] = np.nan
    return out


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

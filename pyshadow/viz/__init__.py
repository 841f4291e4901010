"""pyshadow results as pyvista objects: meshes with AO, image panels, view sets.

Every example script under ``examples/`` draws through this package. It turns
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

Modules
-------
Everything below is imported from ``pyshadow.viz``; the modules only group it:

* :mod:`pyshadow.viz.plotter` -- off-screen setup, plotters, screenshots, titles,
  the example scripts' ``--window`` and ``--screenshot`` options.
* :mod:`pyshadow.viz.meshes` -- meshes and scenes to polydata, per-vertex values
  back onto a pyvista mesh's own points, the camera on them, the ground grid.
* :mod:`pyshadow.viz.images` -- image panels, colour bars, bent-normal colours.
* :mod:`pyshadow.viz.viewsets` -- view sets on the sphere, CSM segment heat maps.
* :mod:`pyshadow.viz.ssao_pass` -- pyvista's own SSAO render pass read back as
  an AO image on a :class:`pyshadow.Camera` (the reference of
  ``pyshadow-bench --method vtk-ssao``).
"""
from __future__ import annotations

from ..mesh import stand_on_ground  # placement helper, part of viz's API
from . import plotter as _plotter
from .images import bent_normal_rgb, colour_bar, image_panel
from .meshes import (ground_grid, look_at_bodies, mesh_to_polydata, point_values, polydata_to_mesh,
                     scene_to_plotter, update_scalars)
from .plotter import (
    BACKGROUND,
    MAX_WINDOW_SIDE,
    TEXT_COLOR,
    add_title,
    add_window_options,
    configure_offscreen,
    finish,
    font_size,
    make_plotter,
    save_screenshot,
    screenshot_path,
    script_plotter,
    update_title,
    window_side,
)
from .ssao_pass import VTKSSAO, vtk_ssao
from .viewsets import add_view_set, segment_heatmap, view_set_points

__all__ = [
    "BACKGROUND",
    "TEXT_COLOR",
    "configure_offscreen",
    "make_plotter",
    "MAX_WINDOW_SIDE",
    "add_window_options",
    "script_plotter",
    "window_side",
    "screenshot_path",
    "finish",
    "save_screenshot",
    "font_size",
    "add_title",
    "update_title",
    "mesh_to_polydata",
    "polydata_to_mesh",
    "point_values",
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
    "vtk_ssao",
    "VTKSSAO",
]

# ``viz.ctypes`` as when viz was one module: configure_offscreen looks EGL and
# OSMesa up through ``ctypes.util.find_library``, which callers may patch there.
ctypes = _plotter.ctypes

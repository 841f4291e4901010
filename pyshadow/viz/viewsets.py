"""View sets on the unit sphere and the segment count of a CSM's texels.

A :class:`pyshadow.ViewSet` is drawn as its ``D`` map directions (unit
vectors, world frame) on a sphere, coloured and joined in compression order;
a :class:`pyshadow.CoherentShadowMap` is summarised as an ``(R, R)`` heat map
of segments per texel for :func:`pyshadow.viz.image_panel`
(``origin='lower'``).
"""
from __future__ import annotations

import numpy as np

from .plotter import _pv, _viewport_pixels

__all__ = [
    "view_set_points",
    "add_view_set",
    "segment_heatmap",
]


def view_set_points(views, radius: float = 1.0, *, path: bool = True):
    """The map directions of a view set on a sphere, ordered.

    Parameters
    ----------
    views : pyshadow.ViewSet
        ``D`` directions in compression order.
    radius : float, optional
        Sphere radius, finite and > 0.
    path : bool, optional
        Also join consecutive directions by one polyline (the traversal).

    Returns
    -------
    pyvista.PolyData
        ``D`` points ``radius * d_k`` with one vertex cell each (and the
        polyline); point data ``'order'`` float64 ``k / (D - 1)`` in [0, 1]
        (0 for ``D = 1``) and ``'index'`` int64 ``k``.

    Raises
    ------
    TypeError
        ``views`` is no ViewSet, ``radius`` no real number (a bool, a
        string), ``path`` not True or False.
    ValueError
        An empty view set, a radius that is not finite and > 0.
    """
    from .._validate import flag, real_scalar
    from ..views import ViewSet

    pv = _pv()
    if not isinstance(views, ViewSet):
        raise TypeError(f"view_set_points: views must be a pyshadow.ViewSet, got {type(views).__name__}")
    D = len(views)
    if D == 0:
        raise ValueError("view_set_points: the view set is empty")
    if not real_scalar(radius):        # True was radius 1, the string "2" radius 2
        raise TypeError(f"view_set_points: radius must be a real number, got {radius!r}")
    path = flag(path, "path")           # the string "no" drew the path
    radius = float(radius)
    if not (np.isfinite(radius) and radius > 0):      # a negative one puts every map on the antipode
        raise ValueError(f"view_set_points: radius must be finite and > 0, got {radius}")
    pts = np.asarray(views.directions, dtype=np.float64) * radius
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
    pts = view_set_points(views, path=path)     # its arguments checked before anything is drawn
    plotter.add_mesh(pv.Sphere(radius=0.985, theta_resolution=48, phi_resolution=48),
                     color=sphere_color, smooth_shading=True)
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
    from ..csm import CoherentShadowMap

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

"""The surface rule: how a CSM answers rays that leave its own surface at a known normal.

A ray that grazes the flat face of a body (a low sun over a plate) is looked
up in the map nearest its direction. When the maps are further apart than
the ray's elevation, that map can lie *below* the face's plane, look at the
face from behind and report the body shadowing its own face; and a map just
above the plane sees the face so obliquely that the stored depth of the
point's texel (that of its centre ray) lies many texels in front of the
point. No bias along the map's axis removes either without hiding real
occluders. With the surface's unit normal ``m`` known (AO always knows it;
``visible`` when given ``normals``), the lookup of a ray leaving its own
body (``v . m > 0``)

1. raises the lookup direction to the elevation :func:`covering_angle` of
   the view set where the ray is lower, so that every map the lookup may
   pick lies above the tangent plane, and
2. compares the point, at each tap, with its own surface: the plane
   through it with normal ``m``, whose depth at the tap's texel centre
   follows from ``m`` (:mod:`pyshadow.csm.core`, ``PLANE_BIAS_TEXELS``). Its
   self-bias is the quantum plus ``PLANE_BIAS_TEXELS + DEFAULT_BIAS_TAN tan
   a`` texels (``a`` between ray and map axis) less the depth by which the
   plane lies behind the point at the centre, and at least the quantum. A
   flat face is never its own occluder, however obliquely the map sees it,
   and a wall rising above the plane beside the point (an inside corner) is
   seen; the constant 1.5 texels hid one within about a texel and a half.
   With a bias given by the caller (``bias=``), or with
   ``pyshadow.visibility.csm.PLANE_BIAS = False``, the rule instead lifts
   the point off the surface along ``m`` by ``max(0, SURFACE_LIFT_TEXELS
   (|m.u| + |m.v|) - b (m.d))`` texels in each map it asks (``u, v, d`` the
   map's rows, ``b`` the self-bias in texels): the least lift after which
   the centre ray of the point's texel passes above a flat face by more
   than the bias covers.

What it costs: self-occluders in the band between the ray's elevation and
the covering angle are answered as at the covering angle (the map spacing
already limits what a CSM resolves there), and occluders rising less than
a quarter texel of depth above the tangent plane are not seen by points on
that surface (a CSM does not resolve them either). The plane is that of the
normal passed: a shading normal far from its face's tilts it. Points on
other bodies or the ground are unchanged: their contact shadows stay sharp.
"""
from __future__ import annotations

import weakref

import numpy as np

__all__ = ["SURFACE_LIFT_TEXELS", "covering_angle", "surface_horizon"]

#: the lift's reach, in texels on each map axis: a point lies within half a
#: texel of its texel's centre ray along u and along v
SURFACE_LIFT_TEXELS = 0.5

#: directions the covering angle is measured on (a Fibonacci sphere)
_COVER_SAMPLES = 1 << 17

_COVER = weakref.WeakKeyDictionary()


def _fibonacci_sphere(n: int) -> np.ndarray:
    i = np.arange(n, dtype=np.float64) + 0.5
    y = 1.0 - 2.0 * i / n
    r = np.sqrt(np.maximum(0.0, 1.0 - y * y))
    phi = i * np.pi * (3.0 - np.sqrt(5.0))
    return np.column_stack([r * np.cos(phi), y, r * np.sin(phi)])


def covering_angle(views, lookup: str = "nearest") -> float:
    """The largest angle between a direction and a map the lookup may ask, radians.

    Measured over ``2**17`` directions of a Fibonacci sphere (the poles and
    the seam included by the layout's own symmetry) with the lookup's own
    choice (:meth:`ViewSet.nearest`, or every map of
    :meth:`ViewSet.filter_window` for the vote), plus the spacing of those
    directions (``sqrt(4 pi / 2**17)``, 0.56 degrees), which bounds what the
    sampling can miss. Cached per view set.

    Parameters
    ----------
    views : ViewSet
    lookup : {'nearest', 'vote'}

    Returns
    -------
    float
        Radians, in ``(0, pi]``.
    """
    from .._validate import check_lookup
    from ..views import ViewSet

    if not isinstance(views, ViewSet):
        raise TypeError(f"views must be a pyshadow.ViewSet, got {type(views).__name__}")
    check_lookup(lookup)                # an array: unhashable or ambiguous
    held = _COVER.setdefault(views, {})
    if lookup not in held:
        d = _fibonacci_sphere(_COVER_SAMPLES)
        if lookup == "nearest":
            maps = np.asarray(views.nearest(d))[:, None]
        else:
            maps = np.asarray(views.filter_window(d)[0])
        dirs = np.asarray(views.directions, np.float64)
        cos = np.einsum("ij,imj->im", d, dirs[maps]).min()
        spacing = np.sqrt(4.0 * np.pi / _COVER_SAMPLES)
        held[lookup] = float(min(np.pi, np.arccos(np.clip(cos, -1.0, 1.0)) + spacing))
    return held[lookup]


def surface_horizon(csm, lookup: str = "nearest") -> float:
    """The sine of the lowest elevation a ray leaving the CSM's own surface is looked up at.

    Parameters
    ----------
    csm : CoherentShadowMap
    lookup : {'nearest', 'vote'}

    Returns
    -------
    float
        ``sin`` of :func:`covering_angle` of ``csm.views`` (at most 1).
    """
    if not hasattr(csm, "views"):       # a ViewSet failed with "'ViewSet' object has no attribute 'views'"
        raise TypeError(f"csm must be a CoherentShadowMap (it has the view set), got {type(csm).__name__}")
    return float(np.sin(min(covering_angle(csm.views, lookup), 0.5 * np.pi)))

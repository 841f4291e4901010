"""The ``"embree"`` backend: ray tracing against the casters' meshes (the ground truth).

Answers through :mod:`pyshadow.embree` on the identical rays: a ray starts at
the point lifted off its surface by :func:`pyshadow.embree.surface_epsilon`
and runs to infinity (or to ``max_distance``: every ray is answered, there
is nothing to ``straddle``; distance AO is exact, from the hit
distances); the ground plane is tested analytically as the
kernels do. ``bias`` does not apply (there is no depth to compare) and
``surface_ids`` is not needed (the lift keeps a ray off its own surface); they,
``visible``'s ``normals`` and ``straddle``, and the options of distance AO,
are still checked as the other backends and :func:`pyshadow.visibility.visible`
check them (a bad value is an error whatever the backend).
Every caster needs its mesh (``Scene.add(csm, mesh=...)``).
"""
from __future__ import annotations

import numpy as np

from .base import check_bias, register

__all__ = ["EmbreeVisibility"]


class EmbreeVisibility:
    """Exact visibility by Embree occlusion rays (embreex)."""

    name = "embree"
    #: Renders give it points on their faces' planes in float64 (:func:`pyshadow.gbuffer.on_face_planes`):
    #: its lift off a surface (:mod:`pyshadow._embree_lift`) is smaller than a float32 depth's rounding far away.
    exact_surface_points = True

    def __repr__(self) -> str:
        return "<EmbreeVisibility 'embree'>"

    def visible(self, scene, points, directions, *, bias=None, surface_ids=None, normals=None,
                max_distance=None, straddle="error"):
        from .. import embree
        from .finite import check_straddle

        check_bias(bias)
        check_straddle(straddle)
        _check_unused(scene, points, surface_ids, normals)
        return embree.visible(scene, points, directions, max_distance=max_distance)

    def ambient_occlusion(self, scene, points, normals, *, sampling, return_bent_normals=False, bias=None,
                          indices=None, surface_ids=None, max_distance=None, obscurance=None, quadrature=16,
                          straddle="error"):
        """Embree AO; with ``max_distance`` / ``obscurance`` exact distance AO from the hit
        distances (``quadrature`` and ``straddle`` are validated, then not needed)."""
        from .. import embree
        from ..sampling import Sampling
        from .finite import check_ao_options

        if sampling is not None and not isinstance(sampling, Sampling):     # (8: AttributeError 'samples')
            raise TypeError(f"sampling must be a pyshadow.Sampling, got {sampling!r}")
        check_bias(bias)
        check_ao_options(obscurance, quadrature, straddle)
        _check_unused(scene, points, surface_ids, None)
        distance = {}
        if max_distance is not None or obscurance is not None:
            distance = {"max_distance": max_distance, "obscurance": obscurance}
        return embree.ambient_occlusion(scene, points, normals, sampling=sampling,
                                        return_bent_normals=return_bent_normals, indices=indices, **distance)


def _check_unused(scene, points, surface_ids, normals):
    """``surface_ids`` and ``normals`` are not needed here, but are checked as the other backends check
    them: a bad id or normal is an error whatever the backend (not silently answered by this one)."""
    if surface_ids is None and normals is None:
        return
    from .._validate import unit_normals

    shape = np.shape(points)
    if len(shape) != 2:
        return                  # embree names the points' shape
    if surface_ids is not None:
        scene.caster_slots(surface_ids, shape[0])
    if normals is not None:
        unit_normals(normals, shape[0])


register("embree", EmbreeVisibility())

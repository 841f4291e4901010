"""The ``"embree"`` backend: ray tracing against the casters' meshes (the ground truth).

Answers through :mod:`pyshadow.embree` on the identical rays: a ray starts at
the point lifted off its surface by :func:`pyshadow.embree.surface_epsilon`
and runs to infinity (or to ``max_distance``: every ray is answered, there
is nothing to ``straddle``; distance AO is exact, from the hit
distances); the ground plane is tested analytically as the
kernels do. ``bias`` does not apply (there is no depth to compare) and
``surface_ids`` is not needed (the lift keeps a ray off its own surface).
Every caster needs its mesh (``Scene.add(csm, mesh=...)``).
"""
from __future__ import annotations

from .base import register

__all__ = ["EmbreeVisibility"]


class EmbreeVisibility:
    """Exact visibility by Embree occlusion rays (embreex)."""

    name = "embree"

    def __repr__(self) -> str:
        return "<EmbreeVisibility 'embree'>"

    def visible(self, scene, points, directions, *, bias=None, surface_ids=None, normals=None,
                max_distance=None, straddle="error"):
        from .. import embree

        return embree.visible(scene, points, directions, max_distance=max_distance)

    def ambient_occlusion(self, scene, points, normals, *, sampling, return_bent_normals=False, bias=None,
                          indices=None, surface_ids=None, max_distance=None, obscurance=None, quadrature=16,
                          straddle="error"):
        """Embree AO; with ``max_distance`` / ``obscurance`` exact distance AO from the hit
        distances (``quadrature`` and ``straddle`` are validated, then not needed)."""
        from .. import embree
        from .finite import check_ao_options

        distance = {}
        if max_distance is not None or obscurance is not None:
            check_ao_options(obscurance, quadrature, straddle)
            distance = {"max_distance": max_distance, "obscurance": obscurance}
        return embree.ambient_occlusion(scene, points, normals, sampling=sampling,
                                        return_bent_normals=return_bent_normals, indices=indices, **distance)


register("embree", EmbreeVisibility())

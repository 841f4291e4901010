"""Cube-map AO (seed 002, "aolib2"): probes, per-texel AO, projection onto a camera.

:class:`CubeProbe` renders six 90-degree G-buffer faces at a point;
:func:`texel_ao` computes AO per texel by the thesis's horizon estimator or by
marching pyshadow's own sample directions through the probe
(:mod:`~pyshadow.cubemap.estimators`); :class:`CubeMapAO` holds several probes,
places them by the coverage rule and projects their AO onto a camera's pixels
(:mod:`~pyshadow.cubemap.project`); :class:`CubeMapVisibility` answers the
visibility protocol through them (:mod:`~pyshadow.cubemap.backend`), and
:func:`seed_box_filter` is the seed's 7 x 7 edge-aware filter.
"""
from .probe import MAX_RESOLUTION, MIN_RESOLUTION, CubeProbe, direction_texels, face_camera
from .estimators import (ESTIMATORS, horizon_ao_reference, march_defaults, raymarch_visible,
                         raymarch_visible_reference, texel_ao)
from .project import CubeMapAO, Projection, coverage_grid, normal_hash, quality, seed_box_filter
from .backend import CubeMapVisibility

__all__ = ["CubeProbe", "MIN_RESOLUTION", "MAX_RESOLUTION", "direction_texels", "face_camera", "ESTIMATORS", "texel_ao",
           "march_defaults", "raymarch_visible", "raymarch_visible_reference", "horizon_ao_reference",
           "CubeMapAO", "CubeMapVisibility", "Projection", "coverage_grid", "normal_hash", "quality", "seed_box_filter"]

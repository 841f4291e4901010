"""The converged ground truth of :mod:`pyshadow.lighting.shade` (issue 19 item 7).

:func:`reference_radiance` evaluates the same two integrals as the shading
modes, converged, through the Embree backend (``backend="embree"``, the
same :func:`pyshadow.visibility.visible` calls as every other backend):

sky
    the "sampled" estimator ``albedo * (1/S) sum_s L_env(w_s) V(p, w_s)``
    (:func:`pyshadow.lighting.shade.sampled_sky_radiance`) with many
    cosine-weighted directions (``samples``, default 1024), i.e. ``albedo /
    pi * integral L_env V cos dOmega`` up to the estimator's noise at that
    count. It needs the sky's environment map (:attr:`Lighting.env`).
sun
    :func:`pyshadow.lighting.shade.sun_radiance` with ``sun_samples``
    directions spread over the sun's disc (default 1024; a sun of angular
    radius 0 is one direction whatever the count), plus the local lights
    (:func:`pyshadow.lighting.local.lights_radiance`), sphere and area lights
    with ``sun_samples`` points each.

Because the code path is that of ``shade(..., backend="embree")`` in mode
"sampled", a call with ``samples = S``, the same sampling strategy, pattern
count and seed, and ``sun_samples`` equal to the Lighting's reproduces that
shading bit for bit; with the defaults it is the converged reference each
mode's error is measured against.
"""
from __future__ import annotations

import copy
import dataclasses

import numpy as np

from .local import lights_radiance
from .shade import Lighting, _check_lighting, _check_points, sampled_sky_radiance, sun_radiance

__all__ = ["reference_radiance", "REFERENCE_BACKEND"]

#: The visibility backend of the reference.
REFERENCE_BACKEND = "embree"


def _count(v, name: str, hi: int) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= hi:
        raise ValueError(f"{name}: expected an int in 1 .. {hi} (got {v!r})")
    return int(v)


def reference_radiance(scene, points, normals, lighting: Lighting, *, samples: int = 1024,
                       sun_samples: int = 1024, sampling=None, surface_ids=None, indices=None) -> np.ndarray:
    """Converged linear RGB radiance leaving each surface point, by Embree ray tracing.

    Parameters
    ----------
    scene : pyshadow.Scene
        Every caster needs its mesh (``Scene.add(csm, mesh=...)``).
    points, normals : array_like, shape (N, 3)
        World positions and surface normals (normalised here).
    lighting : Lighting
        Its sky map (:attr:`Lighting.env`), sun and albedos; its ``mode`` is
        not used (the reference is the integral every mode approximates).
    samples : int, optional
        Cosine-weighted sky directions per point, 1 .. 4096.
    sun_samples : int, optional
        Directions over the sun's disc (used when its angular radius is
        > 0) and points over each sphere and area light of
        :attr:`Lighting.lights`, 1 .. 1024.
    sampling : pyshadow.Sampling, optional
        Strategy, pattern count and seed of the sky directions (its own
        sample count is replaced by ``samples``); default ``Sampling()``'s.
    surface_ids : int or array_like of int, optional
        Instance id of each point's surface: picks the albedo.
    indices : array_like of int, shape (N,), optional
        Sample-pattern index of each point; default ``arange(N)``.

    Returns
    -------
    ndarray, shape (N, 3), float32
        ``sky + sun`` (+inf beyond float32's range, as :func:`~pyshadow.lighting.shade.shade`).

    Raises
    ------
    ValueError
        Bad points, normals, ids or counts; a Lighting whose sky is SH
        coefficients only (the reference needs the map).
    """
    from ..sampling import MAX_SAMPLES, Sampling

    _check_lighting(lighting)
    s = _count(samples, "samples", MAX_SAMPLES)
    k = _count(sun_samples, "sun_samples", 1024)
    if sampling is None:
        sampling = Sampling()
    elif not isinstance(sampling, Sampling):
        raise TypeError(f"sampling must be a pyshadow.Sampling, got {sampling!r}")
    sampling = dataclasses.replace(sampling, samples=s)
    if lighting.env is None and np.any(lighting.sh != 0):
        raise ValueError("reference_radiance needs the sky's EnvironmentMap (Lighting(sky=EnvironmentMap)); "
                         "this Lighting holds SH coefficients only")
    p, nrm, idx = _check_points(scene, points, normals, surface_ids, indices, lighting, "reference_radiance")
    n = len(p)
    if n == 0:
        return np.zeros((0, 3), np.float32)
    albedo = lighting.albedo_of(surface_ids, n)
    sky, _, _ = sampled_sky_radiance(scene, p, nrm, lighting, albedo, backend=REFERENCE_BACKEND, sampling=sampling,
                                     surface_ids=surface_ids, indices=idx)
    light = copy.copy(lighting)
    light.sun_samples = k
    sun, _ = sun_radiance(scene, p, nrm, light, albedo, backend=REFERENCE_BACKEND, surface_ids=surface_ids,
                          indices=idx)
    sun += lights_radiance(scene, p, nrm, light, albedo, backend=REFERENCE_BACKEND, surface_ids=surface_ids,
                           indices=idx)
    with np.errstate(over="ignore"):        # beyond float32: +inf, as shade_terms (no overflow warning)
        return (sky + sun).astype(np.float32)

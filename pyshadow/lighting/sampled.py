"""The "sampled" sky on the AO kernel, where the backend and the map allow it.

:func:`pyshadow.lighting.sampled_sky_radiance` averages ``L_env(w_s)
V(p, w_s)`` over the AO's cosine-weighted directions. On the host that is
:func:`pyshadow.lighting.transfer.sample_visibility` (every sample ray
through ``visible``) and :meth:`EnvironmentMap.lookup` in float64. A CSM
backend instead sums, inside the AO kernel (``SKY_SAMPLED=1``,
``kernels/envmap.h``), the nearest-texel radiance of each direction the AO
counts as open: :meth:`pyshadow.visibility.csm.CSMVisibility.sampled_sky`.

The kernel route is taken for a CSM backend, a lat-long map whose radiance
is finite in float32 and small enough that the kernel's float32 sum of the
S samples' texels cannot overflow (largest texel times S at most half
float32's largest value), and no ``geometric_normals``. Everything else --
cube-layout maps (their face lookup is not on the device; resampling them
to lat-long would change the values), shading normals, other backends --
takes the host route, unchanged. The map's largest texel, and the device copy
of its radiance (:mod:`pyshadow.visibility.sampled_sky`), are kept between
calls while :attr:`EnvironmentMap.radiance` is the same read-only array. The two agree to float32 rounding except
where a sample direction lies within float rounding of a texel edge, which
the kernel's float32 texel rule may put in the neighbouring texel; AO and
bent normals are the AO kernel's either way.
"""
from __future__ import annotations

import weakref

import numpy as np

__all__ = ["DEVICE_SKY", "device_sampled_sky"]

#: Whether :func:`device_sampled_sky` may use the kernel (False: always the host route; tests).
DEVICE_SKY = True
_largest: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # map -> (weakref to its radiance, largest texel)


def _largest_texel32(env) -> float:
    """The largest texel of ``env.radiance`` rounded to float32 (inf beyond its range), kept while the
    radiance is the same read-only array (rounding is monotone: the largest of the rounded texels)."""
    from ..visibility.sampled_sky import frozen

    rad = env.radiance
    hit = _largest.get(env)
    if hit is not None and hit[0]() is rad and frozen(rad):
        return hit[1]
    with np.errstate(over="ignore"):              # beyond float32: +inf, then the host route
        m = float(np.asarray(rad.max(initial=0.0)).astype(np.float32))
    if frozen(rad):
        _largest[env] = (weakref.ref(rad), m)
    return m


def device_sampled_sky(scene, points, normals, env, *, backend, sampling, indices=None, surface_ids=None,
                       bias=None, geometric_normals=None):
    """The mean sky radiance of the open samples from the AO kernel, or None where the host must answer.

    Parameters
    ----------
    scene : pyshadow.Scene
    points, normals : ndarray, shape (N, 3)
        World positions and unit normals (validated by the caller).
    env : EnvironmentMap or None
        The sky; None (no map): the host route.
    backend : str or VisibilityBackend
    sampling : pyshadow.Sampling
    indices, surface_ids, bias, geometric_normals : optional
        As in :func:`pyshadow.lighting.sampled_sky_radiance`; given
        ``geometric_normals``: the host route.

    Returns
    -------
    tuple or None
        ``(sky, ao, bent)``: (N, 3) float32 ``mean_s L_env(w_s) V(p, w_s)``
        (radiance units), (N,) float32 AO, (N, 3) float32 bent normals; or
        None when the kernel route does not apply (module docstring).
    """
    from ..visibility import get_backend
    from ..visibility.csm import CSMVisibility

    if not DEVICE_SKY or env is None or geometric_normals is not None or env.layout != "latlong":
        return None
    b = get_backend(backend)
    if not isinstance(b, CSMVisibility):
        return None
    m = _largest_texel32(env)
    if not np.isfinite(m):                        # beyond float32's range (or NaN): the float64 host route
        return None
    if m * sampling.samples > 0.5 * float(np.finfo(np.float32).max):
        return None                               # the kernel's float32 sum of S texels could overflow to inf
    return b.sampled_sky(scene, points, normals, env.radiance, env.grid_shape, sampling=sampling, bias=bias,
                         indices=indices, surface_ids=surface_ids)

"""The "sampled" sky on the AO kernel: a part of :class:`pyshadow.visibility.csm.CSMVisibility`.

Stage "visibility kernel": the AO kernel compiled with ``SKY_SAMPLED=1``
also sums a lat-long map's radiance over each point's open directions.

The map's device copy of a read-only array (:attr:`EnvironmentMap.radiance
<pyshadow.lighting.EnvironmentMap.radiance>` is one) is kept between calls,
per OpenCL context, for the :data:`MAX_CACHED_MAPS` maps used last: a 4096 x
2048 map took 0.18 s to check and upload on every call (PoCL CPU), four
times all the rest of a call at 1728 points and 64 samples. A writeable
array is checked and uploaded on every call, as it may have changed.
"""
from __future__ import annotations

import threading
import weakref
from collections import OrderedDict

import numpy as np

from .. import _cl

#: Read-only maps whose device copies are kept between calls (the least recently used goes first).
MAX_CACHED_MAPS = 2
_maps: OrderedDict = OrderedDict()      # (id(array), id(context)) -> (weakref to the array, context, buffer, token)
_maps_lock = threading.Lock()


def frozen(a) -> bool:
    """Whether ``a`` is an array whose contents cannot change unseen: it and every array it views are
    read-only, down to the array that owns the data (as :attr:`EnvironmentMap.radiance`). One whose
    owner is writeable, or a view of a buffer that is no ndarray (bytes, a memory map), is not."""
    while isinstance(a, np.ndarray):
        if a.flags.writeable:
            return False
        if a.base is None:
            return True
        a = a.base
    return False


def _device_map(env: np.ndarray):
    """The float32 device copy of lat-long radiance ``env`` (h, w, 3), checked; cached for a :func:`frozen` one."""
    ctx = _cl.context()
    key = (id(env), id(ctx))
    keep = frozen(env)
    with _maps_lock:
        hit = _maps.get(key)
        if hit is not None and keep and hit[0]() is env and hit[1] is ctx:
            _maps.move_to_end(key)
            return hit[2]
    with np.errstate(over="ignore"):    # beyond float32: inf, refused below by name
        f32 = np.ascontiguousarray(env, np.float32)
    if not np.all(np.isfinite(f32)):
        raise ValueError("env_radiance must be finite (in float32)")
    if (f32 < 0).any():                 # a sky of negative radiance is no sky (EnvironmentMap refuses it)
        raise ValueError(f"env_radiance must be >= 0, got {int((f32 < 0).any(axis=2).sum())} texels below 0 "
                         f"(least {float(f32.min())})")
    buf = _cl.to_device(f32)
    if keep:
        with _maps_lock:
            _maps[key] = (weakref.ref(env), ctx, buf, token := object())
            _maps.move_to_end(key)
            while len(_maps) > MAX_CACHED_MAPS:
                _maps.popitem(last=False)
        weakref.finalize(env, _drop, key, token)    # (not the buffer: an evicted copy is freed at once)
    return buf


def _drop(key, token) -> None:
    """Forget the device copy of a map that is gone (unless another array took its key since)."""
    with _maps_lock:
        if key in _maps and _maps[key][3] is token:
            del _maps[key]


class _SampledSky:
    """The "sampled" sky on the AO kernel (``SKY_SAMPLED=1``), a part of :class:`CSMVisibility`."""

    def sampled_sky(self, scene, points, normals, env_radiance, layout_shape=None, *, sampling, bias=None,
                    indices=None, surface_ids=None):
        """Mean sky radiance of each point's AO directions, with its AO and bent normals, in one AO pass.

        The "sampled" sky (:func:`pyshadow.lighting.sampled_sky_radiance`)
        on the device: ``mean_s L(w_s) V(p, w_s)`` over the AO kernel's
        cosine-weighted directions ``w_s`` (``pyshadow.sample_directions``),
        ``L`` the nearest texel of a lat-long map by the rule of
        :meth:`pyshadow.lighting.EnvironmentMap.texel_index`, evaluated in
        float32 (a direction within float rounding of a texel edge may take
        the neighbouring texel). Cube-layout maps are not handled here.

        Parameters
        ----------
        scene : pyshadow.Scene
        points, normals : array_like, shape (N, 3)
            World positions and unit normals (world frame).
        env_radiance : array_like, shape (h, w, 3)
            Lat-long radiance, linear RGB, row 0 at +y (``EnvironmentMap.radiance``);
            real numbers, >= 0 and finite when rounded to float32. The device
            copy of a read-only array (:func:`frozen`) is kept for the next
            calls (module docstring).
        layout_shape : tuple (h, w), optional
            The map's ``grid_shape``; checked against ``env_radiance``.
        sampling : pyshadow.Sampling
        bias, indices, surface_ids : optional
            As in :meth:`ambient_occlusion`.

        Returns
        -------
        sky : ndarray, shape (N, 3), float32
            Sum of the texel radiance over the unoccluded directions / S.
        ao : ndarray, shape (N,), float32
        bent : ndarray, shape (N, 3), float32
            Both bit-identical to :meth:`ambient_occlusion`'s.
        """
        from .base import check_sampling

        check_sampling(sampling)
        env = np.asarray(env_radiance)
        if env.ndim != 3 or env.shape[2] != 3 or env.shape[0] < 1 or env.shape[1] < 1:
            raise ValueError(f"env_radiance must be a lat-long map of shape (h, w, 3), got {env.shape}")
        if env.dtype.kind not in "iuf":     # complex lost its imaginary part, bools and digit strings passed
            raise TypeError(f"env_radiance must hold real numbers, got dtype {env.dtype}")
        if layout_shape is not None:
            try:
                shape = tuple(layout_shape)
            except TypeError:               # (an int: "'int' object is not iterable", not naming it)
                shape = None
            if shape != env.shape[:2]:
                raise ValueError(f"layout_shape {layout_shape!r} does not match env_radiance {env.shape}")
        sky_env = [_device_map(env), np.int32(env.shape[0]), np.int32(env.shape[1])]
        return self._ao(scene, points, normals, sampling, True, False, bias, indices, surface_ids, sky_env=sky_env)

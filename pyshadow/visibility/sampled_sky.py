"""The "sampled" sky on the AO kernel: a part of :class:`pyshadow.visibility.csm.CSMVisibility`.

Stage "visibility kernel": the AO kernel compiled with ``SKY_SAMPLED=1``
also sums a lat-long map's radiance over each point's open directions.
"""
from __future__ import annotations

import numpy as np

from .. import _cl


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
            real numbers, >= 0 and finite when rounded to float32.
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
        from ..sampling import Sampling

        if not isinstance(sampling, Sampling):
            raise TypeError(f"sampling must be a pyshadow.Sampling, got {sampling!r}")
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
        with np.errstate(over="ignore"):    # beyond float32: inf, refused below by name
            env = np.ascontiguousarray(env, np.float32)
        if not np.all(np.isfinite(env)):
            raise ValueError("env_radiance must be finite (in float32)")
        if (env < 0).any():                 # a sky of negative radiance is no sky (EnvironmentMap refuses it)
            raise ValueError(f"env_radiance must be >= 0, got {int((env < 0).any(axis=2).sum())} texels below 0 "
                             f"(least {float(env.min())})")
        sky_env = [_cl.to_device(env), np.int32(env.shape[0]), np.int32(env.shape[1])]
        return self._ao(scene, points, normals, sampling, True, False, bias, indices, surface_ids, sky_env=sky_env)

"""NumPy references of :mod:`pyshadow.lighting.shadow_map`'s orthographic map (float64; small inputs, for the
tests): :func:`render_reference` mirrors ``sm_raster``, :func:`lookup_reference` ``sm_lookup``. Importable
from :mod:`pyshadow.lighting.shadow_map` as before."""
from __future__ import annotations

import math

import numpy as np

from ..scene_arrays import scene_arrays
from .shadow_map import BIAS_TEXELS, NO_NORMAL_SLOPE, TAN_MAX, ShadowMap, _check_pcf, _check_resolution, _ortho_frame

__all__ = ["render_reference", "lookup_reference"]


def render_reference(scene, direction, resolution: int) -> np.ndarray:
    """The orthographic depth map of ``sm_raster`` in NumPy: (R, R) float64 (+inf where no caster).

    Same frame, texel centres and watertight edge rule
    (:func:`pyshadow.raster.covered_samples`); depth interpolated linearly
    over each triangle and clamped at 0; the nearest depth per texel kept.
    """
    from ..raster import covered_samples

    R = _check_resolution(resolution)
    direction = np.asarray(direction, np.float64) / np.linalg.norm(direction)
    casters = np.flatnonzero(scene_arrays(scene)["casts"])
    A, b, origin, _, _ = _ortho_frame(scene, casters, direction, R)
    out = np.full((R, R), np.inf)
    for i in casters:
        inst = scene.instances[i]
        T = inst.transform
        world = np.asarray(inst.mesh.vertices, np.float64) @ T[:3, :3].T + T[:3, 3]
        q = (world - origin) @ A.T + b
        for f in np.asarray(inst.mesh.faces):
            s = q[f, :2]
            lo = np.maximum(np.ceil(s.min(axis=0)).astype(int), 0)
            hi = np.minimum(np.floor(s.max(axis=0)).astype(int), R - 1)
            if (lo > hi).any():
                continue
            cov = covered_samples(s[0], s[1], s[2], lo, hi)
            if cov is not None:
                rows, cols, w = cov
                np.minimum.at(out, (rows, cols), np.maximum(w.T @ q[f, 2], 0.0))
    return out


def lookup_reference(sm: ShadowMap, depth, points, normals=None, *, pcf: int = 1, bias: float = 0.0,
                     bias_texels: float = BIAS_TEXELS) -> np.ndarray:
    """``sm_lookup`` of an orthographic map in NumPy (float64): the lit fraction of the PCF taps, (N,).

    Parameters
    ----------
    sm : ShadowMap
        An orthographic map (its float32 frame, read as float64).
    depth : ndarray, shape (R, R)
        Its depths (:meth:`ShadowMap.depth` or :func:`render_reference`).
    points, normals : ndarray, shape (N, 3)
        World points and unit normals (None: the rule without normals).
    pcf, bias, bias_texels :
        As for :class:`ShadowMapVisibility`. The ground plane is not applied.
    """
    if sm.kind != "directional":
        raise ValueError("lookup_reference mirrors the orthographic map only")
    f = sm.frame.astype(np.float64)
    U, V, D, tu, tv = f[0:3], f[4:7], f[8:11], f[12], f[13]
    p = np.asarray(points, np.float64) - sm.origin
    col, row, z = p @ U + f[3], p @ V + f[7], p @ D + f[11]
    h = _check_pcf(pcf) // 2
    texels = bias_texels + (0.0 if normals is not None else NO_NORMAL_SLOPE * (h + math.sqrt(0.5)))
    eps = bias + texels * max(tu, tv)
    if normals is not None:
        n = np.asarray(normals, np.float64)
        nu, nv, nd = (n @ U) * tu, (n @ V) * tv, n @ D
    R = depth.shape[0]
    lit = np.zeros(len(p))
    for di in range(-h, h + 1):
        for dj in range(-h, h + 1):
            tj, ti = np.floor(col + 0.5).astype(np.int64) + dj, np.floor(row + 0.5).astype(np.int64) + di
            du, dv = (tj - col) * tu, (ti - row) * tv
            zr = z
            if normals is not None:
                lim = TAN_MAX * (np.abs(du) + np.abs(dv))
                with np.errstate(divide="ignore", invalid="ignore"):
                    shift = np.clip(-(nu * du + nv * dv) / nd, -lim, lim)
                zr = np.where(nd < 0, z + shift, z)
            inside = (tj >= 0) & (tj < R) & (ti >= 0) & (ti < R)
            stored = np.where(inside, depth[np.clip(ti, 0, R - 1), np.clip(tj, 0, R - 1)], np.inf)
            lit += ~inside | (zr - eps <= stored)
    return lit / (2 * h + 1) ** 2

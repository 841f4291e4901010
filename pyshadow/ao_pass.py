"""Which pixels the reduced-resolution AO pass of :func:`pyshadow.render.render` computes (``ao_scale`` > 1).

The AO image of ``ao_scale`` = s is computed at every s-th pixel of every s-th row and upsampled with the
full-resolution G-buffer (:func:`pyshadow.filters.upsample`). Upsampling can only give a pixel the AO of
the low-res samples in its window; where none of them lies on the pixel's own surface it gives another
surface's AO (or ``fill``). Such pixels get their own AO instead (:func:`ao_pass`).
"""
from __future__ import annotations

import numpy as np

from .filters import SIGMA_DEPTH as _SIGMA_DEPTH, SIGMA_NORMAL as _SIGMA_NORMAL     # upsample's, render's

__all__ = ["ao_pass", "ON_SURFACE_WEIGHT"]

#: A low-res sample lies on a pixel's own surface when it is of the same instance and its range weight in
#: :func:`pyshadow.filters.upsample` (depth and normal terms, the filter's default sigmas) is at least this,
#: 27 times a sample's at a right angle (3.7e-6): normals up to 82 degrees apart at the same depth, or the
#: same normal at a relative depth difference up to 8.6 %. A sample on the face of a box at a right angle to
#: the pixel's, or on the far part of a face seen edge-on, is not.
ON_SURFACE_WEIGHT = 1e-4
_LIMIT = -2.0 * float(np.log(ON_SURFACE_WEIGHT))      # the weight's exponent at that weight, times -2


def _on_surface(obj_p, z_p, n_p, obj_q, z_q, n_q) -> np.ndarray:
    """Whether samples ``q`` lie on the surface of pixels ``p`` (ids, depths, (K, 3) normals): the same
    instance and an upsampling range weight of at least :data:`ON_SURFACE_WEIGHT` (its exponent compared)."""
    with np.errstate(invalid="ignore", over="ignore"):
        dz = (z_q - z_p) / (_SIGMA_DEPTH * z_p)             # inf - inf: NaN on the background, False below
        dn = np.maximum(0.0, 1.0 - (n_p[:, 0] * n_q[:, 0] + n_p[:, 1] * n_q[:, 1] + n_p[:, 2] * n_q[:, 2]))
        return (obj_q == obj_p) & (dz * dz + (dn / _SIGMA_NORMAL) ** 2 <= _LIMIT)


def ao_pass(obj, depth, normal, scale: int, radius: int) -> np.ndarray:
    """(H, W) bool: the pixels :func:`pyshadow.render.render` computes AO at for ``ao_scale=scale``.

    Every ``scale``-th covered pixel of every ``scale``-th row (the low-res samples of
    :func:`pyshadow.filters.upsample`), and every covered pixel whose upsampling window (``radius``
    low-res samples per side) holds no sample on its own surface (the same instance, with normal and
    depth close to its own: :data:`ON_SURFACE_WEIGHT`), which upsampling would give its ``fill``
    value (no covered sample), another instance's AO (a thin pole before the ground) or another
    face's (the top of a box seen edge-on, a one-pixel band over its front).

    Parameters
    ----------
    obj : ndarray, shape (H, W), int32
        Instance ids, -1 on the background.
    depth : ndarray, shape (H, W), float
        Distance along each pixel's ray (world units), ``inf`` on the background.
    normal : ndarray, shape (H, W, 3), float
        Unit world normals (the ones the upsampling reads).
    scale : {2, 4}
    radius : int
        Low-res samples per side of the upsampling window.

    Returns
    -------
    ndarray, shape (H, W), bool
        True at the pixels whose AO the pass computes (never on the background).
    """
    (H, W), R = obj.shape, radius
    lo = (obj[::scale, ::scale], np.asarray(depth[::scale, ::scale], np.float32),
          np.asarray(normal[::scale, ::scale], np.float32))
    block = [np.repeat(np.repeat(a, scale, 0), scale, 1)[:H, :W] for a in lo]   # each pixel's block's sample
    z, n = np.asarray(depth, np.float32), np.asarray(normal, np.float32)
    with np.errstate(invalid="ignore", over="ignore"):      # whole images (float32): most pixels are on it
        dz = (block[1] - z) / (np.float32(_SIGMA_DEPTH) * z)
        dn = 1.0 - (n[..., 0] * block[2][..., 0] + n[..., 1] * block[2][..., 1] + n[..., 2] * block[2][..., 2])
        near = (obj == block[0]) & (dz * dz + np.square(np.maximum(dn, 0) / np.float32(_SIGMA_NORMAL)) <= _LIMIT)
    r, c = np.nonzero((obj != -1) & ~near)
    v, zp, nq = obj[r, c], z[r, c], n[r, c]
    pad = [np.pad(lo[0], R, constant_values=-1), np.pad(lo[1], R, constant_values=np.inf),
           np.pad(lo[2], ((R, R), (R, R), (0, 0)))]          # no sample beyond the border
    lonely = np.ones(len(r), bool)
    for di in range(1 - R, R + 1):
        for dj in range(1 - R, R + 1):
            i, j = r // scale + R + di, c // scale + R + dj
            lonely &= ~_on_surface(v, zp, nq, pad[0][i, j], pad[1][i, j], pad[2][i, j])
    keep = np.zeros((H, W), bool)
    keep[r[lonely], c[lonely]] = keep[::scale, ::scale] = True
    return keep & (obj != -1)

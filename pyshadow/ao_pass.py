"""Which pixels the reduced-resolution AO pass of :func:`pyshadow.render.render` computes (``ao_scale`` > 1).

The AO image of ``ao_scale`` = s is computed at every s-th pixel of every s-th row and upsampled with the
full-resolution G-buffer (:func:`pyshadow.filters.upsample`). Upsampling can only give a pixel the AO of
the low-res samples in its window; where none of them lies on the pixel's own surface, or another surface's
samples outweigh them, it gives (mostly) another surface's AO (or ``fill``). Such pixels get their own AO
instead (:func:`ao_pass`).
"""
from __future__ import annotations

import numpy as np

from .filters import SIGMA_DEPTH as _SIGMA_DEPTH, SIGMA_NORMAL as _SIGMA_NORMAL     # upsample's, render's

__all__ = ["ao_pass", "ON_SURFACE_WEIGHT", "OWN_SHARE"]

#: A low-res sample lies on a pixel's own surface when it is of the same instance and its weight in
#: :func:`pyshadow.filters.upsample` (spatial, depth and normal terms, the filter's default sigmas) is at least
#: this, 27 times a sample's at a right angle (3.7e-6) at the pixel itself: for a sample next to the pixel,
#: normals up to 82 degrees apart at the same depth, or the same normal at a relative depth difference up to
#: 8.6 %. A sample on the face of a box at a right angle to the pixel's, on the far part of a face seen
#: edge-on, or so far across the window that upsampling falls back to another tap (a total weight below
#: ``UPSAMPLE_MIN_WEIGHT``, 1e-6), is not.
ON_SURFACE_WEIGHT = 1e-4
#: A pixel's samples on its own surface must carry at least this share of its upsampling weight, so that
#: another surface's AO moves it by at most a quarter of the two's difference (a thin pipe along a wall, at
#: the wall's depth and normal, took up to 98 % of the wall's AO).
OWN_SHARE = 0.75
_LIMIT = -2.0 * float(np.log(ON_SURFACE_WEIGHT))      # the weight's exponent at that weight, times -2
_CHUNK = 1 << 15                                        # pixels whose windows are weighed at once


def _tap(obj_p, z_p, n_p, obj_q, z_q, n_q, spatial):
    """Samples ``q``'s weights in the upsampling of pixels ``p`` (ids, depths, (K, 3) normals; ``spatial`` the
    squared pixel distance over the spatial sigma squared), float32, at least exp(-80) (so never subnormal;
    the background too), and whether they lie on the pixels' surface: the same instance and a weight of at least
    :data:`ON_SURFACE_WEIGHT`."""
    with np.errstate(invalid="ignore", over="ignore"):
        dz = (z_q - z_p) / (_SIGMA_DEPTH * z_p)             # inf on the background: not on it
        dn = np.maximum(0.0, 1.0 - (n_p[..., 0] * n_q[..., 0] + n_p[..., 1] * n_q[..., 1]
                                    + n_p[..., 2] * n_q[..., 2]))
        e = spatial + dz * dz + np.square(dn / np.float32(_SIGMA_NORMAL))
        return np.exp(np.float32(-0.5) * np.minimum(e, np.float32(160.0))), (obj_q == obj_p) & (e <= _LIMIT)


def _window_ids(lo_obj, R):
    """(Hl, Wl) least and greatest instance ids among the covered samples of each low-res sample's upsampling
    window (rows ``i - R + 1 .. i + R``, likewise columns), the background left out."""
    Hl, Wl = lo_obj.shape
    out = []
    for fill, pick in ((np.iinfo(np.int32).max, np.minimum), (np.iinfo(np.int32).min, np.maximum)):
        a = np.pad(np.where(lo_obj == -1, fill, lo_obj), R, constant_values=fill)[1:, 1:]
        rows = a[:Hl]
        for k in range(1, 2 * R):
            rows = pick(rows, a[k:k + Hl])
        m = rows[:, :Wl]
        for k in range(1, 2 * R):
            m = pick(m, rows[:, k:k + Wl])
        out.append(m)
    return out


def ao_pass(obj, depth, normal, scale: int, radius: int) -> np.ndarray:
    """(H, W) bool: the pixels :func:`pyshadow.render.render` computes AO at for ``ao_scale=scale``.

    Every ``scale``-th covered pixel of every ``scale``-th row (the low-res samples of
    :func:`pyshadow.filters.upsample`), and every other covered pixel whose upsampled AO would not come
    mostly from its own surface. A pixel whose block's sample lies on its own surface (the same instance,
    with normal and depth close to its own and near enough to weigh in: :data:`ON_SURFACE_WEIGHT`) and
    whose window (``radius`` low-res samples per side) holds no other instance's sample within 25 % of
    that sample's depth is left out; any other is in the pass when its window's samples on its own surface
    carry less than :data:`OWN_SHARE` of its upsampling weight: none at all, which upsampling would give
    its ``fill`` value (no covered sample), another instance's AO (a thin pole before the ground) or
    another face's (the top of a box seen edge-on, a one-pixel band over its front; the underside of a
    thin rod whose only like sample lies across the window), or too few (a pipe along a wall).

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
    # upsample's spatial term, (distance / sigma)^2 with sigma = scale / 2 pixels: of each pixel to its block's
    # sample, and (below) to the window's samples; the window's far samples weigh as little as exp(-16)
    off = np.square(np.arange(max(H, W)) % scale).astype(np.float32) * np.float32(4.0 / scale ** 2)
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):    # whole images (float32); a background
        # pixel's depth may be 0 (a G-buffer given to render: only the covered pixels' are checked)
        dz = (block[1] - z) / (np.float32(_SIGMA_DEPTH) * z)
        dn = 1.0 - (n[..., 0] * block[2][..., 0] + n[..., 1] * block[2][..., 1] + n[..., 2] * block[2][..., 2])
        near = (obj == block[0]) & (dz * dz + np.square(np.maximum(dn, 0) / np.float32(_SIGMA_NORMAL))
                                    <= (np.float32(_LIMIT) - off[:H, None]) - off[None, :W])
    pad = [np.pad(lo[0], R, constant_values=-1), np.pad(lo[1], R, constant_values=np.inf),
           np.pad(lo[2], ((R, R), (R, R), (0, 0)))]          # no sample beyond the border
    taps = np.arange(1 - R, R + 1)
    # where the window holds samples of one instance, it is the pixel's own (near: its block's sample is of it);
    # where it holds another's, those may outweigh the pixel's own samples (a pipe along a wall), unless they
    # lie 25 % or more off the block's sample's depth (then < 1.4e-11 each for a pixel near that sample)
    Wp = pad[0].shape[1]
    pad = [pad[0].reshape(-1), pad[1].reshape(-1)] + [pad[2][..., k].reshape(-1) for k in range(3)]
    lo_min, lo_max = _window_ids(lo[0], R)
    one = ~(lo_min < lo_max)
    b = np.flatnonzero(~one & (lo[0] != -1))                 # (a background block sample: no pixel is near it)
    bi, bj = np.divmod(b, one.shape[1])
    k = (bi[:, None, None] + R + taps[:, None]) * Wp + (bj[:, None, None] + R + taps)
    oq, ob, zb = np.take(pad[0], k), lo[0].reshape(-1)[b, None, None], lo[1].reshape(-1)[b, None, None]
    with np.errstate(invalid="ignore"):
        close = (oq != ob) & (oq != -1) & (np.abs(np.take(pad[1], k) - zb) < 0.25 * zb)
    one.reshape(-1)[b] = ~close.any(axis=(1, 2))
    one = np.repeat(np.repeat(one, scale, 0), scale, 1)[:H, :W]
    r, c = np.nonzero((obj != -1) & ~(near & one))
    lonely = np.empty(len(r), bool)
    sq = np.square(scale * taps - np.arange(scale)[:, None]).astype(np.float32) * np.float32(4.0 / scale ** 2)
    at = taps[:, None] * Wp + taps                            # a window's taps, from its centre's (flat)
    for a in range(0, len(r), _CHUNK):                        # (pixels, 2R, 2R) taps at a time
        rr, cc = r[a:a + _CHUNK], c[a:a + _CHUNK]
        spatial = sq[rr % scale][:, :, None] + sq[cc % scale][:, None, :]   # pixel to tap, (distance / sigma)^2
        q = [np.take(x, ((rr // scale + R) * Wp + cc // scale + R)[:, None, None] + at) for x in pad]
        w, on = _tap(obj[rr, cc, None, None], z[rr, cc, None, None], n[rr, cc, None, None], q[0], q[1],
                     np.stack(q[2:], axis=-1), spatial)
        own = np.where(on, w, 0.0).sum(axis=(1, 2))
        lonely[a:a + _CHUNK] = ~((own > 0) & (own >= OWN_SHARE * w.sum(axis=(1, 2))))
    keep = np.zeros((H, W), bool)
    keep[r[lonely], c[lonely]] = keep[::scale, ::scale] = True
    return keep & (obj != -1)

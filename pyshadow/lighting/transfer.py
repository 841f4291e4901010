"""The shadowed spherical-harmonic transfer of surface points (the "transfer" shading mode).

For a point with normal ``n`` and visibility ``V``, the transfer vector is
``T_k = integral V(w) Y_k(w) max(n . w, 0) dOmega`` (k = 0 .. 8, the basis
of :mod:`pyshadow.lighting.sh`); under a sky with SH coefficients ``L_k``
(:meth:`EnvironmentMap.sh`) the shadowed irradiance is ``E = sum_k L_k T_k``
per colour channel -- other bodies shadow the sky, where the "bent" mode
only turns the unshadowed irradiance towards the bent normal. Without
occluders ``T_k = A_l Y_k(n)`` and ``E`` is
:func:`pyshadow.lighting.irradiance_sh`.

It is estimated from the AO's own cosine-weighted directions (pdf
``cos / pi``): ``T_k = pi / S * sum over the unoccluded w_s of Y_k(w_s)``,
9 sums beside the AO's one. The CSM backends accumulate them inside the AO
kernel (``CSMVisibility.sh_transfer``); any other backend (the NumPy mirror,
Embree) through :func:`pyshadow.visibility.visible` on the same directions
(:func:`pyshadow.sample_directions`) and the same sums in float64.
"""
from __future__ import annotations

import math

import numpy as np

from ._checks import _floats
from .sh import SH_COUNT, sh_basis

__all__ = ["sh_transfer", "transfer_irradiance"]


def sh_transfer(scene, points, normals, *, backend="csm", sampling=None, surface_ids=None, indices=None,
                bias=None, geometric_normals=None):
    """AO, bent normals and the shadowed SH transfer of surface points.

    Parameters
    ----------
    scene : pyshadow.Scene
    points, normals : array_like, shape (N, 3)
        World positions and unit surface normals (world frame).
    backend : str or VisibilityBackend, optional
        A backend with ``sh_transfer`` (the CSM kernels) answers in one pass;
        any other through ``visible`` on the AO directions, in chunks of
        :data:`pyshadow.lighting.shade.SAMPLED_CHUNK_RAYS` rays.
    sampling : pyshadow.Sampling, optional
        Default ``Sampling()``.
    surface_ids, indices, bias : optional
        As in :func:`pyshadow.visibility.ambient_occlusion`.
    geometric_normals : array_like, shape (N, 3), optional
        Unit geometric normals when ``normals`` are shading normals: the
        hemisphere rule of :mod:`pyshadow.shading_normals` (directions at or
        below the geometric plane are occluded) applies, through ``visible``
        on every backend. Finite and non-zero, one row a point (as
        :func:`pyshadow.shading_normals.ambient_occlusion` checks them).

    Returns
    -------
    ao : ndarray, shape (N,), float32
    bent : ndarray, shape (N, 3), float32
    transfer : ndarray, shape (N, 9), float32
        ``T_k``, steradians: a sky of constant radiance ``c`` (``L_0 = 4 pi
        Y_0 c``, the others 0) gives ``E = pi c AO``.
    """
    from .. import visibility as vis
    from .._validate import check_indices, check_rows, check_values, rows3, unit_normals
    from ..sampling import Sampling, ao_from_samples

    if sampling is None:
        sampling = Sampling()
    elif not isinstance(sampling, Sampling):
        raise TypeError(f"sampling must be a pyshadow.Sampling, got {sampling!r}")
    p = rows3(points, "points")
    n = unit_normals(normals, len(p))
    idx = check_indices(indices, len(p))
    if geometric_normals is not None:       # NaN or zero rows put no direction below the plane: no rule at all
        geometric_normals = check_rows(geometric_normals, "geometric_normals", len(p))
        check_values(geometric_normals, "geometric_normals", nonzero=True)
    b = vis.get_backend(backend)
    if hasattr(b, "sh_transfer") and geometric_normals is None:
        return b.sh_transfer(scene, p, n, sampling=sampling, bias=bias, indices=idx, surface_ids=surface_ids)
    from .shade import SAMPLED_CHUNK_RAYS

    N, S = len(p), sampling.samples
    ids = _surface_ids(surface_ids, N)
    ao, bent, transfer = np.ones(N, np.float32), np.zeros((N, 3), np.float32), np.zeros((N, SH_COUNT), np.float32)
    step = max(1, SAMPLED_CHUNK_RAYS // S)      # points in chunks of rays, as the "sampled" sky: all N S rays at
    for a in range(0, N, step):                 # once took 190 bytes a ray (25 GB: a 1080p frame at 64 samples)
        c = slice(a, min(N, a + step))
        dirs, lit = sample_visibility(scene, p[c], n[c], backend=b, sampling=sampling, indices=idx[c],
                                      surface_ids=ids if np.ndim(ids) == 0 else ids[c], bias=bias,
                                      geometric_normals=None if geometric_normals is None else geometric_normals[c])
        Y = sh_basis(dirs.astype(np.float64))                                    # (m, S, 9)
        transfer[c] = (math.pi / S) * np.einsum("ns,nsk->nk", lit.astype(np.float64), Y)
        ao[c], bent[c] = ao_from_samples(dirs, lit, n[c].astype(np.float32), return_bent_normals=True)
    return ao, bent, transfer


def sample_visibility(scene, points, normals, *, backend, sampling, indices, surface_ids=None, bias=None,
                      geometric_normals=None):
    """The AO directions of each point and whether each reaches the sky, through ``visible``.

    ``dirs`` (N, S, 3) float32 are :func:`pyshadow.sample_directions`' (those the
    AO kernel traces) and ``lit`` (N, S) bool their visibility, asked with the
    points' unit ``normals`` (the surface rule) and ``surface_ids`` (int or (N,)).
    With ``geometric_normals`` (N, 3), directions at or below the geometric
    plane are not lit and not traced (:func:`pyshadow.shading_normals.below_geometric`).
    """
    from .. import visibility as vis
    from ..sampling import sample_directions

    p = np.asarray(points, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    S = sampling.samples
    dirs = sample_directions(n, sampling=sampling, indices=indices)
    ids = _surface_ids(surface_ids, len(p))
    ids = None if ids is None else np.repeat(np.broadcast_to(ids, (len(p),)), S)
    if geometric_normals is None:
        lit = vis.visible(scene, np.repeat(p, S, axis=0), dirs.reshape(-1, 3), backend=backend, bias=bias,
                          surface_ids=ids, normals=np.repeat(n, S, axis=0)).reshape(len(p), S)
        return dirs, lit
    from ..shading_normals import below_geometric

    up = np.flatnonzero(~below_geometric(dirs, geometric_normals).reshape(-1))
    lit = np.zeros(len(p) * S, bool)
    lit[up] = vis.visible(scene, np.repeat(p, S, axis=0)[up], dirs.reshape(-1, 3)[up], backend=backend, bias=bias,
                          surface_ids=None if ids is None else ids[up], normals=np.repeat(n, S, axis=0)[up])
    return dirs, lit.reshape(len(p), S)


def _surface_ids(surface_ids, n: int):
    """``surface_ids`` as an array of shape () or (n,) (one of shape (1,) as ()), or None; ValueError
    for any other shape, as the CSM backends say."""
    if surface_ids is None:
        return None
    if np.shape(surface_ids) not in ((), (1,), (n,)):
        raise ValueError(f"surface_ids must be one id or {n} (one a query), got shape {np.shape(surface_ids)}")
    ids = np.asarray(surface_ids)
    return ids.reshape(()) if ids.shape == (1,) and n != 1 else ids


def transfer_irradiance(coefficients, transfer) -> np.ndarray:
    """Shadowed irradiance ``E = sum_k L_k T_k`` per channel, (N, 3) float64.

    Parameters
    ----------
    coefficients : array_like, shape (9, 3)
        The sky's SH coefficients ``L_k`` (radiance units).
    transfer : array_like, shape (N, 9)
        :func:`sh_transfer`'s ``T_k``.
    """
    L = _floats(coefficients, "coefficients", "SH coefficients of shape (9, 3)")
    T = _floats(transfer, "transfer", "transfer vectors of shape (N, 9)")
    if L.shape != (SH_COUNT, 3) or T.ndim != 2 or T.shape[1] != SH_COUNT:
        raise ValueError(f"transfer_irradiance: coefficients (9, 3) and transfer (N, 9) expected "
                         f"(got {L.shape} and {T.shape})")
    with np.errstate(over="ignore", invalid="ignore"):
        E = T @ L
    if E.size and not -math.inf < E.min() <= E.max() < math.inf:    # NaN or inf in, or beyond float64: named
        what = "coefficients" if not np.isfinite(L).all() else "transfer" if not np.isfinite(T).all() else "E"
        raise ValueError(f"transfer_irradiance: {what} not finite (E overflows float64 or the input holds NaN/inf)")
    return E

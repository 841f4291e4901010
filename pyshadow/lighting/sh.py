"""Real spherical harmonics of order 3 (bands 0-2) in pyshadow's y-up frame.

Frame and basis
---------------
pyshadow is right-handed with y up; a direction with polar angle ``theta``
(from +y) and azimuth ``phi`` (from +x towards +z) is
``d(theta, phi) = (sin theta cos phi, cos theta, sin theta sin phi)``, and back:
``theta = arccos(y)``, ``phi = atan2(z, x)`` (never ``arctan(x / y)``).

The basis is the textbook real SH *without* the Condon-Shortley phase, written
in (theta, phi) above, i.e. with the polar axis on +y. Index
``k = l (l + 1) + m``::

    k  (l, m)   Y_k(x, y, z) for a unit direction
    0  (0,  0)  0.282095
    1  (1, -1)  0.488603 z
    2  (1,  0)  0.488603 y
    3  (1,  1)  0.488603 x
    4  (2, -2)  1.092548 x z
    5  (2, -1)  1.092548 y z
    6  (2,  0)  0.315392 (3 y^2 - 1)
    7  (2,  1)  1.092548 x y
    8  (2,  2)  0.546274 (x^2 - z^2)

Against ``scipy.special.sph_harm_y(l, m, theta, phi)`` (complex, with the
Condon-Shortley phase): ``Y_k = sqrt(2) (-1)^m Re Y_l^m`` for m > 0,
``sqrt(2) (-1)^m Im Y_l^|m|`` for m < 0, ``Y_l^0`` for m = 0; the tests pin
this to 1e-12. These are the signs the Ramamoorthi-Hanrahan constants assume
(thesis 001, eq. 2.20, carries the phase and gets Y_{1,+-1}, Y_{2,+-1} negated;
it also puts the polar axis on z: its (x, y, z) is our (x, z, y)).

Irradiance
----------
``E(n) = sum_k A_l L_k Y_k(n)`` with ``A_0 = pi``, ``A_1 = 2 pi / 3``,
``A_2 = pi / 4`` (the clamped-cosine kernel's bands; Ramamoorthi and Hanrahan
2001, eq. 13 is the same quadratic form with c1 .. c5, see
:data:`RH_CONSTANTS`). ``L_k = integral L(d) Y_k(d) dOmega`` over the sphere.
"""
from __future__ import annotations

import math

import numpy as np

from .._validate import check_int
from ._checks import _floats, bounded_sh, unit_rows

__all__ = ["SH_COUNT", "BAND_OF", "KERNEL_BANDS", "RH_CONSTANTS", "sh_basis", "irradiance_sh",
           "latlong_basis_integrals"]

#: Number of coefficients of order 3 (bands l = 0, 1, 2).
SH_COUNT = 9
#: Band l of each coefficient index k.
BAND_OF = np.array([0, 1, 1, 1, 2, 2, 2, 2, 2])
#: Clamped-cosine kernel per band: A_0 = pi, A_1 = 2 pi / 3, A_2 = pi / 4.
KERNEL_BANDS = np.array([math.pi, 2.0 * math.pi / 3.0, math.pi / 4.0])
#: Ramamoorthi-Hanrahan's c1 .. c5 (6 digits, as published); kept for the tests that
#: check the A_l form against their quadratic form.
RH_CONSTANTS = (0.429043, 0.511664, 0.743125, 0.886227, 0.247708)

_C00 = 0.5 / math.sqrt(math.pi)                  # 0.282095
_C1 = math.sqrt(3.0 / (4.0 * math.pi))           # 0.488603
_C2 = math.sqrt(15.0 / (4.0 * math.pi))          # 1.092548
_C20 = math.sqrt(5.0 / (16.0 * math.pi))         # 0.315392
_C22 = math.sqrt(15.0 / (16.0 * math.pi))        # 0.546274


def sh_basis(directions) -> np.ndarray:
    """The 9 basis functions at unit directions.

    Parameters
    ----------
    directions : array_like, shape (..., 3), float
        Unit vectors in pyshadow's frame (y up). Not renormalised: a non-unit
        vector gives the polynomial's value there.

    Returns
    -------
    Y : ndarray, shape (..., 9), float64
        ``Y[..., k]``, k = l (l + 1) + m, as in the module docstring.
    """
    d = _floats(directions, "sh_basis: directions", "finite numbers of shape (..., 3)")
    if d.ndim == 0 or d.shape[-1] != 3 or (d.size and not -1e150 <= d.min() <= d.max() <= 1e150):  # NaN, inf, overflow
        raise ValueError(f"sh_basis: directions must be finite, shape (..., 3), got shape {d.shape}"
                         f"{'' if d.ndim == 0 or d.shape[-1] != 3 else ' (and |x| <= 1e150)'}")
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([np.full_like(x, _C00), _C1 * z, _C1 * y, _C1 * x,
                     _C2 * x * z, _C2 * y * z, _C20 * (3.0 * y * y - 1.0), _C2 * x * y,
                     _C22 * (x * x - z * z)], axis=-1)


def irradiance_sh(coefficients, normals) -> np.ndarray:
    """Irradiance from 9 SH coefficients of radiance, at unit normals.

    Parameters
    ----------
    coefficients : array_like, shape (9, C), float
        ``L_k`` per channel (C = 3 for RGB), e.g. from
        :meth:`~pyshadow.lighting.EnvironmentMap.sh`; finite.
    normals : array_like, shape (N, 3) or (3,), float
        Unit normals, y up: finite, length 1 +- 1e-6 (as
        :meth:`~pyshadow.lighting.EnvironmentMap.irradiance`). Not
        renormalised: the result is the quadratic form's value at the
        normals given.

    Returns
    -------
    E : ndarray, shape (N, C) or (C,), float64
        ``E(n) = sum_k A_l L_k Y_k(n)``: the cosine-weighted integral of the
        radiance over the hemisphere around n, in radiance units times sr
        (lux for luminance in cd/m^2). May be slightly negative where the
        order-3 truncation rings (a strong lobe opposite n).

    Raises
    ------
    ValueError
        ``coefficients`` not of shape (9, C) or not finite; ``normals`` not
        of shape (N, 3) or (3,), not finite, zero or not of unit length (the
        quadratic form grows with the square of the length: a normal of
        length 5 would give some 25 times the irradiance).
    TypeError
        Either array does not hold real numbers (bools included: True was
        read as a coefficient of 1).
    """
    L = _array(coefficients, "coefficients")
    if L.dtype.kind not in "iuf":
        raise TypeError(f"coefficients: expected real numbers (got dtype {L.dtype})")
    L = L.astype(np.float64, copy=False)
    if L.ndim != 2 or L.shape[0] != SH_COUNT:
        raise ValueError(f"coefficients must have shape (9, C) (got shape {L.shape})")
    if not np.isfinite(L).all():
        bad = np.argwhere(~np.isfinite(L))[0]
        raise ValueError(f"coefficients: {int((~np.isfinite(L)).sum())} entries are not finite "
                         f"(first L[{bad[0]}, {bad[1]}] = {float(L[tuple(bad)])})")
    bounded_sh(L, "coefficients")
    n = _array(normals, "normals")
    if n.dtype.kind not in "iuf":
        raise TypeError(f"normals: expected real numbers (got dtype {n.dtype})")
    rows = unit_rows(n, "normals")
    return _irradiance(L, rows if n.ndim == 2 else rows[0])


def _array(x, name: str) -> np.ndarray:
    """``np.asarray(x)``; ValueError naming ``name`` for a ragged sequence (NumPy's names nothing)."""
    try:
        return np.asarray(x)
    except ValueError:
        raise ValueError(f"{name}: expected real numbers in rows of equal length (got a ragged sequence)") from None


def _sh_of_moments(m0, m1, m2) -> np.ndarray:
    """``integral Y_k dOmega`` from the moments of the direction over a region (the basis of :func:`sh_basis`).

    ``m0`` (C,) ``integral dOmega``, ``m1`` (3, C) ``integral d``, ``m2`` (3, 3, C)
    ``integral d d^T`` (world frame, any trailing axis C, e.g. radiance-weighted
    per channel); returns (9, C). Exact for any region: every Y_k is a
    polynomial of degree <= 2 of the unit direction (``3 y^2 - 1`` is
    ``3 y^2 - |d|^2`` on the sphere).
    """
    return np.stack([_C00 * m0, _C1 * m1[2], _C1 * m1[1], _C1 * m1[0], _C2 * m2[0, 2], _C2 * m2[1, 2],
                     _C20 * (3.0 * m2[1, 1] - m0), _C2 * m2[0, 1], _C22 * (m2[0, 0] - m2[2, 2])])


def _irradiance(L, normals) -> np.ndarray:
    """:func:`irradiance_sh` unchecked: ``L`` (9, C) float64, any normals (zero rows give band 0,
    ``pi Y_0 L_0``: the quadratic form there also holds ``-A_2 0.315392 L_6``, as ``Y_6(0) = -0.315392``)."""
    E = sh_basis(normals) @ (KERNEL_BANDS[BAND_OF][:, None] * L)
    n = np.asarray(normals)
    zero = (n[..., 0] == 0) & (n[..., 1] == 0) & (n[..., 2] == 0)       # 5 ms on 2e6 rows (any(axis=-1): 28)
    if np.any(zero):
        E[zero] = KERNEL_BANDS[0] * _C00 * L[0]
    return E


def latlong_basis_integrals(height: int, width: int):
    """Exact integrals of the 9 basis functions over the texels of a lat-long map.

    Every basis function is a product f(theta) g(phi), so the integral over the
    texel of row i, column j is ``T[i, k] * P[j, k]``, integrated in closed form
    (``dOmega = d(cos theta) d(phi)``).

    Parameters
    ----------
    height, width : int
        Rows and columns of the map, integers >= 1 (Python or NumPy ints,
        not bools; TypeError or ValueError naming the argument otherwise).

    Returns
    -------
    T : ndarray, shape (height, 9), float64
        The theta factor per row (row 0 at the zenith).
    P : ndarray, shape (width, 9), float64
        The phi factor per column (column j covers phi in
        [2 pi j / W, 2 pi (j + 1) / W)).
    """
    height, width = check_int(height, "height", 1), check_int(width, "width", 1)
    t = np.linspace(0.0, math.pi, height + 1)
    u = np.cos(t)
    u[0], u[-1] = 1.0, -1.0
    s = np.sqrt(np.clip(1.0 - u * u, 0.0, None))
    # antiderivatives in u = cos(theta); integrating from u[i+1] up to u[i] (theta grows downwards)
    prims = [u,                                    # 1
             0.5 * u * u,                          # u
             0.5 * (u * s + np.arcsin(u)),         # sin(theta)
             u ** 3 - u,                           # 3u^2 - 1
             -(s ** 3) / 3.0,                      # u sin(theta)
             u - u ** 3 / 3.0]                     # sin^2(theta)
    I = [p[:-1] - p[1:] for p in prims]
    one, uu, sn, p20, us, s2 = I
    T = np.stack([_C00 * one, _C1 * sn, _C1 * uu, _C1 * sn, _C22 * s2, _C2 * us, _C20 * p20,
                  _C2 * us, _C22 * s2], axis=-1)
    f = np.linspace(0.0, 2.0 * math.pi, width + 1)
    df = np.diff(f)
    c1, s1 = np.diff(np.sin(f)), -np.diff(np.cos(f))          # int cos, int sin
    c2, s2p = np.diff(np.sin(2 * f)) / 2.0, -np.diff(np.cos(2 * f)) / 2.0
    P = np.stack([df, s1, df, c1, s2p, s1, df, c1, c2], axis=-1)
    return T, P

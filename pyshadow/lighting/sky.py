"""Skies without files: a clear sky after Preetham et al. 1999 and the CIE overcast sky.

Units and frame
---------------
Both skies are lat-long :class:`~pyshadow.lighting.EnvironmentMap` objects of
linear Rec. 709 (sRGB primaries, D65) RGB whose luminance
``Y = 0.2126 R + 0.7152 G + 0.0722 B`` is in cd/m^2; irradiance from them
(``EnvironmentMap.irradiance``) is then illuminance in lux. y is up; for
:func:`sun_position` north is -z and east is +x (so south is +z).
Below the horizon the maps hold a grey Lambertian ground of albedo
``ground_albedo`` lit by the sky's (and sun's) horizontal illuminance;
0 gives a black lower hemisphere.

The sun disc
------------
:data:`SUN_ANGULAR_RADIUS` = asin(695 700 km / 1 au) = 0.0046505 rad
(0.26645 degrees; thesis 001, eq. 3.1 gets 0.00465 rad from atan with a
rounder solar diameter). The disc is drawn with its exact energy: texels
it covers get ``L_disc * coverage``, coverage the fraction of the texel
inside the disc, found from the disc itself (on lat-long maps integrated
exactly in polar angle, so also where the texels converge at a pole; on
cube faces exactly across each face's rows) and
scaled so that ``sum(coverage * Omega) = 2 pi (1 - cos r)`` exactly; a disc
smaller than a texel is therefore spread over the texels it overlaps (one
to four, or the whole first row around the zenith), never lost or
brightened. Each texel holds its share spread over its whole extent, so a
map places a sub-texel sun only to within its texels' size.
"""
from __future__ import annotations

import math

import numpy as np

from ._checks import _floats, flag, in_range, positive, unit_direction
from .cube import FACE_FRAMES
from .envmap import EnvironmentMap, latlong_directions, latlong_solid_angles

__all__ = ["SUN_ANGULAR_RADIUS", "LUMINANCE_WEIGHTS", "sun_position", "clear_sky", "overcast_sky",
           "add_sun_disc", "disc_solid_angle", "sun_irradiance"]

#: Apparent angular radius of the sun in rad: asin(R_sun / 1 au).
SUN_ANGULAR_RADIUS = math.asin(695_700.0 / 149_597_870.7)
#: Rec. 709 luminance of linear RGB.
LUMINANCE_WEIGHTS = np.array([0.2126, 0.7152, 0.0722])
#: Illuminance of the sun above the atmosphere at 1 au, lux (luminous solar constant).
EXTRATERRESTRIAL_ILLUMINANCE = 128_000.0
_CHANNEL_WAVELENGTH_UM = np.array([0.680, 0.550, 0.440])
_XYZ_TO_RGB = np.array([[3.2404542, -1.5371385, -0.4985314],
                        [-0.9692660, 1.8760108, 0.0415560],
                        [0.0556434, -0.2040259, 1.0572252]])
# Perez coefficients (A, B, C, D, E) = a * T + b for luminance Y and chromaticities x, y
# (Preetham, Shirley and Smits 1999, appendix A.2), rows: a, b.
_PEREZ = {
    "Y": np.array([[0.1787, -0.3554, -0.0227, 0.1206, -0.0670],
                   [-1.4630, 0.4275, 5.3251, -2.5771, 0.3703]]),
    "x": np.array([[-0.0193, -0.0665, -0.0004, -0.0641, -0.0033],
                   [-0.2592, 0.0008, 0.2125, -0.8989, 0.0452]]),
    "y": np.array([[-0.0167, -0.0950, -0.0079, -0.0441, -0.0109],
                   [-0.2608, 0.0092, 0.2102, -1.6537, 0.0529]]),
}
# zenith chromaticity: rows T^2, T, 1; columns theta_s^3, theta_s^2, theta_s, 1
_ZENITH_X = np.array([[0.00166, -0.00375, 0.00209, 0.0],
                      [-0.02903, 0.06377, -0.03202, 0.00394],
                      [0.11693, -0.21196, 0.06052, 0.25886]])
_ZENITH_Y = np.array([[0.00275, -0.00610, 0.00317, 0.0],
                      [-0.04214, 0.08970, -0.04153, 0.00516],
                      [0.15346, -0.26756, 0.06670, 0.26688]])
TURBIDITY_RANGE = (1.7, 10.0)


def disc_solid_angle(radius: float) -> float:
    """Solid angle of a spherical cap (a disc on the sky) of angular radius ``radius``.

    Parameters
    ----------
    radius : float
        Angular radius in rad, in [0, pi]: from the cap's centre to its rim
        (pi: the whole sphere).

    Returns
    -------
    float
        ``2 pi (1 - cos r)`` sr (computed as ``4 pi sin^2(r / 2)``, exact
        for small ``r``), in [0, 4 pi].

    Raises
    ------
    ValueError
        ``radius`` is not finite or outside [0, pi] (a negative or larger
        angle is no cap: the formula would return the cap of ``|r|`` or of
        ``2 pi - r``).
    """
    r = in_range(radius, "radius", 0.0, math.pi)
    return 4.0 * math.pi * math.sin(0.5 * r) ** 2


def _height(height) -> int:
    try:
        h = int(height)
    except (TypeError, ValueError, OverflowError):      # None, inf, NaN, "abc"
        h = None
    if h is None or h != height or h < 4 or h % 2:
        raise ValueError(f"height: must be an even integer >= 4, so that the horizon is a row "
                         f"boundary (got {height!r})")
    return h


def sun_position(latitude: float, day_of_year: float, hour: float) -> np.ndarray:
    """Direction towards the sun from latitude, day of the year and local solar time.

    Parameters
    ----------
    latitude : float
        Degrees, north positive, in [-90, 90].
    day_of_year : float
        1 (1 January) to 366.
    hour : float
        Local *solar* time in hours, [0, 24]; 12 is solar noon (no equation of
        time, no time zone).

    Returns
    -------
    direction : ndarray, shape (3,), float64
        Unit vector, y up, east +x, north -z. Below the horizon when y < 0.

    Notes
    -----
    Declination ``delta = -23.44 deg cos(2 pi (day + 10) / 365)`` (within
    1.3 deg of NOAA's Fourier series for it), hour angle
    ``h = 15 deg (hour - 12)``; in (east, north, up): ``(-cos delta sin h,
    cos lat sin delta - sin lat cos delta cos h, sin lat sin delta + cos lat
    cos delta cos h)``.
    """
    lat = math.radians(in_range(latitude, "latitude", -90.0, 90.0))
    day = in_range(day_of_year, "day_of_year", 1.0, 366.0)
    h = math.radians(15.0 * (in_range(hour, "hour", 0.0, 24.0) - 12.0))
    dec = math.radians(-23.44) * math.cos(2.0 * math.pi * (day + 10.0) / 365.0)
    east = -math.cos(dec) * math.sin(h)
    north = math.cos(lat) * math.sin(dec) - math.sin(lat) * math.cos(dec) * math.cos(h)
    up = math.sin(lat) * math.sin(dec) + math.cos(lat) * math.cos(dec) * math.cos(h)
    v = np.array([east, up, -north])
    return v / np.linalg.norm(v)


def _perez(coef, cos_theta, gamma):
    A, B, C, D, E = coef
    return (1.0 + A * np.exp(B / cos_theta)) * (1.0 + C * np.exp(D * gamma) + E * np.cos(gamma) ** 2)


def _above_horizon(sun_direction) -> np.ndarray:
    """The unit sun direction; ValueError when the sun is below the horizon (y < 0)."""
    s = unit_direction(sun_direction, "sun_direction")
    if s[1] < 0:
        raise ValueError(f"sun_direction: the sun is below the horizon (elevation "
                         f"{math.degrees(math.asin(s[1])):.3g} deg); the clear-sky model needs y >= 0")
    return s


def sun_irradiance(sun_direction, turbidity: float = 3.0) -> np.ndarray:
    """Direct-normal irradiance of the sun through a clear atmosphere, linear RGB, lux-scaled.

    Parameters
    ----------
    sun_direction : array_like, shape (3,)
        Unit vector towards the sun, y up (e.g. from :func:`sun_position`);
        the sun must not be below the horizon (y >= 0), as for :func:`clear_sky`.
    turbidity : float
        Atmospheric turbidity T in [1.7, 10].

    Returns
    -------
    irradiance : ndarray, shape (3,), float64
        RGB irradiance on a surface facing the sun; its luminance
        ``LUMINANCE_WEIGHTS @ irradiance`` is in lux.

    Raises
    ------
    ValueError
        ``sun_direction`` is not a unit 3-vector or points below the horizon
        (y < 0); ``turbidity`` is outside [1.7, 10].

    Notes
    -----
    ``EXTRATERRESTRIAL_ILLUMINANCE * exp(-m (tau_R + tau_A))`` per channel, with
    the Kasten-Young air mass m, Rayleigh depth ``0.008735 lambda^-4.08`` and
    Angstrom aerosol depth ``(0.04608 T - 0.04586) lambda^-1.3`` at 680, 550
    and 440 nm (the turbidity relation of Preetham et al., appendix A.3). The
    sun above the atmosphere is taken as white (R = G = B).

    A sun below the horizon is refused, as :func:`clear_sky` refuses it:
    neither the horizon's value (about (79.7, 1.41, 0.0004) at T = 3, not
    zero: the air mass stays finite there) nor zero would be the model's
    answer, and a sun without its sky would light a scene the sky does not
    match. To animate a sun through a day, take the hours with
    ``sun_position(...)[1] >= 0`` (the horizon itself included) and light
    the others without the sun (or with a night sky of your own).
    """
    d = _above_horizon(sun_direction)
    T = in_range(turbidity, "turbidity", *TURBIDITY_RANGE)
    zen = math.degrees(math.acos(min(1.0, max(0.0, d[1]))))
    m = 1.0 / (math.cos(math.radians(zen)) + 0.50572 * (96.07995 - zen) ** -1.6364)
    lam = _CHANNEL_WAVELENGTH_UM
    tau = 0.008735 * lam ** -4.08 + (0.04608 * T - 0.04586) * lam ** -1.3
    return EXTRATERRESTRIAL_ILLUMINANCE * np.exp(-m * tau)


def _ground(radiance, dirs, omega, albedo, extra_horizontal=0.0):
    """Fill the lower hemisphere with a grey Lambertian ground lit from above."""
    up = dirs[..., 1] > 0
    radiance[~up] = 0.0
    if albedo > 0:
        lum = radiance @ LUMINANCE_WEIGHTS
        e_h = float(np.sum(lum * np.clip(dirs[..., 1], 0, None) * omega)) + extra_horizontal
        radiance[~up] = albedo * e_h / math.pi
    return radiance


def clear_sky(sun_direction, turbidity: float = 3.0, *, height: int = 128, sun: bool = True,
              ground_albedo: float = 0.0) -> EnvironmentMap:
    """A clear sky after Preetham, Shirley and Smits (1999), with the sun's disc.

    Parameters
    ----------
    sun_direction : array_like, shape (3,)
        Unit vector towards the sun, y up (e.g. from :func:`sun_position`);
        the sun must not be below the horizon (y >= 0).
    turbidity : float
        Atmospheric turbidity T in [1.7, 10] (2 very clear, 3 clear, 6 hazy).
        Below T = 2 Preetham's fit breaks down: the zenith's gradation
        ``1 + A e^B`` falls towards 0 (0.17 at T = 2, 0.029 at 1.7, 0 near
        1.645), so the sky brightens instead of darkening as the air clears
        (horizontal illuminance, sun at 30 deg: 24.0 klx at T = 3, 24.2 at 2,
        31.7 at 1.8, 57.9 at 1.7); use T >= 2 for a plausible sky.
    height : int
        Rows of the lat-long map (even); the width is 2 * height.
    sun : bool
        Draw the sun's disc (radius :data:`SUN_ANGULAR_RADIUS`, irradiance
        :func:`sun_irradiance`) into the map. True or False (Python or NumPy
        bools); anything else raises TypeError. False is the sky to pair with
        the sun as a directional light
        (:meth:`pyshadow.lighting.Lighting.clear_sky`): only the
        disc is left out, the sky's glow and the ground are as with True.
    ground_albedo : float
        Albedo in [0, 1] of the grey ground below the horizon, lit by the
        sky's and the sun's horizontal illuminance (the sun's with or
        without its disc in the map).

    Returns
    -------
    sky : EnvironmentMap
        Lat-long, (height, 2 height, 3) linear Rec. 709 RGB, luminance cd/m^2.

    Notes
    -----
    Luminance ``Y = Y_z F(theta, gamma) / F(0, theta_s)`` with the Perez
    function ``F = (1 + A e^(B / cos theta)) (1 + C e^(D gamma) + E cos^2 gamma)``,
    gamma the angle to the sun, zenith luminance
    ``Y_z = (4.0453 T - 4.9710) tan chi - 0.2155 T + 2.4192`` kcd/m^2,
    ``chi = (4/9 - T/120)(pi - 2 theta_s)``; the chromaticities x, y follow
    the same form with their own coefficients and zenith polynomials, and
    xyY -> XYZ -> linear Rec. 709 (negative components clipped to 0).
    Evaluated at texel centres.
    """
    s = _above_horizon(sun_direction)
    T = in_range(turbidity, "turbidity", *TURBIDITY_RANGE)
    albedo = in_range(ground_albedo, "ground_albedo", 0.0, 1.0)
    sun = flag(sun, "sun")
    h = _height(height)
    dirs = latlong_directions(h, 2 * h)
    omega = latlong_solid_angles(h, 2 * h)
    cos_t = np.clip(dirs[..., 1], 1e-4, 1.0)
    gamma = np.arccos(np.clip(dirs @ s, -1.0, 1.0))
    theta_s = math.acos(min(1.0, s[1]))
    chi = (4.0 / 9.0 - T / 120.0) * (math.pi - 2.0 * theta_s)
    zen = {"Y": 1000.0 * ((4.0453 * T - 4.9710) * math.tan(chi) - 0.2155 * T + 2.4192)}
    tv = np.array([theta_s ** 3, theta_s ** 2, theta_s, 1.0])
    tt = np.array([T * T, T, 1.0])
    zen["x"], zen["y"] = tt @ (_ZENITH_X @ tv), tt @ (_ZENITH_Y @ tv)
    val = {}
    for k, ab in _PEREZ.items():
        coef = ab[0] * T + ab[1]
        val[k] = zen[k] * _perez(coef, cos_t, gamma) / _perez(coef, 1.0, theta_s)
    Y, x, y = val["Y"], val["x"], val["y"]
    XYZ = np.stack([x * Y / y, Y, (1.0 - x - y) * Y / y], axis=-1)
    rgb = np.clip(XYZ @ _XYZ_TO_RGB.T, 0.0, None)
    e_sun = sun_irradiance(s, T)        # lights the ground whether or not its disc is drawn
    rgb = _ground(rgb, dirs, omega, albedo, float(LUMINANCE_WEIGHTS @ e_sun) * s[1])
    env = EnvironmentMap(rgb, "latlong", name="clear sky")
    if sun:
        env = add_sun_disc(env, s, e_sun / disc_solid_angle(SUN_ANGULAR_RADIUS))
    return env


def overcast_sky(horizontal_illuminance: float = 10_000.0, *, height: int = 128,
                 ground_albedo: float = 0.0) -> EnvironmentMap:
    """The CIE standard overcast sky (Moon and Spencer 1942), grey.

    ``L(theta) = L_z (1 + 2 cos theta) / 3`` with ``L_z = 9 E_h / (7 pi)``,
    so that the horizontal illuminance is ``E_h`` (lux). Each row holds the
    exact average of L over its texels (``cos theta`` averages to the mean of
    the row's edge values), so ``sum L_i Omega_i = 4 pi L_z / 3`` exactly; the
    map's horizontal illuminance is ``E_h`` to O(pitch^2) (2e-4 at height 64).

    Parameters
    ----------
    horizontal_illuminance : float
        E_h in lux, > 0 (a dull overcast day: 5 000 to 20 000).
    height : int
        Rows of the lat-long map (even); the width is 2 * height.
    ground_albedo : float
        Albedo in [0, 1] of the grey ground below the horizon.

    Returns
    -------
    sky : EnvironmentMap
        Lat-long, R = G = B = luminance in cd/m^2.
    """
    e_h = positive(horizontal_illuminance, "horizontal_illuminance")
    albedo = in_range(ground_albedo, "ground_albedo", 0.0, 1.0)
    h = _height(height)
    u = np.cos(np.linspace(0.0, math.pi, h + 1))
    u[0], u[h // 2], u[-1] = 1.0, 0.0, -1.0
    lz = 9.0 * e_h / (7.0 * math.pi)
    if not math.isfinite(3.0 * lz):                 # the zenith's luminance (lz (1 + 2) / 3 at most) overflows
        raise ValueError(f"horizontal_illuminance: {horizontal_illuminance!r} lux gives a sky luminance beyond "
                         f"float64's range")
    row = lz * (1.0 + (u[:-1] + u[1:])) / 3.0
    rgb = np.repeat(np.repeat(row[:, None, None], 2 * h, axis=1), 3, axis=2)
    rgb[h // 2:] = albedo * e_h / math.pi
    return EnvironmentMap(rgb, "latlong", name="overcast sky")


#: Resolution of the disc's own sampling: at least this many azimuth nodes per column (on a lat-long
#: map and on each cube face; the polar angle, or the face's latitude, is integrated exactly).
_PER_TEXEL = 8
#: Fewest azimuth nodes over a disc on a lat-long map (its rim is a square-root profile in azimuth).
_MIN_NODES = 64
#: Fewest azimuth nodes over a disc on a cube face: the face's edges cut the arcs at kinks (3e-4 of the
#: disc's solid angle at 64 nodes on 2 x 2 faces, 5e-6 at 512).
_MIN_FACE_NODES = 512


def _sin_gap(a, b):
    """cos a - cos b (= 2 sin((a + b) / 2) sin((b - a) / 2), exact for a close to b) for
    0 <= a <= b <= pi; 0 where rounding put a row edge a hair past the end it bounds."""
    return np.maximum(2.0 * np.sin(0.5 * (a + b)) * np.sin(0.5 * (b - a)), 0.0)


def _latlong_coverage(h: int, w: int, d: np.ndarray, r: float):
    """Solid angle of the cap (centre ``d``, radius ``r``) in each texel of an h x w lat-long map.

    The cap is integrated over azimuth at nodes ``phi`` and exactly over polar angle: the meridian
    at ``phi`` crosses the cap in one arc ``|theta - alpha| <= beta`` (``alpha`` the foot of ``d``
    on the meridian's great circle, ``cos r = cos delta cos beta`` with ``delta`` the distance of
    ``d`` from that circle), which is cut at the row boundaries in closed form. Nothing depends on
    how narrow the texels get towards a pole: a cap around a pole crosses every meridian, and the
    nodes are then the same whole number per column in every column (``_PER_TEXEL``, more where that
    leaves fewer than ``_MIN_NODES``). Otherwise the nodes span
    the cap's azimuths ``phi_c +- D``, ``D = asin(sin r / sin theta_c)``, as ``phi = phi_c + D sin t``
    (no square-root end points), ``t`` evenly spaced within each column's piece, at least
    ``_PER_TEXEL`` per column and ``_MIN_NODES`` over the cap.

    Returns flat texel indices and the sr of the cap in each (summing to the cap's solid angle
    up to the azimuth quadrature's error).
    """
    th_c = math.atan2(math.hypot(d[0], d[2]), d[1])
    ph_c = math.atan2(d[2], d[0])
    col = 2.0 * math.pi / w
    if th_c <= r or th_c >= math.pi - r:                      # around a pole: every meridian
        n = w * max(_PER_TEXEL, -(-_MIN_NODES // w))      # a whole number a column: none straddles an edge
        phi = (np.arange(n) + 0.5) * (2.0 * math.pi / n)
        dphi = np.full(n, 2.0 * math.pi / n)
    else:
        D = math.asin(min(1.0, math.sin(r) / math.sin(th_c)))
        n = max(_MIN_NODES, math.ceil(_PER_TEXEL * math.pi * D / col))   # node gap <= column / _PER_TEXEL
        # pieces of t between the column edges the cap spans, so that no node straddles one
        k = np.arange(math.floor((ph_c - D) / col) + 1, math.ceil((ph_c + D) / col))
        edges = np.unique(np.concatenate([[-0.5 * math.pi, 0.5 * math.pi],
                                          np.arcsin(np.clip((k * col - ph_c) / D, -1.0, 1.0))]))
        size = np.diff(edges)
        m = np.maximum(2, np.ceil(n * size / math.pi)).astype(np.int64)
        piece = np.repeat(np.arange(len(size)), m)
        step = (size / m)[piece]
        t = edges[piece] + (np.arange(len(piece)) - np.repeat(np.cumsum(m) - m, m) + 0.5) * step
        phi = ph_c + D * np.sin(t)
        dphi = D * np.cos(t) * step
    cp, sp = np.cos(phi), np.sin(phi)
    sin_delta = np.minimum(np.abs(d[2] * cp - d[0] * sp), 1.0)   # d . (meridian plane's normal)
    half_delta = 0.5 * np.arcsin(sin_delta)
    q = (math.sin(0.5 * r) ** 2 - np.sin(half_delta) ** 2) / np.cos(2.0 * half_delta)
    beta = 2.0 * np.arcsin(np.sqrt(np.clip(q, 0.0, 1.0)))
    alpha = np.arctan2(d[0] * cp + d[2] * sp, d[1])
    jcol = np.floor(np.mod(phi, 2.0 * math.pi) / col).astype(np.int64) % w
    u = np.cos(np.linspace(0.0, math.pi, h + 1))              # row edges, as latlong_solid_angles
    u[0], u[-1] = 1.0, -1.0
    idx, val, inner = [], [], []
    # the arc, and its part past the meridian's end at the antipode (alpha - beta < -pi)
    for shift in (0.0, 2.0 * math.pi):
        a = np.clip(alpha - beta + shift, 0.0, math.pi)
        b = np.clip(alpha + beta + shift, 0.0, math.pi)
        ok = b > a
        a, b, j, wt = a[ok], b[ok], jcol[ok], dphi[ok]
        ia = np.minimum((a * (h / math.pi)).astype(np.int64), h - 1)
        ib = np.minimum((b * (h / math.pi)).astype(np.int64), h - 1)
        one, two = ia == ib, ia != ib
        idx += [ia[one] * w + j[one], ia[two] * w + j[two], ib[two] * w + j[two]]
        val += [wt[one] * _sin_gap(a[one], b[one]),
                wt[two] * _sin_gap(a[two], (ia[two] + 1) * (math.pi / h)),
                wt[two] * _sin_gap(ib[two] * (math.pi / h), b[two])]
        inner.append((ia[two] + 1, ib[two], j[two], wt[two]))     # whole rows ia + 1 .. ib - 1
    first = min((int(x[0].min()) for x in inner if len(x[0])), default=0)
    last = max((int(x[1].max()) for x in inner if len(x[1])), default=0)
    if last > first:
        acc = np.zeros((last - first + 1, w))
        cnt = np.zeros(acc.shape, np.int64)                   # exact: where no arc is, 0 (no residue)
        for i0, i1, j, wt in inner:
            np.add.at(acc, (i0 - first, j), wt)
            np.add.at(acc, (i1 - first, j), -wt)
            np.add.at(cnt, (i0 - first, j), 1)
            np.add.at(cnt, (i1 - first, j), -1)
        run = np.where(np.cumsum(cnt[:-1], axis=0) > 0, np.maximum(np.cumsum(acc[:-1], axis=0), 0.0), 0.0)
        rows = run * (u[first:last] - u[first + 1:last + 1])[:, None]
        ri, rj = np.nonzero(rows)
        idx.append((ri + first) * w + rj)
        val.append(rows[ri, rj])
    return _group(np.concatenate(idx), np.concatenate(val))


def _group(flat, v):
    """Unique indices and the sums of ``v`` over each."""
    uniq, inv = np.unique(flat, return_inverse=True)
    return uniq, np.bincount(inv, weights=v, minlength=len(uniq))


def _cube_coverage(n: int, d: np.ndarray, r: float):
    """Flat texel indices and the sr of the cap (centre ``d``, radius ``r``) in each texel of a cube of
    n x n faces.

    On each face (axes ``c``, right, ``dn`` of :data:`~pyshadow.lighting.cube.FACE_FRAMES`) the cap is
    integrated over the azimuth ``phi = atan(s)`` around the face's ``dn`` axis at nodes, and exactly
    across it: the half great circle ``s = tan phi`` meets the cap in one arc ``|theta - alpha| <=
    beta`` of its latitude ``theta = atan(t cos phi)`` (``cos r = cos delta cos beta``, ``delta`` the
    distance of ``d`` from the circle), ``dOmega = cos theta dtheta dphi``, and the rows' edges ``t``
    are points of that arc. The nodes are placed as on a lat-long map (:func:`_latlong_coverage`):
    ``phi = phi_c + D sin u`` over the cap's azimuths on the face (all of them where the cap holds
    the axis), at least ``_PER_TEXEL`` per column and ``_MIN_FACE_NODES`` over the cap. Nothing
    depends on how the cap compares with a texel.
    """
    e = np.linspace(-1.0, 1.0, n + 1)                           # texel edges in s and t
    col_phi = np.arctan(e)
    col = float(np.diff(col_phi).min())                         # the narrowest column, at the face's sides
    idx, val = [], []
    for f in range(6):
        c, rt, dn = FACE_FRAMES[f]
        x, y, z = float(d @ c), float(d @ rt), float(d @ dn)
        rho = math.hypot(x, y)                                  # sine of d's angle from the axis +-dn
        if rho <= math.sin(r):                                  # the cap holds +-dn: every azimuth
            ph_c, D, lo, hi = 0.0, 0.5 * math.pi, -0.25 * math.pi, 0.25 * math.pi
        else:
            ph_c, D = math.atan2(y, x), math.asin(math.sin(r) / rho)
            lo, hi = max(-0.25 * math.pi, ph_c - D), min(0.25 * math.pi, ph_c + D)
            if not lo < hi:
                continue
        cut = np.concatenate([[lo], col_phi[(col_phi > lo) & (col_phi < hi)], [hi]])
        edges = np.unique(np.arcsin(np.clip((cut - ph_c) / D, -1.0, 1.0)))
        size = np.diff(edges)
        total = max(_MIN_FACE_NODES, _PER_TEXEL * math.pi * D / col)
        m = np.maximum(2, np.ceil(total * size / math.pi)).astype(np.int64)
        piece = np.repeat(np.arange(len(size)), m)
        step = (size / m)[piece]
        u = edges[piece] + (np.arange(len(piece)) - np.repeat(np.cumsum(m) - m, m) + 0.5) * step
        phi = ph_c + D * np.sin(u)
        cp, sp = np.cos(phi), np.sin(phi)
        half_delta = 0.5 * np.arcsin(np.minimum(np.abs(y * cp - x * sp), 1.0))
        q = (math.sin(0.5 * r) ** 2 - np.sin(half_delta) ** 2) / np.cos(2.0 * half_delta)
        beta = 2.0 * np.arcsin(np.sqrt(np.clip(q, 0.0, 1.0)))
        alpha = np.arctan2(z, x * cp + y * sp)
        top = np.arctan(cp)                                     # latitude of the face's edges t = +-1
        a, b = np.maximum(alpha - beta, -top), np.minimum(alpha + beta, top)
        ok = b > a
        a, b, cp, wt = a[ok], b[ok], cp[ok], (D * np.cos(u) * step)[ok]
        j = np.clip(np.floor((np.tan(phi[ok]) + 1.0) * (0.5 * n)), 0, n - 1).astype(np.int64)
        ia = np.clip(np.floor((np.tan(a) / cp + 1.0) * (0.5 * n)), 0, n - 1).astype(np.int64)
        ib = np.clip(np.floor((np.tan(b) / cp + 1.0) * (0.5 * n)), 0, n - 1).astype(np.int64)
        k = ib - ia + 1                                         # rows each arc crosses
        node = np.repeat(np.arange(len(a)), k)
        row = ia[node] + np.arange(len(node)) - np.repeat(np.cumsum(k) - k, k)
        t0, t1 = e[row] * cp[node], e[row + 1] * cp[node]       # tan of the row's edge latitudes
        lo_s = np.maximum(np.sin(a)[node], t0 / np.sqrt(1.0 + t0 * t0))
        hi_s = np.minimum(np.sin(b)[node], t1 / np.sqrt(1.0 + t1 * t1))
        idx.append((f * n + row) * n + j[node])
        val.append(wt[node] * np.maximum(hi_s - lo_s, 0.0))
    if not idx:                                                 # cannot happen (add_sun_disc keeps the energy)
        return np.zeros(0, np.int64), np.zeros(0)
    return _group(np.concatenate(idx), np.concatenate(val))


def add_sun_disc(env: EnvironmentMap, direction, radiance, radius: float = SUN_ANGULAR_RADIUS
                 ) -> EnvironmentMap:
    """A copy of ``env`` with a uniform disc added, its energy exact.

    Parameters
    ----------
    env : EnvironmentMap
        Any layout.
    direction : array_like, shape (3,)
        Unit vector to the disc's centre, y up.
    radiance : array_like, shape (3,)
        Radiance of the disc (added to the map's), >= 0.
    radius : float
        Angular radius in rad, in (0, pi / 2).

    Returns
    -------
    EnvironmentMap
        ``env`` plus ``radiance * coverage`` on every texel the disc overlaps,
        coverage the fraction of the texel's Omega inside the disc;
        ``sum(added * Omega) = radiance * disc_solid_angle(radius)`` to rounding.
        The coverage comes from the disc itself, not from points of the
        texels, so a disc goes where it is however narrow the texels get
        (near a lat-long map's poles): lat-long, integrated exactly in
        polar angle and at azimuth nodes (:func:`_latlong_coverage`; a disc
        at a pole covers the first or last row evenly); cube, integrated
        exactly across each face's rows and at azimuth nodes
        (:func:`_cube_coverage`). The coverages are scaled to the disc's exact
        solid angle (the quadrature's error, well below 1e-3, goes).
    """
    if not isinstance(env, EnvironmentMap):
        raise TypeError(f"env: expected an EnvironmentMap (got {type(env).__name__})")
    d = unit_direction(direction, "direction")
    r = in_range(radius, "radius", 1e-9, math.pi / 2)
    if r >= math.pi / 2:
        raise ValueError(f"radius: must be below pi / 2 (got {radius!r})")
    L = _floats(radiance, "radiance", "3 finite values >= 0")
    if L.shape != (3,) or not np.isfinite(L).all() or (L < 0).any():
        raise ValueError(f"radiance: expected 3 finite values >= 0 (got {L.tolist()})")
    if env.layout == "latlong":
        near, covered = _latlong_coverage(*env.grid_shape, d, r)
    else:
        near, covered = _cube_coverage(env.grid_shape[1], d, r)
    total = covered.sum()
    if not total > 0.0:                                      # cannot happen; keep the energy anyway
        near, covered, total = env.texel_index(d[None, :]), np.ones(1), 1.0
    covered = covered * (disc_solid_angle(r) / total)
    out = env.radiance.reshape(-1, 3).copy()
    om = env.solid_angles().reshape(-1)[near]
    out[near] += L[None, :] * (covered / om)[:, None]
    return env.with_radiance(out.reshape(env.radiance.shape))

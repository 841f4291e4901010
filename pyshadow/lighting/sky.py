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
it covers get ``L_disc * coverage``, coverage found by sub-sampling each
texel and scaled so that ``sum(coverage * Omega) = 2 pi (1 - cos r)``
exactly; a disc smaller than a texel is therefore blurred over one to four
texels, never lost or brightened.
"""
from __future__ import annotations

import math

import numpy as np

from ._checks import in_range, positive, unit_direction
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
    Declination ``delta = -23.44 deg cos(2 pi (day + 10) / 365)`` (accurate to
    about a degree), hour angle ``h = 15 deg (hour - 12)``; in (east, north,
    up): ``(-cos delta sin h, cos lat sin delta - sin lat cos delta cos h,
    sin lat sin delta + cos lat cos delta cos h)``.
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
    height : int
        Rows of the lat-long map (even); the width is 2 * height.
    sun : bool
        Draw the sun's disc (radius :data:`SUN_ANGULAR_RADIUS`, irradiance
        :func:`sun_irradiance`) into the map.
    ground_albedo : float
        Albedo in [0, 1] of the grey ground below the horizon.

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
    e_sun = sun_irradiance(s, T) if sun else np.zeros(3)
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
    row = lz * (1.0 + (u[:-1] + u[1:])) / 3.0
    rgb = np.repeat(np.repeat(row[:, None, None], 2 * h, axis=1), 3, axis=2)
    rgb[h // 2:] = albedo * e_h / math.pi
    return EnvironmentMap(rgb, "latlong", name="overcast sky")


def _subsamples(env: EnvironmentMap, flat: np.ndarray, k: int):
    """k x k sub-sample directions (M, k*k, 3) and weights (M, k*k) summing to each texel's Omega."""
    f = (np.arange(k) + 0.5) / k
    if env.layout == "latlong":
        h, w = env.grid_shape
        i, j = np.divmod(flat, w)
        u0, u1 = np.cos(math.pi * i / h), np.cos(math.pi * (i + 1) / h)
        uu = u0[:, None] + (u1 - u0)[:, None] * f[None, :]            # equal-area in cos(theta)
        ph = 2.0 * math.pi * (j[:, None] + f[None, :]) / w
        U, P = uu[:, :, None], ph[:, None, :]
        S = np.sqrt(np.clip(1.0 - U * U, 0.0, None))
        d = np.stack(np.broadcast_arrays(S * np.cos(P), U, S * np.sin(P)), axis=-1).reshape(len(flat), -1, 3)
        wts = np.full(d.shape[:2], 1.0)
    else:
        from .cube import FACE_FRAMES
        n = env.grid_shape[1]
        fc, rem = np.divmod(flat, n * n)
        i, j = np.divmod(rem, n)
        s = 2.0 * (j[:, None] + f[None, :]) / n - 1.0
        t = 2.0 * (i[:, None] + f[None, :]) / n - 1.0
        Sg, Tg = s[:, None, :], t[:, :, None]
        c, r, dn = (FACE_FRAMES[fc, q][:, None, None, :] for q in range(3))
        d = c + Sg[..., None] * r + Tg[..., None] * dn
        wts = (1.0 / (1.0 + Sg * Sg + Tg * Tg) ** 1.5).reshape(len(flat), -1)
        d = (d / np.linalg.norm(d, axis=-1, keepdims=True)).reshape(len(flat), -1, 3)
    om = env.solid_angles().reshape(-1)[flat]
    return d, wts * (om / wts.sum(axis=1))[:, None]


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
        ``env`` plus ``radiance * coverage`` on every texel the disc touches;
        ``sum(added * Omega) = radiance * disc_solid_angle(radius)`` to rounding.
        A disc that no sub-sample falls in (narrower than their spacing, as
        near a lat-long map's poles, where the texels converge) goes to the
        sub-samples nearest its centre: at a pole, evenly to the whole first
        (or last) row, not to one texel of it.
    """
    d = unit_direction(direction, "direction")
    r = in_range(radius, "radius", 1e-9, math.pi / 2)
    if r >= math.pi / 2:
        raise ValueError(f"radius: must be below pi / 2 (got {radius!r})")
    L = np.asarray(radiance, dtype=np.float64)
    if L.shape != (3,) or not np.isfinite(L).all() or (L < 0).any():
        raise ValueError(f"radiance: expected 3 finite values >= 0 (got {L.tolist()})")
    dirs = env.directions().reshape(-1, 3)
    reach = r + 1.5 * env.pitch
    near = np.flatnonzero(dirs @ d >= math.cos(min(reach, math.pi)))
    near = np.union1d(near, env.texel_index(d[None, :]))
    k = int(min(64, max(4, math.ceil(6.0 * env.pitch / r))))
    sub, wts = _subsamples(env, near, k)
    inside = (sub @ d) >= math.cos(r)
    covered = (wts * inside).sum(axis=1)                     # sr of the disc in each texel
    total = covered.sum()
    omega_disc = disc_solid_angle(r)
    if total == 0.0:                                         # narrower than a sub-sample: the nearest ones
        chord = np.linalg.norm(sub - d, axis=-1)             # (ties: every texel around a pole alike)
        covered = (wts * (chord <= chord.min() * (1.0 + 1e-9))).sum(axis=1)
        total = covered.sum()
    covered *= omega_disc / total
    out = env.radiance.reshape(-1, 3).copy()
    om = env.solid_angles().reshape(-1)[near]
    out[near] += L[None, :] * (covered / om)[:, None]
    return env.with_radiance(out.reshape(env.radiance.shape))

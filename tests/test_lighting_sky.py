"""Skies without files: sun position, the Preetham clear sky with its disc, the CIE overcast sky."""
import math

import numpy as np
import pytest

from pyshadow.lighting import (SUN_ANGULAR_RADIUS, EnvironmentMap, clear_sky, disc_solid_angle,
                               overcast_sky, sun_irradiance, sun_position)
from pyshadow.lighting.sky import LUMINANCE_WEIGHTS


def brute_irradiance(env, n):
    d = env.directions().reshape(-1, 3)
    w = env.radiance.reshape(-1, 3) * env.solid_angles().reshape(-1)[:, None]
    return np.clip(np.asarray(n, float) @ d.T, 0.0, None) @ w


def test_sun_radius_is_the_real_one():
    assert SUN_ANGULAR_RADIUS == pytest.approx(0.0046505, abs=1e-7)
    assert math.degrees(SUN_ANGULAR_RADIUS) == pytest.approx(0.2666, abs=2e-4)


def test_sun_position_at_known_times():
    # equinox (day 80, declination ~0) at the equator: overhead at noon, east at 6 h, west at 18 h
    assert sun_position(0.0, 80, 12.0) @ [0, 1, 0] > math.cos(math.radians(1.0))
    assert sun_position(0.0, 80, 6.0) @ [1, 0, 0] > math.cos(math.radians(1.0))       # east = +x
    assert sun_position(0.0, 80, 18.0) @ [-1, 0, 0] > math.cos(math.radians(1.0))
    # 48 N at the June solstice: noon elevation 90 - 48 + 23.44, in the south (+z)
    d = sun_position(48.0, 172, 12.0)
    assert math.degrees(math.asin(d[1])) == pytest.approx(65.44, abs=0.1)
    assert d[2] > 0 and abs(d[0]) < 1e-9
    assert np.linalg.norm(sun_position(-33.9, 355, 9.5)) == pytest.approx(1.0, abs=1e-15)


@pytest.mark.parametrize("args, match", [((91.0, 1, 12), "latitude"), ((0.0, 0, 12), "day_of_year"),
                                         ((0.0, 1, 25), "hour"), ((np.nan, 1, 12), "latitude")])
def test_sun_position_refuses_out_of_range(args, match):
    with pytest.raises(ValueError, match=match):
        sun_position(*args)


def test_overcast_sky_has_its_horizontal_illuminance_and_cie_gradient():
    sky = overcast_sky(8000.0, height=64)
    assert sky.layout == "latlong" and sky.grid_shape == (64, 128)
    lum = sky.radiance[:, 0] @ LUMINANCE_WEIGHTS
    lz = 9 * 8000.0 / (7 * math.pi)
    lum = sky.radiance[:, 0] @ LUMINANCE_WEIGHTS
    # rows hold exact texel averages, so the map's integral is exact: 2 pi int (1 + 2u)/3 du = 4 pi / 3
    assert sky.integral()[1] == pytest.approx(4 * math.pi / 3 * lz, rel=1e-12)
    # the horizontal illuminance loses the correlation of L and cos inside a row: O(pitch^2)
    u = np.cos(np.linspace(0, math.pi, 65))[:33]
    assert lum[:32] @ (math.pi * (u[:-1] ** 2 - u[1:] ** 2)) == pytest.approx(8000.0, rel=1e-3)
    assert brute_irradiance(sky, [[0, 1, 0]])[0, 0] == pytest.approx(8000.0, rel=1e-3)
    lz = 9 * 8000.0 / (7 * math.pi)
    # CIE: L_z (1 + 2 cos theta) / 3, zenith 3x the horizon; each row its exact average
    e = np.cos(np.linspace(0, math.pi, 65))
    np.testing.assert_allclose(lum[:32], lz * (1 + e[:32] + e[1:33]) / 3, rtol=1e-12)
    assert lum[0] == pytest.approx(lz, rel=1e-3) and lum[31] == pytest.approx(lz / 3, rel=0.06)
    assert (np.diff(lum[:32]) < 0).all() and (lum[32:] == 0).all()
    # order-3 SH misses only the sharp horizon: within 1 %
    assert sky.irradiance([0, 1, 0])[0, 0] == pytest.approx(8000.0, rel=0.01)


def test_overcast_ground_reflects_the_sky():
    sky = overcast_sky(8000.0, height=16, ground_albedo=0.25)
    assert sky.radiance[8:] == pytest.approx(0.25 * 8000.0 / math.pi, rel=1e-14)


def test_clear_sky_zenith_luminance_follows_preetham():
    T, s = 3.0, sun_position(45.0, 100, 10.0)
    sky = clear_sky(s, T, height=256, sun=False)
    theta_s = math.acos(s[1])
    chi = (4 / 9 - T / 120) * (math.pi - 2 * theta_s)
    yz = 1000 * ((4.0453 * T - 4.9710) * math.tan(chi) - 0.2155 * T + 2.4192)   # cd/m^2
    top = sky.radiance[0] @ LUMINANCE_WEIGHTS                 # 0.35 degrees from the zenith
    assert top.mean() == pytest.approx(yz, rel=5e-3)
    assert 1000 < yz < 30000                                  # a daylit zenith, cd/m^2


def test_clear_sky_is_brightest_near_the_sun_and_hazier_is_brighter_at_the_horizon():
    s = sun_position(45.0, 172, 15.0)
    sky = clear_sky(s, 3.0, height=64, sun=False)
    lum = sky.radiance @ LUMINANCE_WEIGHTS
    d = sky.directions()
    i = np.unravel_index(np.argmax(lum), lum.shape)
    assert d[i] @ s > math.cos(math.radians(5.0))
    hazy = clear_sky(s, 8.0, height=64, sun=False).radiance @ LUMINANCE_WEIGHTS
    anti = np.unravel_index(np.argmax(d[:32] @ -s), (32, 128))
    assert hazy[31].mean() > lum[31].mean()                  # haze brightens the horizon ring
    assert (sky.radiance[32:] == 0).all() and np.isfinite(lum).all() and (lum[:32][anti] > 0)


def test_clear_sky_disc_carries_the_sun_irradiance_exactly():
    s = sun_position(52.0, 300, 11.0)
    with_sun, without = clear_sky(s, 2.5, height=64), clear_sky(s, 2.5, height=64, sun=False)
    added = (with_sun.radiance - without.radiance).reshape(-1, 3)
    om = with_sun.solid_angles().reshape(-1)
    np.testing.assert_allclose(added.T @ om, sun_irradiance(s, 2.5), rtol=1e-12)
    touched = np.flatnonzero(added.any(axis=1))
    ang = np.arccos(np.clip(with_sun.directions().reshape(-1, 3)[touched] @ s, -1, 1))
    assert ang.max() <= SUN_ANGULAR_RADIUS + 1.5 * with_sun.pitch and 1 <= len(touched) <= 9
    # direct-normal illuminance through a clear atmosphere at ~25 degrees elevation: 50-100 klx
    assert 50_000 < LUMINANCE_WEIGHTS @ sun_irradiance(s, 2.5) < 100_000
    assert sun_irradiance(s, 2.5)[2] < sun_irradiance(s, 2.5)[0]      # reddened
    assert disc_solid_angle(SUN_ANGULAR_RADIUS) == pytest.approx(6.794e-5, rel=1e-3)


@pytest.mark.parametrize("kwargs, match", [
    (dict(sun_direction=[0, -0.2, math.sqrt(0.96)]), "below the horizon"),
    (dict(sun_direction=[0, 2.0, 0]), "sun_direction: not a unit vector"),
    (dict(sun_direction=[0, 0, 0]), "sun_direction: zero vector"),
    (dict(sun_direction=[0, np.nan, 1]), "sun_direction: not finite"),
    (dict(sun_direction=[0, 1, 0], turbidity=12.0), r"turbidity: must lie in \[1.7, 10\]"),
    (dict(sun_direction=[0, 1, 0], height=33), "height: must be an even integer"),
    (dict(sun_direction=[0, 1, 0], ground_albedo=1.5), "ground_albedo"),
])
def test_clear_sky_refuses_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        clear_sky(**kwargs)


def test_overcast_sky_refuses_bad_input():
    for bad in (0.0, -5.0, np.inf, np.nan):
        with pytest.raises(ValueError, match="horizontal_illuminance: must be a finite number > 0"):
            overcast_sky(bad)


def test_skies_are_environment_maps():
    assert isinstance(overcast_sky(height=8), EnvironmentMap)
    assert isinstance(clear_sky([0, 1, 0], height=8), EnvironmentMap)


# -- input checks of sun_irradiance and disc_solid_angle -----------------------------------------
def test_sun_irradiance_refuses_a_sun_below_the_horizon_as_clear_sky_does():
    """It gave the horizon's value (~80 lux, clamping y to 0) for any sun below the horizon, while
    clear_sky refused the same direction: both refuse it now, with the same message."""
    for d in ([0.0, -1.0, 0.0], [0.0, -1e-9, 1.0], [0.0, -0.2, math.sqrt(0.96)]):
        with pytest.raises(ValueError, match="sun_direction: the sun is below the horizon") as got:
            sun_irradiance(d)
        with pytest.raises(ValueError) as want:
            clear_sky(d, height=8)
        assert str(got.value) == str(want.value)
    with pytest.raises(ValueError, match="elevation -90 deg"):
        sun_irradiance([0, -1, 0])
    # a day: the hours the sun is up give a value, the others are refused
    for hour in np.linspace(0, 24, 49):
        d = sun_position(45.0, 172, hour)
        if d[1] >= 0:
            assert (sun_irradiance(d) > 0).all()
        else:
            with pytest.raises(ValueError, match="below the horizon"):
                sun_irradiance(d)
    with pytest.raises(TypeError, match="turbidity: must be a number"):
        sun_irradiance([0, 1, 0], "clear")


def test_sun_irradiance_of_suns_above_the_horizon_is_unchanged():
    """Bit for bit the Kasten-Young / Angstrom formula, written out here (the horizon, y = 0 and -0.0,
    included)."""
    lam = np.array([0.680, 0.550, 0.440])
    rng = np.random.default_rng(7)
    dirs = rng.normal(size=(40, 3))
    dirs[:, 1] = np.abs(dirs[:, 1])
    dirs = list(dirs / np.linalg.norm(dirs, axis=1, keepdims=True))
    dirs += [np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]), np.array([0.0, -0.0, 1.0])]
    for d in dirs:
        for T in (1.7, 3.0, 6.5, 10.0):
            v = np.asarray(d, np.float64)
            v = v / float(np.linalg.norm(v))
            zen = math.degrees(math.acos(min(1.0, max(0.0, v[1]))))
            m = 1.0 / (math.cos(math.radians(zen)) + 0.50572 * (96.07995 - zen) ** -1.6364)
            tau = 0.008735 * lam ** -4.08 + (0.04608 * T - 0.04586) * lam ** -1.3
            want = 128_000.0 * np.exp(-m * tau)
            assert sun_irradiance(d, T).tobytes() == want.tobytes()


@pytest.mark.parametrize("bad", [-1.0, -1e-300, 4.0, math.pi + 1e-9, np.nan, np.inf, -np.inf])
def test_disc_solid_angle_refuses_radii_outside_0_pi(bad):
    """-1 gave the cap of radius 1, 4 that of 2 pi - 4, nan gave nan: a cap's angular radius is in [0, pi]."""
    with pytest.raises(ValueError, match=r"radius: must lie in \[0, 3.14159\]"):
        disc_solid_angle(bad)
    with pytest.raises(TypeError, match="radius: must be a number"):
        disc_solid_angle("small")


def test_disc_solid_angle_of_valid_radii_is_unchanged():
    for r in (0.0, 1e-300, 1e-9, SUN_ANGULAR_RADIUS, 0.3, 1.0, math.pi / 2, 3.0, math.pi, np.float32(0.25)):
        assert disc_solid_angle(r) == 4.0 * math.pi * math.sin(0.5 * float(r)) ** 2
    assert disc_solid_angle(0.0) == 0.0 and disc_solid_angle(math.pi) == pytest.approx(4 * math.pi, rel=1e-15)

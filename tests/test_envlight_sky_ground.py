"""clear_sky's ground below the horizon, with and without the sun's disc drawn (envlight helper)."""
import math

import numpy as np

from pyshadow.lighting import clear_sky, extract_sun, sun_irradiance

SUN = np.array([0.3, 0.6, 0.5]) / np.linalg.norm([0.3, 0.6, 0.5])
LUM = np.array([0.2126, 0.7152, 0.0722])


def test_ground_of_a_sky_without_its_disc_is_still_lit_by_the_sun():
    """Was: clear_sky(sun=False, ground_albedo=0.3) lit its ground by the sky alone (2780 cd/m^2 where
    sun=True gave 8631 at this sun), so the sky to pair with a directional sun (the disc left out) had a
    ground 3.1 times too dark and a downward face got 0.33 of the irradiance of the extract_sun route.
    Now only the disc is left out: the ground is albedo / pi times the sky's and the sun's horizontal
    illuminance either way."""
    h = 32
    with_disc = clear_sky(SUN, 3.0, height=h, ground_albedo=0.3)
    without = clear_sky(SUN, 3.0, height=h, ground_albedo=0.3, sun=False)
    # independent: the upper half's horizontal illuminance by quadrature of its texels, plus the sun's
    u = np.cos(np.linspace(0.0, math.pi, h + 1))
    om = (u[:-1] - u[1:]) * math.pi / h                       # row solid angle of one texel
    cos_c = np.cos((np.arange(h) + 0.5) * math.pi / h)        # texel-centre cosines, as the model's
    up = slice(0, h // 2)
    e_sky = float(((without.radiance[up] @ LUM) * (cos_c[up] * om[up])[:, None]).sum())
    e_h = e_sky + float(LUM @ sun_irradiance(SUN, 3.0)) * SUN[1]
    ground = without.radiance[h // 2:]
    np.testing.assert_allclose(ground, 0.3 * e_h / math.pi, rtol=1e-9)
    np.testing.assert_array_equal(ground, with_disc.radiance[h // 2:])
    sun, sky = extract_sun(with_disc)
    down = np.array([[0.0, -1.0, 0.0]])
    np.testing.assert_allclose(without.irradiance(down), sky.irradiance(down), rtol=2e-3)


def test_ground_without_albedo_stays_black():
    """The default ground (albedo 0) is black with or without the disc, as before."""
    for disc in (True, False):
        sky = clear_sky(SUN, 3.0, height=16, sun=disc)
        assert (sky.radiance[8:] == 0).all()

"""The SH irradiance's direction-free fallback: a zero normal gives the band-0 irradiance pi Y_0 L_0."""
import math

import numpy as np
import pytest

from pyshadow.lighting import Lighting, clear_sky, overcast_sky
from pyshadow.lighting.sh import _irradiance
from pyshadow.lighting.shade import sky_radiance

Y0 = 0.5 / math.sqrt(math.pi)


def test_irradiance_of_zero_rows_is_band_0_alone(rng):
    """Was: _irradiance (documented "zero rows give band 0") evaluated the quadratic form at 0, where
    Y_6 = 0.315392 (3 y^2 - 1) is -0.315392, not 0: it returned pi Y_0 L_0 - (pi / 4) 0.315392 L_6, off by
    the whole L_6 term (here 0.2477 |L_6|, of the order of the answer). Unit rows are unchanged."""
    L = rng.normal(size=(9, 3))
    n = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-0.0, 0.0, -0.0], [0.6, 0.0, 0.8]])
    E = _irradiance(L, n)
    np.testing.assert_allclose(E[[0, 2]], np.tile(math.pi * Y0 * L[0], (2, 1)), rtol=1e-14)
    A = np.array([math.pi] + [2 * math.pi / 3] * 3 + [math.pi / 4] * 5)       # the kernel's bands
    for k in (1, 3):                                                          # unit rows: the full form
        x, y, z = n[k]
        Y = np.array([Y0, 0.488603 * z, 0.488603 * y, 0.488603 * x, 1.092548 * x * z, 1.092548 * y * z,
                      0.315392 * (3 * y * y - 1), 1.092548 * x * y, 0.546274 * (x * x - z * z)])
        np.testing.assert_allclose(E[k], (A * Y) @ L, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(_irradiance(L, np.zeros(3)), math.pi * Y0 * L[0], rtol=1e-14)


@pytest.mark.parametrize("sky", ["overcast", "clear"])
def test_sky_radiance_zero_bent_normal_is_the_band_0_fallback(sky):
    """Was: sky_radiance (documented: zero bent rows give the sky's band-0 irradiance) returned 7.8 % less
    than band 0 under the CIE overcast sky (1258.1 for 1364.2 at E_h = 10 klx) and 2.8-7.5 % more under a
    clear sky, per channel."""
    env = overcast_sky(1e4, height=16) if sky == "overcast" else clear_sky([0.6, 0.5, 0.6244998], height=16)
    light = Lighting(env)
    albedo = np.full((2, 3), 0.5)
    got = sky_radiance(light, np.array([1.0, 0.25]), np.zeros((2, 3)), albedo)
    band0 = math.pi * Y0 * light.sh[0]                    # = integral of the radiance / 4 (irradiance, lux)
    np.testing.assert_allclose(band0, env.integral() / 4, rtol=1e-12)
    np.testing.assert_allclose(got, albedo / math.pi * band0 * np.array([[1.0], [0.25]]), rtol=1e-12)

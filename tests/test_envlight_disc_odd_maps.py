"""add_sun_disc on a 3 x 6 lat-long map, a disc over a pole (envlight helper)."""
import numpy as np
import pytest

from conftest import disc_texel_shares
from pyshadow.lighting import EnvironmentMap, add_sun_disc, disc_solid_angle


@pytest.mark.parametrize("d, r", [([0.0063, 0.9999, 0.0084], 0.01163), ([-0.0055, 1.0, 0.0034], 1.3311),
                                  ([0.0028, -1.0, -0.0094], 1.4807)])
def test_disc_around_a_pole_of_a_3_by_6_map_lands_in_its_own_columns(d, r):
    """Was: around a pole the disc was integrated at 64 azimuth nodes whatever the width, and 64 is no
    multiple of 6 columns, so nodes straddled column edges: 4.6 % (r = 0.0116, 0.6 deg off the zenith),
    4.2 % and 4.2 % (r = 1.33, 1.48) of the disc's energy sat in the wrong texels (row 0, column 1 got
    0.370 of it for 0.393). Now the nodes are a whole number a column: 7e-4, 2e-5, 2e-5 (the brute-force
    reference's own noise and the azimuth quadrature's)."""
    d = np.asarray(d) / np.linalg.norm(d)
    env = EnvironmentMap(np.zeros((3, 6, 3)))
    got = add_sun_disc(env, d, np.ones(3), radius=r).radiance[..., 0].reshape(-1) * env.solid_angles().reshape(-1)
    ref = disc_texel_shares(env, d, r, n=400_000)
    assert np.abs(got - ref).sum() <= 3e-3 * disc_solid_angle(r)

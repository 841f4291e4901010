"""Environment lighting against independent computations, second pass: a disc drawn into a cube map
(add_sun_disc) against its exact texel shares, from symmetry and from dense points over the disc."""

import numpy as np
import pytest

from pyshadow.lighting import EnvironmentMap, add_sun_disc, disc_solid_angle

from conftest import disc_texel_shares


def unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


@pytest.mark.parametrize("radius", [0.1, 0.01])
def test_cube_disc_at_a_corner_gives_each_face_a_third(radius):
    """A disc centred on the corner (1, 1, 1) of a cube of 1 x 1 faces: the turn by 120 degrees about
    that axis permutes +X, +Y, +Z and the disc, so each face holds exactly a third of its energy.

    Before: the cube took equal shares of 8 rings of points over the disc, and the faces got 0.3269,
    0.3365 and 0.3365 (radius 0.1 and 0.01 alike): 1.9 % of the disc's energy moved from +X to the
    others. Now the disc is integrated exactly across each face's rows: 1/3 each to 1e-6."""
    env = EnvironmentMap(np.zeros((6, 1, 1, 3)))
    added = add_sun_disc(env, unit([1.0, 1.0, 1.0]), np.ones(3), radius).radiance[..., 0]
    energy = (added * env.solid_angles()).reshape(6)
    np.testing.assert_allclose(energy.sum(), disc_solid_angle(radius), rtol=1e-12)
    np.testing.assert_allclose(energy / energy.sum(), [1 / 3, 0, 1 / 3, 0, 1 / 3, 0], atol=1e-5)


WALLS = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=np.float64)


@pytest.mark.parametrize("d, radius_in_pitches", [([1.0, 0.52, 0.03], 0.3), ([1.0, 0.9, 0.5], 2.0),
                                                  ([1.0, 1.0, 1.0], 0.07)],
                         ids=["sub-texel by an edge", "two pitches by a corner", "face corner"])
def test_cube_disc_lights_the_walls_as_its_exact_texel_shares(d, radius_in_pitches):
    """The irradiance of the six axis walls from a disc drawn into a cube of 4 x 4 faces, against the
    same map built from the disc's exact texel shares (400 000 points over the disc; the lat-long
    map's disc meets the same bound, tests/test_lighting_sun.py).

    Before: shares from points (8 rings over a disc narrower than two pitches, 4 x 4 sub-samples a
    texel over a wider one) put the walls 1.8e-3, 5.1e-3 and 1.3e-3 of the disc's normal irradiance
    E_n off (the quadrature's total was 1.2 % off at two pitches, where add_sun_disc's docstring says
    "well below 1e-3"). Now 4e-6 to 1.2e-5 E_n (the reference's own noise included)."""
    env = EnvironmentMap(np.zeros((6, 4, 4, 3)))
    d = unit(d)
    r = radius_in_pitches * env.pitch
    got = add_sun_disc(env, d, np.ones(3), r).irradiance(WALLS)[:, 0]
    shares = disc_texel_shares(env, d, r) / env.solid_angles().reshape(-1)
    ref = env.with_radiance(np.repeat(shares[:, None], 3, axis=1).reshape(env.radiance.shape)).irradiance(WALLS)
    assert np.abs(got - ref[:, 0]).max() <= 1e-4 * disc_solid_angle(r)

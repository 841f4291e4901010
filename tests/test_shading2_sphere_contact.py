"""A sphere light resting on a surface: the contact point is on the light's surface, not within it."""
import math

import numpy as np
import pytest

import pyshadow
from pyshadow.lighting import PointLight
from pyshadow.lighting.local import point_light_radiance


@pytest.fixture(scope="module")
def empty():
    return pyshadow.Scene()


@pytest.mark.parametrize("k", [1, 16])
def test_lamp_resting_on_a_table_lights_the_contact_point(empty, k):
    """Was: a lamp of radius 0.1 resting on a table top at y = 0.75 (centre y = 0.75 + 0.1) raised
    "point 0 lies within the sphere light (distance 0.1, light radius 0.1)": 0.85 - 0.75 rounds to
    0.09999999999999998. Its irradiance there is I / R^2 (the documented value on the surface)."""
    p = np.array([[0.2, 0.75, 0.1]])
    light = PointLight([0.2, 0.75 + 0.1, 0.1], 1.0, radius=0.1)
    radiance, vis = point_light_radiance(empty, p, [[0.0, 1.0, 0.0]], light, 1.0, backend="numpy", samples=k)
    np.testing.assert_allclose(radiance * math.pi * 0.1 ** 2, 1.0, rtol=1e-12)
    np.testing.assert_array_equal(vis, [1.0])


def test_points_under_lamps_of_centre_p_plus_r_n_are_on_the_surface(empty):
    """Was: 146 of 300 points p under lamps of centre p + R n (n a random unit normal, R from 2.3e-3 to
    1.7, p up to 1e5 from the origin) were refused as lying within the light."""
    rng = np.random.default_rng(0)
    for _ in range(300):
        r = float(rng.choice([0.1, 0.3, 0.05, 1.7, 2.3e-3]))
        p = rng.uniform(-1, 1, 3) * float(rng.choice([1, 1e3, 1e4, 1e5]))
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        light = PointLight(p + r * n, 1.0, radius=r)
        radiance, _ = point_light_radiance(empty, p[None], n[None], light, 1.0, backend="numpy", samples=4)
        # E = I / d^2 facing the light; d is R up to the rounding of coordinates of 1e5 (1.5e-11 a spacing,
        # 6e-9 of R = 2.3e-3): E R^2 / I within 2e-8 of 1
        np.testing.assert_allclose(radiance * math.pi * r * r, 1.0, rtol=1e-7)


@pytest.mark.parametrize("inside", [1e-9, 1e-3])
def test_points_truly_within_the_light_are_still_refused(empty, inside):
    light = PointLight([0.2, 0.85, 0.1], 1.0, radius=0.1)
    p = np.array([[0.2, 0.75 + 0.1 * inside, 0.1]])
    with pytest.raises(ValueError, match="within the sphere light"):
        point_light_radiance(empty, p, [[0.0, 1.0, 0.0]], light, 1.0, backend="numpy")


def test_a_point_at_a_point_light_but_for_rounding_is_refused(empty):
    """Was: a mesh vertex at (1e4 + 0.3, 2.7, -1e4 + 0.1) carried through a rotation and back lies 3.7e-13
    from a point light placed at the vertex; it was shaded with E = I / d^2 = 7.4e24 I instead of being
    refused as a point at the light (the exact coincidence was refused; PhongLighting refuses both)."""
    rot = np.array([[0.6, 0.8, 0.0], [-0.8, 0.6, 0.0], [0.0, 0.0, 1.0]])
    v = np.array([1e4 + 0.3, 2.7, -1e4 + 0.1])
    p = rot.T @ (rot @ v)
    assert 0 < np.linalg.norm(p - v) < 1e-12
    with pytest.raises(ValueError, match="at the light"):
        point_light_radiance(empty, p[None], [[0.0, 1.0, 0.0]], PointLight(v, 1.0), 1.0, backend="numpy")
    # a millionth of a unit away is no rounding: lit as I cos / d^2
    q = v - [0.0, 1e-6, 0.0]
    radiance, _ = point_light_radiance(empty, q[None], [[0.0, 1.0, 0.0]], PointLight(v, 1.0), 1.0, backend="numpy")
    np.testing.assert_allclose(radiance * math.pi, 1.0 / np.linalg.norm(v - q) ** 2, rtol=1e-12)

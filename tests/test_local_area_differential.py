"""Differential checks of the local and area lights (pyshadow.lighting.local, pyshadow.lighting.area)
at their edge cases, against the point light and closed forms."""
import math

import numpy as np

import pyshadow
from pyshadow.lighting import PointLight, SpotLight, point_light_radiance


def test_hemisphere_spot_lights_its_own_plane_as_a_point_light():
    """A hard-edged spot of half-angle pi/2 lights the half-space in front of it, its edge (the plane
    through the light across its axis) included as for every other angle (``c >= cos(angle)``). Before,
    cos(pi/2) rounded to 6.1e-17, so a direction exactly across the axis (c = 0) got the factor 0: a
    point in that plane facing the light was black (0 of 4 points lit) where a PointLight of the same
    intensity gives I / (pi d^2)."""
    scene = pyshadow.Scene(ground=0.0)
    spot = SpotLight([0.0, 1.0, 0.0], [1.0, 2.0, 3.0], 0.0, [1.0, 0.0, 0.0], math.pi / 2, 0.0)
    across = np.array([[0.0, -1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    np.testing.assert_array_equal(spot.factor(across), 1.0)
    np.testing.assert_array_equal(spot.factor([[-1.0, 0.0, 0.0], [-1.0, 1e-300, 0.0]]), 0.0)
    np.testing.assert_array_equal(spot.factor([[1.0, 0.0, 0.0]]), 1.0)
    p, n = np.array([[0.0, 0.5, 0.0]]), np.array([[0.0, 1.0, 0.0]])      # below the light, facing it
    rad, vis = point_light_radiance(scene, p, n, spot, 1.0)
    ref, _ = point_light_radiance(scene, p, n, PointLight(spot.position, spot.intensity), 1.0)
    np.testing.assert_array_equal(rad, ref)
    np.testing.assert_allclose(rad[0], np.array([1.0, 2.0, 3.0]) / 0.25 / math.pi, rtol=1e-15)
    assert vis[0] == 1.0


def _across(axis, theta):
    """Unit directions at angle ``theta`` (array) from the unit ``axis``, about an arbitrary side vector."""
    e = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 0.0, 1.0])
    e /= np.linalg.norm(e)
    t = np.asarray(theta, np.float64)[:, None]
    return np.cos(t) * axis + np.sin(t) * e


def test_narrow_spot_cone_is_its_angle_not_the_rounded_cosine():
    """Spots of half-angle 1e-8 and 1e-9 rad (valid: the angle lies in (0, pi/2]). Before, the factor
    compared cosines: cos(angle) rounds to 1.0 below 1.5e-8 rad, so points exactly on the axis (light
    position + t * direction, 400 random lights) were dark for 44 of them, and directions at 5x the
    half-angle were lit for 194 of them. Now a direction at 0.99x the angle is lit, at 1.01x
    dark, and the soft edge is the smoothstep of ``(a^2 - b^2) / (a^2 - (a - f)^2)`` (the cosine form
    at these angles, to a relative 1e-12)."""
    rng = np.random.default_rng(7)
    dark = 0
    for ang in (1e-8, 1e-9):
        for _ in range(200):
            ax = rng.normal(size=3)
            ax /= np.linalg.norm(ax)
            s = SpotLight(rng.uniform(-10, 10, 3), 1.0, 0.0, ax, ang, 0.0)
            to = s.position + rng.uniform(1, 100) * s.direction - s.position
            dark += int(s.factor((to / np.linalg.norm(to))[None])[0] != 1.0)
            np.testing.assert_array_equal(s.factor(_across(s.direction, [0.0, 0.99 * ang, 1.01 * ang, 5 * ang])),
                                          [1.0, 1.0, 0.0, 0.0])
    assert dark == 0
    a, f = 1e-9, 0.5e-9
    s = SpotLight([0.0, 0.0, 0.0], 1.0, 0.0, [0.0, -1.0, 0.0], a, f)
    b = np.array([0.0, 0.3, 0.5, 0.6, 0.75, 0.9, 1.0, 1.2]) * a
    x = np.clip((a * a - b * b) / (a * a - (a - f) ** 2), 0.0, 1.0)
    np.testing.assert_allclose(s.factor(_across(s.direction, b)), x * x * (3 - 2 * x), rtol=1e-12, atol=0)

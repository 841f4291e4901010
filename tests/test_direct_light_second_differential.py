"""Second differential pass over the direct lights (pyshadow.lighting.local, .reference): lights whose size
tends to 0 against the point light, a lamp resting on a surface, and the converged reference against the
shading it reproduces."""
import math

import numpy as np
import pytest

import pyshadow
from pyshadow.lighting import Lighting, PointLight, point_light_radiance, reference_radiance, shade

#: Ground points and their normals.
POINTS = np.array([[0.5, 0.0, 0.25], [-1.0, 0.0, 0.5], [2.0, 0.0, -1.5]])
NORMALS = np.tile([0.0, 1.0, 0.0], (3, 1))
CENTRE = np.array([0.3, 2.0, 0.1])


@pytest.mark.parametrize("radius", [5e-324, 1e-320])
def test_sphere_light_of_subnormal_radius_is_the_point_light(radius):
    """A sphere light of radius 5e-324 or 1e-320 (valid: finite, > 0) at 2 units, 16 rays a point: the point
    light's radiance (its R / d < 1e-8: the cone's factor is 1 / d to 2e-17). Before: 2 sin(asin(R / d) / 2)
    / R lost R's digits: 5e-324 gave 0 (R / d rounded to 0), 1e-320 was up to 0.2 % off (0.0674 for 0.0675)."""
    scene = pyshadow.Scene(ground=0.0)
    point, _ = point_light_radiance(scene, POINTS, NORMALS, PointLight(CENTRE, 3.0), 0.5)
    sphere, vis = point_light_radiance(scene, POINTS, NORMALS, PointLight(CENTRE, 3.0, radius=radius), 0.5,
                                       samples=16)
    np.testing.assert_allclose(sphere, point, rtol=4e-16)        # 16 equal cosines averaged: one rounding
    assert (vis == 1).all() and (point > 0).all()


def test_reference_radiance_beyond_float32_is_inf_as_shade():
    """A lamp of intensity 1e42 (finite) above the ground: shade gives +inf where the radiance leaves
    float32, and reference_radiance, which reproduces its shading on the same rays, gives the same. Before:
    reference_radiance raised "overflow encountered in cast" (a RuntimeWarning; an error with warnings as
    errors) where shade answered."""
    scene = pyshadow.Scene(ground=0.0)
    light = Lighting(lights=[PointLight(CENTRE, 1e42)])
    want = shade(scene, POINTS, NORMALS, light, backend="embree", surface_ids=-2)
    got = reference_radiance(scene, POINTS, NORMALS, light, samples=4, surface_ids=-2)
    assert np.isinf(want).all()
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("samples", [1, 16])
@pytest.mark.parametrize("backend", ["embree", "csm"])
def test_a_sphere_light_resting_on_the_ground_lights_the_point_it_touches(samples, backend):
    """A sphere lamp of radius 0.1 resting on the ground (centre 0.1 up): the ground point it touches lies on
    its surface, not within it, and sees it over its whole hemisphere: E = pi L = I / R^2 (one ray: I cos / d^2
    with d = R; 16 rays: the cone's factor 2 sin(pi / 4) / R squared times the rays' mean cosine, 1/2), the
    light reached. Before: refused ("point 0 lies within the sphere light (distance 0.1, light radius 0.1)"),
    so a grid of ground points through the contact could not be shaded."""
    r, i = 0.1, 2.0
    p, n = np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.0]]), np.tile([0.0, 1.0, 0.0], (2, 1))
    rad, vis = point_light_radiance(pyshadow.Scene(ground=0.0), p, n, PointLight([0.0, r, 0.0], i, radius=r), 0.5,
                                    samples=samples, backend=backend)
    np.testing.assert_allclose(rad[0], 0.5 / math.pi * i / r ** 2, rtol=1e-14)
    far, _ = point_light_radiance(pyshadow.Scene(ground=0.0), p[1:], n[1:], PointLight([0.0, r, 0.0], i, radius=r),
                                  0.5, samples=samples, backend=backend, indices=[1])
    np.testing.assert_array_equal(rad[1], far[0])                 # the other point as on its own
    assert (vis == 1).all()

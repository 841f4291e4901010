"""Lighting's local lights inside a caster's bounding sphere, Phong's "light on a surface" at any scale, and
extract_sun's radius against the largest sun Lighting takes.

Each test's docstring says what the code did before the fix.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

import pyshadow
import pyshadow.render as render_mod
from pyshadow.lighting import (DiscLight, EnvironmentMap, Lighting, PointLight, add_sun_disc, extract_sun, shade,
                               shade_terms)
from pyshadow.lighting.area import area_light_radiance
from pyshadow.lighting.local import lights_radiance, point_light_radiance
from pyshadow.lighting.phong import PhongLighting, phong_shade
from pyshadow.lighting.shade import MAX_SUN_RADIUS

SPHERE, BOX = trimesh.creation.icosphere(2, radius=0.5), trimesh.creation.box((1.0, 1.0, 1.0))
#: 0.8 above the unit box resting at (1.5, 0.5, 0): outside the box, inside its bounding sphere (r 0.866)
LAMP = PointLight([1.5, 1.3, 0.0], 5.0)


@pytest.fixture(scope="module")
def scene():
    """A sphere of radius 0.5 at (0, 1, 0) and a unit box on the ground at (1.5, 0.5, 0), with their meshes."""
    views = pyshadow.ViewSet.zigzag(8, 16)
    s = pyshadow.Scene(ground=0.0, views=views, resolution=32)
    for mesh, t in ((SPHERE, [0, 1, 0]), (BOX, [1.5, 0.5, 0])):
        s.add(pyshadow.CoherentShadowMap.build(mesh, views, resolution=32),
              trimesh.transformations.translation_matrix(t), mesh=mesh)
    return s


def _ground(n=10, half=3.0):
    x, z = np.meshgrid(np.linspace(-half, half, n), np.linspace(-half, half, n))
    return np.c_[x.ravel(), np.zeros(n * n), z.ravel()], np.tile([0.0, 1.0, 0.0], (n * n, 1))


def test_lighting_straddle_embree_shades_a_lamp_inside_a_casters_sphere(scene):
    """Was: TypeError (Lighting had no ``straddle``); shade() could not light such a lamp at all."""
    p, n = _ground()
    want, v = point_light_radiance(scene, p, n, LAMP, 0.5, surface_ids=-2, straddle="embree")
    assert 0 < (v > 0).sum() < len(v)               # the box shades part of the ground: the rays were traced
    lighting = Lighting(lights=[LAMP], straddle="embree", ground_albedo=0.5)
    t = shade_terms(scene, p, n, lighting, surface_ids=-2, sampling=pyshadow.Sampling(4))
    np.testing.assert_array_equal(t.sun, want.astype(np.float32))     # the same rays, the same answer
    assert lighting.straddle == "embree" and lighting.with_mode("sampled").straddle == "embree"
    # a disc light inside the sphere: its rays are answered by Embree too (area_light_radiance)
    disc = DiscLight([1.5, 1.2, 0.0], [0, -1, 0], 0.2, 5.0)
    want = area_light_radiance(scene, p, n, disc, 0.5, samples=4, surface_ids=-2, straddle="embree")[0]
    got = lights_radiance(scene, p, n, Lighting(lights=[disc], sun_samples=4, straddle="embree"), 0.5,
                          surface_ids=-2)
    np.testing.assert_array_equal(got, want)


def test_lighting_straddle_embree_renders(scene):
    """Was: render(lighting=Lighting(lights=[lamp])) raised ValueError and had no way to pass straddle."""
    cam = pyshadow.Camera([3.0, 2.6, 4.6], [0.85, 0.5, 0.2], width=24, height=16)
    lighting = Lighting(lights=[LAMP], straddle="embree")
    frame = render_mod.render(scene, cam, lighting=lighting, sampling=pyshadow.Sampling(4))
    truth = render_mod.render(scene, cam, lighting=lighting, sampling=pyshadow.Sampling(4), visibility="embree")
    assert np.isfinite(frame.radiance).all() and frame.radiance.max() > 0
    # no sky: the radiance is the lamp's alone; where the CSM and Embree agree on the shadow they agree exactly
    lit, lit_truth = frame.radiance.max(axis=2) > 0, truth.radiance.max(axis=2) > 0
    assert (lit == lit_truth).mean() >= 0.95
    both = lit & lit_truth
    np.testing.assert_allclose(frame.radiance[both], truth.radiance[both], rtol=1e-6)


def test_the_straddle_error_names_lightings_option(scene):
    """Was: "pass straddle='embree'", a keyword shade() and render() refused (TypeError)."""
    p, n = _ground(4)
    with pytest.raises(ValueError, match=r"pass Lighting\(straddle='embree'\)"):
        shade(scene, p, n, Lighting(lights=[LAMP]), surface_ids=-2, sampling=pyshadow.Sampling(4))


@pytest.mark.parametrize("bad", ["Embree", None, 1, ["embree"]])
def test_lighting_straddle_is_checked(bad):
    """Was: TypeError (no such argument); now PhongLighting's check."""
    with pytest.raises(ValueError, match="straddle must be one of"):
        Lighting(straddle=bad)


def _phong(s=1.0, off=(0.0, 0.0, 0.0), light=(0.3, 3.0, 0.4)):
    """phong_shade of three ground points in a sphere scene scaled by ``s`` and moved by ``off``."""
    off = np.asarray(off, np.float64)
    sc = pyshadow.Scene(ground=off[1], views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
    sc.add(SPHERE, trimesh.transformations.translation_matrix(s * np.array([0, 1, 0]) + off)
           @ np.diag([s, s, s, 1.0]))
    p = s * np.array([[1.0, 0, 0], [2.0, 0, 1.0], [-1.5, 0, 0.5]]) + off
    n = np.tile([0.0, 1, 0], (3, 1))
    lt = PhongLighting(s * np.asarray(light) + off, ao="off", specular=0.5, exponent=8.0)
    return phong_shade(sc, p, n, s * np.array([5.0, 5, 5]) + off, lt, surface_ids=-2)


@pytest.mark.parametrize("s", [1e-10, 1e-30, 1e20])
def test_phong_light_off_surfaces_is_scale_invariant(s):
    """Was: at scale 1e-10 "light lies on a surface: point 0 is at the light (distance 3.11e-10)"
    (an absolute tolerance of 1e-9; 1e-30 likewise; 1e20 passed and pins the large end); the colour does
    not depend on the scale (no falloff)."""
    c0, _, v0 = _phong()
    c, _, v = _phong(s)
    assert v.tolist() == v0.tolist() == [1.0, 1.0, 1.0]
    np.testing.assert_allclose(c, c0, rtol=1e-12)          # directions from scaled coordinates: a few roundings


@pytest.mark.parametrize("light", [(3.0, 0.005, 0.0), (1.0, 0.005, 0.0)])
def test_phong_light_off_surfaces_is_translation_invariant(light):
    """Was: moved by 1e7 along x, a light 0.005 above the ground (or above point 0) was refused as
    "on a surface" (tolerance 1e-9 * 1e7 = 0.01)."""
    c0, _, v0 = _phong(light=light)
    c, _, v = _phong(off=(1e7, 0.0, 0.0), light=light)
    assert v.tolist() == v0.tolist()
    # coordinates near 1e7 hold 1.9e-9: a direction over 0.005 is good to about 1e-6
    np.testing.assert_allclose(c, c0, rtol=1e-5, atol=1e-7)


def test_phong_light_on_a_surface_is_still_refused():
    """A light exactly at a shaded point, or exactly on the ground, far from the origin or tiny: refused.
    Was: at scale 1e-10 the light on the ground 2e-10 from point 0 was refused as "at the light"."""
    for s, off in ((1.0, (1e7, 0.0, 0.0)), (1e-10, (0.0, 0.0, 0.0)), (1.0, (0.0, 5e6, 0.0))):
        with pytest.raises(ValueError, match="point 0 is at the light"):
            _phong(s, off, light=(1.0, 0.0, 0.0))
        with pytest.raises(ValueError, match="ground plane"):
            _phong(s, off, light=(3.0, 0.0, 0.0))


def _env(disc, res=16):
    d = np.array([0.3, 0.8, 0.2]) / np.linalg.norm([0.3, 0.8, 0.2])
    return add_sun_disc(EnvironmentMap(np.ones((res, 2 * res, 3))), d, np.array([1e2] * 3), disc)


@pytest.mark.parametrize("kwargs", [{"radius": 1.0}, {"radius": 1.5}, {"max_radius": 1.0}])
def test_extract_sun_refuses_a_radius_lighting_refuses(kwargs):
    """Was: extract_sun(env, radius=1.0) returned a sun of angular_radius 1.0, which Lighting then refused
    ("sun angular_radius: must lie in [0, 0.785398]"); max_radius up to pi / 2 was taken."""
    with pytest.raises(ValueError, match=rf"{next(iter(kwargs))}.*MAX_SUN_RADIUS"):
        extract_sun(_env(0.01), **kwargs)


def test_extract_sun_at_the_limit_gives_a_sun_lighting_takes():
    """Was: a disc of radius 1 on a 16 x 32 map measured 1.13 rad with max_radius = pi / 4 (the region
    reaches a pitch past it): Lighting refused that sun. Now it is capped at MAX_SUN_RADIUS."""
    sun, sky = extract_sun(_env(1.0), radius=MAX_SUN_RADIUS, max_radius=MAX_SUN_RADIUS)
    assert sun.angular_radius == MAX_SUN_RADIUS
    assert Lighting(sky, sun=sun).sun.angular_radius == MAX_SUN_RADIUS
    small, _ = extract_sun(_env(0.01), radius=MAX_SUN_RADIUS)      # a sub-texel disc: the radius given
    assert small.angular_radius == MAX_SUN_RADIUS == math.pi / 4

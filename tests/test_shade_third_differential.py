"""Shading with lights and shadow maps (pyshadow.lighting.shade, .shadow_map) against Embree, the ground truth
for ray visibility, at grazing light over a lit caster face. Each test's docstring says what happened before
the fix."""
import math

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import visibility
from pyshadow.lighting.shadow_map import ShadowMapVisibility, lookup_reference, render_reference


def box_scene(offset=(0.0, 0.0, 0.0), s=1.0):
    """A box of side ``s`` standing on the ground at ``offset``; its CSMs are tiny (the shadow map needs the
    mesh only)."""
    o = np.asarray(offset, float)
    sc = pyshadow.Scene(ground=o[1], views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    sc.add(trimesh.creation.box((s, s, s)), trimesh.transformations.translation_matrix(o + [0, 0.5 * s, 0]))
    return sc


def box_top(m, offset=(0.0, 0.0, 0.0), s=1.0):
    """``m`` points on the box's top face (inside its edges by 5 % of its side), normals up."""
    rng = np.random.default_rng(1)
    p = np.c_[rng.uniform(-0.45, 0.45, m), np.ones(m), rng.uniform(-0.45, 0.45, m)] * s + offset
    return p, np.tile([0.0, 1.0, 0.0], (m, 1))


def sun(elevation_deg):
    e = math.radians(elevation_deg)
    d = np.array([math.cos(e), math.sin(e), 0.3 * math.cos(e)])
    return d / np.linalg.norm(d)


@pytest.mark.parametrize("elevation", [0.5, 2.0, 4.0])
@pytest.mark.parametrize("offset, s", [((0.0, 0.0, 0.0), 1.0), ((1e5, 3.0, -1e5), 1e-3)])
def test_a_low_sun_does_not_shadow_the_lit_face_it_grazes(elevation, offset, s):
    """A sun 0.5, 2 or 4 degrees over a box's top face (nothing above it): Embree lights all 1,000 points.
    Was: the receiver-plane rule followed slopes up to TAN_MAX = 10 only (84 degrees from the normal), and
    the shadow map shadowed the face itself at 256^2: 425, 334 and 38 of the 1,000 points hard (0.5, 2 and 4
    degrees), 963, 978 and 717 with 3x3 PCF not wholly lit, at the origin and moved 1e5 away at size 1e-3
    alike. Now every point is lit, hard and with PCF."""
    sc = box_scene(offset, s)
    p, n = box_top(1000, offset, s)
    w = np.tile(sun(elevation), (len(p), 1))
    assert visibility.visible(sc, p, w, normals=n, backend="embree").all()
    for pcf in (1, 3):
        frac = ShadowMapVisibility(256, pcf=pcf).lit_fraction(sc, p, w, normals=n)
        np.testing.assert_array_equal(frac, 1.0)


def test_the_numpy_mirror_follows_the_grazing_slope_as_the_kernel():
    """lookup_reference (float64) on render_reference's depths answers the 2 degree sun over the box top as
    sm_lookup does: every point lit (before: both shadowed about a third of the face, the mirror sharing
    TAN_MAX)."""
    sc = box_scene()
    p, n = box_top(500)
    d = sun(2.0)
    sm = ShadowMapVisibility(128).shadow_map(sc, direction=d)
    depth = render_reference(sc, d, 128)
    np.testing.assert_array_equal(lookup_reference(sm, depth, p, n, pcf=3), 1.0)
    np.testing.assert_array_equal(ShadowMapVisibility(128, pcf=3).lit_fraction(sc, p, np.tile(d, (len(p), 1)),
                                                                                normals=n), 1.0)


@pytest.mark.parametrize("lamp, face", [((0.1, 1.001, 0.2), "top"), ((0.1, 1.01, 0.2), "top"),
                                        ((0.5001, 0.5, 0.1), "side"), ((0.501, 1.001, 0.501), "top")])
@pytest.mark.parametrize("offset, s", [((0.0, 0.0, 0.0), 1.0), ((1e7, 1.0, 1e7), 1.0), ((0.0, 0.0, 0.0), 1e4)])
def test_a_lamp_close_over_a_face_lights_it_as_embree(lamp, face, offset, s):
    """A point light 1 mm or 1 cm over a unit box's top face, 0.1 mm beside its side face, or 1 mm off its top
    corner: Embree lights every one of the face's 1,000 points (nothing lies between). Was: the cube map's
    receiver plane, capped at a slope of 10, shadowed the face's points the lamp's rays graze: 726 of the top
    points (1 mm), 307 (1 cm), 999 of the side points, 956 (corner); alike at 1e7 from the origin and at scale
    1e4. Now none, and point_light_radiance equals Embree's."""
    from pyshadow.lighting import PointLight, point_light_radiance

    o = np.asarray(offset, float)
    sc = box_scene(o, s)
    m = 1000
    rng = np.random.default_rng(2)
    if face == "top":
        p, n = box_top(m, o, s)
    else:
        p = np.c_[np.full(m, 0.5), rng.uniform(0.05, 0.95, m), rng.uniform(-0.45, 0.45, m)] * s + o
        n = np.tile([1.0, 0.0, 0.0], (m, 1))
    light = np.asarray(lamp) * s + o
    w = light - p
    dist = np.linalg.norm(w, axis=1)
    w /= dist[:, None]
    assert visibility.visible(sc, p, w, normals=n, max_distance=dist, backend="embree").all()
    frac = ShadowMapVisibility(256).lit_fraction(sc, p, w, normals=n, max_distance=dist)
    np.testing.assert_array_equal(frac, 1.0)
    pl = PointLight(light, intensity=s * s)
    albedo = np.ones((m, 3))
    by_map = point_light_radiance(sc, p, n, pl, albedo, backend=ShadowMapVisibility(256))
    by_ray = point_light_radiance(sc, p, n, pl, albedo, backend="embree")
    np.testing.assert_array_equal(by_map[0], by_ray[0])
    np.testing.assert_array_equal(by_map[1], 1.0)


@pytest.mark.parametrize("offset, s", [((0.0, 0.0, 0.0), 1.0), ((1e5, 0.0, -1e5), 1e-3)])
@pytest.mark.parametrize("lamp", [(-3.0, 0.05, 0.0), (2.0, 0.02, -2.0)])
def test_a_lamp_by_the_floor_of_a_room_agrees_with_embree(offset, s, lamp):
    """A room whose floor is a caster (a 20 x 20 quad, a wall and a unit box on it), a lamp 5 cm or 2 cm over
    the floor: 4,000 floor points (normals up) asked at 1024^2. Was: 1487 (5 cm) and 1156 (2 cm) of them
    unlike Embree, at the origin and moved 1e5 away at size 1e-3 alike (the floor shadowed itself where the
    lamp's rays graze it, TAN_MAX = 10); now 10 and 6, bound 1 % (points within a texel of a shadow's edge,
    whose footprint on the floor grows as the rays graze it)."""
    from test_light_shadow_map_differential import room

    o = np.asarray(offset, float)
    sc = room(o, s)
    rng = np.random.default_rng(3)
    m = 4000
    p = np.c_[rng.uniform(-5, 2.9, m), np.zeros(m), rng.uniform(-5, 5, m)] * s + o
    n = np.tile([0.0, 1.0, 0.0], (m, 1))
    w = np.asarray(lamp) * s + o - p
    dist = np.linalg.norm(w, axis=1)
    w /= dist[:, None]
    truth = visibility.visible(sc, p, w, normals=n, max_distance=dist, backend="embree")
    got = ShadowMapVisibility(1024).visible(sc, p, w, normals=n, max_distance=dist)
    assert truth.sum() > 0.7 * m
    assert (got != truth).sum() < 0.01 * m

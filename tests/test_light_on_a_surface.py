"""A light on a caster's surface: Embree's finite rays end moved off it (pyshadow/_embree_lift.py ``end_epsilon``).

A lamp standing on a table: the shadow ray from a receiver ends on the table's top. Each test whose docstring
starts "Was:" failed on the code before the fix and says what happened; the others pin what the fix leaves
alone.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import visibility
from pyshadow.lighting import DiscLight
from pyshadow.lighting.area import area_light_radiance

SPHERE, BOX = trimesh.creation.icosphere(3, radius=0.5), trimesh.creation.box((1.0, 1.0, 1.0))


@pytest.fixture(scope="module")
def scene():
    """A sphere of radius 0.5 at (0, 1, 0) and a unit box resting on the ground at (1.5, 0.5, 0): its lid at y = 1."""
    s = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(16, 32), resolution=64)
    s.add(SPHERE, trimesh.transformations.translation_matrix([0, 1, 0]))
    s.add(BOX, trimesh.transformations.translation_matrix([1.5, 0.5, 0]))
    return s


def _towards(light, n=1200):
    """Points of the sphere facing ``light`` (world), unit directions to it and the distances (float64)."""
    p, f = trimesh.sample.sample_surface(SPHERE, n, seed=1)
    p = p + [0, 1, 0]
    w = light - p
    d = np.linalg.norm(w, axis=1)
    w /= d[:, None]
    front = np.einsum("ij,ij->i", w, SPHERE.face_normals[f]) > 0
    return p[front], w[front], d[front]


@pytest.mark.parametrize("backend", ["embree", "csm"])
def test_a_point_light_on_the_lid_lights_what_it_lights_just_above_it(scene, backend):
    """Was: Embree's segment ended exactly on the lid, which hid it by rounding: of the sphere's points facing a light
    at the lid's centre, 62 of 400 lit where the light 1e-6 above lights 222 (the CSM answers these rays, which end
    inside the box's bounding sphere, through Embree). Now the same points are lit, ray for ray."""
    on, above = np.array([1.5, 1.0, 0.0]), np.array([1.5, 1.0 + 1e-6, 0.0])
    p, w, d = _towards(on)
    lit_on = visibility.visible(scene, p, w, backend=backend, max_distance=d, straddle="embree")
    p2, w2, d2 = _towards(above)
    lit_above = visibility.visible(scene, p2, w2, backend=backend, max_distance=d2, straddle="embree")
    assert 0.3 * len(p) < lit_above.sum() < 0.7 * len(p)           # the box's lid hides some: rays are asked
    np.testing.assert_array_equal(lit_on, lit_above)


def test_a_disc_light_lying_on_the_lid_is_not_hidden_by_it(scene):
    """Was: a disc light of radius 0.3 lying on the lid, facing up, lit the sphere's points with a mean lit share of
    0.30 (233 points; its samples' rays ended on the lid), where raised 1e-7 it lights 241 with 0.996. Now the shares
    equal those of the raised disc within 1e-6 (the samples move 1e-7)."""
    p, _, _ = _towards(np.array([1.5, 1.3, 0.0]))
    n = (p - [0, 1, 0]) / 0.5
    share = [area_light_radiance(scene, p, n, DiscLight([1.5, y, 0.0], [0, 1, 0], 0.3, intensity=1.0), 0.5,
                                 backend="embree", surface_ids=0, samples=16)[1] for y in (1.0, 1.0 + 1e-7)]
    assert (share[1] > 0).sum() > 200 and share[1][share[1] > 0].mean() > 0.99
    np.testing.assert_allclose(share[0], share[1], rtol=0, atol=1e-6)


def test_a_light_just_inside_the_box_stays_hidden(scene):
    """What the fix leaves alone: the end moves back by the surface's lift (2e-5 of the scene's radius here, 1.7e-5),
    not through a surface: a light 1 mm under the lid, inside the box, is hidden from every point of the sphere."""
    p, w, d = _towards(np.array([1.5, 1.0 - 1e-3, 0.0]))
    assert not visibility.visible(scene, p, w, backend="embree", max_distance=d).any()


def test_a_light_far_from_the_origin_ends_its_rays_at_it():
    """Was (ea0087d, the end moved back as a float32 point's): a light at (1e7 + 2, 3, 0), which float32 holds exactly,
    was taken for a float32 point of a surface and the rays ended 4 units before it: 50 of 1,600 ground points
    shadowed by a sphere where the same scene at the origin has 112 (and the infinite rays 112 there too). Now the
    finite rays answer as at the origin, point for point."""
    out = []
    for ox in (0.0, 1e7):
        s = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
        s.add(SPHERE, trimesh.transformations.translation_matrix([ox, 1, 0]))
        x, z = np.meshgrid(np.linspace(-3, 3, 40), np.linspace(-3, 3, 40))
        p = np.c_[x.ravel() + ox, np.zeros(x.size), z.ravel()]
        w = np.array([ox + 2.0, 3.0, 0.0]) - p
        d = np.linalg.norm(w, axis=1)
        out.append(visibility.visible(s, p, w / d[:, None], backend="embree", max_distance=d))
    assert (~out[0]).sum() == 112
    np.testing.assert_array_equal(out[1], out[0])


@pytest.mark.parametrize("backend", ["embree", "csm"])
def test_a_lamp_under_a_shade_beside_a_large_body_keeps_its_shadow(backend):
    """Was (ea0087d .. fc446c0, the end moved back by the scene's lift, 2e-5 of its largest radius): beside a sphere of
    radius 1000 far away, a lamp 1 cm under a plate (a shade) stopped its rays 3 cm short, before the plate: 10 of the
    2,000 points over the plate shadowed where every one is (csm answers these rays through Embree). The end now moves
    back by the lift of the body its sphere lies in (the plate's) and the float32 rounding there."""
    s = pyshadow.Scene(ground=None, views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
    s.add(trimesh.creation.box((0.5, 0.002, 0.5)), trimesh.transformations.translation_matrix([0, 2.001, 0]))
    s.add(trimesh.creation.icosphere(2, 1000.0), trimesh.transformations.translation_matrix([10010.0, 0, 0]))
    rng = np.random.default_rng(0)
    p = np.column_stack([rng.uniform(-0.2, 0.2, 2000), np.full(2000, 3.0), rng.uniform(-0.2, 0.2, 2000)])
    w = np.array([0.0, 1.99, 0.0]) - p
    d = np.linalg.norm(w, axis=1)
    assert not visibility.visible(s, p, w / d[:, None], backend=backend, max_distance=d, straddle="embree").any()

"""Embree's ray lift near small casters standing on a large caster mesh (pyshadow._embree_lift.sphere_size).

The reference is the same small boxes on the analytic ground plane instead of a floor mesh: the plane
lies where the floor's top face lies, and with two casters of one size Embree lifts by their size.
"""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling, embree
from pyshadow import _embree_lift
from pyshadow._embree_lift import body_size, sphere_size, surface_epsilon

NEAR_SIZES = getattr(_embree_lift, "NEAR_SIZES", 64.0)      # (read so: the tests also run on the code before)

B = 0.01            # two 1 cm boxes, 5 mm apart
GAP = 0.005


def boxes_scene(floor_size):
    """The two boxes on a floor mesh of side ``floor_size`` (top face at y = 0), or on the ground plane."""
    scene = pyshadow.Scene(ground=None if floor_size else 0.0, views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    if floor_size:
        floor = trimesh.creation.box((floor_size, floor_size / 50, floor_size))
        floor.apply_translation([0.0, -floor_size / 100, 0.0])
        scene.add(floor)
    for x in (0.0, B + GAP):
        box = trimesh.creation.box((B, B, B))
        box.apply_translation([x, B / 2, 0.0])
        scene.add(box)
    return scene


def facing_side(n=150, seed=0):
    """Points on the first box's side facing the second box, and its normal."""
    rng = np.random.default_rng(seed)
    p = np.column_stack([np.full(n, B / 2), rng.uniform(0.05, 0.95, n) * B, rng.uniform(-0.45, 0.45, n) * B])
    return p, np.tile([1.0, 0.0, 0.0], (n, 1))


@pytest.mark.parametrize("floor_size", [100.0, 1000.0])
def test_ao_between_small_boxes_on_a_large_floor_mesh(floor_size):
    """Was: every ray from a small box's side was lifted 2e-5 of the floor's radius (the largest sphere
    holding the point: 1.4 mm on a 100 m floor, 14 mm on a 1 km one), across much or all of the 5 mm gap
    to the other box: Embree's AO there 0.236 / 0.000 against 0.294 on the ground plane (max error 0.125 /
    0.484 a point; float64 ray casting of the same rays agrees with the plane's scene)."""
    p, n = facing_side()
    s = Sampling(64, seed=2)
    want = embree.ambient_occlusion(boxes_scene(None), p, n, sampling=s)
    got = embree.ambient_occlusion(boxes_scene(floor_size), p, n, sampling=s)
    assert 0.2 < want.mean() < 0.4                     # the other box hides a good part of the sky
    # rays grazing the boxes' edges may round either way (other anchors): one sample a point at most
    assert np.abs(got - want).max() <= 1.0 / 64 + 1e-6
    assert np.abs(got - want).mean() <= 0.002


def test_visible_between_small_boxes_on_a_large_floor_mesh():
    """Was: of 9,600 rays from the side of a 1 cm box on a 1 km floor mesh, lifted 14 mm along themselves
    (past the other box's face 5 mm away), 1,547 read otherwise than in the ground-plane scene (72 % of
    them hidden there)."""
    p, n = facing_side(150, seed=1)
    d = pyshadow.sample_directions(n, sampling=Sampling(64, seed=3)).reshape(-1, 3).astype(np.float64)
    P = np.repeat(p, 64, axis=0)
    want = embree.visible(boxes_scene(None), P, d)
    got = embree.visible(boxes_scene(1000.0), P, d)
    assert 0.1 < (~want).mean() < 0.9
    assert (got != want).sum() <= 1e-3 * len(P)


def test_sphere_size_is_bounded_by_nearby_small_spheres():
    """A point on a small sphere held by a large one, one beside it, and one far from it."""
    c = np.array([[0.0, 0.0, 0.0], [0.0, 500.0, 0.0]])
    r = np.array([0.01, 700.0])
    P = np.array([[0.0, 0.01, 0.0],        # on the small one, inside the large one
                  [0.02, 0.0, 0.0],        # 1 cm beside the small one's sphere
                  [300.0, 0.0, 0.0]])      # far from the small one
    np.testing.assert_allclose(sphere_size(P, c, r), [NEAR_SIZES * 0.01, NEAR_SIZES * 0.01, 700.0], rtol=1e-6)
    scene = boxes_scene(100.0)
    p, _ = facing_side(4)
    assert (surface_epsilon(scene, p) < 0.01 * GAP).all()
    assert (body_size(scene, p) <= NEAR_SIZES * B).all()


def test_lamp_on_a_large_floor_mesh_beside_a_small_box():
    """Was: a point light standing on a 1 km floor mesh 3 mm beside a 1 cm box had its rays stopped 2e-5 of
    the floor's radius (14 mm) short of it (end_epsilon: the smallest sphere holding the end, the floor's),
    before they reached the box: 133 of 500 points behind the box read lit (all 3,000 of another sample once
    the start's lift alone was bounded); on the ground plane all are shadowed."""
    rng = np.random.default_rng(0)
    box_scene = boxes_scene(1000.0)
    light = np.array([B / 2 + 0.003, 0.0, 0.0])
    p = np.column_stack([rng.uniform(-0.05, -B / 2 - 1e-4, 500), rng.uniform(5e-4, 0.02, 500),
                         rng.uniform(-0.02, 0.02, 500)])
    d = light - p
    t = np.linalg.norm(d, axis=1)
    d /= t[:, None]
    # the second box stands beyond the light: only the first one lies between
    want = embree.visible(boxes_scene(None), p, d, max_distance=t)
    got = embree.visible(box_scene, p, d, max_distance=t)
    assert not want.any()
    np.testing.assert_array_equal(got, want)
    assert (_embree_lift.end_epsilon(box_scene, p, d, t) < 0.01 * 0.003).all()

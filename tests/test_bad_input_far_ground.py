"""The ground plane far from y = 0 asked with float32 points (pyshadow/contact.py ``ground_tolerance``).

Each test whose docstring starts "Was:" failed on the code before the fix and says what happened; the
others pin what the fix leaves alone.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import contact, embree, visibility
from pyshadow.lighting.shadow_map import ShadowMapVisibility

GROUND = 1000.1
SAMPLING = pyshadow.Sampling(16)


@pytest.fixture(scope="module")
def scene():
    """A unit box resting on a ground plane at y = 1000.1."""
    s = pyshadow.Scene(ground=GROUND, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    s.add(trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix([0, GROUND + .5, 0]))
    return s


def _open_ground(n=300, seed=1):
    """``n`` points of the plane 3-6 m from the box (float64): nothing above them but the sky."""
    xz = np.random.default_rng(seed).uniform(3.0, 6.0, (n, 2))
    return np.column_stack([xz[:, 0], np.full(n, GROUND), xz[:, 1]])


def test_float32_points_are_below_the_plane_by_more_than_the_scale_tolerance(scene):
    """Was (the tolerance itself): rounded to float32, every such point lies up to 2.4e-5 below the plane, beyond 1e-5 of
    the scale (8.7e-6 for the unit box) but within the plane's tolerance (one float32 spacing, 6.1e-5)."""
    depth = GROUND - _open_ground().astype(np.float32)[:, 1].astype(np.float64)
    assert (depth > 0).all() and depth.max() > 2 * 1e-5 * scene.scale()
    assert depth.max() <= 0.5 * np.spacing(np.float32(GROUND))
    assert contact.ground_tolerance(scene) == float(np.spacing(np.float32(GROUND)))


@pytest.mark.parametrize("how", [dict(), dict(lookup="vote"), dict(backend="numpy"), "embree"])
def test_float32_points_on_a_far_ground_see_the_sky(scene, how):
    """Was: every backend (Embree's ground test too) counted the float32 points as below the plane, so
    every ray upwards crossed it: AO 0.0 where the same points in float64 read 0.999. Now the float32
    points' AO is the float64 points' exactly."""
    p64 = _open_ground()
    up = np.tile([0.0, 1.0, 0.0], (len(p64), 1))
    if how == "embree":
        ask = lambda p: embree.ambient_occlusion(scene, p, up, sampling=SAMPLING)  # noqa: E731
    else:
        ask = lambda p: scene.ambient_occlusion(p, up, sampling=SAMPLING, **how)  # noqa: E731
    want = ask(p64)
    assert want.mean() > 0.99
    np.testing.assert_array_equal(ask(p64.astype(np.float32)), want)


def test_float32_points_on_a_far_ground_see_the_sun(scene):
    """Was: ``visible`` towards a sun above answered every float32 point shadowed (kernel, NumPy mirror,
    Embree, shadow map), float64 points lit; now both lit, and a point 1e-4 below the plane (beyond the
    tolerance) stays shadowed."""
    p = _open_ground(100).astype(np.float32)
    sun = np.tile(np.array([0.1, 1.0, 0.2]) / np.linalg.norm([0.1, 1.0, 0.2]), (len(p), 1))
    for backend in ("csm", "numpy", "embree", ShadowMapVisibility(64)):
        assert visibility.visible(scene, p, sun, backend=backend).all(), backend
        below = p.astype(np.float64) - [0.0, 1e-4, 0.0]
        assert not visibility.visible(scene, below, sun, backend=backend).any(), backend


def test_planes_near_the_origin_keep_the_scale_tolerance():
    """Where ``|ground|`` is under about 84 x the scale the tolerance is 1e-5 x the scale, as before."""
    for ground, scale in ((0.0, 1.0), (-3.0, 1.0), (80.0, 1.0), (1.0e4, 200.0), (0.05, 1e-3)):
        assert contact.plane_tolerance(scale, ground) == 1e-5 * scale
    assert contact.plane_tolerance(2.0, None) == 2e-5
    assert contact.plane_tolerance(1.0, 1.0e4) == float(np.spacing(np.float32(1.0e4)))


@pytest.mark.parametrize("lift, rests", [(0.0, True), (3e-5, False)])
def test_a_body_rests_on_a_far_ground_within_the_scale_tolerance_only(lift, rests):
    """The faces' tolerance stays 1e-5 of the scale (8.7e-6 here): a box lifted 3e-5 above a plane at
    y = 1000.1 (within the points' float32 spacing, 6.1e-5) has no footprint, so the ground under it
    stays the CSM's; resting, it has one."""
    s = pyshadow.Scene(ground=GROUND, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    s.add(trimesh.creation.box((1.0, 1.0, 1.0)),
          trimesh.transformations.translation_matrix([0, GROUND + 0.5 + lift, 0]))
    assert len(contact.footprints(s)) == int(rests)


def test_the_lid_of_a_slab_resting_on_a_far_ground_sees_the_sky():
    """Was: with the plane at y = 1e7 (float32 spacing 1) the float64 points of a 0.5-high slab's lid lay
    within one float32 spacing of the plane, so the footprint test took them for ground under the slab:
    every ray of theirs upwards was occluded (0 of 100 open, AO 0.0, on the kernel and the NumPy mirror;
    Embree 100 and 1.0). A height float32 holds exactly may carry half a float32 spacing of rounding, any
    other height one float64 spacing (contact._on_plane); now 100 open, AO 1, as at y = 0."""
    slab = trimesh.creation.box((2.0, 0.5, 2.0))
    rng = np.random.default_rng(0)
    lid = np.column_stack([rng.uniform(-0.9, 0.9, 100), np.full(100, 0.5), rng.uniform(-0.9, 0.9, 100)])
    up = np.tile([0.0, 1.0, 0.0], (100, 1))
    for y in (0.0, 1e7):
        s = pyshadow.Scene(ground=y, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
        s.add(slab, trimesh.transformations.translation_matrix([0, y + 0.25, 0]))
        p = lid + [0.0, y, 0.0]
        assert not contact.contact_mask(s, p).any()
        for backend in ("csm", "numpy"):
            assert visibility.visible(s, p, up, backend=backend, surface_ids=0, normals=up).all()
            ao = visibility.ambient_occlusion(s, p, up, backend=backend, sampling=SAMPLING, surface_ids=0)
            assert ao.min() > 0.9, (y, backend)


@pytest.mark.parametrize("backend", ["csm", "numpy", "csm-vote", "numpy-vote"])
def test_rays_along_the_ground_from_under_a_resting_body_are_occluded(backend):
    """Was: a ray exactly along the ground (w_y = 0) from a point under a resting box (inside its contact
    footprint) kept the CSM's answer, undefined inside a solid: 84 of 1000 read open with the one-texel
    lookup, 324 with the vote (Embree: 0). The footprint's rule now takes them too: all occluded."""
    s = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
    s.add(trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix([0, 0.5, 0]))
    rng = np.random.default_rng(0)
    g = rng.uniform(-0.45, 0.45, (400, 3))
    g[:, 1] = 0.0
    assert contact.contact_mask(s, g).all()
    a = rng.uniform(0.0, 2.0 * np.pi, len(g))
    along = np.column_stack([np.cos(a), np.zeros(len(g)), np.sin(a)])
    assert not visibility.visible(s, g, along, backend=backend, surface_ids=-2).any()

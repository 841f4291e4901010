"""Distance AO (pyshadow.visibility.finite) on the CSM backend and its NumPy mirror against Embree where the ground plane
meets straddling rays: a box resting on the ground, AO of points on its side faces."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import visibility

SAMPLING = pyshadow.Sampling(32)


def box_scene(ground):
    scene = pyshadow.Scene(ground=0.0 if ground else None, views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), np.array([[1.0, 0, 0, 0], [0, 1, 0, 0.5], [0, 0, 1, 0],
                                                               [0, 0, 0, 1]]))
    return scene


@pytest.fixture(scope="module")
def scenes():
    return box_scene(True), box_scene(False)


def side_points(heights):
    """Points on the box's face x = 0.5 (normal +x) at the given heights, z spread over the face."""
    h = np.asarray(heights, np.float64)
    p = np.column_stack([np.full(len(h), 0.5), h, np.linspace(-0.4, 0.4, len(h))])
    return p, np.tile([1.0, 0.0, 0.0], (len(h), 1))


@pytest.mark.parametrize("backend", ["csm", "numpy"])
@pytest.mark.parametrize("straddle", ["infinite", "error"])
def test_ground_beyond_the_end_does_not_darken_straddling_rays(scenes, straddle, backend):
    """Rays of length 0.2 from the side faces (heights 0.3-0.7) end inside the box's bounding sphere and
    never reach the ground 0.3 or more below: nothing is met, AO is exactly 1 (Embree: 1; the same box
    without a ground plane: 1). Before, the plane blocked the unbounded rays going down, which made them
    undecided: 'infinite' kept them occluded (AO 0.5 at every point), 'error' refused."""
    ground, bare = scenes
    p, n = side_points(np.linspace(0.3, 0.7, 12))
    kw = dict(sampling=SAMPLING, surface_ids=0, max_distance=0.2)
    emb = visibility.ambient_occlusion(ground, p, n, backend="embree", **kw)
    assert np.array_equal(emb, np.ones(len(p), np.float32))
    for scene in (ground, bare):
        got = visibility.ambient_occlusion(scene, p, n, straddle=straddle, backend=backend, **kw)
        assert np.array_equal(got, np.ones(len(p), np.float32)), (straddle, got)


@pytest.mark.parametrize("backend", ["csm", "numpy"])
def test_ground_within_the_length_is_decided(scenes, backend):
    """From heights 0.05-0.15 rays of length 0.4 going down meet the ground within their length (the
    plane's rule decides them, occluded) or end above it (the casters decide): with straddle='error'
    nothing is refused, and every point's AO equals Embree's on the same rays (the box's faces are
    axis-aligned: the CSM's texel error does not reach these rays). Before, every such ray going down
    was undecided and 'error' refused the points."""
    ground, _ = scenes
    p, n = side_points(np.linspace(0.05, 0.15, 12))
    kw = dict(sampling=SAMPLING, surface_ids=0, max_distance=0.4)
    emb = visibility.ambient_occlusion(ground, p, n, backend="embree", **kw)
    assert 0.5 < emb.min() and emb.max() < 0.9
    for straddle in ("error", "infinite"):
        got = visibility.ambient_occlusion(ground, p, n, straddle=straddle, backend=backend, **kw)
        assert np.array_equal(got, emb), (straddle, got, emb)

"""Tables kept between queries (pyshadow.visibility.held) for a scene without casters."""
import numpy as np

import pyshadow
from pyshadow.scene_arrays import scene_arrays
from pyshadow.visibility import ambient_occlusion, visible


def test_ground_only_scene_keeps_no_far_anchors():
    """Was: a scene with a ground plane and no casters anchors each query at the mean of its points, and
    ``held_at`` kept an (empty) far-anchor entry for every one of them: 3,001 entries after 3,001 queries
    of 64 rays, each new query re-summing the bytes of all of them (0.2 ms a query at first, 10 ms after
    1,000, 28 ms after 3,000; memory growing some 440 bytes a query). Now none is kept and the answers
    are the ground plane's."""
    s = pyshadow.Scene(ground=0.0)
    rng = np.random.default_rng(0)
    for _ in range(40):
        p = rng.uniform(-5.0, 5.0, (8, 3))
        p[:, 1] = rng.uniform(0.1, 2.0, 8)
        w = rng.normal(size=(8, 3))
        w[:, 1] = np.where(np.abs(w[:, 1]) < 0.05, 0.5, w[:, 1])     # clear of grazing the plane
        got = visible(s, p, w)
        np.testing.assert_array_equal(got, w[:, 1] > 0)
    n = 5
    p = np.c_[rng.uniform(-3, 3, n), np.zeros(n), rng.uniform(-3, 3, n)]
    ao = ambient_occlusion(s, p, np.tile([0.0, 1.0, 0.0], (n, 1)), sampling=pyshadow.Sampling(16))
    np.testing.assert_array_equal(ao, np.ones(n, np.float32))
    assert len(scene_arrays(s).get("far_anchors", {})) == 0

"""The straddle error of distance-limited AO names the caller's point, not a flattened ray index.

Before, ``ambient_occlusion(points, ..., max_distance=...)`` raised "AO ray 49 (and 7 more) ... ends
inside the bounding sphere" for the fourth of four points: 49 was the ray's index among the points'
flattened samples (point-major), or, in the CSM backend, among the rays of one chunk of the points that
the shell test had left; no argument of the caller has 49 entries.
"""
import numpy as np
import pytest
import trimesh

import pyshadow

# three points far from the box (clear), the fourth beside it: its short rays towards the box straddle
POINTS = np.array([[10.0, 0.0, 10.0], [12.0, 0.0, 10.0], [10.0, 0.0, 12.0], [0.55, 0.0, 0.0]])
UP = np.tile([0.0, 1.0, 0.0], (4, 1))


@pytest.mark.parametrize("backend", ["csm", "csm-vote", "numpy"])
@pytest.mark.parametrize("order", [[0, 1, 2, 3], [3, 0, 1, 2], [1, 3, 2, 0]])
def test_the_error_names_the_point_and_its_sample(backend, order):
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix([0, 0.5, 0]))
    sampling = pyshadow.Sampling(16)
    want = order.index(3)
    with pytest.raises(ValueError, match=rf"^AO sample (\d+) of point {want} \(and \d+ more\) of length 0\.3 "
                                         r"ends inside the bounding sphere of caster instance 0") as err:
        scene.ambient_occlusion(POINTS[order], UP, sampling=sampling, max_distance=0.3, backend=backend)
    # the named sample is one of that point's rays that does meet the box (ray traced: it points at it)
    s = int(err.value.args[0].split()[2])
    d = sampling.directions(UP[:1], indices=np.array([want]))[0, s]
    assert d[0] < 0.0                      # towards the box, which lies at x < 0.5 from the point at x = 0.55

"""The ground quad's default size (``render.ground_quad``): the largest ``norm(c - anchor) + r`` over the
instances' world spheres, the same float as taken row by row with ``np.linalg.norm``."""
import numpy as np
import pytest

import pyshadow
from pyshadow.render import ground_quad
from pyshadow.scene_arrays import scene_arrays


@pytest.mark.parametrize("far", [1.0, 1e4, 1e7])
def test_ground_quad_size_is_the_row_by_row_reach(box_csm, far):
    """500 boxes at random places (spread 0.3-30 m, 1 to 1e7 from the origin) and scales 0.01-100, with
    near-ties (boxes mirrored about the anchor): the quad's half side is 8 times the row-by-row reach,
    bit for bit."""
    box, csm = box_csm
    rng = np.random.default_rng(int(far))
    scene = pyshadow.Scene(ground=0.0)
    T = np.tile(np.eye(4), (500, 1, 1))
    T[:, :3, :3] *= rng.uniform(0.01, 100.0, 500)[:, None, None]
    T[:, :3, 3] = far + rng.uniform(-30, 30, (500, 3)) * rng.uniform(0.01, 1, (500, 1))
    T[250:, :3, 3] = 2 * far - T[:250, :3, 3]           # mirrored pairs: equal distances up to rounding
    scene.add(csm, T, mesh=box)
    held, anchor = scene_arrays(scene), scene.anchor()
    reach = max(np.linalg.norm(c - anchor) + r for c, r in zip(held["world_centre"], held["world_radius"]))
    v = ground_quad(scene).vertices
    h = 0.5 * 16.0 * reach
    assert v[1, 0] == anchor[0] + h and v[0, 0] == anchor[0] - h and v[2, 2] == anchor[2] + h

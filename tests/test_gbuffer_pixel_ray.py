"""The G-buffer kernel's pixel rays on images much wider than tall (one rounding of the pixel's offset)."""
import numpy as np
import pytest
import trimesh

from pyshadow import Camera
from pyshadow.gbuffer import render_gbuffer, render_gbuffer_reference


def _tilted_wall():
    """A wide wall in front of the eye, z = 3 + 0.2 x: its distance along a pixel's ray follows the ray's
    horizontal slope, so an error in that slope shows in the depth."""
    v = np.array([[-10.0, -50.0, 1.0], [100.0, -50.0, 23.0], [100.0, 50.0, 23.0], [-10.0, 50.0, 1.0]])
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)


@pytest.mark.parametrize("width", [1000, 2000, 3001])
def test_one_row_depths_follow_the_float64_ray(width):
    """Was: the kernel formed a pixel's horizontal offset as 2 (col + 0.5) / W - 1 in float32, two
    roundings, the first of them a float32 spacing of a number near 1, which the image's tangent
    (width * tan(30 deg): 577 to 1733 here) then multiplies: the wall's depths were up to 9.1e-6, 1.8e-5
    and 3.2e-5 off the float64 ray's (relative). Now the offset is the exact integer 2 col + 1 - W over W,
    one rounding, and the depths agree to float32's products (measured at most 3.4e-7; bound 3e-6: a few
    roundings of 6e-8 in corners and slopes, times 1 / cos <= 5 off the grazing pixels)."""
    cam = Camera(eye=(0.0, 0.0, 0.0), target=(0.0, 0.0, 1.0), width=width, height=1, fov_y=60.0)
    items = [(_tilted_wall(), np.eye(4))]
    got = render_gbuffer(items, cam)["depth"].astype(np.float64)
    ref = render_gbuffer_reference(items, cam)
    want = ref["depth"]
    assert np.array_equal(np.isfinite(got), np.isfinite(want))
    facing = np.abs(np.einsum("...k,...k", cam.ray_directions(), ref["normal"]))
    hit = np.isfinite(want) & (facing > 0.2)        # not grazing: 1 / cos multiplies every rounding
    assert hit.sum() >= 5
    rel = np.abs(got[hit] / want[hit] - 1.0)
    assert rel.max() < 3e-6, rel.max()

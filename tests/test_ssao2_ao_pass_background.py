"""pyshadow.ao_pass.ao_pass on a G-buffer whose background depth is 0 rather than +inf."""
import numpy as np
import pytest

from pyshadow.ao_pass import ao_pass


def _gbuffer(background):
    H, W = 12, 17
    obj = np.full((H, W), -1, np.int32)
    obj[3:, :11] = 0                     # a wall, and the ground before it
    obj[8:, :] = 1
    depth = np.where(obj == -1, background, 4.0 + 0.05 * np.arange(H)[:, None] + 0.0 * np.arange(W))
    normal = np.zeros((H, W, 3))
    normal[obj == 0] = (0.0, 0.0, 1.0)
    normal[obj == 1] = (0.0, 1.0, 0.0)
    return obj, depth.astype(np.float32), normal.astype(np.float32)


@pytest.mark.parametrize("scale", [2, 4])
def test_zero_background_depth_is_background_without_warnings(scale):
    """Was: "RuntimeWarning: divide by zero encountered in divide" from ao_pass (each pixel's relative depth
    to its block's sample) on the background pixels of a G-buffer with depth 0 there, which render(gbuffer=...,
    ao_scale=2) passes on (it checks the covered pixels' depths only): under warnings as errors that warning,
    not the filters' "depth must be > 0 ... or +inf (background)", was what the caller saw. The pixels chosen
    are those of a +inf background."""
    want = ao_pass(*_gbuffer(np.inf), scale, 2)
    got = ao_pass(*_gbuffer(0.0), scale, 2)          # filterwarnings=error: a warning fails here
    np.testing.assert_array_equal(got, want)
    assert want[::scale, ::scale][_gbuffer(np.inf)[0][::scale, ::scale] != -1].all()

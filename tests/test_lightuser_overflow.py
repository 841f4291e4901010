"""A lit frame beyond float32's range is +inf without a warning, as shade()'s points are (lightuser, s36)."""
import warnings

import numpy as np
import pytest

import pyshadow
from pyshadow.lighting import EnvironmentMap, Lighting, shade


@pytest.fixture(scope="module")
def small():
    return pyshadow.data.default_scene(views=pyshadow.ViewSet.zigzag(4, 8), resolution=16, width=16, height=12)


@pytest.mark.parametrize("mode", ["bent", "sampled"])
def test_lit_frame_beyond_float32_is_inf_without_a_warning(small, mode):
    scene, camera = small
    a = np.ones((8, 16, 3))
    a[1, 4] = 1e300                                     # finite, allowed (<= MAX_RADIANCE); its integral too
    light = Lighting(EnvironmentMap(a), mode=mode)
    with warnings.catch_warnings():
        warnings.simplefilter("error")                  # was: RuntimeWarning "overflow encountered in cast"
        frame = scene.render(camera, sampling=pyshadow.Sampling(8), lighting=light)
        r = frame.radiance
        assert r.dtype == np.float32 and np.isposinf(r).any() and not np.isnan(r).any()
        covered = frame.object_id != -1                 # (the ground plane is covered too)
        if mode == "bent":                              # shade()'s documented answer, the frame's too
            assert np.isposinf(shade(scene, np.array([[2.5, 1.5, 3.0]]), np.array([[0.0, 1.0, 0.0]]), light)).all()
        assert (r[~covered] == 0).all()

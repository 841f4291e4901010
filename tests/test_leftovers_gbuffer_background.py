"""render(gbuffer=...) with a G-buffer whose background depth is not +inf (0 from a cleared depth buffer)."""
import numpy as np
import pytest
import trimesh

import pyshadow as ps
from pyshadow.gbuffer import render_gbuffer
from pyshadow.render import render


def box_scene():
    """A unit box (a receiver) standing on the ground, and a 32x24 camera that sees it and the sky."""
    scene = ps.Scene(ground=0.0)
    T = np.eye(4)
    T[1, 3] = 0.5
    scene.add(trimesh.creation.box((1, 1, 1)), transform=T, casts=False)
    return scene, ps.Camera(eye=(2.5, 1.5, 2.5), target=(0, 0.6, 0), up=(0, 1, 0), fov_y=60, width=32, height=24)


@pytest.fixture(scope="module")
def setup():
    scene, cam = box_scene()
    items, _ = scene.draw_items(4.0)
    g = render_gbuffer(items, cam)
    assert (g["object_id"] < 0).any() and (g["object_id"] >= 0).any() and np.isinf(g["depth"][g["object_id"] < 0]).all()
    return scene, cam, g


@pytest.mark.parametrize("ao_scale, denoise", [(1, None), (2, None), (4, None), (1, "bilateral"), (2, "box")])
@pytest.mark.parametrize("background", [0.0, np.nan, -1.0])
def test_a_background_depth_other_than_inf_is_background(setup, ao_scale, denoise, background):
    """Was: with ao_scale 2 or 4, or a denoiser, ValueError "depth must be > 0 (at least 1.18e-38) or +inf
    (background)" from the filters, which name no gbuffer (render checks the covered pixels' depths only, and
    ao_scale=1 without a filter read the zeros nowhere). The frame is now that of the +inf background: AO 1 and
    depth +inf there, every buffer equal."""
    scene, cam, g = setup
    given = {k: np.array(v) for k, v in g.items()}
    back = given["object_id"] < 0
    given["depth"][back] = background
    opts = dict(visibility="embree", ao_scale=ao_scale, denoise=denoise, ground_size=4.0)
    want = render(scene, cam, gbuffer=g, **opts)
    got = render(scene, cam, gbuffer=given, **opts)
    assert (got.ao[back] == 1.0).all() and np.isinf(got.depth[back]).all()
    for name in ("ao", "bent_normal", "depth", "normal", "position", "object_id"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)
    assert np.array_equal(given["depth"][back], np.full(back.sum(), background), equal_nan=True)   # not edited


def test_a_covered_pixel_without_a_depth_is_still_refused(setup):
    scene, cam, g = setup
    given = {k: np.array(v) for k, v in g.items()}
    given["depth"][np.argwhere(given["object_id"] >= 0)[0][0], np.argwhere(given["object_id"] >= 0)[0][1]] = 0.0
    with pytest.raises(ValueError, match=r"gbuffer\['depth'\] must be finite and > 0 where object_id >= 0.*1 other"):
        render(scene, cam, gbuffer=given, visibility="embree", ao_scale=2, ground_size=4.0)

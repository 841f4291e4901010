"""The render stage on awkward input: image sizes that are no multiple of ao_scale, ao_scale values
that are no integer, G-buffers handed in that lack what the Frame needs or hold no surface in front
of the camera."""
import numpy as np
import pytest

import pyshadow
from pyshadow import Sampling, embree
from pyshadow import render as render_stage
from pyshadow.ao_pass import ao_pass


def small_camera(width=48, height=32):
    """test_render's camera: small_scene's box, its contact with the ground and the background."""
    return pyshadow.Camera([2.0, 1.5, 3.0], [0.0, 0.3, 0.0], width=width, height=height)


@pytest.mark.parametrize("ao_scale", [2, 4])
def test_ao_scale_bent_normals_are_the_ao_passs_and_the_sky_term_upsamples_them(small_scene, ao_scale):
    """With ao_scale > 1, Frame.bent_normal holds the AO pass's bent normals (the full render's, unit: its
    grid and its pixels off the grid, pyshadow.ao_pass) and 0 on the other pixels, as documented; the sky
    term upsamples them like the AO, channel by channel with fill 0, made unit, except at the pass's
    pixels off its grid, which keep their own (the render's radiance equals that computed by hand)."""
    from pyshadow.lighting import Lighting, overcast_sky
    from pyshadow.lighting.shade import sky_radiance

    cam = small_camera(41, 27)
    s = Sampling(8)
    full = small_scene.render(cam, sampling=s)
    light = Lighting(sky=overcast_sky(1000.0, height=16), albedo=0.5)
    frame = render_stage.render(small_scene, cam, sampling=s, ao_scale=ao_scale, lighting=light)
    hit = frame.object_id != -1
    grid = np.zeros(hit.shape, bool)
    grid[::ao_scale, ::ao_scale] = True
    assert (hit & grid).any() and (hit & ~grid).any()
    own = ao_pass(full.object_id, full.depth, full.normal, ao_scale, 2) & ~grid    # the pass's pixels off its grid
    np.testing.assert_array_equal(frame.bent_normal[grid | own], full.bent_normal[grid | own])
    np.testing.assert_allclose(np.linalg.norm(frame.bent_normal[hit & (grid | own)], axis=-1), 1, atol=1e-5)
    assert (frame.bent_normal[~grid & ~own] == 0).all()
    up = np.stack([pyshadow.filters.upsample(frame.bent_normal[::ao_scale, ::ao_scale, c], frame.depth,
                                             frame.normal, scale=ao_scale, fill=0.0) for c in range(3)], axis=2)
    up[own] = frame.bent_normal[own]                # those keep their own, as their AO
    b = up[hit].astype(np.float64)
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    want = sky_radiance(light, frame.ao[hit], b, np.full((int(hit.sum()), 3), 0.5))
    sun = frame.radiance[hit] - want
    assert np.abs(sun).max() <= 1e-5 * np.abs(want).max()


@pytest.mark.parametrize("width, height, ao_scale", [(3, 2, 2), (3, 2, 4), (2, 3, 4)])
def test_ao_scale_computes_covered_pixels_that_no_sample_reaches(small_scene, width, height, ao_scale):
    """A covered pixel whose upsampling window held no covered low-res pixel got upsample's fill, AO 1
    (unoccluded), and a bent normal 0, though nothing was computed there: a 2 x 3 image at ao_scale=4
    whose pixel (0, 0) sees the sky drew the box (AO 0.5) and the ground as 1. Now those pixels get
    their own AO and bent normal, the full render's; denoising then filters that image."""
    cam = small_camera(width, height)
    s = Sampling(8)
    full = small_scene.render(cam, sampling=s)
    frame = small_scene.render(cam, sampling=s, ao_scale=ao_scale)
    hit = frame.object_id != -1
    assert hit.any() and (full.ao[hit] < 1).any()
    assert not hit[::ao_scale, ::ao_scale].any()            # no sample of the AO pass sees a surface
    assert frame.ao.shape == (height, width) and frame.bent_normal.shape == (height, width, 3)
    np.testing.assert_array_equal(frame.ao, full.ao)
    np.testing.assert_array_equal(frame.bent_normal, full.bent_normal)
    both = small_scene.render(cam, sampling=s, ao_scale=ao_scale, denoise="bilateral")
    np.testing.assert_array_equal(both.ao, pyshadow.filters.bilateral(full.ao, full.depth, full.normal))


@pytest.mark.parametrize("ao_scale", [2.0, 1.0, np.float64(4.0), np.True_, np.array(2), 2 + 0j])
def test_render_refuses_an_ao_scale_that_is_no_integer(small_scene, no_launch, ao_scale):
    """2.0 passed the check (2.0 in (1, 2, 4)) and failed after rasterising with NumPy's 'slice
    indices must be integers'; np.True_ was taken for 1."""
    with pytest.raises(ValueError, match="ao_scale must be 1, 2 or 4, got"):
        render_stage.render(small_scene, small_camera(), ao_scale=ao_scale)


@pytest.mark.parametrize("ao_scale", [0, -1, 3, 8, 2.0])
def test_surface_points_refuse_an_ao_scale_not_1_2_4(small_scene, ao_scale):
    """covered_pixels and surface_points took any step: -1 kept every pixel, 3 every third, 0 failed
    with NumPy's 'slice step cannot be zero'."""
    cam = small_camera(12, 8)
    g = embree.gbuffer(small_scene.draw_items(30.0)[0], cam)
    obj = np.where(g["object_id"] >= 0, 0, -1).astype(np.int32)
    with pytest.raises(ValueError, match="ao_scale must be 1, 2 or 4"):
        render_stage.covered_pixels(cam, g, obj, ao_scale=ao_scale)
    with pytest.raises(ValueError, match="ao_scale must be 1, 2 or 4"):
        render_stage.surface_points(small_scene, cam, gbuffer=g, ground_size=30.0, ao_scale=ao_scale)


def _gbuffer(scene, cam):
    return {k: np.array(v) for k, v in embree.gbuffer(scene.draw_items(30.0)[0], cam).items()}


def test_render_refuses_a_gbuffer_without_positions(small_scene, no_launch):
    """The G-buffer check asked for object_id, depth and normal only; render then failed with a bare
    KeyError: 'position' when it built the Frame."""
    cam = small_camera(12, 8)
    g = _gbuffer(small_scene, cam)
    del g["position"]
    with pytest.raises(ValueError, match="gbuffer lacks 'position'"):
        render_stage.render(small_scene, cam, gbuffer=g, ground_size=30.0)
    render_stage.surface_points(small_scene, cam, gbuffer=g, ground_size=30.0)   # needs no positions


@pytest.mark.parametrize("value", [-1.0, 0.0, np.inf, np.nan])
def test_render_refuses_a_gbuffer_without_a_surface_in_front(small_scene, no_launch, value):
    """A depth <= 0 on a covered pixel put its point behind the eye and was shaded there without a
    word (inf and NaN failed later as 'points: ... rows are not finite')."""
    cam = small_camera(12, 8)
    g = _gbuffer(small_scene, cam)
    covered = g["object_id"] >= 0
    g["depth"][covered.nonzero()[0][0], covered.nonzero()[1][0]] = value
    with pytest.raises(ValueError, match=r"gbuffer\['depth'\] must be finite and > 0 where object_id >= 0"):
        render_stage.render(small_scene, cam, gbuffer=g, ground_size=30.0)


def test_render_refuses_a_gbuffer_of_objects(small_scene, no_launch):
    """A depth of dtype object was taken and came back as Frame.depth of dtype object."""
    cam = small_camera(12, 8)
    g = _gbuffer(small_scene, cam)
    g["depth"] = g["depth"].astype(object)
    with pytest.raises(TypeError, match=r"gbuffer\['depth'\] must be floats, got object"):
        render_stage.render(small_scene, cam, gbuffer=g, ground_size=30.0)


@pytest.mark.parametrize("phong", [False, True])
def test_ao_scale_lights_covered_pixels_that_no_sample_reaches(small_scene, phong):
    """The lit paths shaded those pixels with AO 1 and the shading normal for a bent normal: the box of
    the 2 x 3 image at ao_scale=4 (AO 0.5) came out up to 0.3 too bright. Now the radiance is the full
    render's."""
    from pyshadow.lighting import DirectionalLight, Lighting, PhongLighting

    sky = np.zeros((9, 3))
    sky[0], sky[2] = [3.0, 2.5, 2.0], [0.8, 0.6, 0.4]
    sun = DirectionalLight([0.6, 0.8, 0.0], [1.0, 1.0, 1.0])
    light = PhongLighting([2.0, 3.0, 2.0]) if phong else Lighting(sky, sun=sun)
    cam = small_camera(2, 3)
    full = render_stage.render(small_scene, cam, sampling=Sampling(8), lighting=light)
    frame = render_stage.render(small_scene, cam, sampling=Sampling(8), lighting=light, ao_scale=4)
    assert (full.ao < 1).any() and np.isfinite(frame.radiance).all()
    np.testing.assert_allclose(frame.radiance, full.radiance, rtol=1e-6, atol=1e-7)

"""The render stage (pyshadow.render, Scene.render): against Embree's render, the Frame it
returns (attributes and mapping), denoising, reduced-resolution AO, bad options."""
import numpy as np
import pytest

import pyshadow
from pyshadow import Sampling, embree, filters
from pyshadow import render as render_stage
from pyshadow.ao_pass import ao_pass
from pyshadow.render import Frame
from pyshadow.scene import GROUND_ID

BUFFERS = ("ao", "bent_normal", "depth", "normal", "object_id", "position")


def small_camera(width=48, height=32):
    """A camera that sees small_scene's box, its contact with the ground and the background."""
    return pyshadow.Camera([2.0, 1.5, 3.0], [0.0, 0.3, 0.0], width=width, height=height)


def assert_frames_equal(a, b, keys=BUFFERS):
    for k in keys:
        x, y = getattr(a, k), getattr(b, k)
        assert x.dtype == y.dtype and x.shape == y.shape, k
        np.testing.assert_array_equal(x, y, err_msg=k)


def test_render_matches_reference_and_has_ground(two_object_scene):
    scene = two_object_scene
    cam = pyshadow.Camera([1.0, 2.0, 5.0], [0.8, 0.3, 0.0], width=96, height=72)
    img = scene.render(cam, sampling=Sampling(36))
    ref = embree.render(scene, cam, sampling=Sampling(36))
    assert set(img) >= {"ao", "bent_normal", "depth", "normal", "object_id"}
    assert img["ao"].dtype == np.float32 and img["ao"].shape == (72, 96)
    assert set(np.unique(img["object_id"])) == {-1, GROUND_ID, 0, 1}
    np.testing.assert_array_equal(img["object_id"], ref["object_id"])
    hit = img["object_id"] != -1
    assert (img["ao"][~hit] == 1).all() and np.isinf(img["depth"][~hit]).all()
    assert 0 <= img["ao"].min() and img["ao"].max() <= 1
    diff = np.abs(img["ao"] - ref["ao"])[hit]
    assert diff.mean() < 0.02


def test_render_embree_visibility_on_embree_gbuffer_is_embree_render(small_scene):
    """The render stage with Embree's G-buffer and the "embree" backend traces
    exactly the rays of embree.render: the same frame, bit for bit."""
    cam = small_camera()
    s = Sampling(16, "halton", 32, 4)
    ref = embree.render(small_scene, cam, sampling=s, ground_size=30.0)
    g = embree.gbuffer(small_scene.draw_items(30.0)[0], cam)
    got = render_stage.render(small_scene, cam, visibility="embree", sampling=s, gbuffer=g, ground_size=30.0)
    assert isinstance(ref, Frame) and isinstance(got, Frame)
    assert_frames_equal(got, ref)
    assert (got.object_id == GROUND_ID).any() and (got.object_id == 0).any() and (got.object_id == -1).any()


@pytest.mark.parametrize("shape", [(6, 5), (6, 5, 3)])
def test_put_pixels_is_the_indexed_assignment(shape):
    """render._put_pixels writes the covered pixels' values as ``image.reshape(H * W, -1)[index] =
    values`` does, bit for bit, cast to the image's dtype: for some pixels (whole rows moved as
    bytes) and for every pixel (one copy)."""
    rng = np.random.default_rng(3)
    k = shape[2] if len(shape) == 3 else 1
    for index in (np.sort(rng.choice(30, 17, replace=False)), np.arange(30)):
        values = rng.normal(size=(len(index), k) if k > 1 else len(index))         # float64 in
        want = np.full(shape, -7.0, np.float32)
        want.reshape(30, -1)[index] = values.reshape(len(index), -1)
        got = np.full(shape, -7.0, np.float32)
        render_stage._put_pixels(got, index, values)
        assert np.array_equal(got, want)
    with pytest.raises(ValueError, match="C-contiguous"):
        render_stage._put_pixels(np.zeros((5, 6), np.float32).T, np.arange(3), np.zeros(3))


def test_scene_render_is_the_render_stage(small_scene):
    """Scene.render is pyshadow.render.render with its lookup as the CSM backend."""
    cam = small_camera()
    s = Sampling(8)
    for lookup, name in (("nearest", "csm"), ("vote", "csm-vote")):
        assert_frames_equal(small_scene.render(cam, sampling=s, lookup=lookup),
                            render_stage.render(small_scene, cam, visibility=name, sampling=s))
    assert_frames_equal(small_scene.render(cam, backend="numpy", sampling=s),
                        render_stage.render(small_scene, cam, visibility="numpy", sampling=s))
    # defaults: Sampling(), the one-texel lookup
    assert_frames_equal(small_scene.render(cam), render_stage.render(small_scene, cam, sampling=Sampling()))


def test_frame_is_a_dataclass_and_a_mapping(small_scene):
    cam = small_camera()
    frame = small_scene.render(cam, sampling=Sampling(8))
    assert isinstance(frame, Frame)
    assert list(frame) == list(BUFFERS) and len(frame) == 6 and frame.shape == (32, 48)
    for k in BUFFERS:
        assert frame[k] is getattr(frame, k)
        assert k in frame
    assert dict(frame).keys() == set(BUFFERS)
    assert frame.radiance is None and "radiance" not in frame
    with pytest.raises(KeyError):
        frame["radiance"]
    with pytest.raises(KeyError):
        frame["colour"]
    assert frame.ao.dtype == np.float32 and frame.ao.shape == (32, 48)
    assert frame.bent_normal.dtype == np.float32 and frame.bent_normal.shape == (32, 48, 3)
    assert frame.depth.dtype == np.float32 and frame.normal.shape == (32, 48, 3)
    assert frame.object_id.dtype == np.int32 and frame.position.shape == (32, 48, 3)
    hit = frame.object_id != -1
    assert hit.any() and (~hit).any()
    assert (frame.ao[~hit] == 1).all() and (frame.bent_normal[~hit] == 0).all()
    np.testing.assert_allclose(np.linalg.norm(frame.bent_normal[hit], axis=-1), 1, atol=1e-5)
    frame.radiance = np.zeros((32, 48, 3), np.float32)            # a lighting stage fills it
    assert list(frame) == [*BUFFERS, "radiance"] and frame["radiance"] is frame.radiance


@pytest.mark.parametrize("denoise", [None, *render_stage.DENOISERS])
def test_render_denoise_filters_the_ao_image(small_scene, denoise):
    """denoise= applies that filter of pyshadow.filters to the raw AO image, guided by
    the frame's own depth and normals; every other buffer is the raw frame's."""
    cam = small_camera()
    s = Sampling(8, seed=2)
    raw = small_scene.render(cam, sampling=s)
    frame = small_scene.render(cam, sampling=s, denoise=denoise)
    assert_frames_equal(frame, raw, [k for k in BUFFERS if k != "ao"])
    want = {None: lambda a: a,
            "bilateral": lambda a: filters.bilateral(a, raw.depth, raw.normal),
            "separable": lambda a: filters.bilateral(a, raw.depth, raw.normal, separable=True),
            "box": lambda a: filters.edge_aware_box(a, raw.depth, raw.normal)}[denoise](raw.ao)
    assert frame.ao.dtype == np.float32
    np.testing.assert_array_equal(frame.ao, want)
    if denoise is not None:
        assert not np.array_equal(frame.ao, raw.ao)


@pytest.mark.parametrize("ao_scale", [2, 4])
def test_render_ao_scale_upsamples_the_low_resolution_ao(small_scene, ao_scale):
    """ao_scale=s computes AO at every s-th pixel (with the full-resolution pixel's
    sample pattern, so those pixels equal the full render's) and upsamples it with
    the full-resolution G-buffer, except at the pass's pixels off its grid (pyshadow.ao_pass),
    which hold their own AO; denoise then filters the upsampled image."""
    cam = small_camera()
    s = Sampling(8)
    full = small_scene.render(cam, sampling=s)
    frame = small_scene.render(cam, sampling=s, ao_scale=ao_scale)
    assert_frames_equal(frame, full, ("depth", "normal", "object_id", "position"))
    low = full.ao[::ao_scale, ::ao_scale]
    want = filters.upsample(low, full.depth, full.normal, scale=ao_scale)
    own = ao_pass(full.object_id, full.depth, full.normal, ao_scale, 2)      # the pass's pixels off its grid
    own[::ao_scale, ::ao_scale] = False                                      # keep their own AO (the box's top)
    want[own] = full.ao[own]
    np.testing.assert_array_equal(frame.ao, want)
    np.testing.assert_array_equal(frame.bent_normal[::ao_scale, ::ao_scale],
                                  full.bent_normal[::ao_scale, ::ao_scale])
    both = small_scene.render(cam, sampling=s, ao_scale=ao_scale, denoise="bilateral")
    np.testing.assert_array_equal(both.ao, filters.bilateral(frame.ao, full.depth, full.normal))


@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(denoise="gauss"), ValueError, "denoise must be None, 'bilateral', 'separable' or 'box', got 'gauss'"),
    (dict(ao_scale=3), ValueError, "ao_scale must be 1, 2 or 4, got 3"),
    (dict(ao_scale=True), ValueError, "ao_scale must be 1, 2 or 4, got True"),
    (dict(sampling=36), TypeError, "sampling must be a pyshadow.Sampling, got 36"),
    (dict(lookup="linear"), ValueError, "lookup must be 'nearest' or 'vote', got 'linear'"),
    (dict(lookup="vote", backend="embree"), TypeError, "with backend= leave it out"),
])
def test_render_rejects_bad_options(small_scene, no_launch, kwargs, exc, match):
    """Bad options fail before anything is rasterised or traced."""
    with pytest.raises(exc, match=match):
        small_scene.render(small_camera(), **kwargs)


def test_render_stage_rejects_bad_options(small_scene, no_launch):
    cam = small_camera()
    with pytest.raises(ValueError, match="denoise must be"):
        render_stage.render(small_scene, cam, denoise="median")
    with pytest.raises(ValueError, match="ao_scale must be 1, 2 or 4"):
        render_stage.render(small_scene, cam, ao_scale=0)
    with pytest.raises(TypeError, match="sampling must be a pyshadow.Sampling"):
        render_stage.render(small_scene, cam, sampling={"samples": 8})


def test_render_unknown_visibility_names_the_backends(small_scene):
    with pytest.raises(ValueError, match="unknown visibility backend 'raytrace'; registered: .*csm-vote.*embree"):
        render_stage.render(small_scene, small_camera(), visibility="raytrace")


@pytest.mark.parametrize("change, exc, match", [
    (lambda g: g.pop("normal"), ValueError, r"gbuffer lacks 'normal'"),
    (lambda g: g.__setitem__("depth", g["depth"][:-1]), ValueError, r"gbuffer\['depth'\] has shape \(31, 48\); the camera needs \(32, 48\)"),
    (lambda g: g.__setitem__("object_id", g["object_id"].astype(np.float32)), TypeError, "must be integers"),
    (lambda g: g.__setitem__("object_id", np.full_like(g["object_id"], 2)), ValueError,
     r"holds 2\.\.2; the scene draws 2 items"),
])
def test_render_refuses_a_gbuffer_that_does_not_fit(small_scene, no_launch, change, exc, match):
    """A G-buffer handed to the render stage is checked against the camera and the scene's
    items before anything indexes with it."""
    cam = small_camera()
    g = {k: np.array(v) for k, v in embree.gbuffer(small_scene.draw_items(30.0)[0], cam).items()}
    change(g)
    with pytest.raises(exc, match=match):
        render_stage.render(small_scene, cam, gbuffer=g, ground_size=30.0)


@pytest.mark.parametrize("size", [0.0, -1.0, float("nan"), float("inf"), "8", True])
def test_ground_quad_refuses_a_size_that_is_no_length(small_scene, size):
    """ground_size must be a finite length > 0: 0, NaN and inf drew no ground, -1 one facing down."""
    with pytest.raises(ValueError, match="ground_size must be a finite number > 0"):
        render_stage.ground_quad(small_scene, size)
    assert np.ptp(render_stage.ground_quad(small_scene, 30.0).vertices[:, 0]) == 30.0

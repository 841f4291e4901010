"""Cube-map AO, second audit: bounded memory of per-texel AO, quality of normals of any length, and inputs
refused by name (face index, texel index, device flag, sampling, empty filter images)."""
from __future__ import annotations

import numpy as np
import pytest

import pyshadow
import pyshadow.cubemap.estimators as estimators
from pyshadow.cubemap import CubeMapAO, CubeProbe, face_camera, quality, raymarch_visible, seed_box_filter, texel_ao

from conftest import wall_scene

D = 1.0


@pytest.fixture(scope="module")
def scene():
    return wall_scene()


@pytest.fixture(scope="module")
def probe(scene):
    return CubeProbe(scene, [0.0, 1.0, 2.0], 16)


@pytest.mark.parametrize("device", [False, True])
def test_texel_ao_marches_texels_in_bounded_batches(probe, monkeypatch, device):
    """Was: texel_ao marched the rays of every texel in one call, about 140 bytes a ray: a probe of R = 256
    with 36 samples (10.2 million rays) peaked 1.4 GB above the probe itself, R = 1024 would take ~23 GB and
    the accepted R = 2048 ~90 GB. Now batches of about ``TEXEL_RAYS`` rays, and the same answer bit for bit."""
    sampling = pyshadow.Sampling(8)
    whole = texel_ao(probe, D, sampling=sampling, device=device)
    calls = []
    march = estimators.raymarch_visible

    def spy(probe, points, *args, **kw):
        calls.append(len(points))
        return march(probe, points, *args, **kw)

    monkeypatch.setattr(estimators, "raymarch_visible", spy)
    monkeypatch.setattr(estimators, "TEXEL_RAYS", 200, raising=False)
    batched = texel_ao(probe, D, sampling=sampling, device=device)
    texels = int(np.isfinite(probe.depth).sum())
    assert sum(calls) == 8 * texels and max(calls) <= 200 and len(calls) >= 8 * texels // 200
    assert np.array_equal(batched, whole, equal_nan=True)
    assert 0.5 < np.nanmean(whole) < 1.0                        # occluded texels among them


def test_quality_of_normals_of_any_length():
    """Was: Q scaled with the normal's length: 2.9 for a normal of length 10 where the unit normal gives 0.29
    (documented in [0, 1]), 2.9e199 for 1e200, 2.9e-201 for 1e-200."""
    pts = np.zeros((5, 3))
    unit = np.array([[0.0, 0.6, 0.8]])
    scaled = unit * np.array([[1.0], [10.0], [1e-200], [1e200], [0.0]])
    before = scaled.copy()
    q = quality(pts, scaled, [0.0, 1.0, 1.0], D)
    exact = quality(pts[:1], unit, [0.0, 1.0, 1.0], D)[0]
    # Q_a Q_b Q_c = (1 / (1 + sqrt 2)) (1 / sqrt 2) (1.4 / sqrt 2) for the unit normal
    assert exact == pytest.approx(1.4 / 2 / (1 + np.sqrt(2)), rel=1e-12)
    np.testing.assert_allclose(q[:4], exact, rtol=1e-12)
    assert q[4] == 0.0                                          # a zero normal faces no probe
    assert np.array_equal(scaled, before)                       # the caller's array is not normalised in place


@pytest.mark.parametrize("face", [-1, 6])
def test_face_camera_face_out_of_range(face):
    """Was: face -1 returned face 5's camera (-z) without a word; face 6: 'index 6 is out of bounds for axis 0
    with size 6'."""
    with pytest.raises(ValueError, match="face must be in 0..5"):
        face_camera([0.0, 0.0, 0.0], face, 16)


def test_face_camera_face_must_be_an_int():
    """Was: IndexError 'only integers, slices ... are valid indices' for face 1.0."""
    with pytest.raises(TypeError, match="face must be an int"):
        face_camera([0.0, 0.0, 0.0], 1.0, 16)


@pytest.mark.parametrize("index", [-1, 6 * 16 * 16])
def test_texel_directions_index_out_of_range(probe, index):
    """Was: texel -1 gave the direction of the last texel (and texel_offsets its point); 6 R^2: 'index 6 is out of
    bounds for axis 0 with size 6'."""
    with pytest.raises(IndexError, match=r"texel index out of range 0\.\.1535"):
        probe.texel_directions([0, index])


def test_texel_offsets_index_minus_one(probe):
    with pytest.raises(IndexError, match="out of range"):
        probe.texel_offsets([-1])


def test_seed_box_filter_on_an_empty_image():
    """Was: ValueError "index can't contain negative values" (np.pad with a width of -1) for a (0, 0) image."""
    out = seed_box_filter(np.zeros((0, 0)), np.ones((0, 0)), np.zeros((0, 0, 3)))
    assert out.shape == (0, 0) and out.dtype == np.float32


def test_device_flag_is_a_bool(probe):
    """Was: device='no' (or 'False') was true: the OpenCL march ran."""
    with pytest.raises(TypeError, match="device"):
        raymarch_visible(probe, [[0.0, 0.5, 1.0]], [[0.0, 1.0, 0.0]], D, device="no")
    with pytest.raises(TypeError, match="device"):
        texel_ao(probe, D, device="no", sampling=pyshadow.Sampling(4))


def test_cubemap_ao_sampling_checked_before_rendering(scene, monkeypatch):
    """Was: CubeMapAO(scene, D, sampling='x') was accepted; the first add_probe rendered the six faces and only
    then raised."""
    def no_render(*args, **kw):
        raise AssertionError("rendered a probe")

    monkeypatch.setattr(CubeProbe, "__init__", no_render)
    with pytest.raises(TypeError, match="sampling must be a pyshadow.Sampling"):
        CubeMapAO(scene, D, resolution=16, sampling="x")

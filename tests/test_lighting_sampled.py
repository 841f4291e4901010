"""The "sampled" shading mode and the converged Embree reference (pyshadow.lighting.shade,
pyshadow.lighting.reference; issue 19 items 4 and 7).

Relative RMSE here: ``sqrt(mean (L - R)^2) / sqrt(mean R^2)`` over every point and RGB channel.
"""
import math

import numpy as np
import pytest

import pyshadow
from pyshadow import Sampling, render, visibility
from pyshadow.lighting import (EnvironmentMap, Lighting, clear_sky, overcast_sky, reference_radiance, shade,
                               shade_terms)
from pyshadow.lighting.shade import sky_radiance
from pyshadow.scene import GROUND_ID

SKY_C = np.array([1.0, 2.0, 0.5])
ALBEDO = np.array([0.5, 0.6, 0.7])
SUN_DIR = np.array([0.6, 0.5, 0.4]) / np.linalg.norm([0.6, 0.5, 0.4])


def rel_rmse(got, ref):
    g, r = np.asarray(got, np.float64), np.asarray(ref, np.float64)
    return float(np.sqrt(np.mean((g - r) ** 2)) / np.sqrt(np.mean(r ** 2)))


def constant_sky(c=SKY_C):
    return EnvironmentMap(np.tile(np.asarray(c, float), (16, 32, 1)))


def top_and_far_ground(n=8):
    """Points on small_scene's box top face (y = 0.5, open sky above) and on the ground 40 units away."""
    g = np.linspace(-0.4, 0.4, n)
    top = np.column_stack([np.repeat(g, n), np.full(n * n, 0.5), np.tile(g, n)])
    p = np.vstack([top, top + [40.0, -0.5, 0.0]])
    nrm = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    ids = np.r_[np.zeros(n * n, np.int32), np.full(n * n, GROUND_ID, np.int32)]
    return p, nrm, ids


@pytest.fixture(scope="module")
def bundled():
    """The bundled scene, small: every covered pixel of a 48 x 36 view as a shading point."""
    scene, cam = pyshadow.data.default_scene(views=pyshadow.ViewSet.zigzag(16, 32), resolution=64, width=48,
                                             height=36)
    sp = render.surface_points(scene, cam)
    return scene, sp


@pytest.fixture(scope="module")
def clear_sky_map():
    """The Preetham clear sky without its sun disc: a sky bright on one side, dark on the other."""
    return clear_sky(SUN_DIR, height=64, sun=False)


@pytest.fixture(scope="module")
def converged(bundled, clear_sky_map):
    """reference_radiance at 1024 samples of the clear sky (no sun) on the bundled scene's pixels."""
    scene, sp = bundled
    light = Lighting(clear_sky_map, mode="sampled")
    return reference_radiance(scene, sp.points, sp.normals, light, samples=1024, surface_ids=sp.surface_ids,
                              indices=sp.index)


def test_sampled_overcast_open_plane_is_albedo_over_pi_times_horizontal_illuminance(small_scene):
    """The CIE overcast sky has horizontal illuminance E_h: an open horizontal surface gets
    albedo / pi * E_h, the estimator's convention (albedo * mean L V = albedo / pi * E). Sampled at 256
    directions within 0.5 %, the 1024-sample reference within 0.2 %."""
    p, nrm, ids = top_and_far_ground()
    e_h = 10_000.0
    light = Lighting(overcast_sky(e_h, height=64), albedo=ALBEDO, ground_albedo=0.25, mode="sampled")
    want = np.where((ids == GROUND_ID)[:, None], 0.25, ALBEDO) * e_h / math.pi
    got = shade(small_scene, p, nrm, light, sampling=Sampling(256), surface_ids=ids)
    np.testing.assert_allclose(got, want, rtol=5e-3)
    ref = reference_radiance(small_scene, p, nrm, light, surface_ids=ids)
    np.testing.assert_allclose(ref, want, rtol=2e-3)


def test_sampled_ao_is_the_ao_kernels_and_a_constant_sky_gives_albedo_c_ao(bundled):
    """The sampled sky traces the AO kernel's directions through visible(normals=): its AO equals
    ambient_occlusion's bit for bit on the CSM backend, and a constant sky c gives L = albedo c AO."""
    scene, sp = bundled
    s = Sampling(32, seed=5)
    light = Lighting(constant_sky(), mode="sampled")
    t = shade_terms(scene, sp.points, sp.normals, light, sampling=s, surface_ids=sp.surface_ids, indices=sp.index)
    ao, bent = visibility.ambient_occlusion(scene, sp.points, sp.normals, sampling=s, return_bent_normals=True,
                                            surface_ids=sp.surface_ids, indices=sp.index)
    assert (ao < 0.9).mean() > 0.1 and (ao > 0.9).mean() > 0.1    # the scene really occludes
    np.testing.assert_array_equal(t.ao, ao)
    np.testing.assert_allclose(t.bent_normal, bent, atol=1e-6)
    albedo = light.albedo_of(sp.surface_ids, len(sp.index))
    np.testing.assert_allclose(t.radiance, albedo * SKY_C * ao[:, None], rtol=3e-7, atol=1e-12)


def test_sampled_on_embree_is_the_reference_bit_for_bit(bundled):
    """shade(backend="embree") in mode "sampled" at S samples and reference_radiance at S samples with the
    same strategy, seed and sun directions are one computation: equal bit for bit, sun included. Another
    seed (other directions) is not."""
    scene, sp = bundled
    light = Lighting.clear_sky(SUN_DIR, height=32, mode="sampled", sun_samples=4)
    s = Sampling(24, "halton", patterns=64, seed=3)
    kw = dict(surface_ids=sp.surface_ids, indices=sp.index)
    got = shade(scene, sp.points, sp.normals, light, backend="embree", sampling=s, **kw)
    ref = reference_radiance(scene, sp.points, sp.normals, light, samples=24, sun_samples=4, sampling=s, **kw)
    assert ref.dtype == np.float32 and ref.shape == (len(sp.index), 3)
    np.testing.assert_array_equal(got, ref)
    other = reference_radiance(scene, sp.points, sp.normals, light, samples=24, sun_samples=4,
                               sampling=Sampling(seed=4), **kw)
    assert (other != ref).any()


def test_sampled_csm_within_2_percent_of_embree_at_256_samples(bundled, clear_sky_map, converged):
    """Issue 19's acceptance: "sampled" at 256 samples on the CSM backend against "sampled" at 256 samples
    on Embree on identical directions, clear sky (its sun is the directional term, tested apart): relative
    RMSE <= 2 % (measured 1.2 %); against the converged reference the two differ by < 2 points (measured
    1.2 % and 0.7 %)."""
    scene, sp = bundled
    light = Lighting(clear_sky_map, mode="sampled")
    kw = dict(sampling=Sampling(256), surface_ids=sp.surface_ids, indices=sp.index)
    csm = shade(scene, sp.points, sp.normals, light, backend="csm", **kw)
    emb = shade(scene, sp.points, sp.normals, light, backend="embree", **kw)
    between = rel_rmse(csm, emb)
    e_csm, e_emb = rel_rmse(csm, converged), rel_rmse(emb, converged)
    print(f"sampled 256: CSM vs Embree {between:.4f}; vs converged: CSM {e_csm:.4f}, Embree {e_emb:.4f}")
    assert between <= 0.02
    assert abs(e_csm - e_emb) <= 0.02
    assert e_emb < 0.015                                     # 256 samples against 1024: near converged


def test_sampled_beats_bent_against_the_converged_reference(bundled, clear_sky_map, converged):
    """Against the converged reference, clear sky (no sun), CSM backend: "sampled" at 36 samples beats
    "bent" at 36 (measured 4.5 % against 22 %), and 256 samples beat 36."""
    scene, sp = bundled
    kw = dict(surface_ids=sp.surface_ids, indices=sp.index)
    err = {}
    for mode, n in (("bent", 36), ("sampled", 36), ("sampled", 256)):
        got = shade(scene, sp.points, sp.normals, Lighting(clear_sky_map, mode=mode), sampling=Sampling(n), **kw)
        err[mode, n] = rel_rmse(got, converged)
    print("relative RMSE against the converged reference:",
          ", ".join(f"{m} {n}: {e:.4f}" for (m, n), e in err.items()))
    assert err["sampled", 36] < 0.5 * err["bent", 36]
    assert err["sampled", 256] < err["sampled", 36]


def test_sampled_needs_the_map(small_scene, no_launch):
    """A Lighting of SH coefficients only has no radiance per direction: "sampled" and the reference refuse
    it before any launch; an unknown mode is refused; the "bent" term refuses a "sampled" Lighting (so
    render(lighting=) cannot shade it as "bent" unawares)."""
    coef = np.zeros((9, 3))
    coef[0] = 1.0
    with pytest.raises(ValueError, match="EnvironmentMap"):
        Lighting(coef, mode="sampled")
    p, nrm, ids = top_and_far_ground(2)
    with pytest.raises(ValueError, match="EnvironmentMap"):
        reference_radiance(small_scene, p, nrm, Lighting(coef), surface_ids=ids)
    with pytest.raises(ValueError, match="samples"):
        reference_radiance(small_scene, p, nrm, Lighting(constant_sky()), samples=0)
    with pytest.raises(ValueError, match="mode"):
        Lighting(constant_sky(), mode="transferred")
    light = Lighting(constant_sky(), mode="sampled")
    assert light.env is not None and Lighting(coef).env is None
    with pytest.raises(ValueError, match="sampled"):
        sky_radiance(light, np.ones(1), np.array([[0.0, 1.0, 0.0]]), np.ones((1, 3)))
    with pytest.raises(ValueError, match="points"):
        shade(small_scene, np.zeros((4, 2)), nrm[:4], light)


def test_sampled_without_sky_is_the_sun_alone(small_scene):
    """No sky in mode "sampled": the sky term is exactly 0 and the sun term that of "bent"."""
    from pyshadow.lighting import DirectionalLight

    p, nrm, ids = top_and_far_ground(3)
    sun = DirectionalLight(SUN_DIR, [100.0, 90.0, 80.0])
    a = shade_terms(small_scene, p, nrm, Lighting(sun=sun, mode="sampled"), sampling=Sampling(8), surface_ids=ids)
    b = shade_terms(small_scene, p, nrm, Lighting(sun=sun), sampling=Sampling(8), surface_ids=ids)
    assert (a.sky == 0).all()
    np.testing.assert_array_equal(a.sun, b.sun)
    assert (a.sun > 0).all()


def test_render_fills_radiance_in_sampled_mode(bundled):
    """render(lighting=Lighting(map, mode="sampled")): under a constant sky c the sampled estimator is
    albedo x c x (the fraction of open directions), and render's AO traces the same directions at
    ao_scale 1 without a denoiser: radiance = albedo x c x frame.ao on every covered pixel, 0 elsewhere."""
    scene, _ = bundled
    cam = pyshadow.data.default_scene(views=pyshadow.ViewSet.zigzag(16, 32), resolution=64, width=48,
                                      height=36)[1]
    lit = Lighting(constant_sky(), mode="sampled", albedo=ALBEDO, ground_albedo=ALBEDO)
    frame = render.render(scene, cam, sampling=Sampling(24), lighting=lit)
    covered = frame.object_id != -1                 # bodies and the ground (GROUND_ID)
    want = frame.ao[..., None] * (ALBEDO * SKY_C)
    np.testing.assert_allclose(frame.radiance[covered], want[covered], rtol=2e-6)
    assert not frame.radiance[~covered].any()
    assert 0.2 < frame.ao[covered].mean() < 0.95

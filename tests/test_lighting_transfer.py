"""The "transfer" shading mode: the shadowed SH transfer from the AO kernel's 9 extra sums (issue 19 item 4).

Relative RMSE here: ``sqrt(mean (L - R)^2) / sqrt(mean R^2)`` over every point and RGB channel.
"""
import math

import numpy as np
import pytest

import pyshadow
from pyshadow import Sampling, render, visibility
from pyshadow.lighting import (EnvironmentMap, Lighting, clear_sky, irradiance_sh, reference_radiance, sh_basis,
                               sh_transfer, shade, shade_terms, transfer_irradiance)

SUN_DIR = np.array([0.6, 0.5, 0.4]) / np.linalg.norm([0.6, 0.5, 0.4])


def rel_rmse(got, ref):
    g, r = np.asarray(got, np.float64), np.asarray(ref, np.float64)
    return float(np.sqrt(np.mean((g - r) ** 2)) / np.sqrt(np.mean(r ** 2)))


@pytest.fixture(scope="module")
def bundled():
    scene, cam = pyshadow.data.default_scene(views=pyshadow.ViewSet.zigzag(16, 32), resolution=64, width=48,
                                             height=36)
    return scene, cam, render.surface_points(scene, cam)


@pytest.mark.parametrize("backend", ["csm", "csm-vote"])
def test_white_sky_transfer_is_pi_ao_on_identical_directions(bundled, backend):
    """Issue 19's acceptance: under a constant white sky (L_0 = 4 pi Y_0, the rest 0) E = sum L_k T_k equals
    pi x AO of the same directions, to float32 rounding; the kernel's AO and bent normals are
    ambient_occlusion's bit for bit (one pass of the same kernel, 9 sums more)."""
    scene, _, sp = bundled
    s = Sampling(32, seed=2)
    kw = dict(sampling=s, surface_ids=sp.surface_ids, indices=sp.index)
    ao, bent, T = sh_transfer(scene, sp.points, sp.normals, backend=backend, **kw)
    ao2, bent2 = visibility.ambient_occlusion(scene, sp.points, sp.normals, backend=backend,
                                              return_bent_normals=True, **kw)
    np.testing.assert_array_equal(ao, ao2)
    np.testing.assert_array_equal(bent, bent2)
    assert 0.3 < ao.mean() < 0.95
    white = np.zeros((9, 3))
    white[0] = 4 * math.pi * sh_basis(np.array([0.0, 1.0, 0.0]))[0]
    E = transfer_irradiance(white, T)
    np.testing.assert_allclose(E, np.repeat(math.pi * ao[:, None].astype(np.float64), 3, axis=1), rtol=2e-6,
                               atol=2e-6)


def test_unshadowed_transfer_converges_to_the_cosine_kernel(rng):
    """No occluder: T_k -> A_l Y_k(n), so sum L_k T_k -> irradiance_sh(L, n). With 4096 Hammersley directions
    the estimate is within 1 % of the closed form on random skies (the quadrature error of a smooth
    polynomial integrand at that count, measured 0.1-0.3 %)."""
    scene = pyshadow.Scene()
    n = rng.normal(size=(50, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    p = rng.normal(size=(50, 3)) * 100
    L = rng.normal(size=(9, 3)) * [1.0, 0.3, 0.3]
    L[0] = np.abs(L[0]) + 3.0
    ao, _, T = sh_transfer(scene, p, n, backend="numpy", sampling=Sampling(4096, "hammersley"))
    assert (ao == 1).all()
    np.testing.assert_allclose(transfer_irradiance(L, T), irradiance_sh(L, n), rtol=1e-2)


@pytest.mark.parametrize("kernel, mirror", [("csm", "numpy"), ("csm-vote", "numpy-vote")])
def test_transfer_kernel_matches_the_host_sums_on_its_mirror(bundled, kernel, mirror):
    """The kernel's 9 float32 sums against the same sums in float64 over the float64 mirror's visibility
    of the same directions: equal up to float32 accumulation (1e-4 of pi) where the rays agree; points
    whose AO differs (float32 deciding a ray: at most 1 ray in 1000) are left out, and are few."""
    scene, _, sp = bundled
    s = Sampling(24, seed=9)
    kw = dict(sampling=s, surface_ids=sp.surface_ids, indices=sp.index)
    ao, _, T = sh_transfer(scene, sp.points, sp.normals, backend=kernel, **kw)
    ao_m, _, T_m = sh_transfer(scene, sp.points, sp.normals, backend=mirror, **kw)
    same = ao == ao_m
    assert same.mean() >= 1 - 24 * 0.001
    np.testing.assert_allclose(T[same], T_m[same], atol=1e-4 * math.pi)


def test_transfer_beats_bent_against_the_converged_reference(bundled):
    """Issue 19's acceptance: on the bundled scene under the clear sky (its sun is the directional term,
    tested apart), relative RMSE of radiance against the converged Embree reference (1024 samples):
    "transfer" must beat "bent" at the same 36 samples."""
    scene, _, sp = bundled
    sky = clear_sky(SUN_DIR, height=64, sun=False)
    kw = dict(surface_ids=sp.surface_ids, indices=sp.index)
    ref = reference_radiance(scene, sp.points, sp.normals, Lighting(sky, mode="sampled"), samples=1024, **kw)
    bent = shade(scene, sp.points, sp.normals, Lighting(sky, mode="bent"), sampling=Sampling(36), **kw)
    tr = shade(scene, sp.points, sp.normals, Lighting(sky, mode="transfer"), sampling=Sampling(36), **kw)
    e_bent, e_tr = rel_rmse(bent, ref), rel_rmse(tr, ref)
    print(f"clear sky, 36 samples, against 1024-sample Embree: bent {e_bent:.4f}, transfer {e_tr:.4f}")
    assert e_tr < e_bent


def test_render_fills_radiance_in_transfer_mode(bundled):
    """render(lighting=Lighting(sky, mode="transfer")) puts shade()'s radiance of the covered pixels in
    Frame.radiance (the same points, directions and backend), 0 on the background."""
    scene, cam, sp = bundled
    sky = EnvironmentMap(np.tile([1.0, 0.8, 0.6], (16, 32, 1)))
    lit = Lighting(sky, mode="transfer", sun=None)
    frame = render.render(scene, cam, sampling=Sampling(16), lighting=lit)
    got = shade_terms(scene, sp.points, sp.normals, lit, sampling=Sampling(16), surface_ids=sp.surface_ids,
                      indices=sp.index)
    flat = frame.radiance.reshape(-1, 3)
    np.testing.assert_allclose(flat[sp.index], got.sky, rtol=1e-6, atol=1e-7)
    mask = np.ones(len(flat), bool)
    mask[sp.index] = False
    assert not flat[mask].any()

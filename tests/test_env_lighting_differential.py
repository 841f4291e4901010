"""Image-based lighting against independent computations: brute-force SH integrals, the white furnace."""
import numpy as np
import pytest

import pyshadow
from pyshadow import Sampling
from pyshadow.lighting import EnvironmentMap, Lighting, sh_basis, shade
from pyshadow.lighting.cube import FACE_FRAMES


def brute_cube_sh(faces, m=48):
    """``sum_texels L_i integral_texel Y_k dOmega`` with m x m Gauss-Legendre points a texel, float64.

    ``dOmega = ds dt / (1 + s^2 + t^2)^(3/2)`` on a face; the integrand is smooth, so 48 points a side
    converge to rounding on texels as large as a whole face (checked: 24 and 48 points agree to 1e-15).
    """
    n = faces.shape[1]
    g, w = np.polynomial.legendre.leggauss(m)
    out = np.zeros((9, 3))
    for f in range(6):
        c, r, dn = FACE_FRAMES[f]
        for i in range(n):
            for j in range(n):
                s = 2.0 * (j + 0.5 + 0.5 * g) / n - 1.0
                t = 2.0 * (i + 0.5 + 0.5 * g) / n - 1.0
                S, T = np.meshgrid(s, t)
                W = np.outer(w, w) / n ** 2 / (1.0 + S * S + T * T) ** 1.5
                d = c + S[..., None] * r + T[..., None] * dn
                d /= np.linalg.norm(d, axis=-1, keepdims=True)
                out += np.einsum("abk,ab->k", sh_basis(d), W)[:, None] * faces[f, i, j][None, :]
    return out


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_cube_sh_of_small_faces_matches_brute_force(n):
    """EnvironmentMap.sh of a cube map against brute-force integration of the basis over its texels.

    Before: 4 x 4 Gauss points a texel whatever the face size, so 1 x 1 faces (a texel a face) were
    0.47 % off (relative to the largest coefficient; 0.008 absolute on radiance in [0, 1)), 2 x 2
    faces 2e-5, although the docstring said "integrated exactly". Now at least 32 points a face side
    below N = 8: 1e-12 relative or better."""
    faces = np.random.default_rng(n).random((6, n, n, 3))
    got = EnvironmentMap(faces).sh()
    ref = brute_cube_sh(faces)
    assert np.abs(got - ref).max() <= 1e-9 * np.abs(ref).max()


def test_sampled_sky_on_the_kernel_does_not_overflow_below_float32_max():
    """White furnace of mode "sampled": no occluder, constant sky L, so the sky term is albedo * L exactly.

    Before: with L = 1e37 (finite in float32, and so is albedo * L = 5e36) the CSM kernel summed the 64
    samples' texels in float32 (6.4e38 > 3.4e38) and shade returned inf on every point, where the
    host route and the "bent" and "transfer" modes gave 5e36. Now a map whose largest texel times the
    sample count could overflow takes the float64 host route."""
    rng = np.random.default_rng(1)
    n = rng.normal(size=(8, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    p = rng.normal(size=(8, 3)) * 10.0
    L = 1e37
    env = EnvironmentMap(np.full((4, 8, 3), L))
    for mode in ("bent", "transfer", "sampled"):
        for backend in ("csm", "numpy"):
            got = shade(pyshadow.Scene(), p, n, Lighting(env, mode=mode, albedo=0.5, ground_albedo=0.0),
                        backend=backend, sampling=Sampling(64, seed=0))
            assert got.dtype == np.float32
            np.testing.assert_allclose(got.astype(np.float64), 0.5 * L, rtol=1e-6, err_msg=f"{mode} {backend}")


def test_sampled_sky_kernel_route_kept_for_ordinary_maps(monkeypatch):
    """The kernel route still answers for ordinary radiance: device_sampled_sky returns the kernel's
    float32 tuple (not None), equal to the host route's mean to float32 rounding in the furnace."""
    from pyshadow.lighting.sampled import device_sampled_sky
    rng = np.random.default_rng(2)
    n = rng.normal(size=(5, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    p = rng.normal(size=(5, 3))
    env = EnvironmentMap(np.full((4, 8, 3), 3.0))
    got = device_sampled_sky(pyshadow.Scene(), p.astype(np.float32), n.astype(np.float32), env, backend="csm",
                             sampling=Sampling(64, seed=0))
    assert got is not None
    np.testing.assert_allclose(got[0], 3.0, rtol=1e-6)
    big = EnvironmentMap(np.full((4, 8, 3), 1e37))
    assert device_sampled_sky(pyshadow.Scene(), p.astype(np.float32), n.astype(np.float32), big, backend="csm",
                              sampling=Sampling(64, seed=0)) is None

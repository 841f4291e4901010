"""Differential checks of shading inputs: barycentric weights of surface points under scaling."""
import numpy as np
import pytest

from pyshadow.materials import barycentrics


def _triangles(n=200, seed=3):
    rng = np.random.default_rng(seed)
    t = rng.normal(size=(n, 3, 3))
    b = rng.dirichlet([1.0, 1.0, 1.0], n)
    return t, b, np.einsum("nk,nkc->nc", b, t)


@pytest.mark.parametrize("exp2", [-400, -300, -260, 260, 300])
def test_barycentrics_exact_under_power_of_two_scale(exp2):
    """Barycentric weights do not change when the triangle and point are scaled by a power of two.

    Before: the Gram determinant's fourth powers of the triangle's size underflowed to 0 for
    triangles under about 1e-77 (2**-260: every point got corner a's weight, (1, 0, 0), an error of
    up to 1 against the true weights) and overflowed above about 1e77 (2**260: RuntimeWarning
    "overflow encountered in multiply", then NaN weights / "invalid value").
    """
    t, b, p = _triangles()
    ref = barycentrics(p, t)
    assert np.abs(ref - b).max() < 1e-11          # the unscaled answer is the true one
    got = barycentrics(np.ldexp(p, exp2), np.ldexp(t, exp2))
    np.testing.assert_array_equal(got, ref)        # power-of-two scaling is exact in float64


def test_barycentrics_tiny_triangle_corners_and_empty():
    """A 1e-100 triangle's corners and centroid get their exact weights; no rows give (0, 3).

    Before: corners b and c and the centroid of such a triangle got weights (1, 0, 0).
    """
    t = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]]) * 1e-100
    pts = np.array([t[0, 0], t[0, 1], t[0, 2], t[0].mean(axis=0)])
    got = barycentrics(pts, np.repeat(t, 4, axis=0))
    np.testing.assert_allclose(got, [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1 / 3, 1 / 3, 1 / 3]], atol=1e-15)
    assert barycentrics(np.zeros((0, 3)), np.zeros((0, 3, 3))).shape == (0, 3)

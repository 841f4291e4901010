"""tonemap of per-vertex radiance (N, 3): the same display values as the same colours laid out as an image, and
auto exposure over the vertices (was: "expected shape (H, W, 3)" for shade() of a mesh's vertices)."""
import numpy as np
import pytest

from pyshadow.lighting import auto_exposure, tonemap


def _colours(n=257, seed=3):
    rng = np.random.default_rng(seed)
    return rng.gamma(1.5, 40.0, size=(n, 3))


@pytest.mark.parametrize("curve", ["srgb", "exponential"])
@pytest.mark.parametrize("exposure", [0.01, "auto"])
def test_vertices_map_as_the_same_colours_in_an_image(curve, exposure):
    rad = _colours()
    out = tonemap(rad, exposure, curve)
    assert out.shape == rad.shape and out.dtype == np.uint8
    assert np.array_equal(out, tonemap(rad[None], exposure, curve)[0])


def test_auto_exposure_of_vertices_is_that_of_their_image():
    rad = _colours()
    assert auto_exposure(rad) == auto_exposure(rad[None])
    keep = np.arange(len(rad)) % 3 > 0
    assert auto_exposure(rad, keep) == auto_exposure(rad[None], keep[None])


@pytest.mark.parametrize("bad", [np.ones(3), np.ones((4, 4)), np.ones((0, 3)), np.ones((2, 0, 3))])
def test_no_colour_axis_or_no_colours_is_refused(bad):
    with pytest.raises(ValueError, match=r"expected shape \(H, W, 3\) or \(N, 3\)"):
        tonemap(bad)

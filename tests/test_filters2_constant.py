"""The filters leave a constant image unchanged and keep smooth images to float32 rounding.

Their means were summed over the window as ``sum w a_q / sum w`` in float32: the rounding of
each of up to 65 x 65 terms moved a constant image by up to hundreds of ulps. They now sum the
differences from the centre pixel's value (upsampling: from the first surface tap's), which
are 0 on a constant image (kernels/filters.cl).
"""
import numpy as np
import pytest

from pyshadow.filters import (
    bilateral,
    edge_aware_box,
    edge_aware_box_reference,
    low_res_shape,
    upsample,
)

SHAPE = (70, 70)
VALUES = [0.1, 0.3, 0.7, 0.9]


def guide(shape=SHAPE, holes=False):
    """Depth 10 with a gentle slope (one surface), normals +z; a few background pixels if ``holes``."""
    h, w = shape
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    depth = (10.0 + 0.001 * x + 0.002 * y).astype(np.float32)
    if holes:
        depth[(x * 7 + y * 3) % 23 == 0] = np.inf
    normal = np.zeros(shape + (3,), np.float32)
    normal[..., 2] = 1.0
    return depth, normal


def assert_constant(out, c, depth):
    surf = np.isfinite(depth)
    moved = out[surf] != np.float32(c)
    assert not moved.any(), (f"{int(moved.sum())} of {int(surf.sum())} pixels moved, "
                             f"by up to {float(np.max(np.abs(out[surf] - np.float32(c)))):.3g}")


@pytest.mark.parametrize("c", VALUES)
def test_edge_aware_box_keeps_a_constant_image(c):
    """Was: a constant 0.9 through the 65 x 65 box came out changed at every pixel of a 70 x 70
    image, by up to 600 ulps (3.6e-5); 0.1 by 526 ulps; the default 7 x 7 box moved it by up to
    6 ulps (here, with holes: 4,680 of 4,686 pixels moved, by up to 3.3e-5)."""
    depth, normal = guide(holes=True)
    ao = np.full(SHAPE, c, np.float32)
    assert_constant(edge_aware_box(ao, depth, normal, size=65), c, depth)
    assert_constant(edge_aware_box(ao, depth, normal), c, depth)


@pytest.mark.parametrize("separable", [False, True])
@pytest.mark.parametrize("c", VALUES)
def test_bilateral_keeps_a_constant_image(c, separable):
    """Was: a constant 0.1 through a radius-32 bilateral window (sigma_spatial 16) changed at 4,833 of
    4,900 pixels, by up to 76 ulps (5.7e-6 relative); the separable form by up to 7 ulps, the
    default radius 4 by up to 6."""
    depth, normal = guide(holes=True)
    ao = np.full(SHAPE, c, np.float32)
    assert_constant(bilateral(ao, depth, normal, radius=32, sigma_spatial=16.0, separable=separable), c, depth)
    assert_constant(bilateral(ao, depth, normal, separable=separable), c, depth)


@pytest.mark.parametrize("c", VALUES + [-0.577])
def test_upsample_keeps_a_constant_image(c):
    """Was: a constant 0.1 upsampled 4x with 8 taps a side (sigma_spatial 20) changed at 4,450 of
    4,900 pixels, by up to 18 ulps; at the default radius by up to 4 (render upsamples the bent
    normals' components, constant on a plane, the same way)."""
    depth, normal = guide(holes=True)
    for scale, radius, ss in [(4, 8, 20.0), (2, 2, None), (4, 2, None)]:
        low = np.full(low_res_shape(SHAPE, scale), c, np.float32)
        out = upsample(low, depth, normal, scale=scale, radius=radius, sigma_spatial=ss)
        assert_constant(out, c, depth)


def test_edge_aware_box_smooth_image_within_rounding():
    """Was: a smooth image (0.6 + 0.05 sin(x / 9)) through the 33 x 33 box came out up to 34 ulps
    off the float64 reference (the float32 sum of 1,089 values near 0.6); now the differences
    from the centre keep it within 2 ulps."""
    depth, normal = guide((40, 44))
    x = np.arange(44)[None, :] + np.zeros((40, 1))
    ao = (0.6 + 0.05 * np.sin(x / 9.0)).astype(np.float32)
    got = edge_aware_box(ao, depth, normal, size=33).astype(np.float64)
    ref = edge_aware_box_reference(ao, depth, normal, size=33).astype(np.float64)
    ulps = np.abs(got - ref) / np.spacing(np.abs(ref).astype(np.float32))
    assert ulps.max() <= 2.0

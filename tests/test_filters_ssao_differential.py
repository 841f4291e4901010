"""Differential checks of the screen-space filters and SSAO at the extremes of float32.

Each test compares two computations that must agree exactly: the kernel on a
scene against the kernel on the same scene scaled by a number (SSAO does not
depend on the unit of length), or the kernel against its NumPy reference.
"""
import numpy as np
import pytest

from pyshadow import filters as F
from pyshadow import ssao as S
from pyshadow.camera import Camera

from conftest import filter_guide


def _corner(scale, H=24, W=32):
    """Analytic G-buffer of three planes meeting in a corner (ground y = 0, walls
    x = -0.5 and z = -0.7), every length times ``scale``, and its camera."""
    eye = np.array([0.3, 1.5, 3.0]) * scale
    cam = Camera(eye=tuple(eye), target=(0.0, 0.0, 0.0), up=(0, 1, 0), fov_y=50, width=W, height=H)
    d = cam.ray_directions().astype(np.float64)
    with np.errstate(divide="ignore"):
        t = np.stack([np.where(d[..., 1] < 0, -eye[1] / d[..., 1], np.inf),
                      np.where(d[..., 0] < 0, (-0.5 * scale - eye[0]) / d[..., 0], np.inf),
                      np.where(d[..., 2] < 0, (-0.7 * scale - eye[2]) / d[..., 2], np.inf)])
    normal = np.array([[0, 1, 0], [1, 0, 0], [0, 0, 1]], np.float32)[np.argmin(t, axis=0)]
    return {"depth": t.min(axis=0), "normal": normal}, cam


@pytest.mark.parametrize("scale", [7.5e37, 7.68e37])
def test_ssao_sample_points_near_float32_max(scale):
    """Before: with the G-buffer up to 3.3e38 away and a radius of 1.5e38 (both
    within float32's range, as documented) the sample points p + radius w
    overflowed float32 in the kernel and counted as open: 84 (97 at 7.68e37) of
    the 768 pixels differed from the unit scene and from the float64 reference,
    by up to 0.16."""
    g1, c1 = _corner(1.0)
    unit = S.screen_space_ao(g1, c1, 2.0, samples=32)
    g, c = _corner(scale)
    assert np.isfinite(g["depth"]).any() and np.nanmax(np.where(np.isfinite(g["depth"]), g["depth"], 0)) > 3e38
    ao = S.screen_space_ao(g, c, 2.0 * scale, samples=32)
    assert (unit < 1).sum() > 50                    # the scene has occluded pixels to get wrong
    np.testing.assert_array_equal(ao, unit)
    np.testing.assert_array_equal(S.screen_space_ao_reference(g, c, 2.0 * scale, samples=32), unit)


def test_ssao_scaling_keeps_ordinary_scenes_bit_identical():
    """Scaling a scene by powers of two far from 1 (2^-100, 2^100) gives the unit
    scene's AO bit for bit (this held before as well: the fix above only
    rescales where float32 would overflow)."""
    g1, c1 = _corner(1.0)
    unit = S.screen_space_ao(g1, c1, 0.5, samples=16)
    for s in (2.0 ** -100, 2.0 ** 100):
        g, c = _corner(s)
        np.testing.assert_array_equal(S.screen_space_ao(g, c, 0.5 * s, samples=16), unit)


@pytest.mark.parametrize("name, kw", [("bilateral", {}), ("bilateral", {"separable": True, "radius": 3}),
                                      ("edge_aware_box", {}),
                                      ("upsample", {"scale": 2, "sigma_spatial": 100.0}),
                                      ("upsample", {"scale": 4, "radius": 8, "sigma_spatial": 100.0})])
def test_filters_of_values_near_float32_max(name, kw):
    """Before: the kernels' float32 tap sums overflowed for AO values near float32's largest
    (any finite value is documented to be filtered alike): every surface pixel of the image
    scaled by 2**127 came back inf, the upsampling's too with wide spatial weights (the
    edge-aware box already at 1e37: 84 of 240 pixels),
    while the float64 reference gave finite means. Now the filter of the scaled image is the
    unit image's answer scaled by 2**127 bit for bit (weights do not depend on the values),
    background pixels keep their input (here NaN), and it agrees with the reference."""
    ao, depth, n = filter_guide()
    ao[~np.isfinite(depth)] = np.nan                      # background: anything, passed through
    f, ref = getattr(F, name), getattr(F, name + "_reference")
    if name == "upsample":
        ao = ao[::kw["scale"], ::kw["scale"]].copy()
        kw = dict(kw, fill=0.75)
    big = np.float32(2.0 ** 127)
    unit = f(ao, depth, n, **kw)
    got = f(ao * big, depth, n, **kw)
    surf = np.isfinite(depth)
    assert np.isfinite(got[surf]).all()
    np.testing.assert_array_equal(got[surf], unit[surf] * big)
    want = ao if name != "upsample" else np.full(depth.shape, 0.75, np.float32)
    np.testing.assert_array_equal(got[~surf], want[~surf])
    np.testing.assert_allclose(got[surf], ref(ao * big, depth, n, **kw)[surf], rtol=2e-6)


def test_filters_ignore_background_values_when_scaling():
    """Huge values on background pixels (which never contribute) do not rescale the
    surface values: tiny surface AO (1e-36) beside a background of 3e38 filters to
    the same bits as beside a background of 0 (so does HEAD, which never rescaled)."""
    ao, depth, n = filter_guide()
    ao = ao * np.float32(1e-36)
    bg = ~np.isfinite(depth)
    for f in (F.bilateral, F.edge_aware_box):
        a = f(np.where(bg, np.float32(3e38), ao), depth, n)
        b = f(np.where(bg, np.float32(0.0), ao), depth, n)
        np.testing.assert_array_equal(a[~bg], b[~bg])
        assert (a[bg] == np.float32(3e38)).all()


@pytest.mark.parametrize("scale", [2.0 ** -110, 2.0 ** -120])
def test_ssao_margins_are_scale_free(scale):
    """Before: screen_space_ao_reference floored the divisors of its relative margins at
    1e-30 world units, so a scene scaled by 2**-110 (7.7e-34) got margins about 300
    times too small (3 of 768 pixels kept the unit scene's margin, 695 fell below
    1e-4 against 9), and at 2**-120 every pixel did. Now AO and margins are the unit
    scene's bit for bit."""
    g1, c1 = _corner(1.0)
    ao1, m1 = S.screen_space_ao_reference(g1, c1, 0.5, samples=16, return_margin=True)
    g, c = _corner(scale)
    ao, m = S.screen_space_ao_reference(g, c, 0.5 * scale, samples=16, return_margin=True)
    np.testing.assert_array_equal(ao, ao1)
    np.testing.assert_array_equal(m, m1)
    np.testing.assert_array_equal(S.screen_space_ao(g, c, 0.5 * scale, samples=16), ao1)


@pytest.mark.parametrize("size", [(8, 8), (1, 1), (40, 3)])
def test_vtk_ssao_small_camera_names_the_camera(size):
    """Before: a camera smaller than 16 pixels (valid everywhere else in pyshadow)
    failed with make_plotter's "window_size must be (width, height) with both in
    16..16384, got (8, 8)", an argument the caller never gave; now the error names
    the camera and its size."""
    pytest.importorskip("pyvista")
    import pyshadow
    from pyshadow.viz.ssao_pass import vtk_ssao

    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    cam = Camera(eye=(0.0, 2.0, 3.0), target=(0.0, 0.0, 0.0), up=(0, 1, 0), fov_y=50,
                 width=size[0], height=size[1])
    with pytest.raises(ValueError, match=rf"camera must be 16\.\.16384 pixels .* got {size[0]}x{size[1]}"):
        vtk_ssao(scene, cam, 0.5)


def _near_threshold_pairs(P=4000, seed=0):
    """Depths and normals of ``2P x 2`` images: row 2k holds a pair of pixels whose relative
    depth difference lies within a few float32 ulps of 0.02 (first image) or whose normals'
    cosine lies within a few of 0.9 (second), the odd rows background, so that each pair's
    window holds only the pair."""
    rng = np.random.default_rng(seed)
    zp = rng.uniform(0.5, 5.0, P).astype(np.float32)
    zq = (zp.astype(np.float64) * (1 + 0.02 * rng.choice([-1, 1], P))
          * (1 + rng.normal(size=P) * 1e-7)).astype(np.float32)
    depth = np.full((2 * P, 2), np.inf, np.float32)
    depth[::2, 0], depth[::2, 1] = zp, zq
    up = np.zeros((2 * P, 2, 3), np.float32)
    up[..., 2] = 1
    c = rng.normal(size=(P, 3))
    c /= np.linalg.norm(c, axis=1, keepdims=True)
    a = np.cross(c, rng.normal(size=(P, 3)))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    th = np.arccos(0.9) * (1 + rng.normal(size=P) * 1e-6)
    tilted = np.zeros((2 * P, 2, 3), np.float32)
    tilted[..., 2] = 1
    tilted[::2, 0], tilted[::2, 1] = c, c * np.cos(th)[:, None] + a * np.sin(th)[:, None]
    flat = np.where(np.isfinite(depth), np.float32(2.0), np.float32(np.inf))
    ao = np.zeros((2 * P, 2), np.float32)
    ao[:, 1] = 1
    return ao, (depth, up), (flat, tilted)


def test_edge_aware_box_reference_decides_in_float32():
    """Before: edge_aware_box_reference decided which neighbours count in float64, the
    device in float32, so pairs within float32 rounding of a threshold disagreed: of
    4000 depth pairs near the default 0.02, 2 pixels differed by 0.5 (a 1 x 2 image
    with depths 1.9554437 and 1.9163349: 0.5 against the device's 0), and 338 pixels
    of the 4000 normal pairs near the default 0.9. Now the reference gives the device's answer
    at every pixel, and the thresholds still split the pairs (both counts non-zero)."""
    ao, *images = _near_threshold_pairs()
    for depth, normal in images:
        got = F.edge_aware_box(ao, depth, normal, size=3)
        ref = F.edge_aware_box_reference(ao, depth, normal, size=3)
        np.testing.assert_array_equal(ref, got)
        pair = got[::2, 0]
        assert 0 < (pair == 0.5).sum() < len(pair)
    d = np.array([[1.9554437, 1.9163349]], np.float32)
    n = np.zeros((1, 2, 3), np.float32)
    n[..., 2] = 1
    a = np.array([[0.0, 1.0]], np.float32)
    np.testing.assert_array_equal(F.edge_aware_box_reference(a, d, n, size=3), [[0.0, 1.0]])
    np.testing.assert_array_equal(F.edge_aware_box(a, d, n, size=3), [[0.0, 1.0]])

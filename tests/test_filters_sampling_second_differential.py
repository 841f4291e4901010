"""Second differential pass over the image filters, SSAO and the sample directions.

Each test compares two computations that must agree: a filter given normals
of a documented-valid length against the same filter given unit normals, a
filter of values near float32's smallest against the same filter of the
image scaled back (and against its float64 NumPy reference), and the sample
directions of the kernels against their NumPy reference (and the AO of the
CSM kernel against its NumPy mirror) for normals whose z lies within
float32's rounding of -0.
"""
import numpy as np
import pytest

from pyshadow import filters as F
from pyshadow import sampling as SA

from conftest import filter_guide

_TINY = np.float32(2.0 ** -140)         # values of 2**-141 .. 2**-140: float32 subnormals
_ULP = 2.0 ** -149                      # float32's smallest subnormal, the spacing of the subnormals


def _call(name, ao, depth, normal, kw):
    """``name`` (a filter of pyshadow.filters) of ``ao``; the upsampling reads ``ao[::2, ::2]``."""
    if name.startswith("upsample"):
        ao = np.ascontiguousarray(ao[::2, ::2])
    return getattr(F, name)(ao, depth, normal, **kw)


def test_normals_off_unit_length_within_the_tolerance_are_scaled_to_unit_length():
    """Before: the filters accept normals within 1e-2 of unit length but used them as given, so
    the cosine of two equal normals of length 0.992 was 0.984: an edge-aware box with
    normal_threshold=0.99 counted no neighbour on a flat 1 x 3 image and returned its input
    [0, 0.5, 1] (unit normals: [0.25, 0.5, 0.75]); a bilateral filter with sigma_normal=0.01 gave
    0.334 instead of 0.421 at its first pixel. Now both equal the unit normals' answers, the
    references likewise, and the caller's normals are left as they were."""
    depth = np.full((1, 3), 2.0, np.float32)
    unit = np.zeros((1, 3, 3), np.float32)
    unit[..., 2] = 1.0
    short = unit * np.float32(0.992)
    ao = np.array([[0.0, 0.5, 1.0]], np.float32)
    for f in (F.edge_aware_box, F.edge_aware_box_reference):
        np.testing.assert_array_equal(f(ao, depth, short, size=3, normal_threshold=0.99), [[0.25, 0.5, 0.75]])
    want = F.bilateral_reference(ao, depth, unit, sigma_normal=0.01)
    np.testing.assert_allclose(want[0, 0], 0.4209592, atol=1e-6)
    for f in (F.bilateral, F.bilateral_reference):
        np.testing.assert_allclose(f(ao, depth, short, sigma_normal=0.01), want, atol=1e-6)
    assert (short[..., 2] == np.float32(0.992)).all()


@pytest.mark.parametrize("length", [0.995, 1.009])
@pytest.mark.parametrize("name, kw", [("edge_aware_box", {}), ("bilateral", {"sigma_normal": 0.01}),
                                      ("bilateral", {"separable": True, "sigma_normal": 0.01}),
                                      ("upsample", {"scale": 2, "sigma_normal": 0.01})])
def test_filters_of_normals_of_any_accepted_length_equal_those_of_unit_normals(name, kw, length):
    """Before: the same G-buffer with its unit normals scaled by 0.995 (or 1.009), both accepted,
    changed 165 (193) of the 231 surface pixels of the default edge-aware box by more than 2e-6,
    by up to 0.064 (0.086), and 228 (230) of the bilateral filter's with sigma_normal=0.01 by
    up to 0.097 (0.117); the separable filter's up to 0.098 (0.196), the upsampling's 0.27
    (0.44). Now every pixel is the unit normals' answer to float32 rounding (the rescaled normals
    are the unit ones to an ulp), and the reference agrees."""
    ao, depth, n = filter_guide()
    surf = np.isfinite(depth)
    want = _call(name, ao, depth, n, kw)
    scaled = n * np.float32(length)
    got = _call(name, ao, depth, scaled, kw)
    np.testing.assert_allclose(got[surf], want[surf], rtol=0, atol=2e-6)
    ref = _call(name + "_reference", ao, depth, scaled, kw)
    np.testing.assert_allclose(ref[surf], want[surf], rtol=0, atol=2e-6)


def test_unit_normals_of_float32_rounding_are_used_as_given():
    """Normals that are unit length to float32 rounding (a G-buffer's, or these nudged by an ulp)
    reach the kernels bit for bit as given, so ordinary answers keep their bits (this held
    before as well), and background normals (here zeros and 1e30) are never touched. Before,
    normals of length 1.005 reached them as given too; now they are replaced by their float64
    normalisation, rounded to float32."""
    from pyshadow.filters_validate import bilateral_inputs

    ao, depth, n = filter_guide()
    bg = ~np.isfinite(depth)
    for given in (n, np.nextafter(n, np.float32(2.0))):
        given = given.copy()
        given[bg] = (0.0, 1e30, 0.0)
        s = np.einsum("ijk,ijk->ij", given, given)[~bg]
        assert np.abs(s - 1).max() < 4e-6
        np.testing.assert_array_equal(bilateral_inputs(ao, depth, given, 1, 2.0, 0.02, 0.2)[2], given)
    off = n.copy()
    off[~bg] *= np.float32(1.005)
    off[bg] = 0.0
    got = bilateral_inputs(ao, depth, off, 1, 2.0, 0.02, 0.2)[2]
    want = off.astype(np.float64)
    want[~bg] /= np.linalg.norm(want[~bg], axis=1, keepdims=True)
    np.testing.assert_array_equal(got, want.astype(np.float32))


@pytest.mark.parametrize("name, kw", [("bilateral", {}), ("bilateral", {"separable": True}),
                                      ("edge_aware_box", {}), ("upsample", {"scale": 2}),
                                      ("upsample", {"scale": 2, "fill": 0.0})])
def test_filters_of_subnormal_values_are_the_scaled_filter(name, kw):
    """Before: values near float32's smallest (2**-141 .. 2**-140, subnormal) made subnormal
    products in the kernels' tap sums, which kept few bits: the upsampling came out up to 12
    subnormal ulps (3 %) off the image upsampled at unit scale and scaled back, at 27 of the 231
    surface pixels by more than an ulp, and so off the float64 reference (which is within an ulp);
    the separable bilateral filter up to 2 ulps. (Any finite value is documented to be filtered
    alike; values near float32's largest were fixed before.) Now the kernels filter the image
    scaled up by a power of two and scale back: within one subnormal ulp of the unit image's
    answer scaled down, and of the reference, for every filter (the 2-D bilateral filter and the
    box were within an ulp before as well)."""
    ao, depth, n = filter_guide()
    surf = np.isfinite(depth)
    img = ao * _TINY
    img[~surf] = 3e38                                   # background: passed through, never read or scaled
    got = _call(name, img, depth, n, kw)
    want = _call(name, ao, depth, n, kw) * _TINY
    ref = _call(name + "_reference", img, depth, n, kw)
    assert np.abs(got - want)[surf].max() <= _ULP
    assert np.abs(got - ref)[surf].max() <= _ULP
    assert (want[surf] > 0).all()
    if name != "upsample":
        np.testing.assert_array_equal(got[~surf], img[~surf])
    else:
        np.testing.assert_array_equal(got[~surf], kw.get("fill", 1.0))


def test_filters_of_smallest_subnormal_values_are_not_zero():
    """Before: an image of values 2**-149 .. 2**-148 (float32's two smallest) upsampled came out 0
    at 28 of its 231 surface pixels, and separably bilateral-filtered at 1, where the reference
    gives the nearest subnormal (never 0, as every value is positive). Now they agree with the
    reference to a subnormal ulp and none is 0."""
    ao, depth, n = filter_guide()
    surf = np.isfinite(depth)
    tiny = np.where(ao < 0.75, np.float32(_ULP), np.float32(2 * _ULP)).astype(np.float32)
    for name, kw in (("bilateral", {}), ("bilateral", {"separable": True}), ("upsample", {"scale": 2})):
        got = _call(name, tiny, depth, n, kw)
        ref = _call(name + "_reference", tiny, depth, n, kw)
        assert (ref[surf] > 0).all()
        assert (got[surf] > 0).all()
        assert np.abs(got - ref)[surf].max() <= _ULP


def test_ordinary_values_are_not_rescaled():
    """AO in [0, 1] (and all-zero images) is passed to the kernels as it is: no scaling, the bits of
    HEAD. Only surface values below 2**-100 scale up, by at most 2**126, and by less where
    ``fill`` is large (fill * scale stays within 2**100)."""
    surf = np.ones((2, 2), bool)
    for img in (np.zeros((2, 2)), np.full((2, 2), 2.0 ** -100), np.eye(2), np.full((2, 2), 2.0 ** 100)):
        assert F._value_scale(img.astype(np.float32), surf) == 1.0
    assert F._value_scale(np.full((2, 2), 2.0 ** -140, np.float32), surf) == 2.0 ** 126
    assert F._value_scale(np.full((2, 2), 2.0 ** -140, np.float32), surf, 1.0) == 2.0 ** 100
    assert F._value_scale(np.full((2, 2), 2.0 ** -140, np.float32), surf, 2.0 ** 99) == 2.0
    assert F._value_scale(np.full((2, 2), 2.0 ** -101, np.float32), surf) == 2.0 ** 126
    assert F._value_scale(np.full((2, 2), 2.0 ** -101, np.float32), ~surf) == 1.0


@pytest.mark.parametrize("nz", [-7e-46, -1e-46, -1e-300])
def test_reference_directions_take_the_kernels_frame_for_z_rounding_to_minus_zero(nz):
    """Before: for a normal whose z is negative but rounds to -0.0 in float32 (here (1, 0, nz),
    (0.6, 0.8, nz), (-0.6, 0.8, nz), valid: finite and non-zero) the kernels take the frame's
    s = +1 branch (-0.0 >= 0) and sample_directions_reference the s = -1 one, a frame rotated about
    the normal: the directions were up to 1.97 apart. Now the reference decides on the float32 z
    as the kernels do: within float32 rounding (2e-7) of the kernel's, and the same as for z = 0.
    Normals whose float32 z is not 0 (down to -1.4e-45) keep their frame (as before)."""
    s = SA.Sampling(8, "hammersley", 4, 0)
    n = np.array([[1.0, 0.0, nz], [0.6, 0.8, nz], [-0.6, 0.8, nz]])
    ref = SA.sample_directions_reference(n, sampling=s)
    assert np.abs(SA.sample_directions(n, sampling=s) - ref).max() < 2e-7
    at0 = n.copy()
    at0[:, 2] = 0.0
    np.testing.assert_array_equal(ref, SA.sample_directions_reference(at0, sampling=s))
    for z in (-1.4e-45, -1e-8):
        n[:, 2] = z
        ref = SA.sample_directions_reference(n, sampling=s)
        assert np.abs(SA.sample_directions(n, sampling=s) - ref).max() < 2e-7
        assert np.abs(ref - SA.sample_directions_reference(at0, sampling=s)).max() > 0.5


def test_ao_mirror_agrees_with_the_kernel_for_z_rounding_to_minus_zero():
    """Before: the NumPy mirror of the AO (backend 'numpy', which traces
    sample_directions_reference's directions) disagreed with the CSM kernel at 41 of 64 points
    with normal (0.8, 0.6, -1e-46) beside a box, by up to 0.1875 (3 of 16 samples); at
    (0.8, 0.6, -1e-8) they agreed at all 64. Now they agree at every point for both."""
    import trimesh

    import pyshadow
    from pyshadow import visibility

    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=64)
    scene.add(trimesh.creation.box((0.6, 0.6, 0.3)), trimesh.transformations.translation_matrix((0.0, 0.3, 0.35)))
    pts = np.tile([[0.0, 0.05, 0.0]], (64, 1))
    s = SA.Sampling(16, "hammersley", 64, 0)
    for nz in (-1e-8, -1e-46):
        nrm = np.tile([[0.8, 0.6, nz]], (64, 1))
        k = visibility.ambient_occlusion(scene, pts, nrm, backend="csm", sampling=s)
        m = visibility.ambient_occlusion(scene, pts, nrm, backend="numpy", sampling=s)
        assert 0.3 < k.mean() < 0.9 and (k < 1).all()
        np.testing.assert_array_equal(m, k)

"""Bad and extreme input to the screen-space and image-space stages: SSAO (pyshadow/ssao.py), the edge-aware
filters (pyshadow/filters*.py) and the smooth shading normals (pyshadow/shading_normals.py).

Each test's docstring says what happened before the fix.
"""
import math

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import ssao
from pyshadow.filters import bilateral, bilateral_reference, upsample, upsample_reference
from pyshadow.gbuffer import render_gbuffer
from pyshadow.shading_normals import check_crease_angle, corner_normals, pixel_surface, shading_gbuffer


def _unit(v):
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _filter_gbuffer(h=6, w=10, seed=4):
    """A small all-surface guide: a depth step at column 5, two normals, noisy AO (float32)."""
    rng = np.random.default_rng(seed)
    depth = np.where(np.arange(w) < 5, 4.0, 6.5)[None, :] + 0.01 * np.arange(h)[:, None]
    normal = np.broadcast_to(_unit([0.0, 0.2, 1.0]), (h, w, 3)).copy()
    normal[:, 5:] = _unit([0.5, 0.0, 1.0])
    ao = rng.uniform(0.2, 1.0, (h, w))
    return ao.astype(np.float32), depth.astype(np.float32), normal.astype(np.float32)


# --------------------------------------------------------------------------
# filters
# --------------------------------------------------------------------------
def test_bilateral_default_radius_with_a_huge_sigma_spatial():
    """Before: ``radius=None`` with sigma_spatial = 1e308 raised OverflowError ("cannot convert float
    infinity to integer": ceil(2 * sigma) of inf) from both bilateral and its reference. The default
    radius is the largest, 32: the same image as radius=32 (a 6 x 10 image: every tap is in the
    window, all spatial weights 1)."""
    ao, d, n = _filter_gbuffer()
    got = bilateral(ao, d, n, sigma_spatial=1e308)
    np.testing.assert_array_equal(got, bilateral(ao, d, n, radius=32, sigma_spatial=1e308))
    np.testing.assert_allclose(bilateral_reference(ao, d, n, sigma_spatial=1e308), got, rtol=0, atol=1e-6)


@pytest.mark.parametrize("sigma", [1e200, 1e-320])
def test_references_take_extreme_spatial_sigmas(sigma):
    """Before: the references squared sigma_spatial as a Python float: 1e200 ** 2 raised OverflowError,
    1e-320 ** 2 = 0 ZeroDivisionError (the device filters, which clamp 1 / sigma, ran). Now they agree
    with the device to float32 rounding (atol 1e-6 on values in [0.2, 1]); with the tiny sigma only the
    centre tap weighs (bilateral returns ``ao``; upsample the sample itself at sample pixels)."""
    ao, d, n = _filter_gbuffer()
    ref = bilateral_reference(ao, d, n, radius=3, sigma_spatial=sigma)
    np.testing.assert_allclose(ref, bilateral(ao, d, n, radius=3, sigma_spatial=sigma), rtol=0, atol=1e-6)
    low = ao[::2, ::2].copy()
    up = upsample_reference(low, d, n, scale=2, sigma_spatial=sigma)
    np.testing.assert_allclose(up, upsample(low, d, n, scale=2, sigma_spatial=sigma), rtol=0, atol=1e-6)
    if sigma < 1:
        np.testing.assert_array_equal(ref, ao)
        np.testing.assert_array_equal(up[::2, ::2], low)


def test_filters_name_finite_ao_beyond_float32():
    """Before: a float64 AO of 1e300 at a surface pixel was refused as holding "NaN/inf" values, quoting
    inf (the value after the float32 cast), not the finite 1e300 the caller passed (and with warnings as
    errors the cast's RuntimeWarning "overflow encountered in cast" came first); likewise ao_low."""
    ao, d, n = _filter_gbuffer()
    big = ao.astype(np.float64)
    big[2, 4] = 1e300
    with pytest.raises(ValueError, match=r"ao holds 1 finite value\(s\) beyond float32's range.*1e\+300"):
        bilateral(big, d, n)
    with pytest.raises(ValueError, match=r"ao_low holds 1 finite value\(s\) beyond float32's range.*1e\+300"):
        upsample_reference(big[::2, ::2], d, n, scale=2)


# --------------------------------------------------------------------------
# SSAO
# --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def ssao_view():
    """A unit cube on a floor slab, seen from above at 40 x 30 pixels (background at the top): its
    G-buffer and camera."""
    floor = trimesh.creation.box((6.0, 0.2, 6.0))
    T_floor = np.eye(4)
    T_floor[1, 3] = -0.1
    cube = trimesh.creation.box((1.0, 1.0, 1.0))
    T_cube = np.eye(4)
    T_cube[1, 3] = 0.5
    cam = pyshadow.Camera((2.0, 2.2, 2.6), (0.0, 0.3, 0.0), fov_y=50.0, width=40, height=30)
    g = render_gbuffer([(floor, T_floor), (cube, T_cube)], cam)
    assert 0 < np.isfinite(g["depth"]).mean() < 1
    return {"depth": g["depth"], "normal": g["normal"]}, cam


def test_ssao_refuses_depths_below_float32s_normal_range(ssao_view):
    """Before: the view scaled by 2**-150 (distances about 1e-45, float32 subnormals or 0 on the device)
    came back open at every pixel (AO 1), where the same view at any scale has occluded pixels. Scaled by
    2**-120 (distances about 1e-36) it is still exactly the unscaled answer; at 2**-150 it is refused."""
    g, cam = ssao_view
    base = ssao.screen_space_ao(g, cam, 0.5, samples=16)
    assert (base < 1).sum() > 20
    d = g["depth"].astype(np.float64)
    small = {"depth": d * 2.0**-120, "normal": g["normal"]}
    np.testing.assert_array_equal(ssao.screen_space_ao(small, cam, 0.5 * 2.0**-120, samples=16), base)
    tiny = {"depth": d * 2.0**-150, "normal": g["normal"]}
    for fn in (ssao.screen_space_ao, ssao.screen_space_ao_reference):
        with pytest.raises(ValueError, match=r"gbuffer\['depth'\] holds distances below float32's normal range"):
            fn(tiny, cam, 0.5 * 2.0**-150, samples=16)
    with pytest.raises(ValueError, match="below float32's normal range"):
        ssao.view_depth(tiny, cam)


def test_ssao_takes_normals_of_any_length(ssao_view):
    """Before: normals shorter than 1e-6 (the unnormalised face normals of a mesh in micrometres) or
    longer than 1e154 (float64: the norm overflowed) were refused as "must be finite and non-zero". Only
    their direction counts: scaled by 2**-30 (float32, exact) the answer is the unit normals', bit for
    bit; by 1e-200 and 1e200 (float64) too (the normalised float32 normals are the same)."""
    g, cam = ssao_view
    base = ssao.screen_space_ao(g, cam, 0.5, samples=16)
    for n in (g["normal"] * np.float32(2.0**-30), g["normal"].astype(np.float64) * 1e-200,
              g["normal"].astype(np.float64) * 1e200):
        np.testing.assert_array_equal(ssao.screen_space_ao({"depth": g["depth"], "normal": n}, cam, 0.5,
                                                           samples=16), base)
    with pytest.raises(ValueError, match="non-zero.*1 rows are zero vectors"):
        n = g["normal"].copy()
        n[-1, 4] = 0.0                  # a surface pixel
        ssao.screen_space_ao({"depth": g["depth"], "normal": n}, cam, 0.5)


def test_ssao_refuses_what_is_no_number(ssao_view, no_launch):
    """Before: a bool depth buffer ran as distances 0 and 1, a depth buffer of strings was parsed, complex
    normals lost their imaginary part (a ComplexWarning), radius=True was 1 and radius="0.5" or
    bias="0.1" were parsed; return_margin=np.array([1, 1]) raised NumPy's "truth value ... is
    ambiguous". Each is now a TypeError naming the argument, before anything is launched."""
    g, cam = ssao_view
    cases = [({"depth": np.ones(g["depth"].shape, bool), "normal": g["normal"]}, {}, r"gbuffer\['depth'\].*bool"),
             ({"depth": g["depth"].astype(str), "normal": g["normal"]}, {}, r"gbuffer\['depth'\].*<U"),
             ({"depth": g["depth"], "normal": g["normal"].astype(complex)}, {}, r"gbuffer\['normal'\].*complex"),
             (g, {"radius": True}, "radius must be a number"),
             (g, {"radius": "0.5"}, "radius must be a number"),
             (g, {"bias": "0.1"}, "bias must be a number"),
             (g, {"bias": True}, "bias must be a number")]
    for gb, kw, match in cases:
        kw = {"radius": 0.5, **kw}
        for fn in (ssao.screen_space_ao, ssao.screen_space_ao_reference):
            with pytest.raises(TypeError, match=match):
                fn(gb, cam, **kw)
    with pytest.raises(TypeError, match="return_margin must be a bool"):
        ssao.screen_space_ao_reference(g, cam, 0.5, return_margin=np.array([1, 1]))


def test_view_depth_checks_the_depth_buffer(ssao_view):
    """Before: view_depth read NaN as background (inf), returned a negative view depth for a negative
    distance, and a buffer of the wrong shape or a bare array failed inside NumPy (a broadcast error,
    an IndexError). Valid distances give depth * cos(angle to forward) (float32)."""
    g, cam = ssao_view
    z = ssao.view_depth(g, cam)
    cos = cam.ray_directions() @ cam.forward
    np.testing.assert_array_equal(z, (g["depth"].astype(np.float64) * cos).astype(np.float32))
    d = g["depth"].copy()
    d[1, 2] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        ssao.view_depth({"depth": d}, cam)
    d[1, 2] = -3.0
    with pytest.raises(ValueError, match="must be > 0"):
        ssao.view_depth({"depth": d}, cam)
    with pytest.raises(ValueError, match=r"has shape \(29, 40\); the camera needs \(30, 40\)"):
        ssao.view_depth({"depth": g["depth"][1:]}, cam)
    with pytest.raises(TypeError, match="gbuffer must be a mapping"):
        ssao.view_depth(g["depth"], cam)


# --------------------------------------------------------------------------
# smooth shading normals
# --------------------------------------------------------------------------
@pytest.mark.parametrize("scale", [2.0**-340, 2.0**600])
def test_corner_normals_at_extreme_mesh_scales(scale):
    """Before: an icosphere in units of 2**-340 (1e-102) got "unit" corner normals of length 1e-206 (the
    squared length of every face's cross product underflowed to 0, so the faces' normals were left
    unnormalised), one of 2**600 (4e180) NaN ones with overflow RuntimeWarnings. Scaled by a power of two
    the corner normals are the unit sphere's, bit for bit."""
    ico = trimesh.creation.icosphere(2)
    scaled = trimesh.Trimesh(ico.vertices * scale, ico.faces, process=False)
    want, smooth = corner_normals(ico, return_smooth=True)
    got, got_smooth = corner_normals(scaled, return_smooth=True)
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(got_smooth, smooth)
    np.testing.assert_allclose(np.linalg.norm(got, axis=-1), 1.0, rtol=0, atol=1e-15)


def test_shading_gbuffer_names_items_that_do_not_match():
    """Before: a G-buffer rendered from two items but shaded with one raised a bare IndexError ("list
    index out of range"), and with the items swapped IndexError "index 28 is out of bounds" (a face of
    the icosphere looked up in the box)."""
    box, ico = trimesh.creation.box(), trimesh.creation.icosphere(2, 0.5)
    T1, T2 = np.eye(4), np.eye(4)
    T2[0, 3] = 1.2
    cam = pyshadow.Camera((2.0, 1.5, 2.5), (0.0, 0.0, 0.0), width=24, height=18)
    g = render_gbuffer([(box, T1), (ico, T2)], cam)
    assert set(np.unique(g["object_id"])) == {-1, 0, 1}
    assert shading_gbuffer([(box, T1), (ico, T2)], g, cam)["normal"].shape == (18, 24, 3)
    with pytest.raises(ValueError, match=r"gbuffer\['object_id'\] holds id 1 but there are 1 items"):
        shading_gbuffer([(box, T1)], g, cam)
    with pytest.raises(ValueError, match=r"gbuffer\['face'\] holds face \d+ of item 1, whose mesh has 12 faces"):
        pixel_surface([(ico, T2), (box, T1)], g, cam)


def test_crease_angle_refuses_strings():
    """Before: check_crease_angle("0.5") returned 0.5 (float() parsed the string)."""
    with pytest.raises(ValueError, match="crease_angle: expected a number of radians"):
        check_crease_angle("0.5")
    assert check_crease_angle(np.float32(0.5)) == float(np.float32(0.5))
    assert check_crease_angle(1) == 1.0 and check_crease_angle(0.0) == 0.0 < math.pi / 2

"""Extreme and bad input of the camera, G-buffer, filters, SSAO, classic shadow map and shading: each case
once crashed with an unrelated message, gave NaN/inf or silently answered wrongly; now it is answered
right or refused with a message naming the argument."""
import re

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import filters, ssao
from pyshadow.gbuffer import gbuffer_triangles
from pyshadow.lighting import DirectionalLight, Lighting
from pyshadow.lighting.phong import PhongLighting, light_terms, phong_shade
from pyshadow.lighting.shade import sky_radiance
from pyshadow.lighting.shadow_map import ShadowMapVisibility


def small_scene(ground=0.0):
    return pyshadow.Scene(ground=ground, views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)


@pytest.fixture(scope="module")
def sphere_scene():
    """A sphere of radius 0.5 floating at height 1 over the ground plane y = 0."""
    scene = small_scene()
    scene.add(trimesh.creation.icosphere(2, radius=0.5), trimesh.transformations.translation_matrix([0, 1, 0]))
    return scene


# ---------------------------------------------------------------------------------------------- camera
@pytest.mark.parametrize("eye, target, forward", [
    ((0.0, 0.0, 0.0), (1e-200, 0.0, 0.0), (1.0, 0.0, 0.0)),          # |target - eye|^2 underflowed: "coincide"
    ((1e308, 0.0, 0.0), (-1e308, 0.0, 0.0), (-1.0, 0.0, 0.0)),       # target - eye overflowed: "parallel"
    ((0.0, 0.0, 5e300), (0.0, 0.0, 0.0), (0.0, 0.0, -1.0)),          # |target - eye| overflowed: "parallel"
])
def test_camera_direction_of_any_finite_eye_and_target(eye, target, forward):
    cam = pyshadow.Camera(eye, target)
    np.testing.assert_array_equal(cam.forward, forward)
    assert np.isfinite(cam.ray_directions()).all()


def test_camera_up_of_any_length():
    """Only up's direction counts: a huge or tiny up is not "parallel to the viewing direction"."""
    big = pyshadow.Camera((0, 0, 0), (0, 0, 1), up=(1e300, 1e300, 0))
    np.testing.assert_allclose(big.up, [np.sqrt(0.5), np.sqrt(0.5), 0.0], rtol=1e-15)
    tiny = pyshadow.Camera((0, 0, 0), (0, 0, 1), up=(0.0, 1e-320, 0.0))
    np.testing.assert_array_equal(np.abs(tiny.up), [0.0, 1.0, 0.0])
    with pytest.raises(ValueError, match=re.escape("Camera: up must not be the zero vector, got [0.0, 0.0, 0.0]")):
        pyshadow.Camera((0, 0, 0), (0, 0, 1), up=(0, 0, 0))


@pytest.mark.parametrize("fov", ["abc", None, np.array([45.0, 50.0]), True])
def test_camera_fov_must_be_a_number(fov):
    with pytest.raises(TypeError, match=re.escape(f"Camera: fov_y must be a number (degrees), got {fov!r}")):
        pyshadow.Camera((0, 0, 0), (0, 0, 1), fov_y=fov)


def test_camera_eye_not_numbers():
    with pytest.raises(ValueError, match=re.escape("Camera: eye must be 3 finite numbers, got 'abc'")):
        pyshadow.Camera("abc", (0, 0, 1))


# ------------------------------------------------------------------------------------------- G-buffer
def _camera(**kw):
    return pyshadow.Camera((0, 0, 5), (0, 0, 0), width=16, height=12, **kw)


def test_gbuffer_checks_a_trimesh_item():
    """A Trimesh is used as given: a NaN vertex silently dropped its triangles (a hole), a stray face
    index raised numpy's IndexError."""
    s = trimesh.creation.icosphere(1)
    nan = trimesh.Trimesh(s.vertices.copy(), s.faces.copy(), process=False)
    nan.vertices[0] = np.nan
    with pytest.raises(ValueError, match=re.escape("item 0: 1 of 42 vertices are not finite (NaN or inf), "
                                                   "e.g. vertex 0 = [nan nan nan]")):
        pyshadow.render_gbuffer([(nan, np.eye(4))], _camera())
    stray = trimesh.Trimesh(s.vertices, np.vstack([s.faces, [[0, 1, 500]]]), process=False)
    with pytest.raises(ValueError, match="^item 0: a face refers to a vertex that does not exist$"):
        pyshadow.render_gbuffer([(stray, np.eye(4))], _camera())


def test_gbuffer_refuses_vertices_its_transform_moves_beyond_float64():
    s = trimesh.creation.icosphere(1)
    huge = trimesh.Trimesh(s.vertices * 1e308, s.faces, process=False)
    T = np.diag([10.0, 10.0, 10.0, 1.0])
    with pytest.raises(ValueError, match=re.escape("item 0: its transform places vertices beyond float64's range "
                                                   "from the camera (largest |vertex| 1e+308, transform scale up "
                                                   "to 10)")):
        gbuffer_triangles([(huge, T)], _camera())


def test_gbuffer_refuses_geometry_beyond_float32():
    """A sphere of radius 1e38 seen from 5e38: the float32 depths were inf at covered pixels."""
    T = np.diag([1e38, 1e38, 1e38, 1.0])
    cam = pyshadow.Camera((0, 0, 5e38), (0, 0, 0), width=16, height=12)
    with pytest.raises(ValueError, match=re.escape(
            "render_gbuffer: the geometry in view lies up to 1.54e+39 from the world origin (eye [0.0, 0.0, 5e+38], "
            "farthest geometry in view 6e+38 from it); the G-buffer's float32 depths and positions hold at most "
            "3.4e+38")):
        pyshadow.render_gbuffer([(trimesh.creation.icosphere(1), T)], cam)


# -------------------------------------------------------------------------------------------- filters
def _guide(H=6, W=8):
    d = np.full((H, W), 2.0)
    n = np.zeros((H, W, 3))
    n[..., 2] = 1.0
    return d, n


@pytest.mark.parametrize("fn", [filters.bilateral, filters.bilateral_reference, filters.edge_aware_box])
def test_filters_refuse_depth_beyond_float32(fn):
    """A finite float64 depth of 1e39 became +inf in float32: the pixel was silently background."""
    d, n = _guide()
    d[0, 3] = 1e39
    with pytest.raises(ValueError, match=re.escape("depth holds 1 finite value(s) beyond float32's range "
                                                   "(|x| > 3.4e+38; the filters compute in float32), first at "
                                                   "(0, 3): 1e+39")):
        fn(np.full(d.shape, 0.5), d, n)


def test_filters_keep_float32_inf_background():
    d, n = _guide()
    d[:, :4] = np.inf
    out = filters.bilateral(np.full(d.shape, 0.5), d, n)
    np.testing.assert_array_equal(out, np.full(d.shape, 0.5, np.float32))


def test_upsample_refuses_fill_beyond_float32():
    d, n = _guide()
    with pytest.raises(ValueError, match=re.escape("fill must lie within float32's range (|fill| <= 3.4e+38), "
                                                   "got 1e+39")):
        filters.upsample(np.full((3, 4), 0.5), d, n, scale=2, fill=1e39)


# ----------------------------------------------------------------------------------------------- SSAO
def _ssao_input():
    cam = pyshadow.Camera((0, 0, 5), (0, 0, 0), width=4, height=3)
    g = {"depth": np.full((3, 4), 5.0), "normal": np.tile(-cam.forward, (3, 4, 1))}
    return g, cam


@pytest.mark.parametrize("kwargs, exc, message", [
    (dict(seed=1.7), TypeError, "seed must be an int, got 1.7"),           # was truncated to seed 1
    (dict(seed="a"), TypeError, "seed must be an int, got 'a'"),
    (dict(bias="a"), TypeError, "bias must be a number (world units) or None, got 'a'"),
    (dict(bias=[1, 2]), TypeError, "bias must be a number (world units) or None, got [1, 2]"),
    (dict(bias=1e39), ValueError, "bias must be at most 3.4e+38 (float32's range; world units), got 1e+39"),
    (dict(radius=1e39), ValueError, "radius must be at most 3.4e+38 (float32's range; world units), got 1e+39"),
    (dict(range_check="no"), TypeError, "range_check must be a bool, got 'no'"),
])
def test_ssao_options(kwargs, exc, message):
    g, cam = _ssao_input()
    radius = kwargs.pop("radius", 0.5)
    for fn in (ssao.screen_space_ao, ssao.screen_space_ao_reference):
        with pytest.raises(exc, match="^" + re.escape(message) + "$"):
            fn(g, cam, radius, **kwargs)


@pytest.mark.parametrize("value, message", [
    (np.nan, "gbuffer['depth'] holds 1 NaN or -inf value(s); use +inf for the background"),
    (-np.inf, "gbuffer['depth'] holds 1 NaN or -inf value(s); use +inf for the background"),
    (1e39, "gbuffer['depth'] holds distances beyond float32's range (up to 1e+39; the kernel reads at most "
           "3.4e+38)"),
])
def test_ssao_refuses_depth_it_took_for_background(value, message):
    """NaN, -inf and float64 depths beyond float32 were read as background (AO 1) without a word."""
    g, cam = _ssao_input()
    g["depth"][1, 2] = value
    with pytest.raises(ValueError, match="^" + re.escape(message) + "$"):
        ssao.screen_space_ao(g, cam, 0.5)


def test_ssao_gbuffer_must_be_a_mapping():
    _, cam = _ssao_input()
    with pytest.raises(TypeError, match=re.escape("gbuffer must be a mapping with 'depth' and 'normal' "
                                                  "(render_gbuffer's dict or a Frame), got NoneType")):
        ssao.screen_space_ao(None, cam, 0.5)


# ------------------------------------------------------------------------------------ classic shadow map
@pytest.mark.parametrize("length", [1e-50, 1e39, 1e300])
def test_shadow_map_normals_of_any_length(length):
    """Normals "of any non-zero length": float32 made a length-1e-50 normal zero (no receiver plane: acne
    on 36 % of a lit slab at 8 degrees) and a 1e39 one infinite (an overflow warning)."""
    scene = small_scene(ground=None)
    scene.add(trimesh.creation.box((4.0, 0.2, 4.0)), trimesh.transformations.translation_matrix([0, 0.1, 0]))
    e = np.radians(8)
    rng = np.random.default_rng(3)
    p = np.c_[rng.uniform(-1.9, 1.9, 3000), np.full(3000, 0.2), rng.uniform(-1.9, 1.9, 3000)]
    w = np.tile([np.cos(e), np.sin(e), 0.0], (len(p), 1))
    sm = ShadowMapVisibility(256)
    assert sm.visible(scene, p, w, normals=np.tile([0.0, 1.0, 0.0], (len(p), 1))).all()
    assert sm.visible(scene, p, w, normals=np.tile([0.0, length, 0.0], (len(p), 1))).all()


def test_shadow_map_opposite_directions(sphere_scene):
    """Directions that cancel out: the mean was the zero vector (NaN in the message, a RuntimeWarning)."""
    p = np.array([[2.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match=re.escape(
            "a shadow map answers the rays of one light: unbounded rays must share one direction (a directional "
            "light), but ray 1's direction [0.0, -1.0, 0.0] lies 3.14 rad from ray 0's direction [0.0, 1.0, 0.0] "
            "(> 1e-06)")):
        ShadowMapVisibility(64).visible(sphere_scene, p, np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]))


def test_shadow_map_point_light_far_from_the_origin(sphere_scene):
    """A point light beyond 2^53 made its cube cameras' targets equal their eye ("Camera: eye and target
    coincide"); the faces are the same axis-aligned frames as near the origin."""
    sm = ShadowMapVisibility(16)
    far = sm.shadow_map(sphere_scene, position=(0.0, 1e17, 0.0))
    near = sm.shadow_map(sphere_scene, position=(0.0, 10.0, 0.0))
    assert far.kind == "point"
    np.testing.assert_array_equal(far.frame, near.frame)


def test_shadow_map_bias_beyond_float32():
    with pytest.raises(ValueError, match=re.escape(
            "bias must be a finite number >= 0 (world units) or None, got 1e+39 (beyond float32's range, 3.4e+38: "
            "the kernel reads it as float32)")):
        ShadowMapVisibility(64, bias=1e39)


# --------------------------------------------------------------------------------------- Phong, shading
def test_phong_specular_at_the_mirror_direction_with_a_huge_exponent():
    """e . r rounded above 1 at the mirror direction: (1 + 2e-16)^1e300 overflowed to inf."""
    light = np.array([-0.9669447289429418, 2.393863614413848, 0.7320932954987329])
    eye = light * [-1, 1, -1]
    _, spec = light_terms(np.zeros((1, 3)), np.array([[0.0, 1.0, 0.0]]), eye, light, 1e300)
    assert spec.tolist() == [1.0]


def test_phong_light_far_away(sphere_scene):
    """A light beyond 1e154: |l|^2 overflowed, l came out zero (no diffuse term) and the shadow rays were
    answered as lit; now the point under the sphere is shadowed, the open one lit."""
    p = np.array([[2.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    n = np.array([[0.0, 1.0, 0.0]] * 2)
    c, _, v = phong_shade(sphere_scene, p, n, (0.0, 5.0, 0.0), PhongLighting((0.0, 1e300, 0.0)), [0.5, 0.5],
                          backend="numpy")
    assert v.tolist() == [1.0, 0.0]
    np.testing.assert_allclose(c[:, 0], [0.8 * (0.5 * 0.2 + 1.0), 0.8 * 0.5 * 0.2], rtol=1e-12)


@pytest.mark.parametrize("albedo, message", [
    (np.nan, "albedo: must be finite and lie in [0, 1] (got nan)"),
    (5.0, "albedo: must be finite and lie in [0, 1] (got 5.0)"),
    ([[0.5, 0.5, -0.1], [0.5, 0.5, 0.5]], "albedo: must be finite and lie in [0, 1] per channel (1 value(s) do "
                                          "not, e.g. -0.1)"),
    (np.ones((3, 3)), "albedo: expected a scalar, an RGB triple or (2, 3) values (got shape (3, 3))"),
])
def test_phong_albedo_is_checked(sphere_scene, albedo, message):
    """phong_shade(albedo=) went into the colour unchecked: NaN, negative or > 1 colours, numpy's
    broadcast error."""
    p = np.array([[2.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
    n = np.array([[0.0, 1.0, 0.0]] * 2)
    with pytest.raises(ValueError, match="^" + re.escape(message) + "$"):
        phong_shade(sphere_scene, p, n, (0.0, 5.0, 0.0), PhongLighting((0.0, 3.0, 0.0)), [0.5, 0.5],
                    backend="numpy", albedo=albedo)


def test_phong_eye_not_numbers(sphere_scene):
    with pytest.raises(ValueError, match=re.escape("eye: expected a finite 3-vector (got 'abc')")):
        phong_shade(sphere_scene, [[2.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]], "abc", PhongLighting((0.0, 3.0, 0.0)),
                    [0.5], backend="numpy")


def test_lighting_albedo_not_numbers():
    with pytest.raises(ValueError, match=re.escape("albedo: expected an RGB albedo of shape (3,) or a scalar "
                                                   "(got [0.1, 'a', 0.3])")):
        Lighting(albedo=[0.1, "a", 0.3])


def test_sky_radiance_refuses_nan():
    lt = Lighting(np.eye(9, 3), sun=DirectionalLight((0, 1, 0), (1, 1, 1)))
    n = np.array([[0.0, 1.0, 0.0]] * 2)
    with pytest.raises(ValueError, match=re.escape("sky_radiance: ao holds 1 non-finite value(s)")):
        sky_radiance(lt, [np.nan, 0.5], n, np.full((2, 3), 0.5))

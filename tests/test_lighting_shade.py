"""Shading ("bent" sky and the sun with its shadow), render(lighting=), tone mapping and EXR output
(pyshadow.lighting.shade, pyshadow.lighting.tonemap; issue 19)."""
import math

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling, visibility
from pyshadow import render as render_stage
from pyshadow.io import read_image
from pyshadow.lighting import (DirectionalLight, EnvironmentMap, Lighting, irradiance_sh, shade, shade_terms,
                               tonemap, write_radiance)
from pyshadow.lighting.shade import sun_directions
from pyshadow.scene import GROUND_ID

from test_render import BUFFERS, assert_frames_equal, small_camera

SKY_C = np.array([1.0, 2.0, 0.5])
ALBEDO = np.array([0.5, 0.6, 0.7])


def constant_sky(c=SKY_C):
    return EnvironmentMap(np.tile(np.asarray(c, float), (16, 32, 1)))


def top_and_far_ground(n=8):
    """Points on small_scene's box top face (y = 0.5, open sky above) and on the ground 40 units away."""
    g = np.linspace(-0.4, 0.4, n)
    top = np.column_stack([np.repeat(g, n), np.full(n * n, 0.5), np.tile(g, n)])
    far = top + [40.0, -0.5, 0.0]
    p = np.vstack([top, far])
    nrm = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    ids = np.r_[np.zeros(n * n, np.int32), np.full(n * n, GROUND_ID, np.int32)]
    return p, nrm, ids


@pytest.mark.parametrize("mode, backend", [("bent", "csm"), ("bent", "csm-vote"), ("bent", "numpy"),
                                           ("sampled", "csm"), ("sampled", "numpy"), ("sampled", "embree")])
def test_constant_sky_on_open_surfaces_is_albedo_times_c(small_scene, mode, backend):
    """A constant sky c and nothing in the way: E = pi c ("bent"), every sample sees c ("sampled"), so
    L = albedo c (float32 rounding), on the box's top face (its albedo) and on the ground far away (the
    ground's albedo)."""
    p, nrm, ids = top_and_far_ground()
    light = Lighting(constant_sky(), albedo=ALBEDO, ground_albedo=0.25, mode=mode)
    t = shade_terms(small_scene, p, nrm, light, backend=backend, sampling=Sampling(36), surface_ids=ids)
    assert t.radiance.dtype == np.float32 and t.radiance.shape == (len(p), 3)
    assert (t.ao == 1).all()
    want = np.where((ids == GROUND_ID)[:, None], 0.25 * SKY_C, ALBEDO * SKY_C)
    np.testing.assert_allclose(t.radiance, want, rtol=2e-7, atol=0)
    assert (t.sun == 0).all() and (t.sun_visibility == 1).all()


def test_render_bent_radiance_is_ao_times_irradiance_at_the_bent_normal(small_scene):
    """render(lighting=) against an independent AO call: L = AO * max(E(bent), 0) / pi * albedo per
    covered pixel, 0 on the background; the ground gets the ground's albedo."""
    cam = small_camera()
    rng = np.random.default_rng(3)
    coef = rng.normal(size=(9, 3)) * 0.3
    coef[0] = [3.0, 2.5, 2.0]                       # a smooth sky, brighter than its rings
    light = Lighting(coef, albedo=ALBEDO, ground_albedo=(0.2, 0.3, 0.4))
    s = Sampling(16)
    frame = render_stage.render(small_scene, cam, sampling=s, lighting=light)
    sp = render_stage.surface_points(small_scene, cam)
    ao, bent = visibility.ambient_occlusion(small_scene, sp.points, sp.normals, sampling=s,
                                            return_bent_normals=True, indices=sp.index,
                                            surface_ids=sp.surface_ids)
    albedo = np.where((sp.surface_ids == GROUND_ID)[:, None], [0.2, 0.3, 0.4], ALBEDO)
    want = ao[:, None] * np.maximum(irradiance_sh(coef, bent), 0) / math.pi * albedo
    assert frame.radiance.dtype == np.float32 and frame.radiance.shape == (32, 48, 3)
    got = frame.radiance.reshape(-1, 3)[sp.index]
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-7)
    assert (frame.radiance[frame.object_id == -1] == 0).all()
    assert (ao < 1).any() and (ao == 1).any()       # the sky term really sees occlusion
    assert "radiance" in frame and list(frame)[-1] == "radiance"


def test_render_without_lighting_is_unchanged(small_scene):
    """lighting=None: the same frame bit for bit as before the argument existed, and the lit frame's
    other buffers are those of the unlit one."""
    cam = small_camera()
    s = Sampling(8)
    a = render_stage.render(small_scene, cam, sampling=s)
    b = render_stage.render(small_scene, cam, sampling=s, lighting=None)
    c = render_stage.render(small_scene, cam, sampling=s, lighting=Lighting(constant_sky()))
    assert_frames_equal(a, b)
    assert_frames_equal(a, c, BUFFERS)
    assert a.radiance is None and b.radiance is None and "radiance" not in b and len(b) == 6


@pytest.mark.parametrize("options", [dict(ao_scale=2), dict(denoise="bilateral")])
def test_render_lights_the_frames_final_ao(small_scene, options):
    """With reduced-resolution AO or a denoiser the radiance uses the frame's final AO image (and
    upsampled bent normals): a constant sky gives L = AO * albedo * c on every covered pixel."""
    cam = small_camera()
    light = Lighting(constant_sky(), albedo=ALBEDO, ground_albedo=ALBEDO)
    frame = render_stage.render(small_scene, cam, sampling=Sampling(8), lighting=light, **options)
    hit = frame.object_id != -1
    want = frame.ao[..., None] * ALBEDO * SKY_C
    np.testing.assert_allclose(frame.radiance[hit], want[hit], rtol=1e-6)
    assert (frame.radiance[~hit] == 0).all() and np.isfinite(frame.radiance).all()


def test_sun_on_a_sphere_has_no_self_shadowed_pixel():
    """A tessellated sphere under the sun, no sky: every pixel with n.l > 0.05 is lit with
    albedo / pi * E * n.l (the surface rule), every pixel with n.l <= 0 is black. The sun directions
    are ones where the same rays asked without normals shadow some pixels (checked: the test bites)."""
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    scene = pyshadow.Scene(views=pyshadow.ViewSet.zigzag(16, 32), resolution=64)
    scene.add(sphere)
    cam = pyshadow.Camera([0.5, 1.0, 3.5], [0.0, 0.0, 0.0], width=96, height=96)
    E = np.array([3.0, 2.0, 1.0])
    without_normals = 0
    for d in ([-0.811, 0.41, 0.417], [0.077, -0.871, -0.485], [0.529, -0.645, 0.551]):
        sun = np.asarray(d) / np.linalg.norm(d)
        light = Lighting(sun=DirectionalLight(sun, E), albedo=ALBEDO)
        frame = render_stage.render(scene, cam, sampling=Sampling(4), lighting=light)
        hit = frame.object_id == 0
        ndl = frame.normal @ sun
        lit = hit & (ndl > 0.05)
        assert lit.sum() > 100
        want = ALBEDO / math.pi * E * ndl[..., None]
        np.testing.assert_allclose(frame.radiance[lit], want[lit], rtol=1e-5)
        assert (frame.radiance[hit & (ndl <= 0)] == 0).all()
        sp = render_stage.surface_points(scene, cam)
        sel = sp.normals @ sun > 0.05
        without_normals += int((~visibility.visible(scene, sp.points[sel], np.tile(sun, (int(sel.sum()), 1)),
                                                    surface_ids=0)).sum())
    assert without_normals > 0


def test_point_under_a_box_is_dark_and_open_ground_is_lit(small_scene):
    """Sun along (1, 1, 0)/sqrt 2 over small_scene's unit box: the ground point (-0.9, 0, 0) looks at
    the sun through the box (dark), (2, 0, 0) and (-0.9, 0, 2) do not (lit: albedo / pi * E / sqrt 2)."""
    sun = np.array([1.0, 1.0, 0.0]) / math.sqrt(2)
    E = np.array([2.0, 2.0, 2.0])
    light = Lighting(sun=DirectionalLight(sun, E), ground_albedo=0.5)
    p = np.array([[-0.9, 0.0, 0.0], [2.0, 0.0, 0.0], [-0.9, 0.0, 2.0]])
    up = np.tile([0.0, 1.0, 0.0], (3, 1))
    for backend in ("csm", "csm-vote", "numpy", "embree"):
        t = shade_terms(small_scene, p, up, light, backend=backend, sampling=Sampling(8), surface_ids=GROUND_ID)
        assert (t.sun[0] == 0).all(), backend
        np.testing.assert_allclose(t.sun[1:], np.tile(0.5 / math.pi * E / math.sqrt(2), (2, 1)), rtol=1e-6)


def test_kernel_matches_the_numpy_composition():
    """The same composition with backend="numpy": the AO rays and sun rays that differ are at most 1 in
    1000 (plus one), as for visibility itself; every pixel that agrees on its rays agrees to float32
    rounding. A soft sun (K = 8, radius 0.15) over a box on the ground, 16 x 32 maps (coarser view sets
    put the whole cone in one map: no penumbra), exercises the cone."""
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(16, 32), resolution=64)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)))
    cam = small_camera(64, 48)
    sun = np.array([-0.5, 0.7, -0.5])
    sun /= np.linalg.norm(sun)
    light = Lighting(constant_sky(), sun=DirectionalLight(sun, [4.0, 4.0, 4.0], 0.15), sun_samples=8)
    sp = render_stage.surface_points(scene, cam)
    s = Sampling(16)
    kw = dict(sampling=s, surface_ids=sp.surface_ids, indices=sp.index)
    a = shade_terms(scene, sp.points, sp.normals, light, backend="csm", **kw)
    b = shade_terms(scene, sp.points, sp.normals, light, backend="numpy", **kw)
    n = len(sp.index)
    ao_rays = np.rint(np.abs(a.ao - b.ao) * s.samples).sum()
    sun_rays = np.rint(np.abs(a.sun_visibility - b.sun_visibility) * 8).sum()
    assert ao_rays <= 1 + n * s.samples / 1000
    assert sun_rays <= 1 + n * 8 / 1000
    assert ((a.sun_visibility > 0) & (a.sun_visibility < 1)).sum() > 50       # a penumbra
    assert (a.sun_visibility == 0).sum() > 50 and (a.ao < 1).sum() > 50     # shadow and occlusion
    same = (a.ao == b.ao) & (a.sun_visibility == b.sun_visibility)
    np.testing.assert_allclose(a.radiance[same], b.radiance[same], rtol=1e-5, atol=1e-6)
    frame = render_stage.render(scene, cam, sampling=s, lighting=light)
    np.testing.assert_array_equal(frame.radiance.reshape(-1, 3)[sp.index], a.radiance)


def test_soft_sun_directions_cover_the_disc_deterministically():
    light = DirectionalLight([0.0, 1.0, 0.0], [1.0, 1.0, 1.0], 0.1)
    d = sun_directions(light, 64, np.arange(5), seed=7)
    assert d.shape == (5, 64, 3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=2), 1.0, atol=1e-12)
    ang = np.arccos(np.clip(d[..., 1], -1, 1))
    assert ang.max() <= 0.1 and ang.min() < 0.02
    np.testing.assert_allclose(d.mean(axis=(0, 1))[[0, 2]], 0.0, atol=5e-3)     # centred on the axis
    np.testing.assert_array_equal(d, sun_directions(light, 64, np.arange(5), seed=7))
    assert not np.array_equal(d, sun_directions(light, 64, np.arange(5), seed=8))
    assert not np.array_equal(d[0], d[1])                                          # turned per point
    hard = DirectionalLight([0.0, 1.0, 0.0], [1.0, 1.0, 1.0], 0.0)
    assert sun_directions(hard, 64, np.arange(3)).shape == (3, 1, 3)


def test_tonemap_srgb_at_known_points():
    L = np.array([[[0.0, 1.0, 0.0031308], [0.5, 2.0, -1.0], [np.inf, 0.18, 1e-9]]], np.float32)
    out = tonemap(L)
    assert out.dtype == np.uint8 and out.shape == (1, 3, 3)
    assert out[0, 0].tolist() == [0, 255, round(0.04045 * 255)]
    assert out[0, 1].tolist() == [188, 255, 0]                     # 1.055 * 0.5^(1/2.4) - 0.055 = 0.7354
    assert out[0, 2].tolist() == [255, 118, 0]                     # 0.18 -> 0.4614
    assert tonemap(L * 0.5, exposure=2.0)[0, 0].tolist() == [0, 255, 10]


def test_tonemap_exponential_is_monotone_and_one_minus_exp():
    L = np.linspace(0, 20, 4001).reshape(1, -1, 1).repeat(3, axis=2)
    for s in (0.5, 1.0, 3.0):
        v = tonemap(L, exposure=s, curve="exponential", gamma=1.0)[0, :, 0].astype(int)
        assert (np.diff(v) >= 0).all() and v[0] == 0 and v[-1] == 255
        one = tonemap(np.ones((1, 1, 3)), exposure=s, curve="exponential", gamma=1.0)
        assert (one == round(255 * (1 - math.exp(-s)))).all()
        g = tonemap(np.ones((1, 1, 3)), exposure=s, curve="exponential")
        assert (g == round(255 * (1 - math.exp(-s)) ** (1 / 2.2))).all()


def test_write_radiance_round_trips_and_is_atomic(tmp_path):
    rad = np.random.default_rng(0).random((6, 5, 3)).astype(np.float32) * 1e4
    path = tmp_path / "radiance.exr"
    write_radiance(path, rad)
    np.testing.assert_array_equal(read_image(path), rad)
    with pytest.raises(ValueError, match="exr"):
        write_radiance(tmp_path / "radiance.png", rad)
    with pytest.raises(ValueError, match="radiance"):
        write_radiance(path, -rad)                                  # refused: the old file stays
    np.testing.assert_array_equal(read_image(path), rad)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["radiance.exr"]


@pytest.mark.parametrize("kwargs, what", [
    (dict(albedo=(0.5, np.nan, 0.5)), "albedo"),
    (dict(albedo=(0.5, -0.1, 0.5)), "albedo"),
    (dict(albedo=(0.5, 0.5)), "albedo"),
    (dict(ground_albedo=np.inf), "ground_albedo"),
    (dict(albedos={0: (0.1, 0.2, -0.3)}), r"albedos\[0\]"),
    (dict(albedos={-3: 0.5}), "albedos"),
    (dict(sky=np.zeros((9, 2))), "sky"),
    (dict(sky=np.full((9, 3), np.nan)), "sky"),
    (dict(sun="north"), "sun"),
    (dict(sun=pyshadow.lighting.SunLight([0.0, 0.0, 0.0], [1.0, 1.0, 1.0], 0.0, None, None)), "sun direction"),
    (dict(sun_samples=0), "sun_samples"),
    (dict(mode="phong"), "mode"),
])
def test_bad_lighting_is_refused(kwargs, what):
    with pytest.raises((ValueError, TypeError), match=what):
        Lighting(**kwargs)


@pytest.mark.parametrize("direction, irradiance, radius, what", [
    ([0.0, 0.0, 0.0], [1, 1, 1], 0.0, "zero vector"),
    ([0.0, 2.0, 0.0], [1, 1, 1], 0.0, "not a unit vector"),
    ([0.0, np.nan, 1.0], [1, 1, 1], 0.0, "not finite"),
    ([0.0, 1.0, 0.0], [1, -1, 1], 0.0, "irradiance"),
    ([0.0, 1.0, 0.0], [1, 1], 0.0, "irradiance"),
    ([0.0, 1.0, 0.0], [1, 1, 1], -0.1, "angular_radius"),
])
def test_bad_sun_is_refused(direction, irradiance, radius, what):
    with pytest.raises(ValueError, match=what):
        DirectionalLight(direction, irradiance, radius)


def test_bad_points_are_refused_before_any_launch(small_scene, no_launch):
    light = Lighting(constant_sky(), sun=DirectionalLight([0.0, 1.0, 0.0], [1.0, 1.0, 1.0]))
    p = np.zeros((4, 3))
    up = np.tile([0.0, 1.0, 0.0], (4, 1))
    with pytest.raises(ValueError, match="points"):
        shade(small_scene, np.zeros((4, 2)), up, light)
    with pytest.raises(ValueError, match="normals"):
        shade(small_scene, p, np.zeros((4, 3)), light)
    with pytest.raises(ValueError, match="normals"):
        shade(small_scene, p, up[:3], light)
    with pytest.raises(ValueError, match="surface_ids"):
        shade(small_scene, p, up, light, surface_ids=[0, 0, 7, 0])
    with pytest.raises(TypeError, match="lighting"):
        shade(small_scene, p, up, "sky")
    with pytest.raises(TypeError, match="lighting"):
        render_stage.render(small_scene, small_camera(), lighting={"sky": 1})
    with pytest.raises(ValueError, match="mode"):
        Lighting(mode="transferred")


def test_tonemap_refuses_bad_input():
    ok = np.ones((2, 2, 3))
    for bad, what in ((np.ones((2, 2)), "shape"), (np.full((2, 2, 3), np.nan), "NaN")):
        with pytest.raises(ValueError, match=what):
            tonemap(bad)
    with pytest.raises(ValueError, match="exposure"):
        tonemap(ok, exposure=0)
    with pytest.raises(ValueError, match="curve"):
        tonemap(ok, curve="aces")


def test_sampled_mode_samples_the_suns_disc_by_default(small_scene):
    """Lighting(mode="sampled") takes SAMPLED_SUN_SAMPLES rays over a sun with a disc unless told otherwise;
    the other modes one ray to its centre. Ground points across the box's shadow edge under a sun 45 deg up,
    0.2 rad in radius (Embree): the sampled mode's default equals sun_samples=16 exactly and gives a
    penumbra (visible fractions strictly between 0 and 1); "bent" by default equals sun_samples=1, hard."""
    from pyshadow.lighting import SAMPLED_SUN_SAMPLES

    assert SAMPLED_SUN_SAMPLES == 16
    sun = DirectionalLight(np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0), [100.0, 90.0, 80.0], 0.2)
    x = np.linspace(-1.4, -0.6, 41)
    p = np.column_stack([x, np.zeros_like(x), np.full_like(x, 0.1)])
    nrm = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    ids = np.full(len(p), GROUND_ID, np.int32)

    def terms(light):
        return shade_terms(small_scene, p, nrm, light, sampling=Sampling(4), surface_ids=ids, backend="embree")

    sampled = Lighting(sun=sun, mode="sampled")
    assert sampled.sun_samples == SAMPLED_SUN_SAMPLES and sampled.with_mode("bent").sun_samples == 1
    assert Lighting(sun=sun).with_mode("sampled").sun_samples == SAMPLED_SUN_SAMPLES
    assert Lighting(sun=sun, sun_samples=3).with_mode("sampled").sun_samples == 3
    soft = terms(sampled)
    np.testing.assert_array_equal(soft.sun, terms(Lighting(sun=sun, mode="sampled", sun_samples=16)).sun)
    frac = soft.sun_visibility
    assert ((frac > 0) & (frac < 1)).sum() >= 3 and frac.min() == 0 and frac.max() == 1
    hard = terms(Lighting(sun=sun))
    np.testing.assert_array_equal(hard.sun, terms(Lighting(sun=sun, sun_samples=1)).sun)
    assert set(np.unique(hard.sun_visibility)) == {0.0, 1.0}


@pytest.mark.parametrize("kw, msg", [
    (dict(exposure="a"), "exposure: must be a number (got 'a')"),
    (dict(exposure=None), "exposure: must be a number (got None)"),
    (dict(curve="exponential", gamma=None), "gamma: must be a number (got None)"),
])
def test_tonemap_names_a_non_numeric_exposure_or_gamma(kw, msg):
    """float('a') / float(None) escaped with messages that named no argument."""
    with pytest.raises(TypeError) as e:
        tonemap(np.zeros((1, 1, 3)), **kw)
    assert str(e.value) == msg


@pytest.mark.parametrize("curve", ["srgb", "exponential"])
def test_tonemap_overflowing_exposure_is_white_without_a_warning(curve):
    """exposure * L beyond float64 raised RuntimeWarning (an error under -W error); it is +inf: white."""
    out = tonemap(np.array([[[1e300, 0.0, 1e-300]]]), exposure=1e10, curve=curve)
    assert out.tolist() == [[[255, 0, 0]]]


def test_write_radiance_beyond_float32_is_inf_without_a_warning(tmp_path):
    """write_radiance cast float64 to float32 itself and warned (an error under -W error) on 1e300;
    write_image documents +inf there."""
    p = tmp_path / "big.exr"
    write_radiance(p, np.array([[[1e300, 1.0, 0.0]]]))
    assert read_image(p).tolist() == [[[np.inf, 1.0, 0.0]]]

"""A lighting without a sky (sun and local lights) shaded and rendered through ShadowMapVisibility, the
backend that answers only light rays: no AO is asked (pyshadow.lighting.shade_checks)."""
import importlib

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import render as render_stage
from pyshadow import visibility
from pyshadow.lighting import (DirectionalLight, EnvironmentMap, Lighting, PointLight, ShadowMapVisibility, shade,
                               shade_terms)
from pyshadow.lighting.phong import PhongLighting
from pyshadow.lighting.shade import sun_radiance

SUN = np.array([-0.5, 0.7, -0.3]) / np.linalg.norm([-0.5, 0.7, -0.3])
LAMP = PointLight([1.5, 2.0, -1.0], 5.0)
SKY = np.zeros((9, 3))
SKY[0] = [1.0, 1.1, 1.3]


def _translate(x, y, z):
    t = np.eye(4)
    t[:3, 3] = x, y, z
    return t


@pytest.fixture(scope="module")
def scene():
    s = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(8, 16), resolution=64)
    s.add(trimesh.creation.box((1.0, 1.0, 1.0)), _translate(0.0, 0.5, 0.0))
    s.add(trimesh.creation.icosphere(2, radius=0.4), _translate(1.2, 0.4, 0.6))
    return s


@pytest.fixture(scope="module")
def camera():
    return pyshadow.Camera([3.0, 3.0, 4.0], [0.0, 0.5, 0.0], fov_y=45.0, width=80, height=60)


def _differing(a, b, covered):
    return int((~np.isclose(a, b, rtol=1e-5, atol=1e-6).all(axis=-1) & covered).sum())


@pytest.mark.parametrize("lights", ["sun", "lamp", "sun+lamp"])
def test_a_sky_less_frame_through_the_shadow_map_agrees_with_embree(scene, camera, lights):
    """Was: render(lighting=Lighting(sun=...), visibility=ShadowMapVisibility(1024)) raised "cannot answer
    ambient occlusion" (the sky term always asked AO, also of a lighting with no sky), as did shade(). Now
    the frame is lit: on a 160 x 120 frame (16,541 covered pixels, 1,709 in the sun's shadow) 0 pixels differ
    from Embree's frame for the sun, 10 for a point light (the map's texels and ε); here <= 1 % of the
    covered pixels, and Frame.ao is NaN where covered (not asked), 1 on the background."""
    light = Lighting(sun=DirectionalLight(SUN, 3.0) if "sun" in lights else None,
                     lights=[LAMP] if "lamp" in lights else ())
    sm = ShadowMapVisibility(1024)
    a = render_stage.render(scene, camera, lighting=light, visibility=sm)
    b = render_stage.render(scene, camera, lighting=light, visibility="embree")
    cov = a.object_id != -1
    assert (cov == (b.object_id != -1)).all() and cov.sum() > 2000
    assert ((b.radiance.sum(axis=2) == 0) & cov).sum() > 100          # shadows to agree on
    assert _differing(a.radiance, b.radiance, cov) <= 0.01 * cov.sum()
    assert np.isnan(a.ao[cov]).all() and (a.ao[~cov] == 1).all()
    assert np.isnan(a.bent_normal[cov]).all() and (a.bent_normal[~cov] == 0).all()
    assert np.isfinite(b.ao).all() and b.ao[cov].min() < 0.9          # a backend answering AO still gives it
    sp = render_stage.surface_points(scene, camera)
    got = shade(scene, sp.points, sp.normals, light, backend=sm, surface_ids=sp.surface_ids, indices=sp.index)
    want = shade(scene, sp.points, sp.normals, light, backend="embree", surface_ids=sp.surface_ids,
                 indices=sp.index)
    assert _differing(got, want, np.ones(len(got), bool)) <= 0.01 * len(got)


@pytest.mark.parametrize("options", [dict(denoise="bilateral"), dict(ao_scale=2, denoise="box"),
                                     dict(ao_scale=4), dict(normals="smooth")])
def test_filters_and_upsampling_leave_the_unasked_ao_alone(scene, camera, options):
    """Was: a ValueError before any frame (no AO from a shadow map); the unasked NaN AO then must not reach
    the filters (they refuse NaN at covered pixels: "ao holds 583 NaN/inf value(s)"). Now the radiance is
    that of the plain frame, bit for bit, with any denoiser, ao_scale or smooth normals (no sky term)."""
    light = Lighting(sun=DirectionalLight(SUN, 3.0))
    sm = ShadowMapVisibility(512)
    plain = render_stage.render(scene, camera, lighting=light, visibility=sm,
                                normals=options.get("normals", "flat"))
    f = render_stage.render(scene, camera, lighting=light, visibility=sm, **options)
    np.testing.assert_array_equal(f.radiance, plain.radiance)
    cov = f.object_id != -1
    assert np.isnan(f.ao[cov]).all() and plain.radiance.max() > 0


def test_sky_less_shade_terms_ask_no_ao_on_any_backend(scene, monkeypatch):
    """Was: shade_terms of Lighting(sun=...) paid a full AO pass (or the "sampled" / "transfer" sky's rays)
    for a sky term of exactly 0 and reported that AO. Now no AO is asked: ao and bent_normal are NaN, the sky
    term 0 and the radiance the sun's plus the lamp's, in every mode."""
    rng = np.random.default_rng(3)
    p = np.c_[rng.uniform(-3, 3, 300), np.zeros(300), rng.uniform(-3, 3, 300)]
    n = np.tile([0.0, 1.0, 0.0], (300, 1))
    sun = DirectionalLight(SUN, [3.0, 2.0, 1.0])
    want = {}
    for mode in ("bent", "transfer", "sampled"):
        want[mode] = sun_radiance(scene, p, n, Lighting(sun=sun, mode=mode), np.full((300, 3), 0.5),
                                  surface_ids=-2)[0]

    def no_ao(*args, **kwargs):
        raise AssertionError("AO asked")

    monkeypatch.setattr(visibility, "ambient_occlusion", no_ao)
    module = importlib.import_module("pyshadow.lighting.shade")       # (pyshadow.lighting.shade: the function)
    monkeypatch.setattr(module, "sampled_sky_radiance", no_ao)
    monkeypatch.setattr(module, "transfer_sky_radiance", no_ao)
    for mode in ("bent", "transfer", "sampled"):
        for backend in ("csm", "embree", ShadowMapVisibility(256)):
            t = shade_terms(scene, p, n, Lighting(sun=sun, mode=mode), backend=backend, surface_ids=-2)
            assert np.isnan(t.ao).all() and np.isnan(t.bent_normal).all() and (t.sky == 0).all()
            if backend == "csm":
                np.testing.assert_array_equal(t.radiance, want[mode].astype(np.float32))
            assert ((t.sun_visibility == 0).sum() > 10) and ((t.sun_visibility == 1).sum() > 10)


def test_has_sky():
    """Was: no way to ask whether a Lighting has a sky term (AO was asked regardless). Now
    Lighting.has_sky: SH not all 0 or a map not all black."""
    sun = DirectionalLight(SUN, 1.0)
    black = EnvironmentMap(np.zeros((8, 16, 3)))
    assert not Lighting().has_sky and not Lighting(sun=sun).has_sky and not Lighting(lights=[LAMP]).has_sky
    assert not Lighting(black, sun=sun, mode="sampled").has_sky and not Lighting(np.zeros((9, 3))).has_sky
    assert Lighting(SKY).has_sky and Lighting(EnvironmentMap(np.ones((8, 16, 3))), mode="sampled").has_sky


@pytest.mark.parametrize("mode", ["bent", "transfer", "sampled"])
def test_a_sky_on_the_shadow_map_is_refused_naming_the_backend(scene, camera, mode):
    """Was: mode "sampled" failed with "unbounded rays must share one direction ... ray 3417's direction lies
    1.55 rad from their mean" (the sky's sample rays asked of a one-light map), "bent" with the backend's
    message that named neither itself nor the lighting. Now shade_terms and render say that the sky term
    needs AO, name the ShadowMapVisibility and the backends to use, before any map is rendered."""
    sky = EnvironmentMap(np.ones((8, 16, 3))) if mode == "sampled" else SKY
    light = Lighting(sky, sun=DirectionalLight(SUN, 1.0), mode=mode)
    sm = ShadowMapVisibility(256)
    p, n = np.array([[2.0, 0.0, 2.0]]), np.array([[0.0, 1.0, 0.0]])
    for call in (lambda: shade(scene, p, n, light, backend=sm),
                 lambda: render_stage.render(scene, camera, lighting=light, visibility=sm)):
        with pytest.raises(ValueError, match=r"sky term.*ShadowMapVisibility 256.*'csm'"):
            call()
    assert sm.renders == 0


def test_phong_with_constant_ambient_renders_through_the_shadow_map(scene, camera):
    """Was: render(lighting=PhongLighting(light, ao="off"), visibility=ShadowMapVisibility(...)) raised
    "cannot answer ambient occlusion" (render's AO pass ran before the shading, which reads no AO). Now the
    frame is lit (<= 1 % of covered pixels unlike Embree's); ao="ao" and "normal" (rays about the normals)
    are refused naming the ambient term."""
    sm = ShadowMapVisibility(1024)
    light = PhongLighting([1.5, 2.0, -1.0], ao="off")
    a = render_stage.render(scene, camera, lighting=light, visibility=sm)
    b = render_stage.render(scene, camera, lighting=light, visibility="embree")
    cov = a.object_id != -1
    assert _differing(a.radiance, b.radiance, cov) <= 0.01 * cov.sum() and a.radiance.max() > 0
    assert np.isnan(a.ao[cov]).all()
    for ao in ("ao", "normal"):
        with pytest.raises(ValueError, match=rf"ambient term \(ao='{ao}'\).*ShadowMapVisibility"):
            render_stage.render(scene, camera, lighting=light.replace(ao=ao), visibility=sm)

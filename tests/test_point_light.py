"""Point, sphere and spot lights (pyshadow.lighting.local): analytic irradiance, units shared with
the sun, the cone's edges, shadows on every backend against Embree, and bad input."""
import math

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import visibility
from pyshadow.lighting import DirectionalLight, Lighting, PointLight, SpotLight, point_light_radiance
from pyshadow.lighting.shade import sun_radiance

from conftest import ground_grid


def test_unoccluded_point_light_is_inverse_square_cosine():
    scene = pyshadow.Scene(ground=0.0)
    p, n = ground_grid(9)
    light = PointLight([0.3, 2.0, -0.2], [1.0, 2.0, 4.0])
    rad, vis = point_light_radiance(scene, p, n, light, [0.5, 0.25, 1.0])
    d = light.position - p
    dist = np.linalg.norm(d, axis=1)
    want = np.array([0.5, 0.25, 1.0]) / math.pi * light.intensity * (d[:, 1] / dist / dist ** 2)[:, None]
    np.testing.assert_allclose(rad, want, rtol=1e-12)
    assert (vis == 1).all()


def test_far_point_light_equals_the_sun_in_the_same_units():
    """A point light of intensity E D^2 at distance D along l lights like DirectionalLight(l, E)."""
    scene = pyshadow.Scene(ground=0.0)
    p, n = ground_grid(5, 1.0)
    ld = np.array([0.48, 0.8, 0.36])
    e = np.array([1.0, 2.0, 3.0])
    D = 1e5
    sun, _ = sun_radiance(scene, p, n, Lighting(sun=DirectionalLight(ld, e)), np.full((len(p), 3), 0.5))
    pt, _ = point_light_radiance(scene, p, n, PointLight(ld * D, e * D ** 2), 0.5)
    np.testing.assert_allclose(pt, sun, rtol=1e-4)


def test_sphere_light_converges_to_the_point_formula_above_the_horizon():
    """A uniform sphere wholly above a point's horizon gives exactly I cos / d^2; K samples converge."""
    scene = pyshadow.Scene(ground=0.0)
    p, n = ground_grid(7, 1.0)
    exact, _ = point_light_radiance(scene, p, n, PointLight([0.0, 2.0, 0.0], 3.0), 1.0)
    errs = []
    for k in (4, 64):
        soft, vis = point_light_radiance(scene, p, n, PointLight([0.0, 2.0, 0.0], 3.0, radius=0.5), 1.0,
                                         samples=k)
        errs.append(np.abs(soft / exact - 1).max())
        assert (vis == 1).all()
    assert errs[1] < 0.002 and errs[1] < errs[0]


def test_sphere_light_soft_shadow_lies_between_lit_and_dark():
    """Ground points under a box's edge: the point light's shadow is hard (0 or 1), the sphere
    light's penumbra gives fractions in between, on the CSM and on Embree alike."""
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(16, 32), resolution=64)
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    box.apply_translation([0.0, 0.5, 0.0])
    scene.add(box)
    x = np.linspace(0.2, 1.6, 57)
    p = np.c_[x, np.zeros_like(x), np.zeros_like(x)]
    n = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    for backend in ("csm", "embree"):
        _, hard = point_light_radiance(scene, p, n, PointLight([0.0, 3.0, 0.0], 1.0), 0.5, backend=backend)
        _, soft = point_light_radiance(scene, p, n, PointLight([0.0, 3.0, 0.0], 1.0, radius=0.4), 0.5,
                                       backend=backend, samples=32)
        assert set(np.unique(hard)) == {0.0, 1.0}
        assert ((soft > 0.1) & (soft < 0.9)).sum() >= 5, backend
        assert soft[0] < 0.05 and soft[-1] > 0.95


def test_spot_cone_edges():
    scene = pyshadow.Scene(ground=0.0)
    h, angle = 2.0, 0.6
    r_edge = h * math.tan(angle)
    x = np.array([0.0, r_edge * 0.999, r_edge * 1.001, 3.0])
    p = np.c_[x, np.zeros(4), np.zeros(4)]
    n = np.tile([0.0, 1.0, 0.0], (4, 1))
    hard = SpotLight([0.0, h, 0.0], 1.0, direction=[0.0, -1.0, 0.0], angle=angle)
    rad, vis = point_light_radiance(scene, p, n, hard, 1.0)
    point, _ = point_light_radiance(scene, p, n, PointLight([0.0, h, 0.0], 1.0), 1.0)
    np.testing.assert_allclose(rad[:2], point[:2])
    assert (rad[2:] == 0).all() and vis.tolist() == [1.0, 1.0, 0.0, 0.0]
    soft = SpotLight([0.0, h, 0.0], 1.0, direction=[0.0, -1.0, 0.0], angle=angle, falloff=0.2)
    mid = h * math.tan(angle - 0.1)
    c = math.cos(angle - 0.1)
    lo, hi = math.cos(angle), math.cos(angle - 0.2)
    t = (c - lo) / (hi - lo)
    f = soft.factor(np.array([[math.sin(angle - 0.1), -c, 0.0]]))
    assert f[0] == pytest.approx(t * t * (3 - 2 * t))
    r2, _ = point_light_radiance(scene, np.array([[mid, 0.0, 0.0]]), n[:1], soft, 1.0)
    p2, _ = point_light_radiance(scene, np.array([[mid, 0.0, 0.0]]), n[:1], PointLight([0.0, h, 0.0], 1.0), 1.0)
    np.testing.assert_allclose(r2, p2 * f[0])
    assert 0.05 < f[0] < 0.95


def test_light_behind_the_receiver_traces_nothing(monkeypatch):
    scene = pyshadow.Scene(ground=0.0)
    p, n = ground_grid(4)
    calls = []
    monkeypatch.setattr(visibility, "visible", lambda *a, **k: calls.append(1))
    rad, vis = point_light_radiance(scene, p, -n, PointLight([0.0, 2.0, 0.0], 1.0), 0.5)
    assert (rad == 0).all() and (vis == 0).all() and not calls


@pytest.mark.parametrize("lookup", ["csm", "csm-vote"])
def test_point_light_shadows_agree_with_embree(two_bodies, lookup):
    """Ground points and a point light above the bodies, outside their spheres: the CSM's
    radiance equals Embree's on almost every point (identical rays), and shadows do occur."""
    light = PointLight([0.9, 3.0, 1.6], 20.0)
    p, n = ground_grid(60, 3.5)
    ours, v_ours = point_light_radiance(two_bodies, p, n, light, 0.5, backend=lookup, surface_ids=-2)
    truth, v_truth = point_light_radiance(two_bodies, p, n, light, 0.5, backend="embree")
    assert 0.02 < 1 - v_truth.mean() < 0.5
    assert (v_ours == v_truth).mean() > 0.98
    lit = v_ours == v_truth
    np.testing.assert_allclose(ours[lit], truth[lit], rtol=1e-12)
    mirror, v_mirror = point_light_radiance(two_bodies, p[:800], n[:800], light, 0.5,
                                            backend=lookup.replace("csm", "numpy"), surface_ids=-2)
    assert (v_mirror == v_ours[:800]).mean() > 0.995


def test_light_inside_a_casters_sphere(two_bodies):
    """Refused by the CSM (the error names the instance); with straddle='embree', Embree's answer."""
    c, r = two_bodies.instances[1].world_sphere()
    p, n = ground_grid(20, 3.5)
    inside = PointLight(c + [0.0, 0.999 * r, 0.0], 5.0)
    outside = PointLight(c + [0.0, 1.01 * r * (1 + 1e-6), 0.0], 5.0)
    with pytest.raises(ValueError, match="caster instance 1"):
        point_light_radiance(two_bodies, p, n, inside, 0.5, surface_ids=-2)
    got, _ = point_light_radiance(two_bodies, p, n, inside, 0.5, surface_ids=-2, straddle="embree")
    want, _ = point_light_radiance(two_bodies, p, n, inside, 0.5, backend="embree")
    np.testing.assert_array_equal(got, want)
    rad, vis = point_light_radiance(two_bodies, p, n, outside, 0.5, surface_ids=-2)
    assert 0 < vis.mean() < 1


def test_bad_input_launches_nothing(two_bodies, no_launch):
    scene = two_bodies
    for bad in (dict(intensity=-1.0), dict(intensity=[1.0, np.nan, 1.0]), dict(radius=-0.1),
                dict(radius=np.inf), dict(position=[0.0, np.inf, 0.0]), dict(position=[0.0, 1.0])):
        kw = dict(position=[0.0, 3.0, 0.0], intensity=1.0) | bad
        with pytest.raises(ValueError):
            PointLight(**kw)
    for bad in (dict(angle=0.0), dict(angle=math.pi / 2 + 1e-9), dict(angle=-0.5), dict(angle=0.5, falloff=0.6),
                dict(direction=[0.0, 0.0, 0.0]), dict(direction=[0.0, np.nan, 1.0]), dict(direction=None)):
        kw = dict(position=[0.0, 3.0, 0.0], intensity=1.0, direction=[0.0, -1.0, 0.0], angle=0.5) | bad
        with pytest.raises(ValueError):
            SpotLight(**kw)
    SpotLight([0.0, 3.0, 0.0], 1.0, direction=[0.0, -1.0, 0.0], angle=math.pi / 2)
    light = PointLight([0.0, 3.0, 0.0], 1.0)
    p, n = ground_grid(3)
    with pytest.raises(ValueError, match="at the light"):           # a point light exactly on a surface point
        point_light_radiance(scene, np.r_[p, [[0.0, 3.0, 0.0]]], np.r_[n, [[0.0, 1.0, 0.0]]], light, 0.5)
    with pytest.raises(ValueError, match="within the sphere light"):
        point_light_radiance(scene, p, n, PointLight([0.0, 0.1, 0.0], 1.0, radius=0.2), 0.5)
    for kw in (dict(samples=0), dict(samples=2.5)):
        with pytest.raises(ValueError, match="samples"):
            point_light_radiance(scene, p, n, light, 0.5, **kw)
    with pytest.raises(ValueError, match="albedo"):
        point_light_radiance(scene, p, n, light, 1.5)
    with pytest.raises(ValueError, match="normals"):
        point_light_radiance(scene, p, 0 * n, light, 0.5)
    with pytest.raises(TypeError, match="PointLight"):
        point_light_radiance(scene, p, n, DirectionalLight([0.0, 1.0, 0.0], [1.0, 1.0, 1.0]), 0.5)


def test_lighting_adds_local_lights_to_shading_render_and_reference(two_bodies):
    """Lighting(lights=...): shade_terms' sun term, render's Frame.radiance and the Embree reference
    all add point_light_radiance (same units as the sun: the terms add)."""
    from pyshadow.lighting import reference_radiance, shade_terms

    light = PointLight([0.9, 3.0, 1.6], 20.0)
    sun = DirectionalLight(np.array([0.0, 1.0, 0.0]), [0.5, 0.5, 0.5])
    lighting = Lighting(sun=sun, lights=[light])
    p, n = ground_grid(20, 3.5)
    t = shade_terms(two_bodies, p, n, lighting, surface_ids=-2, sampling=pyshadow.Sampling(8))
    alb = lighting.ground_albedo
    pt, _ = point_light_radiance(two_bodies, p, n, light, alb, surface_ids=-2)
    only_sun = shade_terms(two_bodies, p, n, Lighting(sun=sun), surface_ids=-2, sampling=pyshadow.Sampling(8))
    np.testing.assert_allclose(t.sun, only_sun.sun + pt, rtol=1e-6, atol=1e-7)
    assert (pt > 0).any() and (pt == 0).any()
    assert lighting.with_mode("transfer").lights == lighting.lights
    ref = reference_radiance(two_bodies, p, n, Lighting(lights=[light]), surface_ids=-2, samples=4)
    truth, _ = point_light_radiance(two_bodies, p, n, light, alb, backend="embree")
    np.testing.assert_allclose(ref, truth, rtol=1e-6, atol=1e-7)
    cam = pyshadow.Camera([3.0, 2.6, 4.6], [0.85, 0.5, 0.2], fov_y=45.0, width=64, height=48)
    lit = pyshadow.render.render(two_bodies, cam, lighting=Lighting(lights=[light]), sampling=pyshadow.Sampling(4))
    dark = pyshadow.render.render(two_bodies, cam, lighting=Lighting(), sampling=pyshadow.Sampling(4))
    assert lit.radiance.max() > 0 and dark.radiance.max() == 0
    with pytest.raises(TypeError, match="lights"):
        Lighting(lights=[sun])


@pytest.mark.parametrize("radius", [1e-6, 1e-9, 1e-30, 1e-200])
def test_tiny_sphere_light_is_the_point_light(radius):
    """Omega = 2 pi (1 - cos a) rounded to 0 for R / d below ~1e-8 (black, not lit) and gave 0 / 0 = NaN
    where R^2 underflowed; a tiny sphere light is the point light."""
    scene = pyshadow.Scene(ground=0.0)
    p, n = ground_grid(5, 1.0)
    exact, _ = point_light_radiance(scene, p, n, PointLight([0.0, 2.0, 0.0], 3.0), 1.0)
    soft, vis = point_light_radiance(scene, p, n, PointLight([0.0, 2.0, 0.0], 3.0, radius=radius), 1.0,
                                     samples=4)
    np.testing.assert_allclose(soft, exact, rtol=max(1e-12, 4 * radius))
    assert (vis == 1).all()


def test_light_beyond_float64_distance_is_refused():
    """|light - point| beyond ~1.3e154 overflowed: visibility 0 (the max_distance was NaN) for a light in
    plain view, or OverflowError from R ** 2 for a sphere light."""
    scene = pyshadow.Scene(ground=0.0)
    for light in (PointLight([0.0, 1e200, 0.0], 1.0), PointLight([0.0, 3e300, 0.0], 1.0, radius=1e300)):
        with pytest.raises(ValueError) as e:
            point_light_radiance(scene, [[0.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]], light, 1.0, backend="embree",
                                 samples=4)
        assert str(e.value) == (f"point 0 lies too far from the light (point [0.0, 0.0, 0.0], light "
                                f"{light.position.tolist()}): their distance overflows float64")


@pytest.mark.parametrize("make, exc, msg", [
    (lambda: PointLight([0, 1, 0], 1.0, radius="x"), TypeError, "light radius: must be a number (got 'x')"),
    (lambda: PointLight([0, 1, 0], 1.0, radius=None), TypeError, "light radius: must be a number (got None)"),
    (lambda: PointLight([0, 1, 0], "x"), ValueError,
     "light intensity: expected an RGB 3-vector or a scalar (got 'x')"),
    (lambda: PointLight("abc", 1.0), ValueError, "light position: expected a finite 3-vector (got 'abc')"),
    (lambda: SpotLight([0, 1, 0], 1.0, direction=[0, -1, 0], angle="x"), TypeError,
     "spot angle: must be a number (got 'x')"),
])
def test_light_arguments_that_are_no_numbers_are_named(make, exc, msg):
    """float('x') / np.asarray('abc', float) escaped with messages that named no argument."""
    with pytest.raises(exc) as e:
        make()
    assert str(e.value) == msg

"""Disc and rectangle lights (pyshadow.lighting.area): closed forms, units shared with the point
light, one-sidedness, soft shadows on every backend against Embree on identical rays, Lighting,
and bad input (also the point, spot and sun checks issue 20 lists that tests/test_point_light.py
does not exercise)."""
import math

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import visibility
from pyshadow.lighting import DirectionalLight, Lighting, PointLight, SpotLight, point_light_radiance
from pyshadow.lighting.area import DiscLight, RectLight, area_light_radiance, area_light_samples

from conftest import ground_grid


def disc_parallel(L, R, h, x):
    """Irradiance at lateral offset x, height h below a facing Lambertian disc (radiance L, radius R)
    parallel to the receiving plane: the classic view-factor closed form."""
    s = h * h + x * x
    return math.pi * L / 2 * (1 - (s - R * R) / np.sqrt((s + R * R) ** 2 - 4 * x * x * R * R))


def polygon_irradiance(L, corners, p, n):
    """Lambert's formula: E = L/2 sum_i angle_i (unit(r_i x r_i+1) . n), a uniform polygon wholly above
    the point's horizon."""
    r = corners - p
    r = r / np.linalg.norm(r, axis=1, keepdims=True)
    tot = 0.0
    for a, b in zip(r, np.roll(r, -1, axis=0)):
        g = np.cross(a, b)
        tot += math.acos(np.clip(a @ b, -1.0, 1.0)) * (g / np.linalg.norm(g)) @ n
    return L / 2 * abs(tot)


def irradiance(scene, p, n, light, **kw):
    rad, vis = area_light_radiance(scene, p, n, light, 1.0, **kw)
    return rad[:, 0] * math.pi, vis


def test_disc_on_axis_closed_form():
    """E = L pi r^2 / (r^2 + h^2) = I / (r^2 + h^2). On the axis the integrand depends on rho^2 only and
    the spiral's radii sqrt((j + 1/2) / K) are the midpoint rule in rho^2: error O(K^-2) (about 1e-9
    at K = 1024, 4e-6 at K = 16 here)."""
    scene = pyshadow.Scene(ground=0.0)
    r, h, i = 0.5, 2.0, 3.0
    light = DiscLight([0.3, h, -0.2], [0.0, -1.0, 0.0], r, intensity=[i, 2 * i, 0.5 * i])
    p, n = np.array([[0.3, 0.0, -0.2]]), np.array([[0.0, 1.0, 0.0]])
    assert light.radiance[0] * math.pi * r * r / (r * r + h * h) == pytest.approx(i / (r * r + h * h))
    for k, tol in ((16, 1e-5), (1024, 1e-8)):
        rad, vis = area_light_radiance(scene, p, n, light, 1.0, samples=k)
        np.testing.assert_allclose(rad[0] * math.pi, light.intensity / (r * r + h * h), rtol=tol)
        assert vis[0] == 1.0


def test_disc_off_axis_closed_form_converges():
    """Points beside the axis against the parallel-disc closed form: the ratio estimator's unshadowed
    irradiance is the exact E_0 at every K (16 and 1024; the sample mean was off by 1.5e-2 and 2.4e-4)."""
    scene = pyshadow.Scene(ground=0.0)
    light = DiscLight([0.0, 2.0, 0.0], [0.0, -1.0, 0.0], 0.5, intensity=3.0)
    x = np.linspace(0.0, 2.5, 11)
    p, n = np.c_[x, 0 * x, 0 * x], np.tile([0.0, 1.0, 0.0], (11, 1))
    want = disc_parallel(light.radiance[0], 0.5, 2.0, x)
    err = [np.abs(irradiance(scene, p, n, light, samples=k)[0] / want - 1).max() for k in (16, 1024)]
    assert max(err) < 1e-12                         # the ratio estimator: exact unshadowed for every K


def test_rectangle_closed_forms():
    """On the axis: E = 2 L (A/sqrt(1+A^2) atan(B/sqrt(1+A^2)) + B/sqrt(1+B^2) atan(A/sqrt(1+B^2))),
    A, B the half-sizes over h; off the axis, tilted normals: Lambert's polygon formula, which the ratio
    estimator's unshadowed irradiance equals at every K (the sample mean was off by 7e-2 at 16, 1.5e-3
    at 1024)."""
    scene = pyshadow.Scene(ground=0.0)
    h = 2.0
    axis = RectLight([0.0, h, 0.0], [0.4, 0.0, 0.0], [0.0, 0.0, 0.3], intensity=2.0)
    np.testing.assert_allclose(axis.normal, [0.0, -1.0, 0.0])
    a, b = 0.4 / h, 0.3 / h
    exact = 2 * axis.radiance[0] * (a / math.hypot(1, a) * math.atan(b / math.hypot(1, a))
                                    + b / math.hypot(1, b) * math.atan(a / math.hypot(1, b)))
    e, _ = irradiance(scene, np.zeros((1, 3)), np.array([[0.0, 1.0, 0.0]]), axis, samples=1024)
    assert e[0] == pytest.approx(exact, rel=2e-5)
    light = RectLight([0.2, h, 0.1], [0.5, 0.0, 0.1], [-0.06, 0.0, 0.3], intensity=2.0)
    rng = np.random.default_rng(3)
    p = rng.uniform(-1.5, 1.5, (40, 3))
    p[:, 1] = rng.uniform(0.0, 1.0, 40)
    n = rng.normal(size=(40, 3))
    n[:, 1] = np.abs(n[:, 1]) + 1.5
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    corners = np.array([light.position + s * light.u + t * light.v for s, t in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
    above = (np.einsum("nkj,nj->nk", corners[None] - p[:, None], n) > 0).all(axis=1)
    assert above.sum() >= 35
    want = np.array([polygon_irradiance(light.radiance[0], corners, p[i], n[i]) for i in range(40)])
    err = [np.abs(irradiance(scene, p, n, light, samples=k)[0] / want - 1)[above].max() for k in (16, 1024)]
    assert max(err) < 1e-12                         # the ratio estimator: exact unshadowed for every K


def test_far_area_lights_equal_a_point_light_and_power_is_pi_intensity():
    """The units: a disc or rectangle of intensity I far away along its normal lights like
    PointLight(I) (E = I / d^2, the sun's units); power Phi = pi I is the same light."""
    scene = pyshadow.Scene(ground=0.0)
    p, n = ground_grid(5, 1.0)
    D, i = 1e3, np.array([1.0, 2.0, 3.0]) * 1e6
    pt, _ = point_light_radiance(scene, p, n, PointLight([0.0, D, 0.0], i), 0.5)
    disc = DiscLight([0.0, D, 0.0], [0.0, -1.0, 0.0], 2.0, intensity=i)
    rect = RectLight.facing([0.0, D, 0.0], [0.0, -1.0, 0.0], 3.0, 1.5, power=math.pi * i)
    np.testing.assert_allclose(rect.intensity, i, rtol=1e-15)
    assert rect.area == pytest.approx(4.5) and disc.area == pytest.approx(4 * math.pi)
    for light in (disc, rect, DiscLight(disc.position, disc.normal, 2.0, power=math.pi * i)):
        got, _ = area_light_radiance(scene, p, n, light, 0.5, samples=16)
        np.testing.assert_allclose(got, pt, rtol=1e-5)


def test_one_sample_is_the_centre():
    scene = pyshadow.Scene(ground=0.0)
    p, n = ground_grid(6, 2.0)
    light = RectLight([0.5, 1.5, 0.0], [0.3, -0.3, 0.0], [0.0, 0.0, 0.2], intensity=4.0)
    rad, _ = area_light_radiance(scene, p, n, light, 1.0, samples=1)
    d = light.position - p
    dist = np.linalg.norm(d, axis=1)
    want = 4.0 * (d[:, 1] / dist) * np.maximum(-(d / dist[:, None]) @ light.normal, 0) / dist ** 2
    from pyshadow.lighting.area_exact import unshadowed_factor      # E = E_0 * V(centre), all lit here
    np.testing.assert_allclose(rad[:, 0] * math.pi, 4.0 / light.area * unshadowed_factor(light, p, n) * (want > 0),
                               rtol=1e-12, atol=1e-15)   # x = 2: in its plane


def test_samples_lie_on_the_light_stratified_and_turned_per_point():
    disc = DiscLight([1.0, 2.0, 0.5], [0.6, -0.8, 0.0], 0.7, intensity=1.0)
    k = 64
    y = area_light_samples(disc, k, np.arange(5), seed=3)
    q = y - disc.position
    np.testing.assert_allclose(q @ disc.normal, 0.0, atol=1e-12)
    radii = np.sort(np.linalg.norm(q, axis=2), axis=1)
    np.testing.assert_allclose(radii, np.broadcast_to(0.7 * np.sqrt((np.arange(k) + 0.5) / k), (5, k)), rtol=1e-12)
    assert not np.allclose(y[0], y[1])                                    # the pattern turns per point
    np.testing.assert_array_equal(y, area_light_samples(disc, k, np.arange(5), seed=3))
    assert not np.allclose(y, area_light_samples(disc, k, np.arange(5), seed=4))
    rect = RectLight([0.0, 2.0, 0.0], [0.5, 0.0, 0.0], [0.0, 0.0, 0.25], intensity=1.0)
    y = area_light_samples(rect, k, np.arange(7), seed=0)
    a, b = (y - rect.position) @ rect.u / 0.25, (y - rect.position) @ rect.v / 0.0625
    assert (np.abs(a) <= 1).all() and (np.abs(b) <= 1).all()
    for coord in (a, b):           # one sample per 1/K stratum along u; the golden lattice along v
        counts = np.stack([np.bincount(np.floor((c + 1) / 2 * k).astype(int), minlength=k) for c in coord])
        assert counts.max() <= (1 if coord is a else 2)
    np.testing.assert_allclose(area_light_samples(rect, 1, [5])[0, 0], rect.position)


def test_behind_a_one_sided_light_and_behind_the_receiver_nothing_is_traced(monkeypatch):
    """Points behind the light's plane, on the plane beside the light, or facing away: 0, no ray."""
    scene = pyshadow.Scene(ground=0.0)
    calls = []
    monkeypatch.setattr(visibility, "visible", lambda *a, **k: calls.append(1))
    p, n = ground_grid(4)
    up = DiscLight([0.0, 2.0, 0.0], [0.0, 1.0, 0.0], 0.5, intensity=1.0)           # faces away from the ground
    beside = np.array([[1.0, 2.0, 0.0], [0.0, 2.0, -0.6]])                            # its plane, outside it
    for light in (up, RectLight.facing([0.0, 2.0, 0.0], [0.0, 1.0, 0.0], 1.0, 1.0, intensity=1.0)):
        for pts, nrm in ((p, n), (beside, np.tile([0.0, 1.0, 0.0], (2, 1)))):
            rad, vis = area_light_radiance(scene, pts, nrm, light, 0.5, samples=16)
            assert (rad == 0).all() and (vis == 0).all()
    down = DiscLight([0.0, 2.0, 0.0], [0.0, -1.0, 0.0], 0.5, intensity=1.0)
    rad, vis = area_light_radiance(scene, p, -n, down, 0.5, samples=16)             # light behind the receiver
    assert (rad == 0).all() and (vis == 0).all() and not calls


def test_point_on_the_light_is_refused(no_launch):
    scene = pyshadow.Scene(ground=0.0)
    up = np.array([[0.0, 1.0, 0.0]])
    disc = DiscLight([0.0, 2.0, 0.0], [0.0, -1.0, 0.0], 0.5, intensity=1.0)
    rect = RectLight([0.0, 2.0, 0.0], [0.4, 0.0, 0.0], [0.0, 0.0, 0.3], intensity=1.0)
    for light, q in ((disc, [0.3, 2.0, 0.3]), (rect, [0.39, 2.0, -0.29]), (rect, [0.0, 2.0, 0.0])):
        with pytest.raises(ValueError, match="plane within its extent"):
            area_light_radiance(scene, np.r_[[[0.0, 0.0, 0.0]], [q]], np.r_[up, up], light, 0.5)


def _record(monkeypatch):
    calls, real = [], visibility.visible

    def rec(scene, points, directions, **kw):
        out = real(scene, points, directions, **kw)
        calls.append((np.array(points), np.array(directions), np.array(kw["max_distance"]), out.copy()))
        return out
    monkeypatch.setattr(visibility, "visible", rec)
    return calls


def test_soft_shadow_estimator_from_embree_and_csm_on_identical_rays(two_bodies, monkeypatch):
    """A disc above the bodies, ground points: Embree's radiance equals the mean of the per-sample
    contributions computed here in NumPy from pyshadow.embree.visible on the sample points; the
    CSM lookups trace the identical rays and agree with Embree on almost all of them."""
    from pyshadow import embree

    light = DiscLight([0.9, 3.0, 1.2], [0.0, -1.0, 0.0], 0.35, intensity=20.0)
    p, n = ground_grid(30, 3.5)
    k = 16
    calls = _record(monkeypatch)
    truth, v_truth = area_light_radiance(two_bodies, p, n, light, 0.5, backend="embree", samples=k)
    y = area_light_samples(light, k, np.arange(len(p)))
    dv = y - p[:, None]
    d = np.linalg.norm(dv, axis=2)
    w = dv / d[..., None]
    lit = embree.visible(two_bodies, np.repeat(p, k, axis=0), w.reshape(-1, 3), max_distance=d.ravel()).reshape(-1, k)
    contrib = 20.0 * w[..., 1] * w[..., 1] / d ** 2 * lit                         # cos = cos_L = w_y here
    from pyshadow.lighting.area_exact import unshadowed_factor      # E = E_0 * lit share, albedo 0.5
    np.testing.assert_allclose(truth[:, 0] * math.pi / 0.5, 20.0 / light.area * unshadowed_factor(light, p, n)
                               * contrib.sum(1) / (w[..., 1] ** 2 / d ** 2 * 20.0).sum(1), rtol=1e-12)
    np.testing.assert_allclose(v_truth, (contrib.sum(1) / (w[..., 1] ** 2 / d ** 2 * 20.0).sum(1)), rtol=1e-12)
    assert 0.02 < 1 - v_truth.mean() < 0.5 and ((v_truth > 0) & (v_truth < 1)).sum() >= 20
    for lookup in ("csm", "csm-vote"):
        ours, v_ours = area_light_radiance(two_bodies, p, n, light, 0.5, backend=lookup, samples=k, surface_ids=-2)
        pe, we, te, ve = calls[0]
        pc, wc, tc, vc = calls[-1]
        np.testing.assert_array_equal(pc, pe)
        np.testing.assert_allclose(wc, we, rtol=0, atol=1e-15)
        np.testing.assert_array_equal(tc, te)
        assert (vc == ve).mean() > 0.98, lookup
        assert np.abs(v_ours - v_truth).mean() < 0.02
        area_light_radiance(two_bodies, p, n, light, 0.5, backend=lookup.replace("csm", "numpy"), samples=k,
                            surface_ids=-2)
        assert (calls[-1][3] == vc).mean() > 0.995                                   # the NumPy mirror


def test_light_between_two_bodies(monkeypatch):
    """A disc facing down between a box below it and a box above it: the box above lies wholly
    beyond every shadow ray's end and is culled -- the answer equals the scene without it, on the
    CSM and on Embree -- while the box below casts a soft shadow."""
    from pyshadow import embree

    views = pyshadow.ViewSet.zigzag(16, 32)
    below, above = np.eye(4), np.eye(4)
    below[:3, 3] = [0.0, 0.4, 0.0]
    above[:3, 3] = [0.0, 4.0, 0.0]
    scenes = []
    for parts in ((below,), (below, above)):
        s = pyshadow.Scene(ground=0.0, views=views, resolution=64)
        for T, size in zip(parts, ((0.8, 0.8, 0.8), (2.0, 0.4, 2.0))):
            s.add(trimesh.creation.box(size), T)
        scenes.append(s)
    light = DiscLight([0.0, 2.2, 0.0], [0.0, -1.0, 0.0], 0.3, intensity=5.0)
    p, n = ground_grid(25, 2.5)
    # the rays made unbounded: the box above would shadow many ground points
    w = light.position - p
    free = [embree.visible(s, p, w) for s in scenes]
    assert (free[0] & ~free[1]).sum() > 100
    for backend in ("embree", "csm", "csm-vote"):
        got = [area_light_radiance(s, p, n, light, 0.5, backend=backend, samples=16, surface_ids=-2) for s in scenes]
        np.testing.assert_array_equal(got[1][0], got[0][0])
        vis = got[1][1]
        assert (vis == 0).sum() >= 4 and ((vis > 0) & (vis < 1)).sum() >= 10 and (vis == 1).sum() > 400, backend


def test_lighting_takes_area_lights(two_bodies):
    """Lighting(lights=[disc, rect]): shade_terms' sun term adds area_light_radiance with sun_samples
    rays; reference_radiance is Embree with 1024 samples."""
    from pyshadow.lighting import reference_radiance, shade_terms

    disc = DiscLight([0.9, 3.0, 1.2], [0.0, -1.0, 0.0], 0.35, intensity=20.0)
    rect = RectLight.facing([-1.5, 1.8, 2.0], [0.6, -0.8, 0.0], 0.6, 0.3, power=30.0)
    p, n = ground_grid(12, 3.0)
    lighting = Lighting(lights=[disc, rect], sun_samples=8, seed=2)
    t = shade_terms(two_bodies, p, n, lighting, surface_ids=-2, sampling=pyshadow.Sampling(4))
    alb = lighting.ground_albedo
    want = sum(area_light_radiance(two_bodies, p, n, x, alb, samples=8, seed=2, surface_ids=-2)[0]
               for x in (disc, rect))
    np.testing.assert_allclose(t.sun, want, rtol=1e-6, atol=1e-7)
    ref = reference_radiance(two_bodies, p[:30], n[:30], Lighting(lights=[disc]), surface_ids=-2, samples=4)
    truth, _ = area_light_radiance(two_bodies, p[:30], n[:30], disc, alb, backend="embree", samples=1024)
    np.testing.assert_allclose(ref, truth, rtol=1e-6, atol=1e-7)


def test_bad_area_lights_are_refused(two_bodies, no_launch):
    ok = dict(position=[0.0, 2.0, 0.0], normal=[0.0, -1.0, 0.0], radius=0.5, intensity=1.0)
    for bad, what in ((dict(normal=[0.0, 0.0, 0.0]), "zero"), (dict(normal=[0.0, np.nan, 0.0]), "finite"),
                      (dict(normal=[0.0, -np.inf, 0.0]), "finite"), (dict(normal=[0.0, -2.0, 0.0]), "unit"),
                      (dict(radius=0.0), "zero-area"), (dict(radius=-0.5), "radius"), (dict(radius=np.nan), "radius"),
                      (dict(radius=np.inf), "radius"), (dict(intensity=-1.0), "intensity"),
                      (dict(intensity=[1.0, np.inf, 1.0]), "intensity"), (dict(position=[0.0, np.nan, 0.0]), "position"),
                      (dict(intensity=None), "exactly one"), (dict(power=2.0), "exactly one")):
        with pytest.raises(ValueError, match=what):
            DiscLight(**(ok | bad))
    with pytest.raises(ValueError, match="power"):
        DiscLight([0.0, 2.0, 0.0], [0.0, -1.0, 0.0], 0.5, power=[1.0, -1.0, 1.0])
    okr = dict(position=[0.0, 2.0, 0.0], u=[0.5, 0.0, 0.0], v=[0.0, 0.0, 0.5], intensity=1.0)
    for bad, what in ((dict(u=[0.0, 0.0, 0.0]), "zero-area"), (dict(v=[0.0, np.nan, 0.0]), "edge v"),
                      (dict(v=[0.5, 0.0, 0.0]), "orthogonal"), (dict(v=[0.1, 0.0, 0.5]), "orthogonal"),
                      (dict(intensity=-2.0), "intensity")):
        with pytest.raises(ValueError, match=what):
            RectLight(**(okr | bad))
    for w, h in ((0.0, 1.0), (1.0, -1.0), (np.nan, 1.0)):
        with pytest.raises(ValueError, match="width|height"):
            RectLight.facing([0.0, 2.0, 0.0], [0.0, -1.0, 0.0], w, h, intensity=1.0)
    light = DiscLight(**ok)
    p, n = ground_grid(3)
    for kw in (dict(samples=0), dict(samples=2.5), dict(samples=True)):
        with pytest.raises(ValueError, match="samples"):
            area_light_radiance(two_bodies, p, n, light, 0.5, **kw)
    with pytest.raises(ValueError, match="albedo"):
        area_light_radiance(two_bodies, p, n, light, -0.5)
    for bad in (0 * n, n + [0.0, np.nan, 0.0]):
        with pytest.raises(ValueError, match="normals"):
            area_light_radiance(two_bodies, p, bad, light, 0.5)
    with pytest.raises(ValueError, match="points"):
        area_light_radiance(two_bodies, p + [np.inf, 0.0, 0.0], n, light, 0.5)
    with pytest.raises(TypeError, match="DiscLight"):
        area_light_radiance(two_bodies, p, n, PointLight([0.0, 2.0, 0.0], 1.0), 0.5)
    with pytest.raises(TypeError, match="lights"):
        Lighting(lights=[light, "lamp"])


def test_point_spot_and_sun_bad_input_not_covered_elsewhere(two_bodies, no_launch):
    """Issue 20's list: non-finite or zero directions, negative radii or intensities, a spot angle
    outside (0, pi/2] -- the cases tests/test_point_light.py and test_lighting_shade.py leave out."""
    for bad in (dict(intensity=[1.0, -1e-12, 1.0]), dict(intensity=np.inf), dict(radius=np.nan),
                dict(radius=-1e-300), dict(position=[np.nan, 0.0, 0.0])):
        with pytest.raises(ValueError):
            PointLight(**(dict(position=[0.0, 3.0, 0.0], intensity=1.0) | bad))
    spot = dict(position=[0.0, 3.0, 0.0], intensity=1.0, direction=[0.0, -1.0, 0.0], angle=0.5)
    for bad, what in ((dict(angle=np.nan), "angle"), (dict(angle=np.inf), "angle"), (dict(angle=math.pi), "angle"),
                      (dict(direction=[0.0, -np.inf, 0.0]), "finite"), (dict(direction=[0.0, -2.0, 0.0]), "unit"),
                      (dict(falloff=-0.1), "falloff"), (dict(falloff=np.nan), "falloff"),
                      (dict(radius=-0.2), "radius"), (dict(intensity=-3.0), "intensity")):
        with pytest.raises(ValueError, match=what):
            SpotLight(**(spot | bad))
    for args, what in ((([0.0, np.inf, 0.0], [1, 1, 1]), "finite"), (([0.0, 1.0, 0.0], [1, 1, 1], np.nan), "angular"),
                       (([0.0, 1.0, 0.0], [1, 1, 1], math.pi / 2), "angular"),
                       (([0.0, 1.0, 0.0], [1, np.inf, 1]), "irradiance")):
        with pytest.raises(ValueError, match=what):
            DirectionalLight(*args)
    p, n = ground_grid(3)
    light = PointLight([0.0, 3.0, 0.0], 1.0)
    with pytest.raises(ValueError, match="normals"):
        point_light_radiance(two_bodies, p, n + [np.inf, 0.0, 0.0], light, 0.5)
    with pytest.raises(ValueError, match="points"):
        point_light_radiance(two_bodies, p + [0.0, np.nan, 0.0], n, light, 0.5)


@pytest.mark.parametrize("make, msg", [
    (lambda: DiscLight([0, 1, 0], [0, -1, 0], "x", intensity=1.0), "disc light radius: must be a number (got 'x')"),
    (lambda: DiscLight([0, 1, 0], [0, -1, 0], None, intensity=1.0), "disc light radius: must be a number (got None)"),
    (lambda: RectLight.facing([0, 1, 0], [0, -1, 0], "x", 1.0, intensity=1.0),
     "rectangle width: must be a number (got 'x')"),
])
def test_area_light_extent_that_is_no_number_is_named(make, msg):
    """float('x') / float(None) escaped with messages that named no argument."""
    with pytest.raises(TypeError) as e:
        make()
    assert str(e.value) == msg

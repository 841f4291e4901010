"""White-furnace and analytic checks of the lighting stage, every shading mode and the reference.

Every case has a closed-form answer (Lambertian: ``L_o = albedo / pi * E``):

- a uniform environment of radiance L around an open point: ``E = pi L`` per hemisphere, so
  ``L_o = albedo L`` whatever the map's layout, size or the normal (full sphere); a sky-only
  (upper hemisphere) map gives ``E = pi L (1 + cos theta) / 2`` at tilt theta;
- the CIE overcast sky of horizontal illuminance E: ``E`` on the ground;
- a sun of irradiance E at elevation h: ``E sin h``; a point light of intensity I at height d:
  ``I / d^2``; disc and rectangle lights: their form factors.

Tolerances. Noise-free terms (the sun, point lights, a constant sky, where every sample sees the
same radiance) are float32 rounding: the radiance is float32 (2^-24 relative) and the CSM kernels
add S float32 terms (``S * 2^-24``). Sampled terms are checked twice: against the estimator
recomputed here from :func:`pyshadow.sample_directions` (float32 rounding, or one sample's weight
where the kernel's float32 texel rule may pick a neighbour at a texel edge), and, averaged over
points with independent patterns, against the analytic value within 4 standard errors of the
Monte Carlo estimate (the patterns are Hammersley nets, better than Monte Carlo: a safe bound).
"""
import math

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling
from pyshadow.lighting import (DirectionalLight, DiscLight, EnvironmentMap, Lighting, PointLight, RectLight,
                               SUN_ANGULAR_RADIUS, SpotLight, add_sun_disc, cube, disc_solid_angle, extract_sun,
                               irradiance_sh, overcast_sky, reference_radiance, sh_basis, shade, shade_terms,
                               tonemap)
from pyshadow.lighting.sh import _C1
from pyshadow.scene import GROUND_ID

MODES = ("bent", "sampled", "transfer")
L = np.array([1.0, 2.0, 0.5])
RHO = 0.4
F32 = 2.0 ** -24


def csm_scene(ground=0.0):
    return pyshadow.Scene(ground=ground, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)


@pytest.fixture(scope="module")
def open_ground():
    """A ground plane with a unit box far away: ground points around the origin see the whole sky."""
    scene = csm_scene()
    T = np.eye(4)
    T[:3, 3] = [60.0, 0.5, 60.0]
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), transform=T)
    rng = np.random.default_rng(7)
    n = 12
    p = np.column_stack([rng.uniform(-10, 10, n), np.zeros(n), rng.uniform(-10, 10, n)])
    return scene, p, np.tile([0.0, 1.0, 0.0], (n, 1)), np.full(n, GROUND_ID)


@pytest.fixture(scope="module")
def overhang():
    """A 2 x 0.4 x 2 slab at y = 0.8 .. 1.2 over the ground; ground points from under it to beside it."""
    scene = csm_scene()
    T = np.eye(4)
    T[1, 3] = 1.0
    scene.add(trimesh.creation.box((2.0, 0.4, 2.0)), transform=T)
    x = np.linspace(0.6, 1.6, 6)
    p = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    return scene, p, np.tile([0.0, 1.0, 0.0], (len(x), 1)), np.full(len(x), GROUND_ID)


def tilted_face(theta, k=6):
    """No ground; a unit box turned by ``theta`` about z, floating: points on its top face, whose
    normal is tilted by ``theta`` from +y (a convex body: the face's hemisphere is open)."""
    scene = csm_scene(ground=None)
    R = trimesh.transformations.rotation_matrix(theta, [0.0, 0.0, 1.0])
    T = R.copy()
    T[1, 3] = 3.0
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), transform=T)
    g = np.linspace(-0.35, 0.35, k)
    local = np.column_stack([np.repeat(g, k), np.full(k * k, 0.5), np.tile(g, k)])
    p = local @ R[:3, :3].T + [0.0, 3.0, 0.0]
    return scene, p, np.tile(R[:3, :3] @ [0.0, 1.0, 0.0], (k * k, 1)), np.zeros(k * k, int)


def constant_maps():
    out = {f"latlong {h}x{2 * h}": EnvironmentMap(np.tile(L, (h, 2 * h, 1))) for h in (1, 4, 16)}
    out.update({f"cube {n}": EnvironmentMap(np.tile(L, (6, n, n, 1))) for n in (1, 3, 8)})
    out["cross 2"] = EnvironmentMap(np.tile(L, (6, 8, 1)))           # a horizontal cross, N = 2
    return out


def sky_only_maps():
    """L above the horizon, 0 below: lat-long of even height and cubes of even size (the horizon on
    texel edges, so the maps are the exact step)."""
    out = {}
    for h in (2, 8):
        m = np.tile(L, (h, 2 * h, 1))
        m[h // 2:] = 0.0
        out[f"latlong {h}x{2 * h}"] = EnvironmentMap(m)
    for n in (2, 4):
        up = cube.face_directions(n)[..., 1] > 0
        out[f"cube {n}"] = EnvironmentMap(np.where(up[..., None], L, 0.0))
    return out


# ---------------------------------------------------------------------------------------------
# uniform environments
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(constant_maps()))
def test_uniform_environment_on_open_ground_is_albedo_times_radiance(open_ground, name):
    """Every mode on the CSM and on Embree, and the reference: albedo L to float32 rounding (36
    samples summed in float32 by the transfer kernel: 36 * 2^-24 = 2.1e-6)."""
    scene, p, n, ids = open_ground
    env = constant_maps()[name]
    want = RHO * L
    for mode in MODES:
        for backend in ("csm", "embree"):
            t = shade_terms(scene, p, n, Lighting(env, mode=mode, ground_albedo=RHO), backend=backend,
                            sampling=Sampling(36), surface_ids=ids)
            assert (t.ao == 1).all()
            np.testing.assert_allclose(t.radiance, np.broadcast_to(want, p.shape), rtol=40 * F32, atol=0,
                                       err_msg=f"{mode} {backend}")
    ref = reference_radiance(scene, p, n, Lighting(env, ground_albedo=RHO), surface_ids=ids, samples=256)
    np.testing.assert_allclose(ref, np.broadcast_to(want, p.shape), rtol=4 * F32, atol=0)


def test_uniform_sky_as_sh_coefficients_only(open_ground):
    """A Lighting made from the constant map's 9 coefficients (no map): "bent" and "transfer" give albedo L."""
    scene, p, n, ids = open_ground
    coef = EnvironmentMap(np.tile(L, (4, 8, 1))).sh()
    np.testing.assert_allclose(coef[1:], 0.0, atol=1e-15)
    np.testing.assert_allclose(coef[0], 4 * math.pi * 0.5 / math.sqrt(math.pi) * L, rtol=1e-14)
    for mode in ("bent", "transfer"):
        r = shade(scene, p, n, Lighting(coef, mode=mode, ground_albedo=RHO), sampling=Sampling(36),
                  surface_ids=ids)
        np.testing.assert_allclose(r, np.broadcast_to(RHO * L, p.shape), rtol=40 * F32, atol=0)


@pytest.mark.parametrize("theta_deg", [30, 90, 135, 180])
def test_uniform_full_sphere_on_a_tilted_face_is_albedo_times_radiance(theta_deg):
    """Without a ground, a face tilted by theta under a uniform full sphere: albedo L, every mode,
    lat-long and cube, and the reference."""
    scene, p, n, ids = tilted_face(math.radians(theta_deg))
    for env in (EnvironmentMap(np.tile(L, (4, 8, 1))), EnvironmentMap(np.tile(L, (6, 2, 2, 1)))):
        for mode in MODES:
            for backend in ("csm", "numpy"):
                r = shade(scene, p, n, Lighting(env, mode=mode, albedo=RHO), backend=backend,
                          sampling=Sampling(36), surface_ids=ids)
                np.testing.assert_allclose(r, np.broadcast_to(RHO * L, p.shape), rtol=40 * F32,
                                           err_msg=f"{env.layout} {mode} {backend}")
        ref = reference_radiance(scene, p, n, Lighting(env, albedo=RHO), surface_ids=ids, samples=64)
        np.testing.assert_allclose(ref, np.broadcast_to(RHO * L, p.shape), rtol=4 * F32)


@pytest.mark.parametrize("name", list(sky_only_maps()))
def test_sky_only_irradiance_of_the_sh_is_exact_at_any_tilt(name):
    """A hemisphere step has no even band above 0 and the clamped cosine no odd band above 1, so the
    9-coefficient irradiance is exact: pi L (1 + cos theta) / 2 (lat-long: closed-form texel
    integrals, 1e-12; cube: 4 x 4 Gauss points a texel, measured 1.3e-5 at N = 2, 3e-8 at N = 4)."""
    env = sky_only_maps()[name]
    th = np.radians([0, 30, 60, 90, 120, 150, 180])
    nrm = np.column_stack([np.sin(th), np.cos(th), np.zeros_like(th)])
    want = math.pi * np.outer((1 + np.cos(th)) / 2, L)
    tol = {"latlong": 1e-12, "cube 2": 3e-5, "cube 4": 1e-7}
    got = irradiance_sh(env.sh(), nrm)
    np.testing.assert_allclose(got, want, rtol=0, atol=tol.get(name, tol["latlong"]) * math.pi * L.max())


@pytest.mark.parametrize("theta_deg", [30, 90, 135])
def test_sky_only_on_a_tilted_face_every_mode(theta_deg):
    """Sky-only map, a face tilted by theta, no occluder: each mode is its estimator on the sample
    directions (exact), and the estimators average to albedo L (1 + cos theta) / 2.

    sampled: albedo L * (share of samples with w_y > 0); bent (AO = 1): albedo L (1 + b_y) / 2 with b
    the samples' normalised mean; transfer: T_k = pi / S sum Y_k, L_0 = 2 pi Y_0 L, L_y = pi C_1 L, so
    albedo L (1/2 + 3/4 mean w_y). Cosine-weighted directions have E[w_y] = 2/3 cos theta."""
    th = math.radians(theta_deg)
    scene, p, n, ids = tilted_face(th)
    s = Sampling(64)
    w = pyshadow.sample_directions(n, sampling=s).astype(np.float64)
    w /= np.linalg.norm(w, axis=2, keepdims=True)
    share = (w[..., 1] > 0).mean(axis=1)
    b = w.sum(axis=1)
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    own = {"sampled": share, "bent": (1 + b[:, 1]) / 2, "transfer": 0.5 + 0.75 * w[..., 1].mean(axis=1)}
    want = (1 + math.cos(th)) / 2
    P = len(p)
    sd_share = math.sqrt(max(want * (1 - want), 1e-12) / (s.samples * P))
    sd_wy = math.sqrt(0.5 / (s.samples * P))             # var(w_y) <= E[w_y^2] <= 1/2
    bound = {"sampled": 4 * sd_share, "transfer": 0.75 * 4 * sd_wy,
             "bent": 4 * sd_wy}                           # |b_y - cos theta| ~ |mean w - E w| / |E w|
    for env in sky_only_maps().values():
        for mode in MODES:
            for backend in ("csm", "numpy"):
                r = shade(scene, p, n, Lighting(env, mode=mode, albedo=RHO), backend=backend, sampling=s,
                          surface_ids=ids)
                np.testing.assert_allclose(r, RHO * np.outer(own[mode], L), rtol=1e-5, atol=3e-5 * RHO * L.max(),
                                           err_msg=f"{env.layout} {mode} {backend}")    # cube 2's SH: 1.3e-5
        assert abs(own["sampled"].mean() - want) <= bound["sampled"] + 1e-12
    assert abs(own["transfer"].mean() - want) <= bound["transfer"]
    assert abs(own["bent"].mean() - want) <= bound["bent"]
    ref = reference_radiance(scene, p, n, Lighting(sky_only_maps()["latlong 8x16"], albedo=RHO), surface_ids=ids,
                             samples=1024)                     # the reference: the "sampled" estimator, S = 1024
    sd_ref = math.sqrt(max(want * (1 - want), 1e-12) / (1024 * P))
    assert np.abs(ref.mean(axis=0) / (RHO * L) - want).max() <= 4 * sd_ref + 1e-6


# ---------------------------------------------------------------------------------------------
# the CIE overcast sky
# ---------------------------------------------------------------------------------------------
def test_overcast_sky_gives_its_horizontal_illuminance(open_ground):
    """overcast_sky(E): the map's own horizontal irradiance (its L_y coefficient / C_1, exact for a
    black lower half) is E to 3e-4 at height 64 (rows are exact averages: O(pitch^2), 2.3e-4);
    "sampled" and the reference estimate it (4 standard errors of the samples' own spread);
    "bent" is the 9-coefficient irradiance, E * 223 / 224 for the continuous sky (the l = 4 band,
    lost: 7 pi / 9 vs pi (1/3 + 7/18 + 5/96) L_z), its bent normal off +y by sampling noise only
    (second order in the irradiance)."""
    scene, p, n, ids = open_ground
    E = 10_000.0
    env = overcast_sky(E, height=64)
    e_map = env.sh()[2, 1] / _C1
    assert abs(e_map / E - 1) < 3e-4
    assert abs(irradiance_sh(env.sh(), [0.0, 1.0, 0.0])[1] / (E * 223 / 224) - 1) < 3e-4
    want = RHO * e_map / math.pi
    for mode, samples in (("sampled", 64), ("reference", 1024)):
        s = Sampling(samples)
        if mode == "reference":
            r = reference_radiance(scene, p, n, Lighting(env, ground_albedo=RHO), surface_ids=ids, samples=samples)
        else:
            r = shade(scene, p, n, Lighting(env, mode=mode, ground_albedo=RHO), sampling=s, surface_ids=ids)
        w = pyshadow.sample_directions(n, sampling=s).reshape(-1, 3).astype(np.float64)
        w /= np.linalg.norm(w, axis=1, keepdims=True)
        own = RHO * env.lookup(w)[:, 1].reshape(len(p), samples)
        np.testing.assert_allclose(r[:, 1], own.mean(axis=1), rtol=1e-5)
        se = own.std(axis=1).mean() / math.sqrt(samples * len(p))
        assert abs(r[:, 1].mean() - want) <= 4 * se, mode
    bent = shade(scene, p, n, Lighting(env, mode="bent", ground_albedo=RHO), sampling=Sampling(64), surface_ids=ids)
    np.testing.assert_allclose(bent[:, 1], RHO / math.pi * E * 223 / 224, rtol=6e-4)
    # "transfer": T_k = pi / S sum_s Y_k(w_s) (all open), so E = pi mean_s L_sh(w_s), the SH radiance
    # at the samples, whose expectation is the 9-coefficient irradiance at +y
    s = Sampling(64)
    tr = shade(scene, p, n, Lighting(env, mode="transfer", ground_albedo=RHO), sampling=s, surface_ids=ids)
    w = pyshadow.sample_directions(n, sampling=s).astype(np.float64)
    own = RHO * (sh_basis(w) @ env.sh()[:, 1])                                   # (P, S)
    np.testing.assert_allclose(tr[:, 1], own.mean(axis=1), rtol=64 * F32)
    se = own.std(axis=1).mean() / math.sqrt(s.samples * len(p))
    assert abs(tr[:, 1].mean() - RHO / math.pi * irradiance_sh(env.sh(), [0.0, 1.0, 0.0])[1]) <= 4 * se


# ---------------------------------------------------------------------------------------------
# the sun
# ---------------------------------------------------------------------------------------------
def sun_dir(h_deg, az=0.7):
    h = math.radians(h_deg)
    return np.array([math.cos(h) * math.cos(az), math.sin(h), math.cos(h) * math.sin(az)])


@pytest.mark.parametrize("h_deg", [90, 30, 10])
def test_sun_of_irradiance_e_gives_e_sin_h_on_the_ground(open_ground, h_deg):
    """A point sun: albedo E sin h / pi exactly in every mode and the reference. A disc of radius r
    sampled uniformly in solid angle: the mean cosine is sin h (1 + cos r) / 2 (exact in the polar
    angle; the azimuths' residual < r cos h / K for the K-point spiral)."""
    scene, p, n, ids = open_ground
    E = np.array([1000.0, 800.0, 600.0])
    d = sun_dir(h_deg)
    sin_h = math.sin(math.radians(h_deg))
    want = RHO * E * sin_h / math.pi
    for mode in MODES:
        r = shade(scene, p, n, Lighting(sun=DirectionalLight(d, E), mode=mode, ground_albedo=RHO), surface_ids=ids)
        np.testing.assert_allclose(r, np.broadcast_to(want, p.shape), rtol=4 * F32)
    light = Lighting(sun=DirectionalLight(d, E, 0.1), ground_albedo=RHO)
    ref = reference_radiance(scene, p, n, light, surface_ids=ids, sun_samples=1024)
    cos_h = math.cos(math.radians(h_deg))
    np.testing.assert_allclose(ref, np.broadcast_to(want * (1 + math.cos(0.1)) / 2, p.shape),
                               rtol=0.1 * cos_h / sin_h / 1024 + 4 * F32)


@pytest.mark.parametrize("layout, size", [("latlong", 64), ("cube", 32)])
@pytest.mark.parametrize("h_deg", [60, 30, 10])
def test_sun_disc_in_a_map_extracted_or_not_gives_the_same_irradiance(open_ground, layout, size, h_deg):
    """The real sun's disc drawn into a black map (add_sun_disc: its energy exact), then shaded
    with the sun extracted (every mode) and with the sun left in the map (the map's exact
    horizontal irradiance, sum_i L_i integral_texel max(y, 0) dOmega = L_y / C_1, what "sampled"
    and the reference estimate). A sub-texel disc lies in its texels, which only place it to within
    a texel: the extracted direction is the texels' energy-weighted centre, whose height differs
    from the texels' mean height at second order in the pitch p (the centre lies p^2 cot theta / 12
    off the solid-angle centroid, cos varies by p^2 / 24 across: p^2 / 8; bound p^2 / 4, 6e-4 and
    1e-3 here, measured <= 6e-4); "sampled" spreads 16 rays over the disc (< r cot h / 16 more)."""
    scene, p, n, ids = open_ground
    E = np.array([1000.0, 800.0, 600.0])
    d = sun_dir(h_deg)
    base = EnvironmentMap(np.zeros((size, 2 * size, 3)) if layout == "latlong" else np.zeros((6, size, size, 3)))
    env = add_sun_disc(base, d, E / disc_solid_angle(SUN_ANGULAR_RADIUS))
    np.testing.assert_allclose(env.integral(), E, rtol=1e-12)
    e_map = env.sh()[2] / _C1
    sun, sky = extract_sun(env)
    np.testing.assert_allclose(sun.irradiance, E, rtol=1e-12)
    assert not sky.radiance.any()
    tol = env.pitch ** 2 / 4
    assert abs(sun.direction[1] * E[1] / e_map[1] - 1) < tol
    for mode in MODES:
        r = shade(scene, p, n, Lighting.from_environment(env, extract=True, mode=mode, ground_albedo=RHO),
                  surface_ids=ids)
        extra = SUN_ANGULAR_RADIUS / math.tan(math.radians(h_deg)) / 16 if mode == "sampled" else 4 * F32
        np.testing.assert_allclose(r, np.broadcast_to(RHO * e_map / math.pi, p.shape), rtol=tol + extra,
                                   err_msg=mode)
    t = shade_terms(scene, p, n, Lighting.from_environment(env, extract=False, ground_albedo=RHO), surface_ids=ids)
    np.testing.assert_allclose(t.radiance, RHO / math.pi * t.ao[:, None] * np.maximum(     # left in: the SH sky's
        irradiance_sh(env.sh(), t.bent_normal.astype(np.float64)), 0), rtol=1e-5)           # 9-term irradiance


def test_large_disc_left_in_the_map_sampled_and_reference_are_unbiased(open_ground):
    """A disc of radius 0.3 at 45 degrees in a lat-long map, not extracted: the "sampled" mode and
    the reference average to the map's exact horizontal irradiance (4 standard errors of the
    samples' own spread)."""
    scene, p, n, ids = open_ground
    E = np.array([1000.0, 800.0, 600.0])
    env = add_sun_disc(EnvironmentMap(np.zeros((32, 64, 3))), sun_dir(45), E / disc_solid_angle(0.3), 0.3)
    want = RHO * (env.sh()[2] / _C1)[1] / math.pi
    for samples in (256, 1024):
        s = Sampling(samples)
        r = shade(scene, p, n, Lighting(env, mode="sampled", ground_albedo=RHO), sampling=s, surface_ids=ids)
        w = pyshadow.sample_directions(n, sampling=s).reshape(-1, 3).astype(np.float64)
        w /= np.linalg.norm(w, axis=1, keepdims=True)
        own = RHO * env.lookup(w)[:, 1].reshape(len(p), samples)
        np.testing.assert_allclose(r[:, 1], own.mean(axis=1), rtol=1e-5, atol=RHO * env.radiance.max() / samples)
        se = own.std(axis=1).mean() / math.sqrt(samples * len(p))
        assert abs(r[:, 1].mean() - want) <= 4 * se


# ---------------------------------------------------------------------------------------------
# local lights
# ---------------------------------------------------------------------------------------------
X = np.array([0.0, 0.5, 1.0, 2.0, 4.0])


def ground_row():
    scene = pyshadow.Scene(ground=0.0)
    p = np.column_stack([X, np.zeros_like(X), np.zeros_like(X)])
    return scene, p, np.tile([0.0, 1.0, 0.0], (len(X), 1)), np.full(len(X), GROUND_ID)


def test_point_and_spot_light_inverse_square_cosine():
    """Intensity I at height d: albedo I d / (pi (d^2 + x^2)^(3/2)) at offset x, I / (pi d^2) below;
    every mode, the reference; a spot of half-angle pi/2 pointing down is the same."""
    scene, p, n, ids = ground_row()
    I, d = np.array([100.0, 50.0, 25.0]), 2.0
    want = RHO * I[None, :] * d / (math.pi * (d * d + X[:, None] ** 2) ** 1.5)
    for light in (PointLight([0.0, d, 0.0], I), SpotLight([0.0, d, 0.0], I, direction=[0, -1, 0], angle=math.pi / 2)):
        for mode in MODES:
            r = shade(scene, p, n, Lighting(lights=[light], mode=mode, ground_albedo=RHO), surface_ids=ids)
            np.testing.assert_allclose(r, want, rtol=4 * F32)
        ref = reference_radiance(scene, p, n, Lighting(lights=[light], ground_albedo=RHO), surface_ids=ids)
        np.testing.assert_allclose(ref, want, rtol=4 * F32)


@pytest.mark.parametrize("radius", [0.3, 1.0, 1.8])
def test_sphere_light_single_ray_is_exact_above_the_horizon(radius):
    """A uniform sphere wholly above a point's horizon lights it exactly as a point light: I cos / d^2.
    With one ray (sun_samples=1, the default of "bent" and "transfer") the old code gave L Omega cos,
    2 / (1 + cos a) too much (0.6 %, 7 %, 39 % here), so the same light differed between modes."""
    scene, p, n, ids = ground_row()
    I, d = np.array([100.0, 50.0, 25.0]), 2.0
    want = RHO * I[None, :] * d / (math.pi * (d * d + X[:, None] ** 2) ** 1.5)
    light = PointLight([0.0, d, 0.0], I, radius=radius)
    for mode in ("bent", "transfer"):
        r = shade(scene, p, n, Lighting(lights=[light], mode=mode, ground_albedo=RHO), surface_ids=ids)
        np.testing.assert_allclose(r, want, rtol=4 * F32, err_msg=mode)
    ref = reference_radiance(scene, p, n, Lighting(lights=[light], ground_albedo=RHO), surface_ids=ids)
    np.testing.assert_allclose(ref, want, rtol=2e-3)                       # 1024 rays over the cone
    sampled = shade(scene, p, n, Lighting(lights=[light], mode="sampled", ground_albedo=RHO), surface_ids=ids)
    np.testing.assert_allclose(sampled, want, rtol=2e-2)                   # 16 rays: measured <= 1.4 %


def disc_irradiance(Lr, R, z, x):
    """Parallel coaxial-plane disc of radiance Lr, radius R, at height z, point offset x."""
    return Lr * math.pi / 2 * (1 - (z * z + x * x - R * R) / math.sqrt((z * z + x * x + R * R) ** 2 - 4 * R * R * x * x))


def rect_irradiance(Lr, w, h, z, x):
    """Parallel rectangle w (along x) by h centred above (0, z, 0), point at offset x: four corner
    rectangles of the configuration factor (1 / 2 pi) (A / sqrt(1 + A^2) atan(B / sqrt(1 + A^2)) + ...)."""
    def corner(a, b):
        return (a / math.sqrt(1 + a * a) * math.atan(b / math.sqrt(1 + a * a))
                + b / math.sqrt(1 + b * b) * math.atan(a / math.sqrt(1 + b * b))) / (2 * math.pi)
    F = 0.0
    for ax in (w / 2 - x, w / 2 + x):
        for az in (h / 2, h / 2):
            F += math.copysign(1, ax) * corner(abs(ax) / z, abs(az) / z)
    return Lr * math.pi * F


def test_disc_and_rectangle_lights_match_their_form_factors():
    """1024 stratified area samples and one: the analytic irradiance within float32 rounding (the ratio
    estimator: the exact unshadowed E_0 times the lit share, all lit here; the sample mean was within
    4e-4 and 2e-4 at 1024, and one sample gave the point light with a cosine lobe, I cos cos_L / d^2)."""
    scene, p, n, ids = ground_row()
    I, d = np.array([100.0, 50.0, 25.0]), 2.0
    disc = DiscLight([0.0, d, 0.0], [0.0, -1.0, 0.0], 0.7, intensity=I)
    rect = RectLight([0.0, d, 0.0], [0.6, 0.0, 0.0], [0.0, 0.0, 0.4], intensity=I)
    assert rect.normal[1] == -1.0
    for light, fn in ((disc, lambda x: disc_irradiance(1.0, 0.7, d, x)),
                      (rect, lambda x: rect_irradiance(1.0, 1.2, 0.8, d, x))):
        want = RHO / math.pi * np.outer([fn(x) for x in X], light.radiance)
        r = shade(scene, p, n, Lighting(lights=[light], ground_albedo=RHO, sun_samples=1024), surface_ids=ids)
        np.testing.assert_allclose(r, want, rtol=4 * F32)
        one = shade(scene, p, n, Lighting(lights=[light], ground_albedo=RHO), surface_ids=ids)
        np.testing.assert_allclose(one, want, rtol=4 * F32)        # K = 1: E_0 V(centre), all lit here


# ---------------------------------------------------------------------------------------------
# energy, tone mapping
# ---------------------------------------------------------------------------------------------
def test_sampled_and_reference_never_gain(overhang):
    """"sampled" and the reference average albedo L(w) V over directions: never above albedo max L,
    on random maps, under the overhang and in the open ("bent" and "transfer" can, by the order-3
    truncation: up to 2 % for a cap of 105 degrees, see the audit notes)."""
    scene, p, n, ids = overhang
    rng = np.random.default_rng(5)
    q = np.vstack([p, [[6.0, 0.0, 3.0], [-7.0, 0.0, 1.0]]])
    m = np.tile([0.0, 1.0, 0.0], (len(q), 1))
    qi = np.full(len(q), GROUND_ID)
    for env in (EnvironmentMap(rng.uniform(0, 3, (8, 16, 3))), EnvironmentMap(rng.uniform(0, 3, (6, 3, 3, 3)))):
        cap = 1.0 * env.radiance.reshape(-1, 3).max(axis=0)
        r = shade(scene, q, m, Lighting(env, mode="sampled", ground_albedo=1.0), surface_ids=qi)
        assert (r <= cap * (1 + 4 * F32)).all()
        ref = reference_radiance(scene, q, m, Lighting(env, ground_albedo=1.0), surface_ids=qi, samples=256)
        assert (ref <= cap * (1 + 4 * F32)).all()


def test_tonemap_of_zero_and_huge_values():
    """0 (and -0, negatives, denormals) -> 0; huge, float64's largest and +inf -> 255, for both curves
    and any exposure; the sRGB curve's knee values; monotone."""
    vals = np.array([0.0, -0.0, -1.0, -np.inf, 5e-324, 1e-3, 0.0031308, 0.5, 1.0, 10.0, 1e30,
                     np.finfo(np.float64).max, np.inf])
    img = np.repeat(vals[None, :, None], 3, axis=2)
    srgb = tonemap(img)[0, :, 0]
    assert srgb.tolist() == [0, 0, 0, 0, 0, 3, 10, 188, 255, 255, 255, 255, 255]
    expo = tonemap(img, curve="exponential")[0, :, 0]
    assert expo[:5].tolist() == [0] * 5 and expo[-3:].tolist() == [255] * 3
    assert expo[8] == round(255 * (1 - math.exp(-1)) ** (1 / 2.2))
    for curve in ("srgb", "exponential"):
        for exposure in (1e-30, 1.0, 1e30):
            sweep = np.logspace(-40, 300, 200)[None, :, None].repeat(3, axis=2)
            v = tonemap(sweep, exposure, curve)[0, :, 0]
            assert (np.diff(v.astype(int)) >= 0).all() and v[-1] == 255
            assert tonemap(np.zeros((1, 1, 3)), exposure, curve).max() == 0


# ---------------------------------------------------------------------------------------------
# occluded points: the modes agree
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("backend", ["csm", "embree"])
def test_constant_sky_under_an_overhang_every_mode_is_albedo_l_ao(overhang, backend):
    """Under the slab (AO 0.4 .. 0.85) a constant sky gives albedo L AO in every mode (one AO, the same
    samples), to float32 rounding; the reference's converged AO is within 4 Monte Carlo standard
    errors, sqrt(AO (1 - AO) / S), of each."""
    scene, p, n, ids = overhang
    env = EnvironmentMap(np.tile(L, (8, 16, 1)))
    s = Sampling(256)
    out = {}
    for mode in MODES:
        t = shade_terms(scene, p, n, Lighting(env, mode=mode, ground_albedo=RHO), backend=backend, sampling=s,
                        surface_ids=ids)
        np.testing.assert_allclose(t.radiance, RHO * np.outer(t.ao, L), rtol=300 * F32)
        out[mode] = t.ao
    assert ((out["bent"] > 0.3) & (out["bent"] < 0.9)).all()
    np.testing.assert_array_equal(out["bent"], out["sampled"])
    np.testing.assert_array_equal(out["bent"], out["transfer"])
    ref = reference_radiance(scene, p, n, Lighting(env, ground_albedo=RHO), surface_ids=ids, samples=4096)
    ao_ref = ref[:, 1] / (RHO * L[1])
    sd = np.sqrt(ao_ref * (1 - ao_ref) / s.samples) + np.sqrt(ao_ref * (1 - ao_ref) / 4096)
    assert (np.abs(out["bent"] - ao_ref) <= 4 * sd).all()


def test_band_limited_sky_under_an_overhang_transfer_is_sampled(overhang):
    """A sky L = a + b y (bands 0 and 1 only): the shadowed transfer and the sampled estimator are the
    same sum over the same open directions, the one of the SH radiance, the other of the map's texels
    (nearest texel: within b * pi / (2 H) of a + b y; measured 7e-4 at H = 64)."""
    scene, p, n, ids = overhang
    a, b, H = 1.0, 0.6, 64
    u = np.cos(np.linspace(0.0, math.pi, H + 1))
    env = EnvironmentMap(np.repeat(np.repeat((a + b * (u[:-1] + u[1:]) / 2)[:, None, None], 2 * H, 1), 3, 2))
    for backend in ("csm", "embree"):
        ts = shade_terms(scene, p, n, Lighting(env, mode="sampled", ground_albedo=1.0), backend=backend,
                         sampling=Sampling(64), surface_ids=ids)
        tt = shade_terms(scene, p, n, Lighting(env, mode="transfer", ground_albedo=1.0), backend=backend,
                         sampling=Sampling(64), surface_ids=ids)
        np.testing.assert_array_equal(ts.ao, tt.ao)
        assert np.abs(tt.sky - ts.sky).max() <= b * math.pi / (2 * H) * ts.ao.max()

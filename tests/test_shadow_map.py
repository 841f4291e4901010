"""The classic shadow map baseline (pyshadow.lighting.shadow_map): against Embree and closed forms on
small analytic scenes, the bias rule (no acne at grazing light, bounded peter-panning), PCF, cube maps,
re-rendering after set_transform, the lighting calls through it, and bad input."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree, visibility
from pyshadow.lighting import DirectionalLight, Lighting, PointLight, point_light_radiance
from pyshadow.lighting.shade import sun_radiance
from pyshadow.lighting.shadow_map import BIAS_TEXELS, ShadowMapVisibility

R = 256                     # texels per side: small, fast, and still a few texels per feature


def small_scene(ground=0.0):
    """A scene whose CSMs are tiny (the shadow map needs only the meshes)."""
    return pyshadow.Scene(ground=ground, views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)


def translate(x, y, z):
    return trimesh.transformations.translation_matrix([x, y, z])


def sun(azimuth_deg, elevation_deg):
    a, e = np.radians(azimuth_deg), np.radians(elevation_deg)
    return np.array([np.cos(e) * np.cos(a), np.sin(e), np.cos(e) * np.sin(a)])


def map_axes(sm):
    """World unit axes u, v, d and texel sizes tu, tv of an orthographic ShadowMap (from its frame)."""
    f = sm.frame.astype(np.float64)
    tu, tv = f[12], f[13]
    u, v, d = f[0:3] * tu, f[4:7] * tv, f[8:11]
    return u / np.linalg.norm(u), v / np.linalg.norm(v), d / np.linalg.norm(d), tu, tv


@pytest.fixture(scope="module")
def sphere_scene():
    """A sphere of radius 0.5 floating at height 1 over the ground plane y = 0."""
    scene = small_scene()
    scene.add(trimesh.creation.icosphere(3, radius=0.5), translate(0, 1, 0))
    return scene


def test_directional_agrees_with_embree_and_the_closed_form_away_from_the_edge(sphere_scene):
    """Ground points: exact (== Embree == the faceted sphere's closed form) farther than 2 texels from the
    shadow's edge; the mismatches, all within that band, are a few % of it. Lit sphere points: all lit."""
    l = sun(30, 50)
    rng = np.random.default_rng(1)
    p = np.c_[rng.uniform(-2, 2, 20000), np.zeros(20000), rng.uniform(-2, 2, 20000)]
    nrm = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    w = np.tile(l, (len(p), 1))
    sm = ShadowMapVisibility(R)
    v = visibility.visible(sphere_scene, p, w, backend=sm, normals=nrm)
    truth = embree.visible(sphere_scene, p, w)
    mesh = sphere_scene.instances[0].mesh
    r_in = float(np.abs(np.einsum("ij,ij->i", mesh.face_normals, mesh.triangles_center)).min())  # inscribed
    rc = np.array([0.0, 1.0, 0.0]) - p
    rho = np.linalg.norm(rc - (rc @ l)[:, None] * l, axis=1)       # distance of the centre from each ray
    t = max(map_axes(sm.shadow_map(sphere_scene, direction=l))[3:])
    far = (rho < r_in - 2 * t) | (rho > 0.5 + 2 * t)
    assert far.sum() > 15000 and (~truth[far]).sum() > 1000
    np.testing.assert_array_equal(v[far], truth[far])
    np.testing.assert_array_equal(truth[far], rho[far] > 0.5)
    # near the edge: the nearest texel moves the edge by at most sqrt(2)/2 texel, a band of 4 texels
    assert np.mean(v[~far] != truth[~far]) < 0.25
    # the sphere's own lit side: no acne
    pts = trimesh.sample.sample_surface(mesh, 3000, seed=2)[0]
    ns = pts / np.linalg.norm(pts, axis=1, keepdims=True)
    keep = ns @ l >= 0.2
    q = pts[keep] + [0.0, 1.0, 0.0]
    vs = sm.visible(sphere_scene, q, np.tile(l, (len(q), 1)), normals=ns[keep])
    assert vs.all() and embree.visible(sphere_scene, q, np.tile(l, (len(q), 1))).all()


def test_bias_rule_no_acne_at_20_degrees_and_bounded_peter_panning():
    """A cube on a slab, sun 20 degrees over the slab: the lit slab shows no acne with the rule (nor at 8
    degrees; there, without normals, plenty); points the cube really shadows come out lit only within
    eps + 2 texels of the contact (eps = BIAS_TEXELS texels)."""
    scene = small_scene(ground=None)
    scene.add(trimesh.creation.box((4.0, 0.2, 4.0)), translate(0, 0.1, 0))
    scene.add(trimesh.creation.box((0.5, 0.5, 0.5)), translate(0, 0.45, 0))
    l = sun(0, 20)
    rng = np.random.default_rng(3)
    p = np.c_[rng.uniform(-1.9, 1.9, 30000), np.full(30000, 0.2), rng.uniform(-1.9, 1.9, 30000)]
    p = p[(np.abs(p[:, 0]) > 0.26) | (np.abs(p[:, 2]) > 0.26)]          # not under the cube
    nrm = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    w = np.tile(l, (len(p), 1))
    truth = embree.visible(scene, p, w)
    sm = ShadowMapVisibility(R)
    v = sm.visible(scene, p, w, normals=nrm)
    t = max(map_axes(sm.shadow_map(scene, direction=l))[3:])
    # the cube's shadow: x in [-0.25 - 0.5 / tan 20, -0.25], |z| <= 0.25; far from its edges: exact
    x0 = -0.25 - 0.5 / np.tan(np.radians(20))
    edge = np.minimum.reduce([np.abs(p[:, 0] + 0.25), np.abs(p[:, 0] - x0), np.abs(np.abs(p[:, 2]) - 0.25)])
    lit_far = truth & (edge > 3 * t)
    assert lit_far.sum() > 20000 and v[lit_far].all()                   # no acne at all
    # at 8 degrees (slope tan 82 = 7.1): the receiver plane still leaves no acne; without normals the
    # tolerance covers slopes up to NO_NORMAL_SLOPE only, and acne appears
    l8 = sun(0, 8)
    side = np.abs(p[:, 2]) > 0.4                                     # beside the long shadow: all lit
    w8 = np.tile(l8, (side.sum(), 1))
    assert embree.visible(scene, p[side], w8).all()
    assert sm.visible(scene, p[side], w8, normals=nrm[side]).all()
    acne = sm.visible(scene, p[side], w8)
    assert np.mean(~acne) > 0.1
    assert not v[~truth & (edge > 3 * t)].any()      # shadowed far from the edges: exact
    # the strip at the contact edge x = -0.25 (away from the other edges): the cube shadows it all; light
    # leaks (peter-panning) at most eps + 2 texels from the cube along the light's horizontal
    delta = rng.uniform(0.0, 8 * t, 4000)
    q = np.c_[-0.25 - delta, np.full(len(delta), 0.2), rng.uniform(-0.2, 0.2, len(delta))]
    wq = np.tile(l, (len(q), 1))
    assert not embree.visible(scene, q, wq).any()
    leak = sm.visible(scene, q, wq, normals=np.tile([0.0, 1.0, 0.0], (len(q), 1)))
    assert not leak[delta > (BIAS_TEXELS + 2.0) * t].any()


def test_pcf_is_the_mean_of_hard_lookups_at_the_shifted_texels(sphere_scene):
    """pcf=k: the fraction equals the mean of the hard answers of the points moved along their plane by
    whole texels (dj, di), |dj|, |di| <= k // 2; values in [0, 1] in steps of 1/k^2."""
    l = sun(-60, 45)
    hard = ShadowMapVisibility(R)
    sm = hard.shadow_map(sphere_scene, direction=l)
    u, v, d, tu, tv = map_axes(sm)
    f = sm.frame.astype(np.float64)
    # points on y = 0 at texel coordinates (integer + [-0.3, 0.3]): none near a rounding boundary
    rng = np.random.default_rng(4)
    cr = rng.integers(20, R - 20, (4000, 2)) + rng.uniform(-0.3, 0.3, (4000, 2))
    A = np.stack([f[0:3], f[4:7], [0.0, 1.0, 0.0]])
    rhs = np.c_[cr[:, 0] - f[3], cr[:, 1] - f[7], -np.full(len(cr), sm.origin[1])]
    p = np.linalg.solve(A, rhs.T).T + sm.origin
    nrm = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    w = np.tile(l, (len(p), 1))
    for k in (3, 5):
        frac = ShadowMapVisibility(R, pcf=k).lit_fraction(sphere_scene, p, w, normals=nrm)
        assert frac.dtype == np.float32 and 0.0 <= frac.min() and frac.max() <= 1.0
        taps = []
        for di in range(-(k // 2), k // 2 + 1):
            for dj in range(-(k // 2), k // 2 + 1):
                s = dj * tu * u + di * tv * v
                s -= s[1] / d[1] * d                      # back onto the plane y = 0 along the light
                taps.append(hard.visible(sphere_scene, p + s, w, normals=nrm))
        np.testing.assert_array_equal(frac, np.mean(taps, axis=0).astype(np.float32))
        assert ((frac > 0) & (frac < 1)).sum() >= 20                   # a penumbra band exists
    assert hard.renders == 1                                           # every call reused the one map


def test_point_light_between_two_bodies_and_behind_the_receiver():
    """A cube map at a light between two boxes: the facing sides lit, a wall behind one box shadowed where
    the box hides it, the wall's far side (light behind the receiver) all shadowed; == Embree away from
    edges, and point_light_radiance through it equals Embree's there."""
    scene = small_scene()
    scene.add(trimesh.creation.box((0.6, 1.0, 0.6)), translate(-1.5, 0.5, 0))
    scene.add(trimesh.creation.box((0.6, 1.0, 0.6)), translate(1.5, 0.5, 0))
    scene.add(trimesh.creation.box((0.1, 2.0, 3.0)), translate(3.0, 1.0, 0))
    L = np.array([0.0, 0.6, 0.1])
    rng = np.random.default_rng(5)
    m = 3000
    yz = np.c_[rng.uniform(0.05, 1.95, m), rng.uniform(-1.45, 1.45, m)]
    faces = {
        "wall front": (np.c_[np.full(m, 2.95), yz], [-1.0, 0, 0]),
        "wall back": (np.c_[np.full(m, 3.05), yz], [1.0, 0, 0]),
        "box A facing": (np.c_[np.full(m, -1.2), yz[:, 0] / 2, yz[:, 1] / 5], [1.0, 0, 0]),
        "ground": (np.c_[rng.uniform(-2.9, 2.9, m), np.zeros(m), rng.uniform(-2, 2, m)], [0, 1.0, 0]),
    }
    sm = ShadowMapVisibility(R)
    for name, (p, n) in faces.items():
        d = L - p
        dist = np.linalg.norm(d, axis=1)
        w = d / dist[:, None]
        nrm = np.tile(n, (m, 1))
        v = visibility.visible(scene, p, w, max_distance=dist, backend=sm, normals=nrm)
        truth = embree.visible(scene, p, w, max_distance=dist)
        if name == "wall back":
            assert not v.any() and not truth.any()
        elif name == "box A facing":
            assert v.all() and truth.all()
        else:
            assert 0.1 < truth.mean() < 0.95
            assert np.mean(v == truth) >= 0.99            # the mismatches: a texel or two at the edges
            # PCF on the cube: fractions in [0, 1]; where all 9 taps agree, they agree with the hard answer
            frac = ShadowMapVisibility(R, pcf=3).lit_fraction(scene, p, w, max_distance=dist, normals=nrm)
            assert 0.0 <= frac.min() and frac.max() <= 1.0 and ((frac > 0) & (frac < 1)).any()
            whole = (frac == 0) | (frac == 1)
            np.testing.assert_array_equal(frac[whole] == 1, v[whole])
        light = PointLight(L, [1.0, 2.0, 3.0])
        rad, vis = point_light_radiance(scene, p, nrm, light, 0.5, backend=sm)
        rad_e, vis_e = point_light_radiance(scene, p, nrm, light, 0.5, backend="embree")
        same = vis == vis_e
        assert same.mean() >= 0.99
        np.testing.assert_allclose(rad[same], rad_e[same], rtol=1e-12)
    assert sm.renders == 1


def test_sun_radiance_through_the_shadow_map(sphere_scene):
    l = sun(10, 40)
    rng = np.random.default_rng(6)
    p = np.c_[rng.uniform(-2, 2, 5000), np.zeros(5000), rng.uniform(-2, 2, 5000)]
    nrm = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    lighting = Lighting(sun=DirectionalLight(l, [3.0, 2.0, 1.0]))
    rad, vis = sun_radiance(sphere_scene, p, nrm, lighting, np.full((len(p), 3), 0.5),
                            backend=ShadowMapVisibility(R))
    rad_e, vis_e = sun_radiance(sphere_scene, p, nrm, lighting, np.full((len(p), 3), 0.5), backend="embree")
    same = vis == vis_e
    assert same.mean() >= 0.995 and (vis_e == 0).sum() > 100
    np.testing.assert_allclose(rad[same], rad_e[same], rtol=1e-12)


def test_set_transform_renders_again_and_the_answer_follows():
    scene = small_scene()
    i = scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), translate(0, 1.5, 0))
    p = np.array([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
    w = np.tile([0.0, 1.0, 0.0], (2, 1))
    nrm = w.copy()
    sm = ShadowMapVisibility(64)
    assert sm.visible(scene, p, w, normals=nrm).tolist() == [False, True]
    assert sm.visible(scene, p[::-1].copy(), w, normals=nrm).tolist() == [True, False]
    assert sm.renders == 1                          # unchanged transforms: the map is reused
    scene.set_transform(i, translate(3.0, 1.5, 0))
    assert sm.visible(scene, p, w, normals=nrm).tolist() == [True, False]
    assert sm.renders == 2
    np.testing.assert_array_equal(sm.visible(scene, p, w, normals=nrm), embree.visible(scene, p, w))
    assert sm.renders == 2


def test_bad_input_is_refused_before_any_launch(sphere_scene, no_launch):
    for res in (4, 8193, 1.5, True, None):
        with pytest.raises(ValueError, match="resolution"):
            ShadowMapVisibility(res)
    for pcf in (0, 2, 4, 9, 3.0, True):
        with pytest.raises(ValueError, match="pcf"):
            ShadowMapVisibility(64, pcf=pcf)
    for bias in (-1e-3, np.nan, np.inf, "x"):
        with pytest.raises(ValueError, match="bias"):
            ShadowMapVisibility(64, bias=bias)
    with pytest.raises(ValueError, match="bias_texels"):
        ShadowMapVisibility(64, bias_texels=-1.0)
    sm = ShadowMapVisibility(64)
    p = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    up = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    with pytest.raises(ValueError, match="bias"):
        sm.visible(sphere_scene, p, up, bias=-1.0)
    with pytest.raises(ValueError):
        sm.visible(sphere_scene, p, [[0.0, 1.0, 0.0], [np.nan, 1.0, 0.0]])
    with pytest.raises(ValueError):
        sm.visible(sphere_scene, p, [[0.0, 1.0, 0.0], [0.0, 0.0, 0.0]])
    with pytest.raises(ValueError):
        sm.visible(sphere_scene, [[0.0, np.inf, 0.0], [1.0, 0.0, 0.0]], up)
    with pytest.raises(ValueError, match="share one direction"):
        sm.visible(sphere_scene, p, [[0.0, 1.0, 0.0], [0.1, 1.0, 0.0]])
    with pytest.raises(ValueError, match="end at one point"):
        sm.visible(sphere_scene, p, up, max_distance=2.0)        # parallel segments: two ends
    with pytest.raises(ValueError, match="not a mix"):
        sm.visible(sphere_scene, p, up, max_distance=[2.0, np.inf])
    with pytest.raises(ValueError, match="max_distance"):
        sm.visible(sphere_scene, p, up, max_distance=-1.0)
    with pytest.raises(ValueError, match="ambient occlusion"):
        visibility.ambient_occlusion(sphere_scene, p, up, backend=sm)
    with pytest.raises(ValueError, match="ambient occlusion"):
        sm.ambient_occlusion(sphere_scene, p, up, sampling=pyshadow.Sampling(4), max_distance=1.0)
    with pytest.raises(ValueError, match="exactly one"):
        sm.shadow_map(sphere_scene)
    with pytest.raises(ValueError, match="zero"):
        sm.shadow_map(sphere_scene, direction=[0, 0, 0])
    assert sm.renders == 0


def test_a_caster_without_its_mesh_is_refused():
    ball = trimesh.creation.icosphere(1)
    csm = pyshadow.CoherentShadowMap.build(ball, pyshadow.ViewSet.zigzag(2, 4), resolution=8, progress=False)
    scene = pyshadow.Scene(ground=0.0)
    scene.add(csm)
    with pytest.raises(ValueError, match="no mesh"):
        ShadowMapVisibility(64).visible(scene, [[3.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])


def test_render_and_lookup_match_their_numpy_references():
    """sm_raster == render_reference (coverage by the same edge rule; depths to float32 rounding of the
    scene's size, but for texel centres within rounding of a shared edge) and sm_lookup == lookup_reference on the kernel's own depths, hard and PCF, with and
    without normals (float32 against float64: a tap within rounding of a tie may differ; none does here)."""
    from pyshadow.lighting.shadow_map import lookup_reference, render_reference

    scene = small_scene()
    scene.add(trimesh.creation.icosphere(1, radius=0.5), translate(0, 1, 0))
    scene.add(trimesh.creation.box((0.6, 0.4, 0.8)),
              trimesh.transformations.rotation_matrix(0.4, [0.2, 1, 0.1]) @ translate(1.0, 0.3, 0.2))
    l = sun(70, 35)
    sm = ShadowMapVisibility(48)
    got = sm.shadow_map(scene, direction=l).depth()
    want = render_reference(scene, l, 48)
    np.testing.assert_array_equal(np.isfinite(got), np.isfinite(want))
    assert np.isfinite(want).mean() > 0.2
    fin = np.isfinite(want)
    err = np.abs(got[fin] - want[fin])
    # float32 corners: a texel centre within rounding of an edge shared by two triangles may go to the
    # neighbour; the depth is continuous across the edge, so it differs only a little there
    assert np.mean(err <= 2e-6 * 3.0) >= 0.99 and err.max() <= 1e-3
    rng = np.random.default_rng(7)
    p = np.c_[rng.uniform(-2.5, 2.5, 5000), np.zeros(5000), rng.uniform(-2.5, 2.5, 5000)]
    n = rng.normal(size=(5000, 3)) * 0.3 + [0.0, 1.0, 0.0]
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    w = np.tile(l, (len(p), 1))
    mp = sm.shadow_map(scene, direction=l)
    for k in (1, 3):
        for nrm in (n, None):
            frac = ShadowMapVisibility(48, pcf=k).lit_fraction(scene, p, w, normals=nrm)
            ref = lookup_reference(mp, got, p, nrm, pcf=k)
            np.testing.assert_allclose(frac, ref, rtol=0, atol=1e-6)
            assert 0.02 < np.mean(ref < 1) < 0.5


def test_points_far_off_the_map_are_lit_by_its_casters(sphere_scene):
    """Points whose texel coordinates would overflow an int: lit (no caster projects there), ground rule kept."""
    l = sun(30, 50)
    p = np.array([[1e12, 0.0, 3e11], [-4e11, 2.0, 1e12], [1e12, -5.0, 0.0]])
    w = np.tile(l, (3, 1))
    sm = ShadowMapVisibility(64)
    np.testing.assert_array_equal(sm.visible(sphere_scene, p, w), [True, True, False])   # below the ground
    np.testing.assert_array_equal(embree.visible(sphere_scene, p, w), [True, True, False])

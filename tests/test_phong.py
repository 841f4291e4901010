"""Thesis 000's shading modes (pyshadow.lighting.phong): eq. 3.2 on hand-computed points, the
specular peak, the light's shadow, AO on the ambient term only, the "normal" (no AO) sample,
Gouraud corners, CSM against Embree, render integration, and bad input."""
import math

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import render, visibility
from pyshadow.lighting import PointLight
from pyshadow.lighting.phong import PhongLighting, display, light_terms, phong_shade, vertex_terms

UP = np.array([0.0, 1.0, 0.0])
S2 = math.sqrt(0.5)


def reference_colour(x, n, eye, light, a, v, c_r, c_a, c_l, c_p, p):
    """Eq. 3.2 for one point, written out scalar by scalar (the NumPy-free reference)."""
    def unit(u):
        s = math.sqrt(sum(t * t for t in u))
        return [t / s for t in u]

    n = unit(n)
    l = unit([light[i] - x[i] for i in range(3)])
    e = unit([eye[i] - x[i] for i in range(3)])
    nl = sum(n[i] * l[i] for i in range(3))
    r = [2.0 * nl * n[i] - l[i] for i in range(3)]
    er = max(0.0, sum(e[i] * r[i] for i in range(3)))
    spec = er ** p if nl > 0 else 0.0
    return [c_r[i] * (a * c_a[i] + v * c_l[i] * max(0.0, nl)) + v * c_l[i] * c_p[i] * spec for i in range(3)]


def box_scene(views=(16, 32), resolution=64, lift=0.0):
    """A unit box on (or ``lift`` above) the ground y = 0, with its mesh."""
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(*views), resolution=resolution)
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    box.apply_translation([0.0, 0.5 + lift, 0.0])
    scene.add(box)
    return scene


@pytest.fixture(scope="module")
def lifted_box():
    return box_scene(lift=1.0)


def test_hand_computed_points():
    """Light overhead: n.l = 1, r = n; light at 45 deg with the eye on r (peak) or on n ((1/sqrt 2)^p);
    light behind the surface: ambient only. c_r = (0.5, 1, 0.25), p = 2, no casters."""
    scene = pyshadow.Scene()
    kw = dict(ambient=(0.2, 0.4, 0.6), light_colour=(1.0, 0.5, 0.25), specular=(0.5, 0.5, 1.0), exponent=2.0)
    c_r = np.array([0.5, 1.0, 0.25])
    p = np.zeros((1, 3))
    cases = [((0.0, 2.0, 0.0), (0.0, 5.0, 0.0), 1.0, 1.0),       # (light, eye, n.l, specular factor)
             ((1.0, 1.0, 0.0), (-3.0, 3.0, 0.0), S2, 1.0),
             ((1.0, 1.0, 0.0), (0.0, 3.0, 0.0), S2, 0.5),
             ((1.0, -1.0, 0.0), (-3.0, 3.0, 0.0), 0.0, 0.0)]
    for light, eye, nl, s in cases:
        c, amb, v = phong_shade(scene, p, [UP], eye, PhongLighting(light, **kw), [0.75], albedo=c_r)
        want = c_r * (0.75 * np.array([0.2, 0.4, 0.6]) + np.array([1.0, 0.5, 0.25]) * nl) \
            + np.array([1.0, 0.5, 0.25]) * np.array([0.5, 0.5, 1.0]) * s
        np.testing.assert_allclose(c[0], want, rtol=1e-12, atol=1e-15)
        assert amb[0] == 0.75 and v[0] == (1.0 if nl > 0 else 0.0)


def test_formula_against_the_scalar_reference(rng):
    """500 random points, normals, eyes and AO: phong_colour's arrays against the scalar loop."""
    n = 500
    x = rng.normal(size=(n, 3))
    nrm = rng.normal(size=(n, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    eye, light = np.array([0.3, 4.0, 5.0]), np.array([-3.0, 6.0, 1.0])
    ao = rng.random(n)
    c_r = rng.random((n, 3))
    lt = PhongLighting(light, ambient=(0.1, 0.2, 0.7), light_colour=(0.9, 0.3, 0.1), specular=(0.4, 0.5, 0.6),
                       exponent=7.5, shadows=False)
    c, _, v = phong_shade(pyshadow.Scene(), x, nrm, eye, lt, ao, albedo=c_r)
    assert (v == 1).all()
    want = [reference_colour(x[i], nrm[i], eye, light, ao[i], 1.0, c_r[i], lt.ambient, lt.light_colour,
                             lt.specular, 7.5) for i in range(n)]
    np.testing.assert_allclose(c, want, rtol=1e-11, atol=1e-14)


def test_specular_peaks_where_r_meets_e():
    """The eye circles the point in the plane of n and l (light at 60 deg from n): the specular
    factor is largest (1) at the mirror angle -60 deg and falls off as cos^p of the offset."""
    ang = np.radians(np.arange(-89.0, 90.0, 0.5))
    eyes = 3.0 * np.c_[np.sin(ang), np.cos(ang), np.zeros_like(ang)]
    light = 2.0 * np.array([math.sin(math.radians(60)), math.cos(math.radians(60)), 0.0])
    spec = np.array([light_terms(np.zeros((1, 3)), UP[None], e, light, 10.0)[1][0] for e in eyes])
    k = int(np.argmax(spec))
    assert ang[k] == pytest.approx(math.radians(-60.0), abs=1e-12) and spec[k] == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(spec, np.maximum(np.cos(ang + math.radians(60)), 0.0) ** 10, rtol=1e-10, atol=1e-15)


@pytest.mark.parametrize("backend", ["csm", "embree"])
def test_shadowed_point_gets_only_the_ambient_term(lifted_box, backend):
    """Ground point under the lifted box, light straight above the box: c = c_r AO c_a exactly; a
    ground point beside the box gets the full formula (no caster between it and the light)."""
    p = np.array([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
    lt = PhongLighting([0.0, 4.0, 0.0], ambient=(0.3, 0.3, 0.9), light_colour=(1.0, 0.2, 0.2), specular=0.5,
                       exponent=8.0)
    c, _, v = phong_shade(lifted_box, p, [UP, UP], [5.0, 3.0, 5.0], lt, [0.6, 0.9], backend=backend,
                          surface_ids=[-2, -2])
    c_r = lt.ground_albedo
    assert v.tolist() == [0.0, 1.0]
    np.testing.assert_allclose(c[0], c_r * 0.6 * lt.ambient, rtol=1e-12)
    want = reference_colour(p[1], UP, [5.0, 3.0, 5.0], lt.position, 0.9, 1.0, c_r, lt.ambient, lt.light_colour,
                            lt.specular, 8.0)
    np.testing.assert_allclose(c[1], want, rtol=1e-12)
    # without shadows (eq. 3.2 as printed) the hidden point is lit
    c_off, _, v_off = phong_shade(lifted_box, p, [UP, UP], [5.0, 3.0, 5.0], lt.replace(shadows=False),
                                  [0.6, 0.9], backend=backend)
    assert (v_off == 1).all() and (c_off[0] > c[0]).all()


def test_ao_scales_the_ambient_term_only(rng):
    """c(AO = a) = c(AO = 0) + a c_r c_a for every point, lit or not; ao="off" is AO = 1."""
    n = 64
    x = np.c_[rng.uniform(-2, 2, n), np.zeros(n), rng.uniform(-2, 2, n)]
    nrm = np.tile(UP, (n, 1))
    lt = PhongLighting([0.5, 1.5, -0.3], ambient=(0.25, 0.5, 1.0), light_colour=(1.0, 0.0, 0.0), specular=1.0,
                       exponent=4.0)
    a = rng.random(n)
    scene = pyshadow.Scene()
    c_a, *_ = phong_shade(scene, x, nrm, [0, 3, 4], lt, a)
    c_0, *_ = phong_shade(scene, x, nrm, [0, 3, 4], lt, np.zeros(n))
    c_1, *_ = phong_shade(scene, x, nrm, [0, 3, 4], lt.replace(ao="off"))
    np.testing.assert_allclose(c_a - c_0, a[:, None] * lt.albedo * lt.ambient, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(c_1 - c_0, np.tile(lt.albedo * lt.ambient, (n, 1)), rtol=1e-12, atol=1e-15)
    assert np.ptp(c_0[:, 0]) > 0.1          # the red light's term varies over the points


@pytest.mark.parametrize("backend", ["csm", "embree"])
def test_no_ao_mode_samples_along_the_normal(lifted_box, backend):
    """ao="normal": A = V(x, n), one shadow ray along the normal -- 0 under the lifted box, 1 beside
    it, equal to visibility.visible on Embree; the light's terms are unchanged."""
    p = np.array([[0.0, 0.0, 0.0], [0.2, 0.0, -0.3], [3.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    nrm = np.tile(UP, (4, 1))
    ids = np.array([-2, -2, -2, 0])
    lt = PhongLighting([4.0, 4.0, 1.0], ao="normal", ambient=(0.0, 0.0, 1.0), light_colour=(1.0, 0.0, 0.0),
                       shadows=False)
    c, amb, _ = phong_shade(lifted_box, p, nrm, [5, 3, 5], lt, backend=backend, surface_ids=ids)
    truth = visibility.visible(lifted_box, p, nrm, backend="embree").astype(float)
    assert amb.tolist() == truth.tolist() == [0.0, 0.0, 1.0, 1.0]
    np.testing.assert_allclose(c[:, 2], lt.albedo_of(ids)[:, 2] * truth, rtol=1e-12)
    c_off, *_ = phong_shade(lifted_box, p, nrm, [5, 3, 5], lt.replace(ao="off"), surface_ids=ids)
    np.testing.assert_allclose(c[:, 0], c_off[:, 0], rtol=1e-12)


def test_no_ao_preset():
    lt = PhongLighting.no_ao([1.0, 2.0, 3.0], exponent=5.0)
    assert (lt.ao, lt.per_vertex, lt.shadows, lt.exponent) == ("normal", True, False, 5.0)


def test_vertex_terms_interpolate_the_corners():
    """Gouraud on one triangle (moved by a transform): the barycentric mix of light_terms at the
    world corners with the world vertex normals; a pixel normal facing the other way flips them."""
    tri = trimesh.Trimesh([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]], [[0, 1, 2]], process=False)
    T = np.eye(4)
    T[:3, 3] = [0.5, 0.2, 0.0]
    bary = np.array([[0.2, 0.3, 0.5], [1.0, 0.0, 0.0]])
    lt = PhongLighting([0.3, 2.0, 0.4], specular=1.0, exponent=3.0)
    world = np.asarray(tri.vertices) + T[:3, 3]
    wn = np.tile(UP, (3, 1))
    dif, spc = light_terms(world, wn, [2.0, 3.0, 1.0], lt.position, 3.0)
    got = vertex_terms([(tri, T)], [0, 0], [0, 0], bary, np.tile(UP, (2, 1)), [2.0, 3.0, 1.0], lt)
    np.testing.assert_allclose(got[0], bary @ dif, rtol=1e-12)
    np.testing.assert_allclose(got[1], bary @ spc, rtol=1e-12)
    flipped = vertex_terms([(tri, T)], [0], [0], bary[:1], [-UP], [2.0, 3.0, 1.0], lt)
    assert flipped[0][0] == 0.0 and flipped[1][0] == 0.0          # the light is above, the face looks down


def test_csm_and_embree_agree_on_a_box():
    """The same points, AO and light on both backends: colours equal wherever the light's shadow
    agrees, and it agrees on >= 99 % of the ground grid (the CSM's texel and map spacing move the
    shadow's edge by about a texel; the grid's few edge points are where they may differ)."""
    scene = box_scene()
    x, z = np.meshgrid(np.linspace(-3, 3, 61), np.linspace(-3, 3, 61))
    p = np.c_[x.ravel(), np.zeros(x.size), z.ravel()]
    p = p[(np.abs(p[:, 0]) > 0.55) | (np.abs(p[:, 2]) > 0.55)]          # not under the box
    n = np.tile(UP, (len(p), 1))
    ao = np.linspace(0.2, 1.0, len(p))
    lt = PhongLighting([-2.0, 2.5, 1.0], ambient=(0.1, 0.1, 0.5), light_colour=(1.0, 0.1, 0.1), specular=0.3)
    cc, _, vc = phong_shade(scene, p, n, [3, 3, 4], lt, ao, backend="csm", surface_ids=-2)
    ce, _, ve = phong_shade(scene, p, n, [3, 3, 4], lt, ao, backend="embree", surface_ids=-2)
    same = vc == ve
    assert 0.05 < 1 - ve.mean() < 0.5                  # a real shadow on the grid (about 10 %)
    assert same.mean() >= 0.99
    np.testing.assert_array_equal(cc[same], ce[same])


def test_render_fills_radiance_with_the_colour():
    """render(lighting=PhongLighting) puts phong_shade of the frame's own points, normals and AO in
    Frame.radiance (float32, 0 on the background) and changes no other buffer."""
    scene = box_scene(views=(8, 16), resolution=32)
    cam = pyshadow.Camera([2.5, 2.0, 3.0], [0.0, 0.4, 0.0], fov_y=45.0, width=48, height=36)
    lt = PhongLighting([-2.0, 2.5, 1.0], ambient=(0.1, 0.1, 0.5), light_colour=(1.0, 0.1, 0.1), specular=0.3)
    plain = render.render(scene, cam)
    f = render.render(scene, cam, lighting=lt)
    for key in ("ao", "bent_normal", "depth", "normal", "object_id"):
        np.testing.assert_array_equal(f[key], plain[key])
    assert f.radiance.dtype == np.float32 and f.radiance.shape == (36, 48, 3)
    sp = render.surface_points(scene, cam)
    want, *_ = phong_shade(scene, sp.points, sp.normals, cam.eye, lt, f.ao.reshape(-1)[sp.index],
                           surface_ids=sp.surface_ids)
    np.testing.assert_array_equal(f.radiance.reshape(-1, 3)[sp.index], want.astype(np.float32))
    assert (f.radiance[f.object_id == -1] == 0).all()
    assert display(f.radiance).dtype == np.uint8


def test_render_per_vertex_matches_vertex_terms():
    """no_ao's Gouraud pixels: phong_shade with vertex_terms of the pixels' faces and barycentrics."""
    from pyshadow.shading_normals import pixel_surface

    scene = box_scene(views=(8, 16), resolution=32)
    cam = pyshadow.Camera([2.5, 2.0, 3.0], [0.0, 0.4, 0.0], fov_y=45.0, width=40, height=30)
    lt = PhongLighting.no_ao([-2.0, 2.5, 1.0], specular=0.5, exponent=4.0)
    f = render.render(scene, cam, lighting=lt)
    items = scene.draw_items()[0]
    g = pyshadow.render_gbuffer(items, cam)
    _, item, face, bary = pixel_surface(items, g, cam)
    sp = render.surface_points(scene, cam, gbuffer=g)
    terms = vertex_terms(items, item, face, bary, sp.normals, cam.eye, lt)
    want, *_ = phong_shade(scene, sp.points, sp.normals, cam.eye, lt, terms=terms, surface_ids=sp.surface_ids)
    np.testing.assert_allclose(f.radiance.reshape(-1, 3)[sp.index], want, rtol=1e-6, atol=1e-7)
    per_pixel, *_ = phong_shade(scene, sp.points, sp.normals, cam.eye, lt, surface_ids=sp.surface_ids)
    assert np.abs(per_pixel - want).max() > 0.05      # the corners' mix is not the per-pixel light


@pytest.mark.parametrize("kwargs, match", [
    (dict(ambient=(-0.1, 0.0, 0.0)), "ambient"),
    (dict(light_colour=(1.0, np.nan, 1.0)), "light_colour"),
    (dict(specular=-1.0), "specular"),
    (dict(exponent=0.0), "exponent"),
    (dict(exponent=-2.0), "exponent"),
    (dict(exponent=np.inf), "exponent"),
    (dict(exponent=np.nan), "exponent"),
    (dict(exponent="8"), "exponent"),
    (dict(albedo=1.5), "albedo"),
    (dict(ao="bent"), "ao"),
    (dict(shadows="yes"), "shadows"),
])
def test_bad_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        PhongLighting([0.0, 2.0, 0.0], **kwargs)


def test_bad_lights():
    for light in ([0.0, np.inf, 0.0], [1.0, 2.0], PointLight([0, 2, 0], 1.0, radius=0.1)):
        with pytest.raises(ValueError, match="light"):
            PhongLighting(light)
    assert PhongLighting(PointLight([0.0, 2.0, 0.0], 5.0)).position.tolist() == [0.0, 2.0, 0.0]


def test_light_on_a_surface_is_refused_before_any_launch(no_launch, lifted_box):
    p = np.array([[1.0, 0.0, 1.0], [3.0, 0.0, 0.0]])
    n = np.tile(UP, (2, 1))
    with pytest.raises(ValueError, match="on a surface"):          # at a shaded point
        phong_shade(lifted_box, p, n, [5, 3, 5], PhongLighting([1.0, 0.0, 1.0]), [1.0, 1.0])
    with pytest.raises(ValueError, match="ground plane"):          # on the ground plane
        phong_shade(lifted_box, p, n, [5, 3, 5], PhongLighting([-4.0, 0.0, 0.0]), [1.0, 1.0])
    with pytest.raises(ValueError, match="sphere|straddl|inside"):  # on the box's face: inside its sphere
        phong_shade(lifted_box, p, n, [5, 3, 5], PhongLighting([0.0, 2.0, 0.0]), [1.0, 1.0])
    with pytest.raises(ValueError, match="ao"):
        phong_shade(lifted_box, p, n, [5, 3, 5], PhongLighting([0.0, 5.0, 0.0]), [1.0, 1.5])
    with pytest.raises(ValueError, match="ao"):
        phong_shade(lifted_box, p, n, [5, 3, 5], PhongLighting([0.0, 5.0, 0.0]))
    with pytest.raises(TypeError, match="PhongLighting"):
        phong_shade(lifted_box, p, n, [5, 3, 5], object(), [1.0, 1.0])

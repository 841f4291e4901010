"""The shadow map backend (pyshadow.lighting.shadow_map) at extremes of distance: a scene far from the world
origin (the kept maps' light match), a point light a hair's breadth from a caster's face (the cube faces'
near plane), and a point light 1e7 and more away (float32 depths from the light)."""
import numpy as np
import trimesh

import pyshadow
from pyshadow import visibility
from pyshadow.lighting.shadow_map import ShadowMapVisibility


def translate(x, y, z):
    return trimesh.transformations.translation_matrix([x, y, z])


def ground_grid(n, offset=(0.0, 0.0, 0.0)):
    x, z = np.meshgrid(np.linspace(-3, 3, n), np.linspace(-3, 3, n))
    p = np.c_[x.ravel(), np.zeros(x.size), z.ravel()] + np.asarray(offset, float)
    return p, np.tile([0.0, 1.0, 0.0], (len(p), 1))


def rays_to(p, light):
    w = np.asarray(light, float) - p
    d = np.linalg.norm(w, axis=1)
    return w / d[:, None], d


def sphere_scene(offset=(0.0, 0.0, 0.0)):
    """A sphere r = 0.5 (icosphere: its faces within 0.5 (1 - 0.003) of the centre) 1 above the ground."""
    o = np.asarray(offset, float)
    sc = pyshadow.Scene(ground=o[1], views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    sc.add(trimesh.creation.icosphere(3, radius=0.5), translate(*(o + [0, 1, 0])))
    return sc


def test_kept_map_of_another_point_light_is_not_reused_far_from_the_origin():
    """Before: the kept maps matched a point light within 1e-6 (|light|_max + scene scale), 10 world units at
    1e7 from the origin: the backend answered light B with light A's map 4 units away (one render; the
    shadow of B fell where A's does: 228 of 1600 points answered differently from a fresh backend)."""
    o = np.array([1e7, 0.0, 0.0])
    sc = sphere_scene(o)
    p, n = ground_grid(40, o)
    A, B = o + [-2.0, 3.0, 0.0], o + [2.0, 3.0, 0.0]
    shared = ShadowMapVisibility(256)
    wa, da = rays_to(p, A)
    a = shared.visible(sc, p, wa, normals=n, max_distance=da)
    wb, db = rays_to(p, B)
    b = shared.visible(sc, p, wb, normals=n, max_distance=db)
    fresh = ShadowMapVisibility(256).visible(sc, p, wb, normals=n, max_distance=db)
    assert shared.renders == 2
    np.testing.assert_array_equal(b, fresh)
    # the two shadows are mirror images about x = 1e7 (the grid is symmetric): B's is A's mirrored, not A's
    mirror = np.arange(len(p)).reshape(40, 40)[:, ::-1].ravel()
    assert (~b).sum() > 50 and np.array_equal(b, a[mirror]) and not np.array_equal(b, a)
    # the same light again (its ends recomputed) is kept
    shared.visible(sc, p, wb, normals=n, max_distance=db)
    assert shared.renders == 2


def box_scene():
    sc = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    sc.add(trimesh.creation.box((1.0, 1.0, 1.0)), translate(1.5, 0.5, 0.0))      # x in [1, 2], y in [0, 1]
    return sc


def test_point_light_a_hair_above_a_caster_face_shadows_what_lies_behind_it():
    """Before: a light 1e-9 .. 1e-6 above the box's top face (or beside its side face) raised the G-buffer's
    'render_gbuffer: face 9 of item 0 reaches into the view nearer than the near plane ... a smaller
    ground_size' ValueError. Now the face is rasterised at its depth: above the top face every ground
    point is behind the box (its top face covers the light's whole lower half); beside the -X face the
    points left of the box are lit and every other one (but those under the box) is shadowed."""
    sc = box_scene()
    p, n = ground_grid(20)
    for h in (1e-9, 1e-7, 1e-6):
        w, d = rays_to(p, [1.5, 1.0 + h, 0.0])
        frac = ShadowMapVisibility(128).lit_fraction(sc, p, w, normals=n, max_distance=d)
        np.testing.assert_array_equal(frac, 0.0)
    under = (p[:, 0] > 1) & (p[:, 0] < 2) & (np.abs(p[:, 2]) < 0.5)
    left = p[:, 0] < 1
    for h in (1e-9, 1e-7):
        w, d = rays_to(p, [1.0 - h, 0.5, 0.0])
        v = ShadowMapVisibility(128).visible(sc, p, w, normals=n, max_distance=d)
        assert left.sum() == 260 and v[left].all()
        assert (~under & ~left).sum() == 128 and not v[~under & ~left].any()


def test_distant_point_light_keeps_its_shadow():
    """Before: a point light 1e7 or 1e9 away lost every shadow (the fitted cube stores float32 depths from
    the light, a world unit apart at 1e7, and its tolerance of 4 such units covered the sphere 1 above
    the ground: 0 points shadowed of the 98 Embree finds). Now such a light is answered by the map along
    its casters' cone: shadowed where the ray passes within 0.47 of the sphere's centre (inside the
    icosphere), lit where it passes beyond 0.52."""
    sc = sphere_scene()
    p, n = ground_grid(60)
    el = np.array([0.5, 0.7, -0.3]) / np.linalg.norm([0.5, 0.7, -0.3])
    smv = ShadowMapVisibility(512)
    for D in (1e7, 1e9):
        w, d = rays_to(p, D * el)
        v = smv.visible(sc, p, w, normals=n, max_distance=d)
        c = np.array([0.0, 1.0, 0.0]) - p
        miss = np.linalg.norm(c - (c * w).sum(axis=1)[:, None] * w, axis=1)     # ray's distance to the centre
        assert (miss < 0.47).sum() > 80 and not v[miss < 0.47].any()
        assert v[miss > 0.52].all()


def test_a_lamp_beside_another_near_a_small_box_gets_its_own_map():
    """Was (1489bff: a kept map matched within 1e-6 of the light's reach over all casters): with a unit sphere 1e4 away,
    a lamp 9 mm beside another, 4 cm over a 2 cm box, reused the other's cube map (1 render; 46 of 1,981 ground answers
    wrong). A kept map now matches within 1e-6 of the light's distance to the nearest caster: 2 renders, and the answers
    equal a fresh backend's."""
    s = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
    s.add(trimesh.creation.box((0.02, 0.02, 0.02)), trimesh.transformations.translation_matrix([0, 0.01, 0]))
    s.add(trimesh.creation.icosphere(2, 1.0), trimesh.transformations.translation_matrix([1e4, 1.0, 0]))
    rng = np.random.default_rng(0)
    g = np.column_stack([rng.uniform(-0.1, 0.1, 2000), np.zeros(2000), rng.uniform(-0.1, 0.1, 2000)])
    g = g[np.abs(g[:, [0, 2]]).max(axis=1) > 0.011]
    kept = ShadowMapVisibility(resolution=512)
    for light in ([0.0, 0.04, 0.0], [0.009, 0.04, 0.0]):
        w = np.array(light) - g
        d = np.linalg.norm(w, axis=1)
        got = visibility.visible(s, g, w / d[:, None], max_distance=d, backend=kept, surface_ids=-2)
        fresh = visibility.visible(s, g, w / d[:, None], max_distance=d, backend=ShadowMapVisibility(resolution=512),
                                   surface_ids=-2)
        np.testing.assert_array_equal(got, fresh)
    assert kept.renders == 2

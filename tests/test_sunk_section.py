"""Bodies sunk partly into the ground plane: the ground's points inside them are occluded on every ray
(:mod:`pyshadow.contact_sunk`), as Embree's are; before, the CSM answered them as points inside a solid
(AO 0.17-0.50 on average with a box sunk 10-50 %, Embree 0)."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.contact import contact_mask

VIEWS = pyshadow.ViewSet.zigzag(8, 16)
UP = np.array([0.0, 1.0, 0.0])


@pytest.fixture(scope="module")
def box():
    mesh = trimesh.creation.box((1.0, 1.0, 1.0))
    return mesh, pyshadow.CoherentShadowMap.build(mesh, VIEWS, resolution=32)


@pytest.fixture(scope="module")
def bunny():
    mesh = pyshadow.data.bunny()
    return mesh, pyshadow.CoherentShadowMap.build(mesh, VIEWS, resolution=32)


def _scene(mesh, csm, T):
    scene = pyshadow.Scene(ground=0.0)
    return scene, scene.add(csm, T, mesh=mesh)


def _ground(n, lo, hi, seed=0):
    rng = np.random.default_rng(seed)
    return np.c_[rng.uniform(lo, hi, n), np.zeros(n), rng.uniform(lo, hi, n)]


@pytest.mark.parametrize("sink", [0.1, 0.3, 0.5])
@pytest.mark.parametrize("lookup", ["nearest", "vote"])
def test_ground_inside_a_sunk_box_is_closed(box, sink, lookup):
    """The ground inside a box sunk by ``sink``: every AO ray and every ray upwards occluded, as Embree."""
    scene, _ = _scene(*box, trimesh.transformations.translation_matrix([0.0, 0.5 - sink, 0.0]))
    p = _ground(300, -0.45, 0.45)
    n = np.tile(UP, (len(p), 1))
    s = pyshadow.Sampling(32)
    truth = scene.ambient_occlusion(p, n, sampling=s, backend="embree")
    assert truth.max() == 0.0
    ao = scene.ambient_occlusion(p, n, sampling=s, lookup=lookup, surface_ids=-2)
    assert ao.max() == 0.0
    w = np.random.default_rng(1).normal(size=(len(p), 3))
    w[:, 1] = np.abs(w[:, 1])
    assert not scene.visible(p, w, lookup=lookup, surface_ids=-2).any()


def test_ground_beside_a_sunk_box_keeps_its_answers(box):
    """Points of the ground outside the section (beside it, within a texel of its outline) are the CSM's."""
    scene, _ = _scene(*box, trimesh.transformations.translation_matrix([0.0, 0.2, 0.0]))
    p = np.c_[np.full(50, 0.5 + 1e-3), np.zeros(50), np.linspace(-0.4, 0.4, 50)]
    m = contact_mask(scene, p)
    assert m is None or not m.any()
    ao = scene.ambient_occlusion(p, np.tile(UP, (50, 1)), sampling=pyshadow.Sampling(32), surface_ids=-2)
    assert ao.min() > 0.3


def test_section_is_the_solid_inside(box):
    """A tilted, turned box and a torus sunk at random: the masked points of the plane are exactly those
    inside the solid (trimesh's test), but within the body's tolerance of the section's outline."""
    rng = np.random.default_rng(5)
    for mesh in (box[0], trimesh.creation.torus(1.0, 0.3)):
        csm = box[1] if mesh is box[0] else pyshadow.CoherentShadowMap.build(mesh, VIEWS, resolution=16)
        for _ in range(2):
            T = trimesh.transformations.random_rotation_matrix(rng.random(3))
            T[:3, 3] = rng.uniform(-0.3, 0.3, 3)
            scene, _ = _scene(mesh, csm, T)
            p = _ground(4000, -1.5, 1.5, seed=int(rng.integers(1 << 30)))
            world = mesh.copy()
            world.apply_transform(T)
            inside = world.contains(p)
            assert inside.any()
            np.testing.assert_array_equal(contact_mask(scene, p), inside)


def test_resting_and_wholly_sunk_bodies_have_no_section(box):
    from pyshadow.contact_sunk import sections

    mesh, csm = box
    # resting, resting within its tolerance, wholly below, its lid flush with the ground (1e-7 above: the ground
    # there is its lid, open; Embree's AO 1), sunk 20 %
    for y, n in ((0.5, 0), (0.5 - 1e-7, 0), (-0.6, 0), (-0.5 + 1e-7, 0), (0.3, 1)):
        scene, _ = _scene(mesh, csm, trimesh.transformations.translation_matrix([0.0, y, 0.0]))
        assert len(sections(scene)) == n


def test_open_body_closed_above_the_ground(bunny):
    """The bunny (open: holes in its base) sunk 30 %: its holes lie below the plane, so the ground's points
    inside it are closed in (Embree: AO 0 at 256 samples there, and nowhere else masked); upright and sunk
    2 %, its holes reach above the plane: no section (the CSM's answers)."""
    from pyshadow.contact_sunk import sections

    mesh, csm = bunny
    lo, hi = mesh.bounds[:, 1]
    scene, _ = _scene(mesh, csm, trimesh.transformations.translation_matrix([0.0, -lo - 0.3 * (hi - lo), 0.0]))
    p = _ground(1500, -0.12, 0.12)
    m = contact_mask(scene, p)
    assert m.sum() > 50
    n = np.tile(UP, (len(p), 1))
    truth = scene.ambient_occlusion(p, n, sampling=pyshadow.Sampling(256), backend="embree")
    assert truth[m].max() == 0.0
    ao = scene.ambient_occlusion(p, n, sampling=pyshadow.Sampling(16), surface_ids=-2)
    assert ao[m].max() == 0.0
    scene, _ = _scene(mesh, csm, trimesh.transformations.translation_matrix([0.0, -lo - 0.02 * (hi - lo), 0.0]))
    assert sections(scene) == []


def test_distance_ao_inside_a_sunk_box_is_embree_s(box):
    """Distance AO of the ground inside a sunk box: every ray is occluded unbounded, so each ray ending inside
    the box's sphere is Embree's with straddle='embree' (the CSM's own answers differed: mean 0.885 against
    0.691 at max_distance 0.5, 0.797 against 0.683 with obscurance 2)."""
    from pyshadow import visibility

    scene, _ = _scene(*box, trimesh.transformations.translation_matrix([0.0, 0.2, 0.0]))
    p = _ground(200, -0.4, 0.4)
    n = np.tile(UP, (len(p), 1))
    s = pyshadow.Sampling(16)
    for kw in (dict(max_distance=0.5), dict(obscurance=2.0)):
        truth = visibility.ambient_occlusion(scene, p, n, sampling=s, backend="embree", **kw)
        got = visibility.ambient_occlusion(scene, p, n, sampling=s, surface_ids=-2, straddle="embree", **kw)
        if "max_distance" in kw:
            np.testing.assert_array_equal(got, truth)
        else:           # the CSM's distance weights are binned (within 0.013 here; 0.11 apart on average before)
            assert np.abs(got - truth).mean() < 0.01


@pytest.fixture(scope="module")
def l_block():
    """A closed L-shaped block: 2 x 1 at the bottom, 1 x 1 on its left (its tread at y = 1 over x in [1, 2])."""
    p = np.array([(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2), (0, 1)], float)
    cap = [(0, 1, 2), (0, 2, 3), (0, 3, 6), (6, 3, 4), (6, 4, 5)]
    faces = cap + [(a + 7, c + 7, b + 7) for a, b, c in cap]
    for i in range(7):
        j = (i + 1) % 7
        faces += [(i, j + 7, j), (i, i + 7, j + 7)]
    mesh = trimesh.Trimesh(np.r_[np.c_[p, np.zeros(7)], np.c_[p, np.ones(7)]], np.array(faces))
    trimesh.repair.fix_normals(mesh)
    return mesh, pyshadow.CoherentShadowMap.build(mesh, VIEWS, resolution=16)


@pytest.mark.parametrize("dy", [1e-7, -1e-7, 1e-3])
def test_a_tread_flush_with_the_ground_stays_open(l_block, dy):
    """The L block sunk with its tread within its tolerance of the plane: the ground there is the tread, open
    (Embree's AO about 0.8), not a section; the ground under the tall part is; a tread 1e-3 above is sunk."""
    scene, _ = _scene(*l_block, trimesh.transformations.translation_matrix([0.0, -1.0 + dy, 0.0]))
    rng = np.random.default_rng(2)
    tread = np.c_[rng.uniform(1.05, 1.95, 100), np.zeros(100), rng.uniform(0.05, 0.95, 100)]
    tall = np.c_[rng.uniform(0.05, 0.95, 100), np.zeros(100), rng.uniform(0.05, 0.95, 100)]
    assert contact_mask(scene, tall).all()
    assert contact_mask(scene, tread).all() == (dy > 1e-5) and contact_mask(scene, tread).any() == (dy > 1e-5)

"""Closed bodies resting on the ground: the footprint's points are closed in (pyshadow/contact.py).

A point of the ground inside the footprint of a closed body lying on it is
occluded in every direction (Embree: AO exactly 0); the CSM alone leaks light
on rays that leave such a point outwards near the footprint's edge (thinner
than a texel). These tests hold the exact answer for both lookups and the
float64 mirror, and check the points that must stay the CSM's: the body's
sides just above the ground, a body lifted off the ground, open and tilted
bodies.
"""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import contact, embree
from pyshadow.scene import GROUND_ID
from pyshadow.scene_arrays import scene_arrays

VIEWS = pyshadow.ViewSet.zigzag(16, 32)
RES = 64


def _box(size=(1.0, 1.0, 1.0), lift=0.0, turn=0.0, at=(0.0, 0.0, 0.0)):
    m = trimesh.creation.box(size)
    T = trimesh.transformations.rotation_matrix(turn, [0, 1, 0])
    T[:3, 3] = [at[0], size[1] / 2 + lift + at[1], at[2]]
    return m, T


def _scene(*bodies, ground=0.0):
    scene = pyshadow.Scene(ground=ground, views=VIEWS, resolution=RES)
    for m, T in bodies:
        scene.add(m, T)
    return scene


def _under(n, half, seed, ground=0.0, edge=None):
    """``n`` ground points in the square |x|, |z| < half (or within ``edge`` of its border, but farther
    than 1e-4, ten times the ground's tolerance at these scenes' scale: nearer, a point is the CSM's)."""
    rng = np.random.default_rng(seed)
    p = rng.uniform(-half, half, (n, 2))
    if edge is not None:            # push one coordinate to within `edge` of the border
        k = rng.integers(0, 2, n)
        p[np.arange(n), k] = np.sign(p[np.arange(n), k]) * (half - rng.uniform(1e-4, edge, n))
    return np.column_stack([p[:, 0], np.full(n, ground), p[:, 1]])


@pytest.fixture(scope="module")
def resting():
    return _scene(_box())


@pytest.mark.parametrize("lookup", ["nearest", "vote"])
def test_the_ground_under_a_resting_box_is_closed_in_to_the_footprints_edge(resting, lookup):
    p = np.concatenate([_under(600, 0.5, 1), _under(600, 0.5, 2, edge=0.01)])      # 600 within 1 cm of the edge
    up = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    s = pyshadow.Sampling(32)
    assert embree.ambient_occlusion(resting, p, up, sampling=s).max() == 0.0
    ao, bent = resting.ambient_occlusion(p, up, sampling=s, surface_ids=-2, lookup=lookup, return_bent_normals=True)
    assert ao.max() == 0.0
    np.testing.assert_array_equal(bent, up.astype(np.float32))     # no open sample: the normal, as the kernel gives
    # without the footprint the CSM leaks light near the edge (what this rule fixes)
    held = scene_arrays(resting)
    key = ("contact", 0.0)
    saved = held.pop(key)
    try:
        held[key] = []
        leak = resting.ambient_occlusion(p, up, sampling=s, surface_ids=-2, lookup=lookup)
    finally:
        held[key] = saved
    assert leak.max() > 0.0


def test_rays_from_the_footprint_the_kernel_and_the_mirror(resting):
    rng = np.random.default_rng(3)
    p = _under(300, 0.5, 4, edge=0.02)
    d = rng.normal(size=(300, 3))
    for backend in ("csm", "csm-vote", "numpy"):
        v = pyshadow.visibility.visible(resting, p, d, backend=backend, surface_ids=-2)
        assert not v.any(), backend           # up: into the box; down: the ground
    assert not embree.visible(resting, p, d).any()


def test_the_bottom_face_is_closed_in_and_the_sides_just_above_the_ground_are_not(resting):
    rng = np.random.default_rng(5)
    bottom = np.column_stack([rng.uniform(-0.49, 0.49, 200), np.zeros(200), rng.uniform(-0.49, 0.49, 200)])
    down = np.tile([0.0, -1.0, 0.0], (200, 1))
    assert resting.ambient_occlusion(bottom, down, sampling=pyshadow.Sampling(16), surface_ids=0).max() == 0.0
    # points of the +x side within the ground's tolerance of it, and on its bottom edge: not in the footprint
    side = np.column_stack([np.full(200, 0.5), rng.uniform(0.0, 5e-6, 200), rng.uniform(-0.45, 0.45, 200)])
    assert not contact.contact_mask(resting, side).any()
    ao = resting.ambient_occlusion(side, np.tile([1.0, 0.0, 0.0], (200, 1)), sampling=pyshadow.Sampling(32),
                                   surface_ids=0)
    ref = embree.ambient_occlusion(resting, side, np.tile([1.0, 0.0, 0.0], (200, 1)), sampling=pyshadow.Sampling(32))
    assert abs(ao.mean() - ref.mean()) < 0.02 and ao.mean() > 0.3


def test_a_turned_box_closes_its_own_footprint_only():
    scene = _scene(_box(turn=np.pi / 5, at=(3.0, 0.0, -1.0)))
    R = trimesh.transformations.rotation_matrix(np.pi / 5, [0, 1, 0])[:3, :3]
    rng = np.random.default_rng(6)
    local = np.column_stack([rng.uniform(-0.499, 0.499, 500), np.zeros(500), rng.uniform(-0.499, 0.499, 500)])
    inside = local @ R.T + [3.0, 0.0, -1.0]
    outside = np.column_stack([rng.uniform(-0.7, 0.7, 2000), np.zeros(2000), rng.uniform(-0.7, 0.7, 2000)])
    a = np.abs(outside[:, [0, 2]]).max(axis=1) > 0.501
    outside = outside[a] @ R.T + [3.0, 0.0, -1.0]
    assert contact.contact_mask(scene, inside).all()
    assert not contact.contact_mask(scene, outside).any()


@pytest.mark.parametrize("case", ["lifted 1 mm", "tilted on an edge", "open (no top)", "no ground"])
def test_no_footprint_where_the_body_does_not_close_the_ground(case):
    m, T = _box(lift=1e-3 if case == "lifted 1 mm" else 0.0)
    if case == "tilted on an edge":
        T = trimesh.transformations.rotation_matrix(np.pi / 4, [0, 0, 1])
        T[:3, 3] = [0.0, np.sqrt(0.5), 0.0]
    if case == "open (no top)":             # its floor lies on the ground, but it encloses nothing
        keep = m.face_normals[:, 1] < 0.5
        m = trimesh.Trimesh(m.vertices, m.faces[keep], process=False)
    scene = _scene((m, T), ground=None if case == "no ground" else 0.0)
    assert contact.footprints(scene) == []
    assert contact.contact_mask(scene, _under(10, 0.4, 7)) is None


def test_lifting_a_body_opens_the_ground_under_it_to_the_csm(resting):
    scene = _scene(_box())
    p = _under(400, 0.5, 8, edge=0.005)
    up = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    assert scene.ambient_occlusion(p, up, sampling=pyshadow.Sampling(32), surface_ids=-2).max() == 0.0
    scene.set_transform(0, trimesh.transformations.translation_matrix([0, 0.5 + 0.05, 0]))     # 5 cm up
    assert contact.footprints(scene) == []
    ao = scene.ambient_occlusion(p, up, sampling=pyshadow.Sampling(32), surface_ids=-2)
    ref = embree.ambient_occlusion(scene, p, up, sampling=pyshadow.Sampling(32))
    assert ref.mean() > 0.1 and abs(ao.mean() - ref.mean()) < 0.05


def test_a_csm_placed_without_its_mesh_has_no_footprint():
    m, T = _box()
    csm = pyshadow.CoherentShadowMap.build(m, VIEWS, resolution=RES, progress=False)
    scene = pyshadow.Scene(ground=0.0)
    scene.add(csm, T)
    assert contact.footprints(scene) == []
    scene.add(csm, T @ trimesh.transformations.translation_matrix([3.0, 0, 0]), mesh=m)
    fp = contact.footprints(scene)
    assert len(fp) == 1 and len(fp[0][0]) == 2 and len(fp[0][1]) == 4       # two triangles, four outline edges
    assert np.allclose(np.sort(fp[0][0].reshape(-1, 2)[:, 0]), np.repeat([2.5, 3.5], 3))


def test_transfer_and_sampled_sky_of_the_footprint_are_zero(resting):
    """The AO kernel's other outputs for footprint points: no open sample, so the shadowed SH transfer
    and the sampled sky are 0 (the same points beside the box keep theirs)."""
    from pyshadow.visibility import get_backend

    inside = _under(200, 0.5, 9, edge=0.01)
    beside = inside + [1.5, 0.0, 0.0]
    P = np.concatenate([inside, beside])
    up = np.tile([0.0, 1.0, 0.0], (len(P), 1))
    csm = get_backend("csm")
    ao, bent, tr = csm.sh_transfer(resting, P, up, sampling=pyshadow.Sampling(32), surface_ids=-2)
    assert (ao[:200] == 0).all() and (tr[:200] == 0).all()
    assert (ao[200:] > 0).all() and (np.abs(tr[200:]).sum(axis=1) > 0).all()
    env = np.ones((16, 32, 3), np.float32)
    sky, ao2, _ = csm.sampled_sky(resting, P, up, env, sampling=pyshadow.Sampling(32), surface_ids=-2)
    assert (sky[:200] == 0).all() and (ao2[:200] == 0).all()
    np.testing.assert_allclose(sky[200:, 0], ao2[200:], rtol=1e-6)     # a white sky: the open fraction


def _variant(name):
    """A unit box on the ground as a mesh of another make: the same closed surface."""
    m, _ = _box()
    v, f = np.asarray(m.vertices) + [0, 0.5, 0], np.asarray(m.faces)
    if name == "shuffled vertices":
        perm = np.random.default_rng(11).permutation(len(v))
        v, f = v[perm], np.argsort(perm)[f]
    elif name == "inverted winding":
        f = f[:, ::-1]
    elif name == "inconsistent winding":
        f = f.copy()
        f[::2] = f[::2, ::-1]
    elif name == "duplicate and reversed faces":
        f = np.vstack([f, f[:4], f[4:6, ::-1]])
    elif name == "unmerged vertices":             # every face on vertices of its own, as a raw STL
        v, f = v[f.reshape(-1)], np.arange(3 * len(f)).reshape(-1, 3)
    elif name == "zero-area faces":
        v = np.vstack([v, 0.5 * (v[f[0, 0]] + v[f[0, 1]])])
        f = np.vstack([f, [[f[0, 0], f[0, 0], f[0, 1]], [f[0, 0], len(v) - 1, f[0, 1]]]])
    return trimesh.Trimesh(v, f, process=False)


@pytest.mark.parametrize("name", ["shuffled vertices", "inverted winding", "inconsistent winding",
                                  "duplicate and reversed faces", "unmerged vertices", "zero-area faces"])
def test_any_closed_surface_on_the_ground_has_its_footprint(name):
    """Closedness is the surface's, not its winding's or its vertex list's: each variant has the
    clean box's footprint (area 1, four outline edges) and closes the same points."""
    mesh = _variant(name)
    scene = _scene((mesh, np.eye(4)))
    (tri, outline), = contact.footprints(scene)
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    assert np.isclose(np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum() / 2, 1.0)
    assert len(outline) == 4
    p = _under(300, 0.5, 12, edge=0.01)
    assert contact.contact_mask(scene, p).all()
    assert not contact.contact_mask(scene, p + [1.2, 0.0, 0.0]).any()


def test_a_box_sunk_to_its_top_does_not_close_the_ground_over_it():
    """Its top face lies on the plane, but the body is below it: the rays from there are open."""
    m, _ = _box(at=(0.0, -1.0, 0.0))               # y from -1 to 0
    scene = _scene((m, trimesh.transformations.translation_matrix([0, -0.5, 0])))
    assert contact.footprints(scene) == []


def _open_box_scene():
    m, T = _box()
    m = trimesh.Trimesh(m.vertices, m.faces[m.face_normals[:, 1] < 0.5], process=False)   # no top
    return _scene((m, T))


@pytest.mark.parametrize("lookup", ["nearest", "vote"])
def test_the_ground_on_an_open_bodys_floor_is_asked_as_that_body(lookup, monkeypatch):
    """The floor of a box without a lid lies on the ground: the ground's points there are the box's
    own (Embree's rays leave through the floor into the box). Asked with the ground's id they answer as
    with the box's, ray for ray, kernel and mirror; the ground around it stays the ground's. Asked as
    the ground before, the coincident floor answered for them (the extremes table's open box: those
    points 11.4 % against Embree, 6.1 % as the box's own)."""
    scene = _open_box_scene()
    up = np.tile([0.0, 1.0, 0.0], (300, 1))
    under, around = _under(300, 0.45, 3), _under(300, 1.5, 4)
    around = around[np.abs(around[:, [0, 2]]).max(axis=1) > 0.55]
    assert [s for s, _ in contact.sheets(scene)] == [0] and contact.footprints(scene) == []
    ids = np.full(len(under), GROUND_ID, np.int32)
    slots = scene.caster_slots(ids, len(under), under)
    assert (slots == 0).all() and (ids == GROUND_ID).all()         # the caller's array untouched
    assert (scene.caster_slots(GROUND_ID, len(around), around) == -2).all()
    s = pyshadow.Sampling(16)
    d = pyshadow.sample_directions(up, sampling=s).reshape(-1, 3).astype(np.float64)
    P, N = np.repeat(under, 16, axis=0), np.repeat(up, 16, axis=0)
    as_ground = scene.visible(P, d, surface_ids=GROUND_ID, normals=N, lookup=lookup)
    as_box = scene.visible(P, d, surface_ids=0, normals=N, lookup=lookup)
    assert np.array_equal(as_ground, as_box)
    ref = pyshadow.visibility.visible_reference(scene, P, d, surface_ids=GROUND_ID, normals=N, lookup=lookup)
    assert np.array_equal(ref, as_box)
    ao_g = scene.ambient_occlusion(under, up, sampling=s, surface_ids=GROUND_ID, lookup=lookup)
    ao_b = scene.ambient_occlusion(under, up, sampling=s, surface_ids=0, lookup=lookup)
    assert np.array_equal(ao_g, ao_b) and np.array_equal(ao_b, as_box.reshape(-1, 16).mean(axis=1, dtype=np.float32))
    # without the rule the coincident floor answers for them (here 505 and 384 of 4,800 rays open, against
    # 1,175 and 1,024 as the box's: one-texel, vote)
    monkeypatch.setattr(pyshadow.scene, "ground_sheet_slots", lambda scene, points, own: own)
    before = scene.visible(P, d, surface_ids=GROUND_ID, normals=N, lookup=lookup)
    assert before.sum() < as_box.sum()


def test_no_sheet_where_the_open_body_does_not_lie_on_the_ground_or_covers_it():
    """Lifted 1 mm, closed (its footprint answers instead), without a ground, or open but covering its
    floor (a box with a fin on a top edge: an edge of three faces, so no footprint either; the ground
    under it stays the CSM's): no sheet."""
    m, T = _box(lift=1e-3)
    m = trimesh.Trimesh(m.vertices, m.faces[m.face_normals[:, 1] < 0.5], process=False)
    assert contact.sheets(_scene((m, T))) == []
    assert contact.sheets(_scene(_box())) == [] and len(contact.footprints(_scene(_box()))) == 1
    assert contact.sheets(_scene(*[(m, _box()[1])], ground=None)) == []
    box, T = _box()
    top = box.faces[box.face_normals[:, 1] > 0.5][0]
    fin = trimesh.Trimesh(np.vstack([box.vertices, [[0.0, 1.5, 0.0]]]),
                          np.vstack([box.faces, [[top[0], top[1], len(box.vertices)]]]), process=False)
    finned = _scene((fin, T))
    assert contact.footprints(finned) == [] and contact.sheets(finned) == []
    under = _under(50, 0.45, 5)
    assert (finned.caster_slots(GROUND_ID, len(under), under) == -2).all()


def test_contact_helpers_check_their_shapes(resting):
    """Was: IndexErrors ('too many indices', 'boolean index did not match') from NumPy."""
    assert contact.contact_mask(resting, [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]).tolist() == [True, False]
    with pytest.raises(ValueError, match=r"^points must have shape \(N, 3\), got \(3,\)$"):
        contact.contact_mask(resting, [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"^points must have shape \(N, 3\), got \(1, 2\)$"):
        contact.contact_mask(resting, [[0.0, 0.0]])
    with pytest.raises(ValueError, match=r"^directions \(N, 3\) and visible \(N,\) must match points' 1 rows, "
                                         r"got \(2, 3\) and \(1,\)$"):
        contact.occlude_contacts(resting, np.zeros((1, 3)), np.tile([0.0, 1.0, 0.0], (2, 1)), np.ones(1, bool))
    sheet = pyshadow.Scene(ground=0.0, views=VIEWS, resolution=RES)
    sheet.add(trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 0, 1]], [[0, 1, 2]], process=False))
    p = np.array([[0.1, 0.0, 0.1], [0.2, 0.0, 0.2]])
    assert contact.ground_sheet_slots(sheet, p, np.array([-2, -2], np.int32)).tolist() == [0, 0]
    with pytest.raises(ValueError, match=r"^own must have shape \(2,\) \(one caster slot per point\), got \(1,\)$"):
        contact.ground_sheet_slots(sheet, p, np.array([-2], np.int32))

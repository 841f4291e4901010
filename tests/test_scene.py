"""Scenes: placement of CSM casters and receivers -- transforms, instances, several CSM
types, caster slots, bad instances. (The queries: test_visibility, test_render.)"""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling, embree
from pyshadow.scene import GROUND_ID
from pyshadow.visibility.csm import _device_atlas

from conftest import load, surface_queries, unit_frame


def test_set_transform_moves_without_rebuilding(monkeypatch):
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(16, 32), resolution=64)
    i = scene.add(box, trimesh.transformations.translation_matrix([0, 0.5, 0]))
    point = np.array([[0.0, 0.0, 1.2]])
    up = np.array([[0.0, 1.0, 0.0]])
    s256 = Sampling(256)
    ao_before = scene.ambient_occlusion(point, up, sampling=s256)
    atlas_before = _device_atlas(scene)[0]

    def no_build(*a, **k):
        raise AssertionError("a CSM was rebuilt")
    monkeypatch.setattr(pyshadow.CoherentShadowMap, "build", no_build)
    scene.set_transform(i, trimesh.transformations.translation_matrix([0, 0.5, 20]))
    ao_after = scene.ambient_occlusion(point, up, sampling=s256)
    assert _device_atlas(scene)[0] is atlas_before
    truth = embree.ambient_occlusion(scene, point, up, sampling=s256)
    assert ao_after[0] == 1.0 and truth[0] == 1.0
    scene.set_transform(i, trimesh.transformations.translation_matrix([0, 0.5, 0]))
    truth = embree.ambient_occlusion(scene, point, up, sampling=s256)
    assert ao_before[0] < 0.9 and abs(ao_before[0] - truth[0]) < 0.02
    # and back: the same answer as before
    np.testing.assert_array_equal(scene.ambient_occlusion(point, up, sampling=s256), ao_before)


def test_scene_with_several_csm_types_is_order_independent(rng):
    """Every CSM type of a scene is found at its own place in the concatenated data."""
    fan, monkey = load("fandisk.obj"), load("suzanne.ply")
    csm_f = pyshadow.CoherentShadowMap.build(fan, pyshadow.ViewSet.zigzag(16, 32), resolution=64,
                                             progress=False)
    csm_m = pyshadow.CoherentShadowMap.build(monkey, pyshadow.ViewSet.hilbert(4, True), resolution=32,
                                             progress=False)
    results = []
    for order in (0, 1):
        scene = pyshadow.Scene()
        far = unit_frame(monkey, offset=(100.0, 0.0, 0.0))
        if order:
            scene.add(csm_m, far, mesh=monkey)
        i = scene.add(csm_f, np.eye(4), mesh=fan)
        if not order:
            scene.add(csm_m, far, mesh=monkey)
        p, d = surface_queries(scene, i, 3000, 8, np.random.default_rng(0))
        results.append(scene.visible(p, d))
        assert (results[-1] == embree.visible(scene, p, d)).mean() > 0.96   # 0.90 when misplaced
    np.testing.assert_array_equal(results[0], results[1])


def test_instances_share_one_csm():
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    scene = pyshadow.Scene(views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
    a = scene.add(box)
    b = scene.add(box, trimesh.transformations.translation_matrix([3, 0, 0]))
    assert scene.instances[a].csm is scene.instances[b].csm
    assert _device_atlas(scene)[0]["ntypes"] == 1


def test_caster_types_and_anchor():
    """caster_types: the distinct CSMs of the casters in first-use order (receivers have
    none); anchor: the mean of the instances' bounding-sphere centres."""
    box, ball = trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.creation.icosphere(1)
    scene = pyshadow.Scene(views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    assert scene.caster_types() == ([], {})
    np.testing.assert_array_equal(scene.anchor(), np.zeros(3))
    np.testing.assert_array_equal(scene.anchor(np.array([[1.0, 2.0, 3.0], [3.0, 2.0, 1.0]])), [2.0, 2.0, 2.0])
    scene.add(ball, trimesh.transformations.translation_matrix([0, 0, 4]), casts=False)
    scene.add(box, trimesh.transformations.translation_matrix([2, 0, 0]))
    scene.add(ball)
    scene.add(box, trimesh.transformations.translation_matrix([-2, 0, 0]))
    types, index = scene.caster_types()
    assert types == [scene.instances[1].csm, scene.instances[2].csm]
    assert index == {id(scene.instances[1].csm): 0, id(scene.instances[2].csm): 1}
    assert scene.casters == [1, 2, 3]
    want = np.mean([inst.world_sphere()[0] for inst in scene.instances], axis=0)
    np.testing.assert_allclose(scene.anchor(), want, atol=1e-12)
    # points do not move the anchor of a scene that has instances
    np.testing.assert_array_equal(scene.anchor(np.array([[50.0, 0.0, 0.0]])), scene.anchor())


def test_caster_slots():
    """Surface ids (instance ids, -1 unknown, GROUND_ID) become caster slots: the
    caster's position in scene.casters, -1 unknown, -2 for receivers and the ground."""
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(box)                                            # caster, slot 0
    scene.add(box, casts=False)                               # receiver
    scene.add(box, trimesh.transformations.translation_matrix([3, 0, 0]))   # caster, slot 1
    np.testing.assert_array_equal(scene.caster_slots(None, 4), [-1, -1, -1, -1])
    assert scene.caster_slots(None, 4).dtype == np.int32
    got = scene.caster_slots([0, 1, 2, -1, GROUND_ID], 5)
    assert got.dtype == np.int32
    np.testing.assert_array_equal(got, [0, -2, 1, -1, -2])
    np.testing.assert_array_equal(scene.caster_slots(2, 3), [1, 1, 1])          # one id for every point
    np.testing.assert_array_equal(scene.caster_slots(np.array([2, 0], np.int32), 2), [1, 0])
    for bad in (3, -3, [0, 7]):
        with pytest.raises(ValueError, match="surface_ids must be instance ids"):
            scene.caster_slots(bad, 2)
    with pytest.raises(TypeError, match="surface_ids must be integers"):
        scene.caster_slots([0.0, 1.0], 2)
    # the slot table is kept with the scene's arrays: instances added later get theirs
    scene.add(box, casts=False)                               # receiver, id 3
    scene.add(box, trimesh.transformations.translation_matrix([0, 0, 3]))   # caster, id 4, slot 2
    np.testing.assert_array_equal(scene.caster_slots([4, 3, 2, -1, GROUND_ID], 5), [2, -2, 1, -1, -2])
    # every instance casts: int32 ids are the slots and pass through unmapped
    casters = pyshadow.Scene(ground=0.0)
    casters.add(scene.instances[0].csm, mesh=box)
    casters.add(scene.instances[0].csm, trimesh.transformations.translation_matrix([3, 0, 0]), mesh=box)
    ids = np.array([1, 0, -1, GROUND_ID], np.int32)
    assert casters.caster_slots(ids, 4) is ids
    np.testing.assert_array_equal(casters.caster_slots(ids.astype(np.int64), 4), ids)


@pytest.mark.parametrize("T, match", [
    (np.diag([1.0, 2.0, 1.0, 1.0]), "not rigid"),
    (np.diag([-1.0, 1.0, 1.0, 1.0]), "mirrors"),
    (np.array([[1, 0.5, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]]), "not rigid"),
    (np.eye(3), "4x4"),
])
def test_scene_rejects_non_rigid_transforms(small_scene, T, match):
    with pytest.raises(ValueError, match=match):
        small_scene.set_transform(0, T)
    with pytest.raises(ValueError, match=match):
        small_scene.add(small_scene.instances[0].csm, T)


def test_scene_rejects_bad_instances(small_scene):
    with pytest.raises(IndexError):
        small_scene.set_transform(5, np.eye(4))
    with pytest.raises(ValueError, match="always casts"):
        small_scene.add(small_scene.instances[0].csm, casts=False)
    with pytest.raises(ValueError, match="does not match"):
        small_scene.add(small_scene.instances[0].csm, mesh=trimesh.creation.icosphere())


def test_scene_refuses_a_csm_whose_frame_is_not_its_meshs(tmp_path):
    """With its mesh given, a CSM (its file's checksum made good after an edit) whose sphere or box does not
    fit that mesh is refused: the mesh hash does not cover them. The file as written is accepted."""
    mesh = load("spot.obj")
    path = pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(2, 4), resolution=8,
                                            progress=False).save(tmp_path / "s.csm")
    pyshadow.Scene().add(pyshadow.CoherentShadowMap.load(path), np.eye(4), mesh=mesh)       # as written
    moved = pyshadow.CoherentShadowMap.load(path)
    moved.centre = moved.centre + [0.0, 0.3 * moved.radius, 0.0]
    with pytest.raises(ValueError, match="frame does not hold its mesh"):
        pyshadow.Scene().add(moved, np.eye(4), mesh=mesh)
    nudged = pyshadow.CoherentShadowMap.load(path)      # inside the sphere still, but the box moves
    nudged.centre = nudged.centre + [0.0, 1e-3 * nudged.radius, 0.0]
    nudged.radius *= 1.01
    with pytest.raises(ValueError, match="box is not its mesh's"):
        pyshadow.Scene().add(nudged, np.eye(4), mesh=mesh)
    shrunk = pyshadow.CoherentShadowMap.load(path)
    shrunk.box = shrunk.box * 0.9
    with pytest.raises(ValueError, match="box is not its mesh's"):
        pyshadow.Scene().add(shrunk, np.eye(4), mesh=mesh)


@pytest.mark.parametrize("vertices, faces, match", [
    ([[0, 0, 0], [1, 0, 0], [np.nan, 0, 1], [0, 0, 1]], [[0, 1, 2], [0, 1, 3]], "vertices are not finite"),
    ([[0, 0, 0], [1, 0, 0], [0, 0, 1]], [[0, 1, 5]], "a face refers to a vertex that does not exist"),
    (np.zeros((0, 3)), np.zeros((0, 3), int), "no triangles"),
])
def test_scene_add_checks_a_mesh_object_as_load_mesh_does(vertices, faces, match):
    """A receiver (or caster) handed over as a mesh object is used as it is, but checked: refused at add,
    not by every later query of the scene."""
    bad = trimesh.Trimesh(vertices, faces, process=False)
    scene = pyshadow.Scene(ground=0.0)
    with pytest.raises(ValueError, match=match):
        scene.add(bad, casts=False)
    with pytest.raises(ValueError, match=match):
        scene.add(bad)
    assert scene.instances == []


def test_scene_add_and_queries_refuse_loose_arguments(small_scene):
    """casts must be a bool (a truthy string cast), lookup one of the three names (it was ignored), a
    complex transform is refused (its imaginary part was dropped with a warning), and surface_ids of the
    wrong length is named (a NumPy broadcast error before)."""
    csm = small_scene.instances[0].csm
    with pytest.raises(TypeError, match="casts must be True or False"):
        pyshadow.Scene().add(trimesh.creation.box(), casts="no")
    with pytest.raises(ValueError, match="lookup must be 'nearest', 'vote' or 'auto'"):
        pyshadow.Scene().add(csm, lookup="x")
    with pytest.raises(TypeError, match="transform must hold real numbers"):
        pyshadow.Scene().add(csm, np.eye(4) + 0j)
    p, d = np.array([[0.0, 3, 0]] * 3), np.array([[0.0, 1, 0]] * 3)
    with pytest.raises(ValueError, match=r"surface_ids must be one id or 3 \(one a query\), got shape \(2,\)"):
        small_scene.visible(p, d, surface_ids=[0, 0])
    np.testing.assert_array_equal(small_scene.visible(p, d, surface_ids=[0]), small_scene.visible(p, d))


def test_stand_on_ground_refuses_what_is_no_placement():
    mesh = load("spot.obj")
    for kw, match in ((dict(position=(np.nan, 0)), "position must be 2 finite numbers"),
                      (dict(position=(1, 2, 3)), "position must be 2 finite numbers"),
                      (dict(ground=np.inf), "ground finite"),
                      (dict(radius=np.inf), "radius must be finite and positive"),
                      (dict(rotation=np.nan), "rotation must be 3x3 or 4x4"),
                      (dict(rotation=np.diag([1.0, 1, -1])), "mirrors")):
        with pytest.raises(ValueError, match=match):
            pyshadow.stand_on_ground(mesh, **kw)
    T = pyshadow.stand_on_ground(mesh, radius=2.0, position=(1.0, 2.0), ground=0.5)
    v = mesh.vertices @ T[:3, :3].T + T[:3, 3]
    assert v[:, 1].min() == pytest.approx(0.5, abs=1e-12)
    c, r = pyshadow.bounding_sphere(mesh)
    np.testing.assert_allclose((T[:3, :3] @ c + T[:3, 3])[[0, 2]], [1.0, 2.0], atol=1e-12)
    assert np.cbrt(np.linalg.det(T[:3, :3])) * r == pytest.approx(2.0)


@pytest.mark.parametrize("ground", [float("nan"), float("inf"), 1e40, -1e39])
def test_scene_ground_must_be_a_float32_height(ground):
    """The kernels take the ground's height as a float32: beyond its range it overflowed (a warning, then
    an infinite plane)."""
    with pytest.raises(ValueError, match="ground must be a finite height within float32's range"):
        pyshadow.Scene(ground=ground)
    assert pyshadow.Scene(ground=3e38).ground == 3e38

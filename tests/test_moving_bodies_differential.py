"""A scene of moving rigid bodies answers as a scene built afresh with the same instances and poses.

The queries keep tables derived from the scene (``scene_arrays``, the instance rows, tree and grid) until
``Scene.add`` or ``Scene.set_transform`` changes it; these tests compare a scene moved through a sequence
of poses with a fresh one (the same CSM objects), bit for bit, and cover the ways a scene's kept state went
stale: a shallow copy moved on its own, and a receiver's mesh changed in place.
"""
import copy

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.csm import CoherentShadowMap

tt = trimesh.transformations
VIEWS = pyshadow.ViewSet.zigzag(4, 8)
# the box sits on the ground at x = 0: a ray from (3, 0.5, 0) towards -x meets it
POINT, DIRECTION = np.array([[3.0, 0.5, 0.0]]), np.array([[-1.0, 0.0, 0.0]])


@pytest.fixture(scope="module")
def parts():
    meshes = {"box": trimesh.creation.box((1.0, 1.0, 1.0)), "ball": trimesh.creation.icosphere(1, 0.7)}
    return meshes, {k: CoherentShadowMap.build(m, VIEWS, resolution=16, progress=False) for k, m in meshes.items()}


def _fresh(scene):
    """A scene built afresh with ``scene``'s ground, instances and poses (its CSM objects reused)."""
    other = pyshadow.Scene(ground=scene.ground, views=VIEWS, resolution=16)
    for inst in scene.instances:
        if inst.casts:
            other.add(inst.csm, inst.transform.copy(), mesh=inst.mesh)
        else:
            other.add(inst.mesh, inst.transform.copy(), casts=False)
    return other


def _answers(scene, points, directions, ground_points):
    sampling = pyshadow.Sampling(16)
    gid = pyshadow.scene.GROUND_ID if scene.ground is not None else -1
    out = {}
    for backend in ("csm", "csm-vote", "numpy"):
        out["visible " + backend] = scene.visible(points, directions, backend=backend)
        out["ao " + backend] = scene.ambient_occlusion(ground_points + [0.0, scene.ground or 0.0, 0.0],
                                                       np.tile([0.0, 1.0, 0.0], (len(ground_points), 1)),
                                                       sampling=sampling, backend=backend, surface_ids=gid)
    return out


def test_moves_far_and_back_quarter_turns_scales_and_ground_changes_answer_as_a_fresh_scene(parts):
    """Every answer after each step of a sequence of moves equals, bit for bit, that of a scene built afresh
    (held tables, anchors and compiled variants follow the scene; none is stale)."""
    meshes, csms = parts
    rng = np.random.default_rng(1)
    points = rng.uniform([-4.0, 0.01, -4.0], [4.0, 3.0, 4.0], (200, 3))
    directions = rng.normal(size=(200, 3))
    ground_points = np.c_[rng.uniform(-3, 3, 60), np.zeros(60), rng.uniform(-3, 3, 60)]
    scene = pyshadow.Scene(ground=0.0, views=VIEWS, resolution=16)
    scene.add(csms["box"], tt.translation_matrix([0.0, 0.5, 0.0]), mesh=meshes["box"])
    scene.add(csms["ball"], tt.translation_matrix([2.0, 1.0, 0.0]) @ tt.scale_matrix(1.5), mesh=meshes["ball"])
    scene.add(meshes["box"], tt.translation_matrix([-2.0, 0.5, 0.0]), casts=False)
    scene.add(csms["box"], tt.translation_matrix([0.0, 0.25, 2.0]) @ tt.scale_matrix(0.5), mesh=meshes["box"])
    first = _answers(scene, points, directions, ground_points)
    steps = [lambda: scene.set_transform(0, tt.translation_matrix([1e6, 0.5, 0.0])),
             lambda: scene.set_transform(0, tt.translation_matrix([0.0, 0.5, 0.0])),
             lambda: scene.set_transform(1, tt.translation_matrix([1.0, 1.0, 1.0]) @ tt.rotation_matrix(
                 np.pi / 2, [1.0, 0.0, 0.0]) @ tt.scale_matrix(2.0)),
             lambda: setattr(scene, "ground", 0.25), lambda: setattr(scene, "ground", None),
             lambda: scene.add(csms["ball"], tt.translation_matrix([-1.0, 0.35, -2.0]) @ tt.scale_matrix(0.5),
                               mesh=meshes["ball"])]
    for k, step in enumerate(steps):
        step()
        got, want = _answers(scene, points, directions, ground_points), _answers(_fresh(scene), points, directions,
                                                                                 ground_points)
        for name in want:
            assert got[name].tobytes() == want[name].tobytes(), f"step {k}: {name}"
        if k == 1:          # moved far and back: the very first answers
            assert all(got[name].tobytes() == first[name].tobytes() for name in first)


def test_a_shallow_copy_moves_and_grows_on_its_own(parts):
    """``copy.copy(scene)`` shared the instance list and the instances: ``copy.set_transform(0, ...)`` moved
    the original's box too (its transform read z = 10), and the original's kept tables, its version unchanged,
    went on answering from the old place: the CSM kernel said the ray was blocked (False) while the NumPy
    mirror and Embree, reading the moved instance, said free (True). ``copy.add`` added to the original."""
    meshes, csms = parts
    scene = pyshadow.Scene(ground=0.0, views=VIEWS, resolution=16)
    scene.add(csms["box"], tt.translation_matrix([0.0, 0.5, 0.0]), mesh=meshes["box"])
    assert scene.visible(POINT, DIRECTION).tolist() == [False]
    other = copy.copy(scene)
    other.set_transform(0, tt.translation_matrix([0.0, 0.5, 10.0]))
    for backend in ("csm", "numpy", "embree"):
        assert scene.visible(POINT, DIRECTION, backend=backend).tolist() == [False], backend
        assert other.visible(POINT, DIRECTION, backend=backend).tolist() == [True], backend
    assert scene.transform(0)[:3, 3].tolist() == [0.0, 0.5, 0.0]
    assert other.instances[0].csm is scene.instances[0].csm             # the CSM and mesh are shared
    other.add(meshes["box"], tt.translation_matrix([5.0, 0.5, 0.0]), casts=False)
    assert (len(scene.instances), len(other.instances)) == (1, 2)
    with pytest.raises(AttributeError, match="read-only"):
        other.instances[0].casts = False


def test_vertex_ao_follows_a_receiver_mesh_changed_in_place(parts):
    """A receiver's mesh turned in place (``mesh.apply_transform``) after a ``vertex_ao``: its vertex normals
    were a copy kept with the instance, so the AO of the moved vertices was asked along the old normals
    (all 8 vertices of a box differed from a fresh scene's, by up to 0.31; the normals by 0.58)."""
    meshes, csms = parts
    receiver = trimesh.creation.box((1.0, 1.0, 1.0))

    def build():
        scene = pyshadow.Scene(ground=0.0, views=VIEWS, resolution=16)
        scene.add(csms["box"], tt.translation_matrix([0.0, 0.5, 0.0]), mesh=meshes["box"])
        scene.add(receiver, tt.translation_matrix([2.0, 0.0, 0.0]), casts=False)
        return scene

    scene = build()
    scene.vertex_ao(1, sampling=pyshadow.Sampling(16))
    before = scene.vertex_points(1)[1]
    receiver.apply_transform(tt.rotation_matrix(np.pi / 4, [0.0, 0.0, 1.0]) @ tt.translation_matrix([0.0, 0.5, 0.0]))
    fresh = build()
    got_p, got_n = scene.vertex_points(1)
    want_p, want_n = fresh.vertex_points(1)
    np.testing.assert_array_equal(got_p, want_p)
    np.testing.assert_array_equal(got_n, want_n)
    assert np.abs(got_n - before).max() > 0.5            # turned by 45 degrees: the normals turned with it
    np.testing.assert_array_equal(scene.vertex_ao(1, sampling=pyshadow.Sampling(16)),
                                  fresh.vertex_ao(1, sampling=pyshadow.Sampling(16)))


@pytest.mark.parametrize("placed", ["mesh", "csm"])
def test_a_caster_mesh_changed_in_place_is_refused_by_name(parts, placed):
    """A caster's mesh moved in place (``mesh.apply_translation``) after ``Scene.add``: Embree followed the
    changed mesh (the ray at y = 2 blocked: False) while the CSM kernel answered for the mesh as it was
    (free: True), with no error. Now the kernels, the NumPy mirror and Embree refuse the scene, naming the
    instance; an unchanged scene, also pickled or copied, answers as before."""
    meshes, csms = parts
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    scene = pyshadow.Scene(ground=0.0, views=VIEWS, resolution=16)
    scene.add(meshes["ball"], tt.translation_matrix([0.0, 0.7, 5.0]), casts=False)
    if placed == "mesh":
        scene.add(box, tt.translation_matrix([0.0, 0.5, 0.0]))
    else:
        scene.add(csms["box"], tt.translation_matrix([0.0, 0.5, 0.0]), mesh=box)
    high = POINT + [0.0, 1.5, 0.0]
    for other in (scene, copy.deepcopy(scene)):
        assert [other.visible(high, DIRECTION, backend=b).tolist() for b in ("csm", "embree")] == [[True]] * 2
        assert other.visible(POINT, DIRECTION).tolist() == [False]
    box.apply_translation([0.0, 1.5, 0.0])
    for backend in ("csm", "csm-vote", "numpy", "embree"):
        with pytest.raises(ValueError, match="mesh of instance 1 was changed in place after Scene.add"):
            scene.visible(high, DIRECTION, backend=backend)
    with pytest.raises(ValueError, match="instance 1 was changed in place"):
        scene.ambient_occlusion(POINT, DIRECTION, sampling=pyshadow.Sampling(8))


def test_a_csm_built_by_add_is_reused_for_its_own_mesh_only():
    """Was: Scene.add kept the CSMs it built by ``id(mesh)`` alone. In a deep copy (or an unpickled scene) the keys
    are the original meshes' ids, which a new mesh may take once the original is freed: add() would then give the
    new mesh the old mesh's CSM. Now an entry answers only for the geometry it was built of (keyed by the mesh's
    hash: no id to take over; a copy's meshes freed and a new mesh added below); the same mesh added twice
    still shares one CSM."""
    import copy
    import gc

    first = pyshadow.Scene(ground=None, views=VIEWS, resolution=16)
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    first.add(box)
    first.add(box, tt.translation_matrix([3.0, 0.0, 0.0]))
    scene = copy.deepcopy(first)
    del first, box
    gc.collect()                                            # the original meshes' ids are free to take
    assert scene.instances[0].csm is scene.instances[1].csm
    ball = trimesh.creation.icosphere(1, radius=2.0)
    scene.add(ball)
    assert scene.instances[2].csm is not scene.instances[0].csm
    assert scene.instances[2].csm.mesh_hash == pyshadow.mesh.mesh_hash(ball)

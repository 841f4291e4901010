"""Scene.add with no transforms (an empty list places the object no times, as a (0, 4, 4) stack does and
as Scene.set_transform([], []) moves none), and removing an object (a scene has none: its message says how)."""
import numpy as np
import pytest
import trimesh

import pyshadow


@pytest.mark.parametrize("empty", [[], (), np.array([]), [T for T in ()]], ids=["list", "tuple", "array", "comp"])
def test_an_empty_list_of_poses_places_nothing_and_the_scene_answers_as_before(box_csm, empty):
    """Was: ``Scene.add(obj, [])`` (a level without this object: ``[pose(p) for p in positions]``) raised
    "transform must be a 4x4 matrix, got shape (0,)", while ``np.zeros((0, 4, 4))`` returned no ids and
    ``Scene.set_transform([], [])`` moved none."""
    box, csm = box_csm
    scene = pyshadow.Scene(ground=0.0)
    first = scene.add(csm, trimesh.transformations.translation_matrix([0.0, 0.15, 0.0]), mesh=box)
    p, d = [[0.0, 0.5, 0.0], [2.0, 0.5, 0.0]], [[0.0, -1.0, 0.0], [0.0, -1.0, 0.0]]
    before = scene.visible(p, d)
    ids = scene.add(csm, empty, mesh=box)
    assert isinstance(ids, np.ndarray) and ids.dtype == np.int64 and ids.shape == (0,)
    assert len(scene.instances) == 1 and first == 0
    assert np.array_equal(scene.visible(p, d), before) and before.tolist() == [False, False]
    # a receiver and a mesh caster: nothing placed, no CSM built
    ball = trimesh.creation.icosphere(1, radius=0.2)
    assert scene.add(ball, empty, casts=False).shape == (0,)
    assert scene.add(ball, empty).shape == (0,)
    assert len(scene.instances) == 1 and scene.caster_types()[0] == [csm]
    # the next add still gets the next id
    assert scene.add(csm, trimesh.transformations.translation_matrix([2.0, 0.15, 0.0]), mesh=box) == 1


def test_an_empty_list_is_not_a_malformed_transform(box_csm):
    """Was: as above; a transform of another shape is still refused, naming its shape."""
    box, csm = box_csm
    scene = pyshadow.Scene()
    with pytest.raises(ValueError, match=r"shape \(3,\)"):
        scene.add(csm, [1.0, 2.0, 3.0], mesh=box)
    with pytest.raises(ValueError, match="4x4"):
        scene.add(csm, np.eye(3), mesh=box)
    assert scene.add(csm, [], mesh=box).shape == (0,) and not scene.instances


def test_removing_an_instance_says_how_and_the_advice_answers_as_a_scene_built_without_it(box_csm):
    """Was: ``del scene.instances[i]`` and ``scene.instances.pop(i)`` said the list is read-only, that add places
    and set_transform moves, but not how to remove an object (a scene has no removal). Following the
    advice, the new scene answers bit for bit as one built without the object, its CSM not rebuilt."""
    box, csm = box_csm
    floor = trimesh.creation.box((4.0, 0.1, 4.0))
    rng = np.random.default_rng(2)
    scene = pyshadow.Scene(ground=0.0)
    poses = [trimesh.transformations.translation_matrix([x, 0.15, 0.0]) for x in (-0.6, 0.0, 0.6)]
    poses[1] = poses[1] @ trimesh.transformations.rotation_matrix(np.pi, [1.0, 0.0, 0.0])
    scene.add(floor, trimesh.transformations.translation_matrix([0.0, -0.05, 0.0]), casts=False)
    for T in poses:
        scene.add(csm, T, mesh=box)
    scene.set_transform(3, trimesh.transformations.translation_matrix([0.6, 0.15, 0.3]))
    for remove in (lambda: scene.instances.pop(2), lambda: scene.instances.__delitem__(2)):
        with pytest.raises(TypeError, match=r"Scene\.remove takes one out"):
            remove()
    new = pyshadow.Scene(ground=0.0)
    for i, inst in enumerate(scene.instances):
        if i == 2:
            continue
        if inst.casts:
            new.add(inst.csm, inst.transform, mesh=inst.mesh)
        else:
            new.add(inst.mesh, inst.transform, casts=False)
    built = pyshadow.Scene(ground=0.0)
    built.add(floor, trimesh.transformations.translation_matrix([0.0, -0.05, 0.0]), casts=False)
    built.add(csm, poses[0], mesh=box)
    built.add(csm, trimesh.transformations.translation_matrix([0.6, 0.15, 0.3]), mesh=box)
    assert all(n.csm is b.csm for n, b in zip(new.instances, built.instances))
    p = rng.uniform([-1.0, 0.0, -1.0], [1.0, 0.6, 1.0], (400, 3))
    nrm = rng.normal(size=(400, 3))
    assert np.array_equal(new.ambient_occlusion(p, nrm), built.ambient_occlusion(p, nrm))
    assert np.array_equal(new.vertex_ao(1), built.vertex_ao(1))

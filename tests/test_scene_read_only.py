"""A scene's instance list and its instances' fields are read-only once placed.

The queries keep tables derived from ``Scene.instances`` (``scene_arrays``: the stacked transforms, the
spheres, the caster types, the grid) until ``Scene.add`` or ``Scene.set_transform`` advances the scene's
version. Before, a list edit or a replaced field left them stale: after one query, swapping two
instances, deleting one and adding another, or setting ``inst.casts = False`` answered for the old
scene. Each test below failed on the code before (no error, stale answers).
"""
import copy
import pickle

import numpy as np
import pytest
import trimesh

import pyshadow

# the box sits on the ground at x = 0: a ray from (3, 0.5, 0) towards -x meets it, one from (-3, 0.5, 0) does not
POINTS = np.array([[3.0, 0.5, 0.0], [-3.0, 0.5, 0.0]])
DIRECTIONS = np.array([[-1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])


def _two_boxes():
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    scene.add(box, trimesh.transformations.translation_matrix([0.0, 0.5, 0.0]))
    scene.add(box, trimesh.transformations.translation_matrix([0.0, 0.5, 20.0]), casts=False)
    return scene


@pytest.mark.parametrize("edit", ["swap", "delete", "append", "pop", "insert", "clear", "sort", "reverse",
                                  "extend", "remove", "iadd", "imul", "slice"])
def test_every_list_edit_is_refused_and_the_answers_stay(edit):
    """``scene.instances[0], scene.instances[1] = scene.instances[1], scene.instances[0]`` after a query
    answered the rays with the box still a caster (the kept tables); ``del scene.instances[0]`` left the
    grid listing a caster that was gone. Every mutator of the list now raises and changes nothing."""
    scene = _two_boxes()
    before = scene.visible(POINTS, DIRECTIONS)
    assert before.tolist() == [False, True]                      # the box blocks the first ray only
    ins = scene.instances
    first, second = ins[0], ins[1]
    edits = {
        "swap": lambda: ins.__setitem__(0, second),
        "delete": lambda: ins.__delitem__(0),
        "append": lambda: ins.append(first),
        "pop": lambda: ins.pop(),
        "insert": lambda: ins.insert(0, second),
        "clear": lambda: ins.clear(),
        "sort": lambda: ins.sort(key=id),
        "reverse": lambda: ins.reverse(),
        "extend": lambda: ins.extend([first]),
        "remove": lambda: ins.remove(first),
        "iadd": lambda: ins.__iadd__([first]),
        "imul": lambda: ins.__imul__(2),
        "slice": lambda: ins.__setitem__(slice(0, 2), [second, first]),
    }
    with pytest.raises(TypeError, match="Scene.instances is read-only"):
        edits[edit]()
    assert list(scene.instances) == [first, second]
    np.testing.assert_array_equal(scene.visible(POINTS, DIRECTIONS), before)


def test_the_list_itself_cannot_be_replaced():
    """``scene.instances = []`` replaced the list under the kept tables (2 instances were still asked)."""
    scene = _two_boxes()
    with pytest.raises(AttributeError):
        scene.instances = []
    assert len(scene.instances) == 2


@pytest.mark.parametrize("name, value", [("casts", False), ("transform", np.eye(4)), ("csm", None),
                                          ("mesh", None)])
def test_an_instance_field_is_read_only_once_placed(name, value):
    """``scene.instances[0].casts = False`` after a query: the box still blocked the ray (the kept
    caster list). ``.transform = np.eye(4)`` moved it for the NumPy mirror but not for the kept tables."""
    scene = _two_boxes()
    before = scene.visible(POINTS, DIRECTIONS)
    with pytest.raises(AttributeError, match=f"Instance.{name} is read-only"):
        setattr(scene.instances[0], name, value)
    np.testing.assert_array_equal(scene.visible(POINTS, DIRECTIONS), before)
    np.testing.assert_array_equal(scene.visible(POINTS, DIRECTIONS, backend="numpy"), before)


def test_set_transform_still_moves_and_the_answers_follow():
    scene = _two_boxes()
    inst = scene.instances[0]
    scene.set_transform(0, trimesh.transformations.translation_matrix([0.0, 0.5, 10.0]))
    assert scene.instances[0] is inst                            # moved in place: a held reference sees it
    assert inst.transform[2, 3] == 10.0
    assert scene.visible(POINTS, DIRECTIONS).tolist() == [True, True]


def test_a_pickled_or_copied_scene_answers_as_the_original_and_stays_read_only():
    """The read-only list must survive pickling (process pools, Dask) and copying: a list subclass is
    rebuilt through append/extend by default, which it refuses."""
    scene = _two_boxes()
    rays = np.random.default_rng(3).normal(size=(500, 3))
    pts = np.random.default_rng(4).uniform(-3, 3, (500, 3)) + [0.0, 3.5, 0.0]
    want = scene.visible(pts, rays)
    for other in (pickle.loads(pickle.dumps(scene)), copy.deepcopy(scene), copy.copy(scene)):
        assert type(other.instances) is type(scene.instances) and len(other.instances) == 2
        np.testing.assert_array_equal(other.visible(pts, rays), want)
        with pytest.raises(TypeError, match="read-only"):
            other.instances.append(other.instances[0])
        with pytest.raises(AttributeError, match="read-only"):
            other.instances[1].casts = True
    assert scene.instances == [scene.instances[0], scene.instances[1]]      # still equal to a plain list


def test_instances_compare_and_hash_by_identity():
    """Instances compared field by field: ``a == b`` raised NumPy's "truth value of an array is
    ambiguous" for two instances of one mesh at one place, and ``hash(inst)`` was refused."""
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    scene.add(box)
    scene.add(box)
    a, b = scene.instances
    assert a == a and a != b and not (a == b)
    assert len({a, b, a}) == 2
    assert scene.instances.index(b) == 1

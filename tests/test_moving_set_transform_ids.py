"""Scene.set_transform's instance ids as a user passes them: one id in any integer form, or none at all.

The one-id form asked only whether the id was a Python or NumPy int: a 0-d integer array was refused as
"no instance array(2)", and a set or an iterator of ids as one id out of range.
"""
import numpy as np
import pytest
import trimesh

from test_scene_moves import _scene

tt = trimesh.transformations


UP = tt.translation_matrix([0.0, 1.0, 0.0])


def test_a_0d_integer_array_id_moves_that_instance(box_csm):
    """Was: ``set_transform(np.array(2), T)`` (an id picked as ``ids[k, ...]`` or ``np.asarray(2)``) raised
    IndexError "no instance array(2) (the scene has 4)" although instance 2 exists."""
    scene = _scene(box_csm, 4)
    for k, one in enumerate([np.array(2), np.array(1, np.uint8), np.int16(3)]):
        version = scene._version
        scene.set_transform(one, UP @ tt.translation_matrix([0.0, 0.0, k]))
        assert np.array_equal(scene.transform(int(one)), UP @ tt.translation_matrix([0.0, 0.0, k]))
        assert scene._version == version + 1


@pytest.mark.parametrize("bad", [{1, 2}, frozenset({3}), (i for i in [1, 2]), iter([0, 1]), {1: UP}.keys()])
def test_a_set_or_an_iterator_of_ids_is_a_type_error_and_moves_nothing(box_csm, bad):
    """Was: a set, a generator or another iterator of ids (NumPy reads them as one object) raised
    IndexError "no instance {1, 2} (the scene has 4)", as if one id were out of range."""
    scene = _scene(box_csm, 4)
    before = [inst.transform.copy() for inst in scene.instances]
    with pytest.raises(TypeError, match=r"a 1-D sequence of ints \(a list, tuple, range or array\)"):
        scene.set_transform(bad, np.stack([UP, UP]))
    assert all(np.array_equal(inst.transform, t) for inst, t in zip(scene.instances, before))


def test_no_ids_given_as_two_empty_lists_moves_nothing(box_csm):
    """Was: a frame that moves no body, its ids and poses gathered in lists (``set_transform([], [])``),
    raised ValueError "transforms must have shape (0, 4, 4) for 0 instance ids, got (0,)"."""
    scene = _scene(box_csm, 4)
    version = scene._version
    scene.set_transform([], [])
    scene.set_transform(np.zeros(0, np.int32), np.zeros((0, 4, 4)))
    assert scene._version == version
    with pytest.raises(ValueError, match=r"shape \(0, 4, 4\)"):
        scene.set_transform([], np.zeros((1, 4, 4)))


def test_a_fortran_ordered_stack_is_held_as_contiguous_rows(box_csm):
    """Was: a Fortran-ordered (k, 4, 4) stack was held as strided views (``c_contiguous`` False), unlike
    every other transform the scene holds; the values were the same."""
    scene = _scene(box_csm, 4)
    T = np.stack([UP @ tt.translation_matrix([0.5 * k, 0.0, 0.0]) for k in range(3)])
    scene.set_transform([3, 0, 2], np.asfortranarray(T))
    for k, i in enumerate([3, 0, 2]):
        held = scene.instances[i].transform
        assert held.flags.c_contiguous and not held.flags.writeable
        assert np.array_equal(held, T[k])

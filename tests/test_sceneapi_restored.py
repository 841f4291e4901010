"""A scene restored by pickle or ``copy.deepcopy`` keeps its placed transforms read-only, as the original.

The queries keep tables derived from each instance's transform until ``Scene.set_transform``; an edit in
place of the held array is refused so that they cannot answer from the old place.
"""
import copy
import pickle

import numpy as np
import pytest
import trimesh

import pyshadow

tt = trimesh.transformations
POINT = np.array([[3.0, 0.5, 0.0]])
LEFT = np.array([[-1.0, 0.0, 0.0]])


def _scene(x):
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), tt.translation_matrix([x, 0.5, 0.0]))
    return scene


@pytest.mark.parametrize("restore", [copy.deepcopy, lambda s: pickle.loads(pickle.dumps(s))],
                         ids=["deepcopy", "pickle"])
def test_a_restored_scene_refuses_an_edit_in_place_of_a_placed_transform(restore):
    """Was: the restored transform was writeable (pickle and deepcopy drop NumPy's read-only flag), so
    ``inst.transform[0, 3] = 10`` after a query was taken silently: the CSM backend went on answering from
    the kept tables (the ray from (3, 0.5, 0) towards -x still blocked: visible False) while Embree and a
    fresh scene with the box at x = 10 said visible True. Now the edit raises, as on the original scene."""
    scene = restore(_scene(0.0))
    assert not scene.visible(POINT, LEFT)[0]
    held = scene.instances[0].transform
    assert not held.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        held[0, 3] = 10.0
    np.testing.assert_array_equal(held, tt.translation_matrix([0.0, 0.5, 0.0]))
    scene.set_transform(0, tt.translation_matrix([10.0, 0.5, 0.0]))        # the way to move it still works
    assert scene.visible(POINT, LEFT)[0] == _scene(10.0).visible(POINT, LEFT)[0] == True    # noqa: E712
    assert not scene.instances[0].transform.flags.writeable


@pytest.mark.parametrize("height", [np.nan, np.inf, -np.inf, 1e40])
def test_a_ground_set_later_is_checked_as_the_constructor_checks_it(height):
    """Was: ``Scene(ground=nan)`` was refused but ``scene.ground = nan`` was taken: the plane was then dropped
    silently (a ray from (3, 1, 0) straight down: visible True from the CSM kernel and Embree, where the
    scene before said False); 1e40 overflowed float32 in the kernels (RuntimeWarning) and made the plane an
    infinitely high one (an upward ray blocked). Now it raises, and the scene keeps its ground."""
    scene = _scene(0.0)
    down = np.array([[0.0, -1.0, 0.0]])
    with pytest.raises(ValueError, match="ground must be a finite height"):
        pyshadow.Scene(ground=height)
    with pytest.raises(ValueError, match="ground must be a finite height"):
        scene.ground = height
    assert scene.ground == 0.0
    assert scene.visible(np.array([[3.0, 1.0, 0.0]]), down).tolist() == [False]


def test_a_ground_set_later_answers_as_a_fresh_scene_and_is_a_float():
    """Was: a height set later was held as given (``np.float32(0.25)`` stayed a float32, where the constructor
    holds a float). Now it is held as the constructor holds it (a float, or None); the queries follow it."""
    scene = _scene(0.0)
    points, up = np.array([[3.0, 0.1, 0.0]]), np.array([[0.0, 1.0, 0.0]])
    assert scene.visible(points, up).tolist() == [True]
    scene.ground = np.float32(0.25)
    assert type(scene.ground) is float and scene.ground == 0.25
    assert scene.visible(points, up).tolist() == [False]          # below the raised plane
    scene.ground = None
    assert scene.ground is None and scene.visible(points, up).tolist() == [True]
    assert copy.copy(scene).ground is None and pickle.loads(pickle.dumps(scene)).ground is None

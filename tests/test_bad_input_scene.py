"""Bad and extreme input to the Scene helpers, the "embree" backend and scene_arrays: refused with a
message naming the argument, never answered silently or with an unrelated error."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling
from pyshadow.scene_arrays import anchor_groups, points_bound


@pytest.fixture(scope="module")
def scene():
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    s = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    s.add(box, trimesh.transformations.translation_matrix([0.0, 0.5, 0.0]))
    s.add(trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix([3.0, 0.5, 0.0]),
          casts=False)
    return s


_P = np.array([[2.0, 0.2, 0.0], [0.0, 1.5, 0.0]])
_UP = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
_BAD_IDS = [(99, ValueError, "surface_ids"), (-3, ValueError, "surface_ids"),
            (np.array([0.5, 1.0]), TypeError, "surface_ids"), ([0, 1, 0], ValueError, "surface_ids"),
            (True, TypeError, "surface_ids")]


@pytest.mark.parametrize("ids, error, word", _BAD_IDS)
def test_embree_backend_refuses_bad_surface_ids_as_the_others_do(scene, ids, error, word):
    """Before: the "embree" backend ignored ``surface_ids`` unchecked, so an id out of range (99, -3),
    float or bool ids or a wrong count were answered silently, where "csm" and "numpy" raise."""
    for backend in ("numpy", "embree"):
        with pytest.raises(error, match=word):
            scene.visible(_P, _UP, backend=backend, surface_ids=ids)
        with pytest.raises(error, match=word):
            scene.ambient_occlusion(_P, _UP, backend=backend, surface_ids=ids, sampling=Sampling(4))


@pytest.mark.parametrize("normals, match", [(np.zeros((2, 3)), "zero"), (np.full((2, 3), np.nan), "finite"),
                                            (np.ones((3, 3)), "rows")])
def test_embree_backend_refuses_bad_normals_in_visible(scene, normals, match):
    """Before: ``visible(..., normals=)`` on the "embree" backend accepted zero, NaN or mis-shaped normals
    silently (the other backends raise)."""
    for backend in ("numpy", "embree"):
        with pytest.raises(ValueError, match=match):
            scene.visible(_P, _UP, backend=backend, normals=normals)


def test_embree_backend_still_answers_with_valid_ids_and_normals(scene):
    plain = scene.visible(_P, _UP, backend="embree")
    np.testing.assert_array_equal(scene.visible(_P, _UP, backend="embree", surface_ids=[1, -1], normals=_UP), plain)
    np.testing.assert_array_equal(scene.visible(_P, _UP, backend="embree", surface_ids=np.int64(-2)), plain)


def test_points_bound_of_no_points_is_zero():
    """Before: ``points_bound`` of an empty (0, 3) array raised numpy's unrelated 'zero-size array to
    reduction operation maximum which has no identity'."""
    assert points_bound(np.zeros((0, 3))) == 0.0
    assert points_bound(np.array([[-2.0, 1.0, 0.5]])) == 2.0


def test_anchor_of_an_empty_scene_takes_any_point_array():
    """Before: ``Scene().anchor([[1, 2, 3]])`` (a list) raised "AttributeError: 'list' object has no
    attribute 'mean'", and a 1-D array gave a scalar anchor instead of a (3,) point."""
    s = pyshadow.Scene()
    np.testing.assert_array_equal(s.anchor([[1.0, 2.0, 3.0], [3.0, 2.0, 1.0]]), [2.0, 2.0, 2.0])
    np.testing.assert_array_equal(s.anchor(np.zeros((0, 3))), np.zeros(3))
    with pytest.raises(ValueError, match="points"):
        s.anchor(np.array([1.0, 2.0, 3.0]))


@pytest.mark.parametrize("bad", [-1, -2, 2, 10 ** 30, 1.0, True, np.int64(-1), np.float64(0.0),
                                 np.uint64(2 ** 64 - 1)])
def test_instance_ids_out_of_range_or_not_integers_are_refused(scene, bad):
    """Guard: -1 must not wrap to the last instance; floats and bools are not ids (a TypeError naming what an id
    is, as a list's index; was IndexError 'no instance 1.0')."""
    integer = isinstance(bad, (int, np.integer)) and not isinstance(bad, bool)
    for call in (scene.transform, scene.vertex_points, scene.vertex_ao,
                 lambda i: scene.set_transform(i, np.eye(4))):
        with pytest.raises(IndexError if integer else TypeError,
                           match="no instance" if integer else "an instance id is an int .*got"):
            call(bad)


def test_anchor_groups_of_extreme_points(scene):
    """Guard: empty points give one group; points spread over 1e-6..1e30 each find an anchor within reach."""
    assert [(r, tuple(a)) for r, a in anchor_groups(scene, np.zeros((0, 3)))] == [(None, tuple(scene.anchor()))]
    p = np.array([[1e-6, 0.0, 0.0], [1e3, 0.0, 0.0], [1e10, 0.0, 0.0], [1e30, 0.0, 0.0]])
    groups = anchor_groups(scene, p)
    rows = np.sort(np.concatenate([np.arange(len(p)) if r is None else r for r, _ in groups]))
    np.testing.assert_array_equal(rows, np.arange(4))
    # within reach (pyshadow.anchor_reach): 512 radii of the caster, or its distance to the caster's sphere
    c, radius = scene.instances[0].world_sphere()
    reach = np.maximum(512 * radius, np.linalg.norm(p - c, axis=1) - radius)
    for r, a in groups:
        r = np.arange(len(p)) if r is None else r
        assert (np.abs(p[r] - a).max(axis=1) <= reach[r]).all()

"""Moving many instances at once: Scene.set_transform(ids, transforms) and check_transforms.

The bulk form must hold exactly what one call per instance holds (the same
float64 matrices, bit for bit, including those replaced by their nearest
rotation), answer queries identically, and on any bad transform move nothing.
"""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow._validate import check_transform, check_transforms


def _poses(k, seed=3):
    """k rigid transforms: random rotations, scales 1e-3..1e4, translations to 1e4; every third
    rounded to 5 decimals (off a rotation by ~1e-5: the nearest-rotation path), some float32."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(k, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    w, x, y, z = q.T
    R = np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
                  2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                  2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=1).reshape(k, 3, 3)
    s = 10.0 ** rng.uniform(-3, 4, k)
    T = np.zeros((k, 4, 4))
    T[:, :3, :3] = R * s[:, None, None]
    T[:, :3, 3] = rng.normal(0, 1e4, (k, 3))
    T[:, 3, 3] = 1.0
    T[::3, :3, :3] = np.round(T[::3, :3, :3] / s[::3, None, None], 5) * s[::3, None, None]
    T[1::5] = T[1::5].astype(np.float32)
    return T


def test_check_transforms_is_check_transform_matrix_by_matrix():
    T = _poses(3000)
    one = np.stack([check_transform(t, rigid=True) for t in T])
    assert np.array_equal(check_transforms(T, rigid=True).view(np.uint64), one.view(np.uint64))
    assert not np.array_equal(one, T)           # the rounded ones were replaced (the other path was taken)
    nr = T.reshape(30, 100, 4, 4)
    assert np.array_equal(check_transforms(nr, rigid=True).reshape(-1, 4, 4), one)
    # a stack in another order (frames and bodies swapped): each matrix as one at a time, in place
    sw = np.swapaxes(nr, 0, 1)
    assert np.array_equal(check_transforms(sw, rigid=True), np.swapaxes(one.reshape(30, 100, 4, 4), 0, 1))


@pytest.mark.parametrize("bad, message", [
    (lambda t: t.__setitem__((0, 0), np.nan), "non-finite"),
    (lambda t: t.__setitem__((3, 0), 1e-6), "affine"),
    (lambda t: t.__setitem__((slice(0, 3), 0), 0.0), "singular"),
    (lambda t: t.__setitem__((slice(0, 3), 0), -t[:3, 0]), "mirrors"),
    (lambda t: t.__setitem__((0, 1), t[0, 1] + 0.01 * abs(t[:3, :3]).max()), "not rigid"),
])
def test_check_transforms_raises_check_transforms_error_naming_the_matrix(bad, message):
    T = _poses(50)
    bad(T[37])
    with pytest.raises(ValueError, match=message) as err:
        check_transforms(T, rigid=True, name="poses")
    assert "poses[37]" in str(err.value)
    with pytest.raises(ValueError, match=message):
        check_transform(T[37], rigid=True)      # the same rule one at a time


def _scene(box_csm, n=40):
    box, csm = box_csm
    s = pyshadow.Scene(ground=0.0)
    for i in range(n):
        s.add(csm, trimesh.transformations.translation_matrix([i % 8, 0.15, i // 8]), mesh=box)
    return s


def _turned(n, seed=1):
    rng = np.random.default_rng(seed)
    T = np.zeros((n, 4, 4))
    for i in range(n):
        T[i] = trimesh.transformations.rotation_matrix(rng.uniform(0, 6.3), [0, 1, 0])
        T[i, :3, 3] = [(i % 8) + rng.uniform(-0.2, 0.2), 0.15 + rng.uniform(0, 0.05), i // 8]
    T[::4, :3, :3] = np.round(T[::4, :3, :3], 5)
    return T


def test_moving_many_at_once_holds_and_answers_as_one_at_a_time(box_csm):
    a, b = _scene(box_csm), _scene(box_csm)
    ids = np.arange(3, 40, 2)
    T = _turned(40)[ids]
    for i, t in zip(ids, T):
        a.set_transform(int(i), t)
    b.set_transform(ids, T)
    assert all(np.array_equal(x.transform, y.transform) for x, y in zip(a.instances, b.instances))
    assert not b.instances[5].transform.flags.writeable
    rng = np.random.default_rng(2)
    p = np.c_[rng.uniform(-1, 9, 500), np.zeros(500), rng.uniform(-1, 6, 500)]
    up = np.tile([0.0, 1.0, 0.0], (500, 1))
    ao_a = a.ambient_occlusion(p, up, sampling=pyshadow.Sampling(16))
    ao_b = b.ambient_occlusion(p, up, sampling=pyshadow.Sampling(16))
    assert np.array_equal(ao_a, ao_b)
    # the move took effect: the boxes turned and shifted, so the ground's AO changed
    assert not np.array_equal(ao_b, _scene(box_csm).ambient_occlusion(p, up, sampling=pyshadow.Sampling(16)))


def test_a_bad_transform_moves_nothing(box_csm):
    s = _scene(box_csm)
    before = [x.transform.copy() for x in s.instances]
    version = s._version
    T = _turned(40)
    T[17, 0, 0] = np.inf
    with pytest.raises(ValueError, match=r"transforms\[17\] \(instance 17\) has non-finite"):
        s.set_transform(np.arange(40), T)
    T = _turned(40)
    T[9, :3, 0] *= 2.0                          # non-uniform scale
    with pytest.raises(ValueError, match=r"transforms\[4\] \(instance 9\) is not rigid"):
        s.set_transform(np.arange(5, 15), T[5:15])
    assert s._version == version
    assert all(np.array_equal(x.transform, y) for x, y in zip(s.instances, before))


@pytest.mark.parametrize("ids, shape, error, match", [
    ([1, 2, 40], (3, 4, 4), IndexError, "no instance 40"),
    ([1, -1], (2, 4, 4), IndexError, "no instance -1"),
    ([1, 2, 1], (3, 4, 4), ValueError, "instance 1 is given more than once"),
    ([1, 2], (3, 4, 4), ValueError, r"shape \(2, 4, 4\)"),
    ([1, 2], (4, 4), ValueError, r"shape \(2, 4, 4\)"),
    ([[1, 2]], (2, 4, 4), TypeError, "1-D sequence of ints"),
    ([1.0, 2.0], (2, 4, 4), TypeError, "1-D sequence of ints"),
    ([True, False], (2, 4, 4), TypeError, "1-D sequence of ints"),
])
def test_bad_ids_and_shapes_are_named(box_csm, ids, shape, error, match):
    s = _scene(box_csm)
    T = np.broadcast_to(np.eye(4), shape).copy()
    with pytest.raises(error, match=match):
        s.set_transform(ids, T)


def test_no_ids_is_no_change(box_csm):
    s = _scene(box_csm)
    version = s._version
    s.set_transform([], np.zeros((0, 4, 4)))
    assert s._version == version


def test_adding_a_stack_places_the_object_k_times_as_k_adds(box_csm):
    box, csm = box_csm
    T = _turned(40)
    one, many = pyshadow.Scene(ground=0.0), pyshadow.Scene(ground=0.0)
    ids_one = [one.add(csm, t, mesh=box) for t in T]
    ids = many.add(csm, T, mesh=box)
    assert ids.dtype == np.int64 and ids.tolist() == ids_one
    assert all(np.array_equal(a.transform, b.transform) for a, b in zip(one.instances, many.instances))
    assert all(b.csm is csm and b.mesh is box for b in many.instances)
    floor = trimesh.creation.box((2.0, 0.1, 2.0))           # receivers: one mesh placed twice
    F = np.stack([trimesh.transformations.translation_matrix([x, -0.05, 0.0]) for x in (0.0, 2.0)])
    assert one.add(floor, F[0], casts=False) == 40 and one.add(floor, F[1], casts=False) == 41
    assert many.add(floor, F, casts=False).tolist() == [40, 41]
    (c1, r1), (c2, r2) = many.instances[41].object_sphere(), one.instances[41].object_sphere()
    assert np.array_equal(c1, c2) and r1 == r2
    assert many.instances[41]._sphere is many.instances[40]._sphere      # found once for the stack
    rng = np.random.default_rng(5)
    p = np.c_[rng.uniform(-1, 9, 400), np.zeros(400), rng.uniform(-1, 6, 400)]
    up = np.tile([0.0, 1.0, 0.0], (400, 1))
    S = pyshadow.Sampling(16)
    np.testing.assert_array_equal(one.ambient_occlusion(p, up, sampling=S), many.ambient_occlusion(p, up, sampling=S))
    mesh_scene = pyshadow.Scene(views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
    assert mesh_scene.add(box, T[:3]).tolist() == [0, 1, 2]             # a mesh: its CSM built once
    assert len({id(x.csm) for x in mesh_scene.instances}) == 1


def test_adding_a_stack_with_a_bad_transform_places_nothing(box_csm):
    box, csm = box_csm
    s = _scene(box_csm, 3)
    T = _turned(6)
    T[4, :3, 0] *= 3.0
    with pytest.raises(ValueError, match=r"transforms\[4\] is not rigid"):
        s.add(csm, T, mesh=box)
    with pytest.raises(ValueError, match="always casts"):
        s.add(csm, _turned(6), casts=False)
    assert len(s.instances) == 3
    assert s.add(csm, np.zeros((0, 4, 4))).tolist() == [] and len(s.instances) == 3

"""A scene over many edits answers as a scene built directly in its final state; bad edits are refused.

The reference of every answer here is a fresh :class:`pyshadow.Scene` built in the final state (the
same CSMs, meshes, transforms and ground), compared bit for bit.
"""
import os

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.csm import CoherentShadowMap

tt = trimesh.transformations
VIEWS = pyshadow.ViewSet.zigzag(4, 8)


@pytest.fixture(scope="module")
def box():
    mesh = trimesh.creation.box((1.0, 1.0, 1.0))
    return mesh, CoherentShadowMap.build(mesh, VIEWS, resolution=16, progress=False)


def _rays(n=200, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform([-4.0, 0.01, -4.0], [4.0, 2.5, 4.0], (n, 3)), rng.normal(size=(n, 3))


def _answers(scene):
    points, directions = _rays()
    ground = np.c_[np.linspace(-3.0, 3.0, 60), np.zeros(60), np.linspace(3.0, -2.0, 60)]
    up = np.tile([0.0, 1.0, 0.0], (60, 1))
    out = {"anchor": scene.anchor(), "scale": np.float64(scene.scale())}
    for backend in ("csm", "csm-vote", "embree"):
        out["visible " + backend] = scene.visible(points, directions, backend=backend)
        out["ao " + backend] = scene.ambient_occlusion(ground, up, sampling=pyshadow.Sampling(16), backend=backend)
    return out


def _fresh(scene):
    fresh = pyshadow.Scene(ground=scene.ground, views=VIEWS, resolution=16)
    for inst in scene.instances:
        if inst.casts:
            fresh.add(inst.csm, inst.transform.copy(), mesh=inst.mesh)
        else:
            fresh.add(inst.mesh, inst.transform.copy(), casts=False)
    return fresh


def _same(a, b):
    return {k: int(np.sum(np.asarray(a[k]) != np.asarray(b[k]))) for k in a
            if np.asarray(a[k]).tobytes() != np.asarray(b[k]).tobytes()}


def _placed(rng, far=False):
    T = tt.random_rotation_matrix(rng.random(3))
    T[:3, :3] *= rng.choice([0.5, 1.0, 2.0])
    T[:3, 3] = rng.uniform(-3.0, 3.0, 3) * [1.0, 0.3, 1.0] + [0.0, 0.6, 0.0]
    if far:
        T[:3, 3] += rng.choice([1e4, 1e5]) * rng.normal(size=3)
    return T


@pytest.mark.parametrize("seed", [3, 11])
def test_a_scene_after_adds_moves_far_trips_and_ground_changes_answers_as_one_built_there(box, seed):
    """Was: already bit for bit the same (150 random sequences of adds, stacks, receivers, moves of one and
    many, moves 1e4-1e5 away and back, the same transform again and ground on/off, queried between: 0
    answers differed); kept as a guard of the scene's kept tables (each edit must drop what it changes)."""
    mesh, csm = box
    wall = trimesh.creation.box((4.0, 2.0, 0.2))
    rng = np.random.default_rng(seed)
    scene = pyshadow.Scene(ground=0.0, views=VIEWS, resolution=16)
    scene.add(csm, _placed(rng), mesh=mesh)
    scene.add(wall, _placed(rng), casts=False)
    scene.add(csm, np.stack([_placed(rng) for _ in range(3)]), mesh=mesh)
    _answers(scene)
    scene.set_transform(2, _placed(rng))
    scene.set_transform([0, 3, 1], np.stack([_placed(rng) for _ in range(3)]))
    _answers(scene)
    back = scene.transform(4)
    scene.set_transform(4, _placed(rng, far=True))
    _answers(scene)
    scene.set_transform(4, back)
    scene.set_transform(0, scene.transform(0))
    scene.ground = None
    _answers(scene)
    scene.ground = 0.0
    scene.add(csm, _placed(rng), mesh=mesh)
    assert not _same(_answers(scene), _answers(_fresh(scene)))


@pytest.mark.parametrize("ground", [True, np.bool_(False), "0.5", b"0", np.array([0.0]), [0.0]])
def test_a_ground_that_is_no_height_is_refused_and_the_scene_answers_as_before(box, ground):
    """Was: ``Scene(ground=True)`` (meant as "with a ground plane") put the plane at y = 1, through a unit
    box resting on y = 0: the AO of a point on y = 0 beside it was 0 (with the plane at 0: 0.98); ``"0.5"``
    was read as 0.5, and ``np.array([0.0])`` raised NumPy's "only 0-dimensional arrays can be converted"."""
    mesh, csm = box
    with pytest.raises(TypeError, match="ground must be a height"):
        pyshadow.Scene(ground=ground, views=VIEWS, resolution=16)
    scene = pyshadow.Scene(ground=0.0, views=VIEWS, resolution=16)
    scene.add(csm, tt.translation_matrix([0.0, 0.5, 0.0]), mesh=mesh)
    before = _answers(scene)
    with pytest.raises(TypeError, match="ground must be a height"):
        scene.ground = ground
    assert scene.ground == 0.0
    assert not _same(_answers(scene), before)
    ao = scene.ambient_occlusion([[3.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]], sampling=pyshadow.Sampling(64))
    assert ao[0] > 0.9


def test_numbers_of_every_kind_are_still_heights():
    """Was: taken (kept so): a NumPy float32 or int height, a 0-d array, and None."""
    for g, want in ((np.float32(0.25), 0.25), (np.int64(-2), -2.0), (np.array(1.5), 1.5), (3, 3.0), (None, None)):
        assert pyshadow.Scene(ground=g).ground == want


def test_a_file_added_many_times_builds_one_csm(tmp_path):
    """Was: ``Scene.add("ico.obj", T)`` loaded a new mesh object each call and built a CSM for each (three
    adds: three CSMs, 13 s each at the default options, three caster types on the device); now the file
    loads once, its instances share one mesh and one CSM, and answer as the loaded mesh added three times,
    bit for bit. A file changed since (its content) gets its own."""
    path = tmp_path / "ico.obj"
    trimesh.creation.icosphere(1, 0.5).export(path)
    where = [tt.translation_matrix([2.0 * k - 2.0, 0.5, 0.0]) for k in range(3)]
    scene = pyshadow.Scene(ground=0.0, views=VIEWS, resolution=16)
    ids = [scene.add(path, T) for T in where[:2]] + [scene.add(str(path), where[2])]
    first = scene.instances[ids[0]]
    assert all(scene.instances[i].csm is first.csm and scene.instances[i].mesh is first.mesh for i in ids)
    assert len(scene.caster_types()[0]) == 1
    direct = pyshadow.Scene(ground=0.0, views=VIEWS, resolution=16)
    for T in where:
        direct.add(first.mesh, T)
    assert not _same(_answers(scene), _answers(direct))
    receiver = scene.add(path, tt.translation_matrix([0.0, 0.0, -3.0]), casts=False)
    assert scene.instances[receiver].mesh is first.mesh
    was = os.stat(path)
    trimesh.creation.icosphere(1, 0.7).export(path)          # new content of the same size and time
    os.utime(path, ns=(was.st_atime_ns, was.st_mtime_ns))
    assert os.stat(path).st_size == was.st_size
    other = scene.instances[scene.add(path, np.eye(4))]
    assert other.csm is not first.csm and other.mesh is not first.mesh
    assert other.csm.radius == pytest.approx(0.7, rel=1e-6)

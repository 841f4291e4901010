"""Scene.remove: stable ids, its errors (nothing removed on any), the instance grid and tree rebuilt, removing
then adding, removing the last caster, copies, and the device buffers a removed CSM no longer holds."""
import copy
import gc
import pickle
import weakref

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling
from pyshadow.scene_arrays import scene_arrays
from pyshadow.visibility import csm as csm_backend
from pyshadow.visibility.bvh import BVH_MIN_INSTANCES

tr = trimesh.transformations.translation_matrix


def _row(xs, y=0.15, z=0.0):
    return np.stack([tr([x, y, z]) for x in xs])


def _scene(box_csm, poses, ground=0.0):
    box, csm = box_csm
    scene = pyshadow.Scene(ground=ground, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)   # (meshes added)
    scene.add(csm, poses, mesh=box)
    return scene


def _queries(n=400, seed=3, lo=(-1.0, 0.0, -1.0), hi=(1.0, 0.6, 1.0)):
    rng = np.random.default_rng(seed)
    p = rng.uniform(lo, hi, (n, 3))
    p[: n // 3, 1] = 0.0
    nrm = rng.normal(size=(n, 3))
    nrm[: n // 3] = [0.0, 1.0, 0.0]
    return p, nrm


def _same(a, b):
    a, b = np.atleast_1d(a), np.atleast_1d(b)
    assert a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a.view(np.uint8), b.view(np.uint8))


def _answers(scene, p, n, ids=()):
    """visible and AO (nearest, vote with bent normals) of ``scene``, and vertex AO of instances ``ids``."""
    d = np.where(n[:, 1:2] >= 0, n, -n)
    out = [scene.visible(p, d), scene.visible(p, d, lookup="vote"), scene.ambient_occlusion(p, n),
           *scene.ambient_occlusion(p, n, lookup="vote", return_bent_normals=True)]
    return out + [scene.vertex_ao(i, sampling=Sampling(16)) for i in ids]


def test_ids_stay_and_the_removed_are_placeholders(box_csm):
    scene = _scene(box_csm, _row([-0.6, 0.0, 0.6, 1.2]))
    held = [scene.instances[i] for i in range(4)]
    T2 = scene.transform(2)
    version = scene._version
    scene.remove(1)
    assert scene._version > version
    assert scene.instances[0] is held[0] and scene.instances[2] is held[2] and scene.instances[3] is held[3]
    gone = scene.instances[1]
    assert gone is not held[1] and held[1].csm is box_csm[1] and not held[1].removed   # the caller's one: intact
    assert (gone.removed, gone.casts, gone.csm, gone.mesh) == (True, False, None, None)
    assert len(scene.instances) == 4 and scene.casters == [0, 2, 3]
    _same(scene.transform(2), T2)
    assert scene.add(box_csm[1], tr([0.0, 0.15, 1.0]), mesh=box_csm[0]) == 4     # a new id, 1 not reused
    assert scene.add(box_csm[1], _row([2.0, 3.0]), mesh=box_csm[0]).tolist() == [5, 6]
    assert scene.instances[1].removed and scene.casters == [0, 2, 3, 4, 5, 6]
    scene.remove(np.int64(6))
    scene.remove(np.array(5))
    scene.remove([])                    # none: nothing changes
    assert scene.casters == [0, 2, 3, 4]
    assert scene_arrays(scene)["live"].tolist() == [True, False, True, True, True, False, False]
    with pytest.raises(AttributeError, match="read-only"):
        gone.removed = False
    with pytest.raises(AttributeError, match="read-only"):
        scene.instances[0].removed = True
    with pytest.raises(TypeError, match=r"Scene\.remove takes one out"):
        scene.instances.pop(1)


@pytest.mark.parametrize("bad, error, message", [
    (99, IndexError, r"no instance 99"), (-1, IndexError, r"no instance -1"),
    ([0, 99], IndexError, r"no instance 99"), ([0, -3], IndexError, r"no instance -3"),
    ([0, 2, 0], ValueError, r"instance 0 is given more than once"),
    ([3, 1], IndexError, r"instance 1 was removed"), (1, IndexError, r"instance 1 was removed"),
    (True, TypeError, r"an int"), (1.0, TypeError, r"an int"), ("0", TypeError, r"an int"),
    ([0.0, 2.0], TypeError, r"1-D sequence of ints"), ([[0, 2]], TypeError, r"1-D sequence of ints"),
    ([True, False], TypeError, r"1-D sequence of ints"), ({0, 2}, TypeError, r"got a set"),
    (iter([0, 2]), TypeError, r"got a list_iterator"),
])
def test_bad_ids_are_refused_naming_them_and_nothing_is_removed(box_csm, bad, error, message):
    scene = _scene(box_csm, _row([-0.6, 0.0, 0.6, 1.2]))
    scene.remove(1)
    version, before = scene._version, list(scene.instances)
    with pytest.raises(error, match=message):
        scene.remove(bad)
    assert scene._version == version and list(scene.instances) == before and scene.casters == [0, 2, 3]


@pytest.mark.parametrize("call", ["transform", "transforms", "set_transform", "set_transforms", "vertex_ao",
                                  "vertex_points", "remove", "remove_many"])
def test_calls_on_a_removed_instance_name_it(box_csm, call):
    scene = _scene(box_csm, _row([-0.6, 0.0, 0.6]))
    scene.remove(1)
    before = scene.transform([0, 2])
    calls = {"transform": lambda: scene.transform(1), "transforms": lambda: scene.transform([0, 1]),
             "set_transform": lambda: scene.set_transform(1, np.eye(4)),
             "set_transforms": lambda: scene.set_transform([0, 1, 2], np.stack([np.eye(4)] * 3)),
             "vertex_ao": lambda: scene.vertex_ao(1), "vertex_points": lambda: scene.vertex_points(1),
             "remove": lambda: scene.remove(1), "remove_many": lambda: scene.remove([2, 1])}
    with pytest.raises(IndexError, match=r"^instance 1 was removed"):
        calls[call]()
    _same(scene.transform([0, 2]), before)          # none moved, none removed
    assert scene.casters == [0, 2]


@pytest.mark.parametrize("use_grid", [True, False], ids=["grid", "tree"])
@pytest.mark.parametrize("keep", [BVH_MIN_INSTANCES + 4, BVH_MIN_INSTANCES - 1], ids=["many", "few"])
def test_removing_among_many_casters_rebuilds_their_grid_or_tree(box_csm, monkeypatch, use_grid, keep):
    """A scene of BVH_MIN_INSTANCES + 8 casters asked (its grid or tree kept), then bodies removed: it answers
    as one built with the others (the structure made anew for them; below BVH_MIN_INSTANCES, none)."""
    monkeypatch.setattr(csm_backend, "USE_GRID", use_grid)
    k = BVH_MIN_INSTANCES + 8
    xs = np.linspace(-1.2, 1.2, 6)
    poses = np.concatenate([_row(xs, z=z) for z in np.linspace(-1.2, 1.2, -(-k // 6))])[:k]
    removed = _scene(box_csm, poses)
    p, n = _queries(lo=(-1.4, 0.0, -1.4), hi=(1.4, 0.5, 1.4))
    first = _answers(removed, p, n)
    accel = csm_backend.instance_accel(removed)
    assert accel == ("grid" if use_grid else "tree")
    gone = np.random.default_rng(1).choice(k, k - keep, replace=False)
    removed.remove(gone)
    kept = np.setdiff1d(np.arange(k), gone)
    built = _scene(box_csm, poses[kept])
    assert csm_backend.instance_accel(removed) == csm_backend.instance_accel(built)
    assert csm_backend.instance_accel(built) == (accel if keep >= BVH_MIN_INSTANCES else "all")
    got, want = _answers(removed, p, n, kept[:2]), _answers(built, p, n, [0, 1])
    for a, b in zip(got, want):
        _same(a, b)
    assert not all(np.array_equal(a, b) for a, b in zip(first, got))   # the removed bodies did shadow


def test_remove_then_add(box_csm):
    """Removed, then a body added (a new id) and another CSM type: as the scene built with the survivors and
    the new ones, in the order of their ids."""
    box, csm = box_csm
    ball = trimesh.creation.icosphere(1, 0.15)
    removed = _scene(box_csm, _row([-0.6, 0.0, 0.6, 1.2]))
    p, n = _queries()
    _answers(removed, p, n)
    removed.remove([3, 0])
    assert removed.add(ball, tr([0.0, 0.5, 0.3])) == 4
    assert removed.add(csm, tr([0.0, 0.15, 0.6]), mesh=box) == 5
    built = _scene(box_csm, _row([0.0, 0.6]))
    built.add(removed.instances[4].csm, tr([0.0, 0.5, 0.3]), mesh=removed.instances[4].mesh)
    built.add(csm, tr([0.0, 0.15, 0.6]), mesh=box)
    assert [len(removed.caster_types()[0]), removed.casters] == [2, [1, 2, 4, 5]]
    for a, b in zip(_answers(removed, p, n, [1, 4, 5]), _answers(built, p, n, [0, 2, 3])):
        _same(a, b)
    # the mesh's CSM, built by add, is kept by the scene when its last instance goes: added again, not rebuilt
    ball_csm = removed.instances[4].csm
    removed.remove(4)
    assert removed.instances[removed.add(ball, tr([0.0, 0.5, -0.3]))].csm is ball_csm


@pytest.mark.parametrize("ground", [0.0, None], ids=["ground", "no-ground"])
def test_removing_the_last_caster_asks_as_a_scene_that_never_had_casters(box_csm, ground, monkeypatch):
    plate = trimesh.creation.box((0.8, 0.1, 0.8))
    removed = _scene(box_csm, _row([-0.3, 0.3]), ground=ground)
    removed.add(plate, tr([0.0, 0.05, 0.7]), casts=False)
    built = pyshadow.Scene(ground=ground)
    built.add(plate, tr([0.0, 0.05, 0.7]), casts=False)
    p, n = _queries()
    _answers(removed, p, n)
    removed.remove([1, 0])
    backend = csm_backend.CSMVisibility("nearest")
    for kernel, extra in (("scene_visible", {}), ("scene_ao", {}), ("scene_ao", {"BENT_NORMALS": 1})):
        assert backend.query_defines(removed, kernel, **extra) == backend.query_defines(built, kernel, **extra)
    assert backend.query_defines(built, "scene_ao", BENT_NORMALS=1)["NTYPES"] == 0      # no CSM lookup compiled
    assert csm_backend.instance_accel(removed) == "none"
    _same(removed.anchor(p), built.anchor(p))
    assert removed.scale() == built.scale() and removed.casters == []
    for a, b in zip(_answers(removed, p, n, [2]), _answers(built, p, n, [0])):
        _same(a, b)
    _same(removed.render(pyshadow.Camera([1.5, 1.2, 2.0], [0.0, 0.1, 0.3], width=24, height=16),
                         sampling=Sampling(4)).ao,
          built.render(pyshadow.Camera([1.5, 1.2, 2.0], [0.0, 0.1, 0.3], width=24, height=16),
                       sampling=Sampling(4)).ao)
    if ground is None:                  # nothing occludes: answered without launching a kernel
        from pyshadow import _cl

        monkeypatch.setattr(_cl, "kernel", lambda *a, **k: pytest.fail("a kernel was launched"))
        assert removed.visible(p, n).all() and (removed.ambient_occlusion(p, n) == 1).all()
    removed.remove(2)                   # the last instance: as an empty scene
    empty = pyshadow.Scene(ground=ground)
    _same(removed.anchor(p), empty.anchor(p))
    assert removed.scale() == empty.scale() == 1.0
    _same(removed.ambient_occlusion(p, n), empty.ambient_occlusion(p, n))


def test_a_removed_csm_holds_no_device_buffers_through_the_scene(box_csm):
    """The scene's packed atlas of caster types goes where a removal changes its types (kept where it does not),
    and a CSM no remaining instance uses is held by nothing of the scene (the caller's last reference gone, it is
    collected, its buffers with it)."""
    box, csm = box_csm
    ball = trimesh.creation.icosphere(1, 0.15)
    ball_csm = pyshadow.CoherentShadowMap.build(ball, pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)
    scene = _scene(box_csm, _row([-0.6, 0.0]))
    scene.add(ball_csm, _row([0.6, 1.0], y=0.2), mesh=ball)
    p, n = _queries()
    scene.ambient_occlusion(p, n)
    atlas = csm_backend._ATLAS[scene]
    scene.remove(2)                     # the ball's CSM still has an instance: the atlas kept
    assert csm_backend._ATLAS[scene] is atlas
    scene.remove(3)
    assert scene not in csm_backend._ATLAS
    scene.ambient_occlusion(p, n)
    assert len(csm_backend._ATLAS[scene][0][1]) == 1
    gone = weakref.ref(ball_csm)
    del ball_csm
    gc.collect()
    assert gone() is None


def test_copies_and_pickles_keep_their_removals_apart(box_csm):
    scene = _scene(box_csm, _row([-0.6, 0.0, 0.6]))
    p, n = _queries()
    before = _answers(scene, p, n)
    other = copy.copy(scene)
    other.remove(1)
    assert scene.casters == [0, 1, 2] and other.casters == [0, 2]
    for a, b in zip(_answers(scene, p, n), before):
        _same(a, b)
    back = pickle.loads(pickle.dumps(other))
    assert back.instances[1].removed and back.casters == [0, 2]
    for a, b in zip(_answers(back, p, n, [2]), _answers(other, p, n, [2])):
        _same(a, b)
    with pytest.raises(IndexError, match="instance 1 was removed"):
        back.remove(1)


def test_the_tables_kept_with_the_scenes_arrays_go_with_the_removal(box_csm):
    """Without a CSM query since (no atlas to compare), the arrays kept for the old instances, and the tables
    kept with them, are let go at once, not at the next query."""
    scene = _scene(box_csm, _row([-0.6, 0.0, 0.6]))
    kept = weakref.ref(scene_arrays(scene)["world_centre"])
    scene.remove(1)
    gc.collect()
    assert kept() is None
    assert scene_arrays(scene)["live"].tolist() == [True, False, True]


def test_a_tracer_and_a_probe_of_the_scene_are_stale_after_a_removal(box_csm):
    from pyshadow.cubemap import CubeProbe
    from pyshadow.embree import EmbreeTracer

    scene = _scene(box_csm, _row([-0.6, 0.0, 0.6]))
    probe = CubeProbe(scene, [0.0, 1.0, 0.0], 16)
    p, n = _queries(8)
    with EmbreeTracer(scene, 1) as tracer:
        tracer.prepare(p, n, np.tile([0.0, 1.0, 0.0], (8, 1)).astype(np.float32), 1)
        scene.remove(1)
        with pytest.raises(ValueError, match="the scene changed since the tracer was built"):
            tracer.prepare(p, n, np.tile([0.0, 1.0, 0.0], (8, 1)).astype(np.float32), 1)
    assert probe.stale


def test_a_placeholder_has_no_sphere(box_csm):
    scene = _scene(box_csm, _row([-0.6, 0.0]))
    scene.remove(0)
    with pytest.raises(ValueError, match="a removed instance"):
        scene.instances[0].world_sphere()
    _same(scene_arrays(scene)["world_radius"][1:], np.array([scene.instances[1].world_sphere()[1]]))

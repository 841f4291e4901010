"""A move made by another thread while a query runs (pyshadow/visibility/csm.py, ``_instance_data``, ``_scene_args``;
pyshadow/contact.py, ``contact_mask``, ``ground_sheet_slots``).

The CSM backends keep a scene's instance table, tree or grid with the scene's arrays (:mod:`pyshadow.visibility.held`)
until the scene changes. A table was made from the arrays of one moment and then kept with those fetched a moment
later: a move landing between the two (a simulation thread's ``set_transform`` while the display thread renders)
kept the table of the old poses with the new arrays, and the scene went on answering from the old poses after the
move, call after call, wherever the move left the scene's anchor where it was (two bodies moved towards each other,
a body turned about its centre; the footprints of bodies resting on the ground wherever it went). The keeper is now
fetched first: a table is never older than the arrays it is kept with. The move is made to land inside the query by
a hook on a function the query calls, as another thread's would;
the test then asks again and compares with a scene built at the new poses, bit for bit. Before the fix 9 of the 18
cases failed (7 of the tables, 2 of the footprints), in 10 of 10 runs (they are deterministic).
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh
from trimesh.transformations import rotation_matrix, translation_matrix

import pyshadow
from pyshadow.visibility import csm as csm_backend

SLAB = trimesh.creation.box((2.0, 0.5, 0.4))      # its bounding sphere's centre is its origin
POSES = [translation_matrix([2.5 * (k % 5), 0.3, 2.5 * (k // 5)]) for k in range(20)]
# instances 0 and 1 moved 1.5 towards each other: the anchor (the mean of the centres) stays, bit for bit;
# or instance 0 turned about its centre: the anchor and every world sphere stay
MOVES = {"pair": ([0, 1], [translation_matrix([1.5, 0.3, 0.0]), translation_matrix([1.0, 0.3, 0.0])]),
         "turn": ([0], [POSES[0] @ rotation_matrix(1.3, [0, 1, 0])])}


@pytest.fixture(scope="module")
def slab_csm():
    return pyshadow.CoherentShadowMap.build(SLAB, pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)


def _scene(csm, count, moved=None):
    poses = list(POSES[:count])
    for i, T in zip(*(moved or ((), ()))):
        poses[i] = T
    scene = pyshadow.Scene(ground=0.0)
    scene.add(csm, np.array(poses))
    return scene


def _ask(scene):
    rng = np.random.default_rng(0)
    p = np.c_[rng.uniform(-1.5, 1.5, 300), np.zeros(300), rng.uniform(-1.5, 1.5, 300)]
    return scene.ambient_occlusion(p, np.tile([0.0, 1.0, 0.0], (300, 1)), sampling=pyshadow.Sampling(16),
                                   surface_ids=-2)


# 2 casters: every caster's sphere tested; 20: the grid (16 or more), whose tables alone ask ground_tolerance
@pytest.mark.parametrize("count, hook, call", [(2, "scene_arrays", k) for k in range(3)]
                         + [(20, "scene_arrays", k) for k in range(3)] + [(20, "ground_tolerance", 0)])
@pytest.mark.parametrize("move", sorted(MOVES))
def test_move_inside_query_keeps_no_old_tables(slab_csm, monkeypatch, count, move, hook, call):
    ids, poses = MOVES[move]
    moved = _ask(_scene(slab_csm, count, MOVES[move]))
    scene = _scene(slab_csm, count)
    before = _ask(scene)
    assert not np.array_equal(before, moved), "the move changes nothing: no test"
    scene.set_transform(ids, np.array(scene.transform(ids)))       # a fresh version: the tables are made again
    original, calls = getattr(csm_backend, hook), []

    def landing(*args, **kwargs):           # the other thread's move lands as this call of the query returns
        got = original(*args, **kwargs)
        if len(calls) == call:
            scene.set_transform(ids, np.array(poses))
        calls.append(hook)
        return got

    monkeypatch.setattr(csm_backend, hook, landing)
    _ask(scene)                             # this query may answer for either pose (set_transforms' docstring)
    monkeypatch.undo()
    assert len(calls) > call, f"the query made {len(calls)} calls of {hook}: the move did not land"
    after = _ask(scene)
    assert np.array_equal(after, moved), (f"after the move, {int((after != moved).sum())} of {len(moved)} points "
                                          "answer otherwise than a scene built at the new poses")


@pytest.mark.parametrize("query", ["ambient_occlusion", "visible"])
@pytest.mark.parametrize("call", [0, 1])
def test_move_inside_query_keeps_no_old_footprints(slab_csm, monkeypatch, query, call):
    """The footprints of bodies resting on the ground (pyshadow/contact.py): their parts were kept with the arrays
    fetched after the footprints, as the instance tables were."""
    from pyshadow import contact

    resting = translation_matrix([0.0, 0.25, 0.0])         # on the ground: a footprint
    turned = resting @ rotation_matrix(1.3, [0, 1, 0])      # turned about its centre: the anchor stays
    rng = np.random.default_rng(1)
    p = np.c_[rng.uniform(-1.2, 1.2, 2000), np.zeros(2000), rng.uniform(-1.2, 1.2, 2000)]

    def scene_at(T):
        scene = pyshadow.Scene(ground=0.0)
        scene.add(slab_csm, np.array([T, translation_matrix([5.0, 0.25, 0.0])]), mesh=SLAB)
        return scene

    def ask(scene):
        if query == "visible":
            return scene.visible(p, np.tile([0.3, 1.0, 0.2], (len(p), 1)), surface_ids=-2)
        return scene.ambient_occlusion(p, np.tile([0.0, 1.0, 0.0], (len(p), 1)), sampling=pyshadow.Sampling(16),
                                       surface_ids=-2)

    moved = ask(scene_at(turned))
    scene = scene_at(resting)
    assert not np.array_equal(ask(scene), moved), "the move changes nothing: no test"
    scene.set_transform(0, resting)         # a fresh version: the footprints are found again
    original, calls = contact._on_ground, []

    def landing(*args, **kwargs):
        got = original(*args, **kwargs)
        if len(calls) == call:
            scene.set_transform(0, turned)
        calls.append(args[1])
        return got

    monkeypatch.setattr(contact, "_on_ground", landing)
    ask(scene)
    monkeypatch.undo()
    if len(calls) <= call:
        pytest.skip(f"the query makes {len(calls)} calls of _on_ground")
    after = ask(scene)
    assert np.array_equal(after, moved), (f"after the move, {int((after != moved).sum())} of {len(moved)} points "
                                          "answer otherwise than a scene built at the new poses")

"""Threads whose first queries of a scene make its arrays at once share the arrays one of them kept.

Each made a dict of its own and kept it, the last one winning: the tables another thread kept with its dict
(the far anchors' entries of ``held_at``, the instance tables) were lost, and made again (the far-anchor test of
tests/test_threads_far_anchors.py found its entry gone, now and then). Here the other thread is simulated: while
the arrays are made, a query made them first and kept a table with them.
"""
from __future__ import annotations

import numpy as np
import trimesh
from trimesh.transformations import translation_matrix

import pyshadow
from pyshadow import scene_arrays as sa
from pyshadow.visibility.held import held_at, kept


def _scene():
    csm = pyshadow.CoherentShadowMap.build(trimesh.creation.box((1.0, 1.0, 1.0)), pyshadow.ViewSet.zigzag(4, 8),
                                           resolution=16, progress=False)
    scene = pyshadow.Scene(ground=0.0)
    scene.add(csm, np.array([translation_matrix([3.0 * k, 0.5, 0.0]) for k in range(3)]))
    return scene


def _race(monkeypatch, scene):
    """scene_arrays(scene), while another query makes the same arrays first and keeps a far table with them."""
    posed, other = sa._posed, {}

    def meanwhile(out, T, version):
        if not other:                           # (once) the other thread: arrays made, kept, a table kept there
            monkeypatch.setattr(sa, "_posed", posed)
            other["held"] = sa.scene_arrays(scene)
            kept(held_at(scene, np.array([1.0, 2.0, 2000.0])), "table", lambda: np.arange(4))
        return posed(out, T, version)

    monkeypatch.setattr(sa, "_posed", meanwhile)
    mine = sa.scene_arrays(scene)
    monkeypatch.setattr(sa, "_posed", posed)
    return mine, other["held"]


def test_first_arrays_made_at_once_are_shared(monkeypatch):
    scene = _scene()
    mine, theirs = _race(monkeypatch, scene)
    assert mine is theirs and sa.scene_arrays(scene) is theirs
    assert "table" in held_at(scene, np.array([1.0, 2.0, 2000.0]))          # the other thread's table kept


def test_arrays_after_a_move_made_at_once_are_shared(monkeypatch):
    scene = _scene()
    sa.scene_arrays(scene)
    scene.set_transform(1, translation_matrix([3.0, 0.5, 1.0]))
    mine, theirs = _race(monkeypatch, scene)
    assert mine is theirs and sa.scene_arrays(scene) is theirs
    assert "table" in held_at(scene, np.array([1.0, 2.0, 2000.0]))
    assert np.array_equal(mine["world_centre"][1], [3.0, 0.5, 1.0])

"""Queries far from a scene, from several threads at once (pyshadow/visibility/held.py, ``held_at``).

Points far from a scene's anchor are asked relative to anchors of their own, whose tables the scene keeps in a
most-recently-used list, measured and evicted by ``held_at``. Threads querying one scene at once (read-only) changed
that list together: "RuntimeError: OrderedDict mutated during iteration". The test asks ``held_at`` for many far
anchors from 8 threads, each filling its entry as a query does, with Python's thread switch interval at 1
microsecond (the default 5 ms makes the race rarer); before the lock it failed in 10 of 10 runs.
"""
from __future__ import annotations

import sys
import threading

import numpy as np
import trimesh
from trimesh.transformations import translation_matrix

import pyshadow
from pyshadow.visibility.held import held_at, kept


def test_far_anchors_from_threads():
    csm = pyshadow.CoherentShadowMap.build(trimesh.creation.box((1.0, 1.0, 1.0)), pyshadow.ViewSet.zigzag(4, 8),
                                           resolution=16, progress=False)
    scene = pyshadow.Scene(ground=0.0)
    scene.add(csm, np.array([translation_matrix([3000.0 * k, 0.5, 0.0]) for k in range(4)]))
    errors, start = [], threading.Barrier(8)

    def queries(t):
        start.wait()
        try:
            for i in range(200):
                anchor = np.array([float(i), float(t), 2000.0])             # far anchors, each new
                held = held_at(scene, anchor)
                for k in range(4):          # the tables a query keeps there
                    kept(held, ("table", k), lambda: np.zeros(64))
        except Exception as e:              # (a thread's exception would be printed, not raised)
            errors.append(f"{type(e).__name__}: {e}")

    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    try:
        threads = [threading.Thread(target=queries, args=(t,)) for t in range(8)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(old)
    assert not errors, f"{len(errors)} of 8 threads failed: {errors[0]}"
    assert sorted(held_at(scene, np.array([5.0, 3.0, 2000.0]))) == [("table", k) for k in range(4)]

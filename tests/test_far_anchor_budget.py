"""The far anchors' tables are kept by bytes (held.FAR_BYTES), not by a count of 8.

A query whose points span more regions (anchors) than the count rebuilt
most of their tables on every call: 40,000 small boxes 2 m apart over 400 m,
AO of 20,000 points among them (16 regions), 0.60 s a query against 0.086 s
with the tables kept.
"""
import numpy as np
import trimesh

import pyshadow
from pyshadow.scene_arrays import anchor_groups, scene_arrays
from pyshadow.visibility import csm as csm_backend
from pyshadow.visibility import held


def _field():
    """12 x 12 boxes of 0.3 m, 30 m apart (a field of 330 m: regions of 128 m), and 2,000 points on the
    ground within 1 m of them (up normals)."""
    box = trimesh.creation.box((0.3, 0.3, 0.3))
    csm = pyshadow.CoherentShadowMap.build(box, pyshadow.ViewSet.zigzag(8, 16), resolution=32, progress=False)
    s = pyshadow.Scene(ground=0.0)
    for i in range(144):
        s.add(csm, trimesh.transformations.translation_matrix([30.0 * (i % 12), 0.15, 30.0 * (i // 12)]), mesh=box)
    rng = np.random.default_rng(4)
    at = rng.integers(0, 144, 2000)
    p = np.c_[30.0 * (at % 12) + rng.uniform(-1, 1, 2000), np.zeros(2000), 30.0 * (at // 12) + rng.uniform(-1, 1, 2000)]
    return s, p, np.tile([0.0, 1.0, 0.0], (2000, 1))


def _counting(monkeypatch):
    calls = []
    rows = csm_backend._instance_rows
    monkeypatch.setattr(csm_backend, "_instance_rows", lambda *a: calls.append(1) or rows(*a))
    return calls


def test_a_query_over_more_regions_than_eight_builds_its_tables_once(monkeypatch):
    """Was: with more than 8 far regions in one query, every call built the tables of at least all but 8
    of them again (here 9 regions: 9 of 10 tables built on each call)."""
    s, p, up = _field()
    groups = anchor_groups(s, p)
    assert len(groups) >= 10                          # the scene's anchor and 9 or more regions of its own
    calls = _counting(monkeypatch)
    S = pyshadow.Sampling(8, seed=3)
    first = s.ambient_occlusion(p, up, sampling=S)
    assert len(calls) == len(groups)                  # one instance table per anchor
    again = s.ambient_occlusion(p, up, sampling=S)
    assert len(calls) == len(groups)                  # none built again
    np.testing.assert_array_equal(first, again)
    far = scene_arrays(s)["far_anchors"]
    assert len(far) == len(groups) - 1 and held._bytes(far) <= held.FAR_BYTES


def test_the_budget_bounds_what_is_kept_and_answers_do_not_depend_on_it(monkeypatch):
    s, p, up = _field()
    S = pyshadow.Sampling(8, seed=3)
    want = s.ambient_occlusion(p, up, sampling=S)
    far = scene_arrays(s)["far_anchors"]
    one = max(held._bytes(t) for t in far.values())
    assert one > 0
    s.set_transform(0, s.transform(0))                 # a scene change: nothing kept
    monkeypatch.setattr(held, "FAR_BYTES", 2.5 * one)
    calls = _counting(monkeypatch)
    got = s.ambient_occlusion(p, up, sampling=S)
    far = scene_arrays(s)["far_anchors"]
    last = next(reversed(far.values()))
    assert 2 <= len(far) <= 4 and held._bytes(far) - held._bytes(last) <= 2.5 * one
    np.testing.assert_array_equal(got, want)
    n = len(calls)
    np.testing.assert_array_equal(s.ambient_occlusion(p, up, sampling=S), want)
    assert len(calls) > n                             # beyond the budget: built again, the same answers

"""The far anchors' bytes (pyshadow/visibility/held.py) are measured once per entry filled, not summed
again over every entry for each new anchor; eviction is what it was."""
from collections import OrderedDict

import numpy as np
import trimesh

import pyshadow
from pyshadow.scene_arrays import scene_arrays
from pyshadow.visibility import held


def _scene():
    box = trimesh.creation.box((0.3, 0.3, 0.3))
    csm = pyshadow.CoherentShadowMap.build(box, pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)
    s = pyshadow.Scene(ground=0.0)
    s.add(csm, trimesh.transformations.translation_matrix([0.0, 0.15, 0.0]), mesh=box)
    return s


def _walks(monkeypatch):
    """Counts of held._bytes's outer calls (one per entry measured; its own recursion not counted)."""
    calls = []
    inner = held._bytes
    monkeypatch.setattr(held, "_bytes", lambda x, seen=None: (calls.append(1) if seen is None else None) or
                        inner(x, seen))
    return calls


def _fill(entry, n):
    entry["table"] = np.zeros(n, np.uint8)


def test_each_new_anchor_measures_only_the_entries_filled_since(monkeypatch):
    """Was: each new far anchor summed the bytes of every entry again, n^2 / 2 walks for n anchors (a render
    with 137 anchor groups spent 1.94 s of 3.46 s there); now each entry is measured once after it is
    filled, and again only after it was asked for (its caller may add tables)."""
    s = _scene()
    calls = _walks(monkeypatch)
    n = 200
    for k in range(n):
        _fill(held.held_at(s, np.array([1000.0 * (k + 1), 0.0, 0.0])), 100)
    assert len(calls) == n - 1                                  # was n (n - 1) / 2 = 19,900
    calls.clear()
    entry = held.held_at(s, np.array([1000.0, 0.0, 0.0]))      # asked again, given more tables
    entry["more"] = np.zeros(5000, np.uint8)
    held.held_at(s, np.array([-1.0e4, 0.0, 0.0]))
    assert len(calls) == 2                                      # the entry asked again, and the last new one
    assert scene_arrays(s)["far_anchor_bytes"][np.array([1000.0, 0.0, 0.0]).tobytes()] == 5100


def test_eviction_keeps_the_most_recent_entries_within_the_budget(monkeypatch):
    """The same entries are kept as when every entry was measured afresh: the oldest go first until the
    others fit FAR_BYTES, the one asked now kept whatever its size; an entry that grew after it was asked
    for again counts at its new size."""
    monkeypatch.setattr(held, "FAR_BYTES", 2500)
    s = _scene()
    keys = [np.array([1000.0 * (k + 1), 0.0, 0.0]) for k in range(6)]
    model = OrderedDict()                                       # the rule, measured afresh every time
    for k, a in enumerate(keys):
        e = held.held_at(s, a)
        while sum(model.values()) > 2500:
            model.popitem(last=False)
        model[a.tobytes()] = 1000
        _fill(e, 1000)
        assert list(scene_arrays(s)["far_anchors"]) == list(model), k
    big = held.held_at(s, keys[4])                              # asked again: it grows to 3000
    model.move_to_end(keys[4].tobytes())
    big["more"] = np.zeros(2000, np.uint8)
    model[keys[4].tobytes()] = 3000
    held.held_at(s, np.array([-5000.0, 0.0, 0.0]))
    while sum(model.values()) > 2500:
        model.popitem(last=False)
    assert list(scene_arrays(s)["far_anchors"])[:-1] == list(model) == []

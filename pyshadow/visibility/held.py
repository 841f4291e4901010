"""Tables the CSM backends keep with a scene between queries, per anchor.

The instance table, the instance tree or grid and their device copies are
derived from a scene and the anchor its queries are asked relative to
(:func:`pyshadow.scene_arrays.anchor_groups`); they are kept with the
scene's arrays (:func:`pyshadow.scene_arrays.scene_arrays`) until the scene
changes, so a query among many casters builds and copies no table. Queries
far from the scene have anchors of their own, one per region they lie in:
those tables are kept for the anchors used last, up to :data:`FAR_BYTES`
in all (host and device copies), so that points scattered far and wide
cannot fill memory (each such anchor among 10,000 casters holds about 8 MB),
while a query whose points span many regions finds all of their tables
again the next time (a count of 8 made a scene of 40,000 casters over 400
m, its points in 16 regions, build 15 anchors' tables every query: 0.6 s a
query against 0.12 s within one region).
"""
from __future__ import annotations

import threading
from collections import OrderedDict

import numpy as np

from .. import _cl
from ..scene_arrays import scene_arrays

__all__ = ["FAR_BYTES", "held_at", "kept", "on_device", "check_tables"]

#: Held while the far anchors' entries are looked up, measured and evicted: threads querying one scene at once
#: (read-only) changed them together ("RuntimeError: OrderedDict mutated during iteration").
_FAR_LOCK = threading.Lock()

#: Bytes of the tables kept for anchors other than the scene's (the most recently used first; the
#: anchor asked last is kept whatever its size).
FAR_BYTES = 512 * 2 ** 20


def _bytes(x, seen=None) -> int:
    """Bytes of the arrays and device buffers held in ``x`` (dicts, tuples and lists walked), each counted
    once (a device copy's entry holds its host array too, which the tables hold already)."""
    seen = set() if seen is None else seen
    if isinstance(x, (dict, tuple, list)):      # (a copy of a dict's values: another thread's query may add to it)
        return sum(_bytes(v, seen) for v in (list(x.values()) if isinstance(x, dict) else x))
    if id(x) in seen or not isinstance(x, (np.ndarray, _cl.cl.MemoryObject)):
        return 0
    seen.add(id(x))
    return x.nbytes if isinstance(x, np.ndarray) else int(x.size)


def held_at(scene, anchor) -> dict:
    """Where the tables of queries at ``anchor`` are kept: the scene's arrays for the scene's own
    anchor, else that anchor's entry among the far anchors' (dropped with the scene's arrays when it
    changes, or when more recently used anchors' tables fill :data:`FAR_BYTES`). A scene without casters
    keeps nothing for other anchors: an empty scene's anchor follows each query's points
    (:meth:`pyshadow.Scene.anchor`), so every query of a ground-only scene had an entry of its own (of
    no bytes, never evicted), and each new one re-summed the bytes of all the others."""
    held = scene_arrays(scene)
    at = np.asarray(anchor, np.float64).tobytes()
    if at == scene.anchor().tobytes():
        return held
    if not held["casts"].any():                 # tables of nothing: made anew (as _instance_data's), not kept
        return {}
    with _FAR_LOCK:
        far = held.setdefault("far_anchors", OrderedDict())
        sizes = held.setdefault("far_anchor_bytes", {})     # each entry's bytes, measured once it is filled
        if at in far:
            far.move_to_end(at)
            sizes.pop(at, None)                     # the caller may add tables to it: measured again when needed
            return far[at]
        # every entry filled since it was last measured (its caller's query has ended), measured once: summing
        # them all again for each new anchor took 1.94 s of a 3.46 s render with 137 anchors (137^2 / 2 walks)
        for k, v in far.items():
            if k not in sizes:
                sizes[k] = _bytes(v)
        total = sum(sizes.values())
        while total > FAR_BYTES and far:           # the oldest out; the one asked now is kept whatever its size
            total -= sizes.pop(far.popitem(last=False)[0])
        got = far[at] = {}
        return got


def kept(held, key, make):
    """``held[key]``, made by ``make()`` the first time (``held``: a scene's arrays, dropped when it changes)."""
    if key not in held:
        held[key] = make()
    return held[key]


def on_device(held, array):
    """The device copy of a read-only table that ``held`` keeps (or a module constant), made once
    per OpenCL context and kept with it: a query among many casters copies no table per call."""
    key = ("device", id(_cl.context()), id(array))
    got = held.get(key)
    if got is None or got[0] is not array:      # (the array is kept with its copy: its id is not reused)
        got = held[key] = (array, _cl.to_device(array))
    return got[1]


#: The compiled defines that say how the atlas is laid out (the kernel reads its buffers so).
_ATLAS_DEFINES = {"DEPTH_BITS": "bits", "IEND_T": "iend_t", "PAIR_WIDE": "pair_wide"}


def check_tables(defines, atlas, itype, ninst) -> None:
    """That a query's kernel, compiled with ``defines``, may read the atlas and instance types it is given
    (RuntimeError if not). Each is taken from the scene when it is needed; another thread's ``Scene.add`` of a
    new CSM (or ``Scene.remove``) landing in between gave a type index past the atlas's types, or an atlas laid
    out otherwise than compiled: the kernel would read past its buffers. The query is refused instead."""
    same = defines is None or (all(defines[k] == atlas[a] for k, a in _ATLAS_DEFINES.items() if k in defines)
                               and defines.get("NTYPES", 2) == min(atlas["ntypes"], 2)
                               and all(defines.get(f"LAYOUT_{x.upper()}", 1) >= int(x in atlas["layouts"])
                                       for x in ("zigzag", "hilbert")))
    if not same or (ninst and not 0 <= int(np.min(itype[:ninst])) <= int(np.max(itype[:ninst])) < atlas["ntypes"]):
        raise RuntimeError("the scene's caster types changed during this query (another thread's Scene.add or "
                           "Scene.remove); ask again: change a scene between its queries")

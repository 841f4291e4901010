"""Tables the CSM backends keep with a scene between queries, per anchor.

The instance table, the instance tree or grid and their device copies are
derived from a scene and the anchor its queries are asked relative to
(:func:`pyshadow.scene_arrays.anchor_groups`); they are kept with the
scene's arrays (:func:`pyshadow.scene_arrays.scene_arrays`) until the scene
changes, so a query among many casters builds and copies no table. Queries
far from the scene have anchors of their own, one per region they lie in:
those tables are kept for the :data:`FAR_ANCHORS` anchors used last, so
that points scattered far and wide cannot fill memory (each such anchor
among 10,000 casters holds about 8 MB).
"""
from __future__ import annotations

from collections import OrderedDict

import numpy as np

from .. import _cl
from ..scene_arrays import scene_arrays

__all__ = ["FAR_ANCHORS", "held_at", "kept", "on_device"]

#: Anchors other than the scene's whose tables are kept (the most recently used).
FAR_ANCHORS = 8


def held_at(scene, anchor) -> dict:
    """Where the tables of queries at ``anchor`` are kept: the scene's arrays for the scene's own
    anchor, else that anchor's entry among the last :data:`FAR_ANCHORS` (dropped with the scene's
    arrays when it changes, or when more recently used anchors push it out)."""
    held = scene_arrays(scene)
    at = np.asarray(anchor, np.float64).tobytes()
    if at == scene.anchor().tobytes():
        return held
    far = held.setdefault("far_anchors", OrderedDict())
    if at in far:
        far.move_to_end(at)
        return far[at]
    got = far[at] = {}
    while len(far) > FAR_ANCHORS:
        far.popitem(last=False)
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

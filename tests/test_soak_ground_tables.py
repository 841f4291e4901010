"""A ground plane moved under unmoved bodies keeps one set of contact tables, not one per height.

The footprints and sheets of the bodies on the ground, and their parts, are kept with the scene's arrays
(dropped when a body moves or is added) under ``(name, ground height)``. Setting ``Scene.ground`` is no such
change: a ground moved every frame (a slider, a water level) while the bodies rested kept four more tables a
frame for as long as none moved.
"""
from __future__ import annotations

import numpy as np
import trimesh

import pyshadow
from pyshadow.scene import GROUND_ID
from pyshadow.scene_arrays import _HELD

HEIGHTS = 12


def test_ground_moved_under_resting_bodies_keeps_one_table_per_name():
    box = trimesh.creation.box((0.4, 0.4, 0.4))
    box.apply_translation([0.0, 0.2, 0.0])
    csm = pyshadow.CoherentShadowMap.build(box, pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene = pyshadow.Scene(ground=0.0)
    for k in range(3):
        scene.add(csm, trimesh.transformations.translation_matrix([0.6 * k, 0.0, 0.0]), mesh=box)
    rng = np.random.default_rng(1)
    p = np.column_stack([rng.uniform(-0.3, 1.5, 200), np.zeros(200), rng.uniform(-0.4, 0.4, 200)])
    up = np.tile([0.0, 1.0, 0.0], (200, 1))
    first = None
    for k in range(HEIGHTS):
        scene.ground = 1e-7 * k         # within the contact tolerance: the bodies still rest on it
        p[:, 1] = scene.ground
        ao = scene.ambient_occlusion(p, up, sampling=pyshadow.Sampling(8), surface_ids=GROUND_ID)
        first = ao if first is None else first
    kept = [key for key in _HELD[scene] if isinstance(key, tuple) and len(key) == 2
            and isinstance(key[1], float) and key[0] in ("contact", "sheets", "contact parts", "sheet parts")]
    assert len(kept) <= 4, f"{len(kept)} ground tables kept after {HEIGHTS} heights: {sorted(kept)[:6]}"
    scene.ground = 0.0                  # back at the first height: the same answers
    p[:, 1] = 0.0
    assert np.array_equal(scene.ambient_occlusion(p, up, sampling=pyshadow.Sampling(8), surface_ids=GROUND_ID), first)

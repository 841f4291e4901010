"""A scene that takes a body of a new mesh now and then builds no new query program for each.

The query kernels were compiled with ``NTYPES`` = the number of distinct CSMs of the scene's casters, where
they ask only whether it is 0, 1 or more (``#if NTYPES``, ``#if NTYPES > 1``): every new type count built
the same code again (a stall of the frame it entered) and kept one more program for good.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import _cl

TYPES = 5


@pytest.fixture(scope="module")
def boxes():
    out = []
    for k in range(TYPES):
        box = trimesh.creation.box((0.3, 0.2 + 0.05 * k, 0.3))
        box.apply_translation([0.0, 0.1 + 0.025 * k, 0.0])
        out.append((box, pyshadow.CoherentShadowMap.build(box, pyshadow.ViewSet.zigzag(4, 8), resolution=16)))
    return out


def test_new_caster_types_build_no_new_query_program(boxes, monkeypatch):
    asked = []                  # the programs (file, options) the queries ask for, whether built now or before
    kernel = _cl.kernel

    def spy(source_file, name, defines=None):
        asked.append((source_file, _cl._options(_cl._with_lanes(source_file, defines))))
        return kernel(source_file, name, defines)
    monkeypatch.setattr(_cl, "kernel", spy)
    scene = pyshadow.Scene(ground=0.0)
    rng = np.random.default_rng(2)
    pts = np.column_stack([rng.uniform(-3.0, 3.0, 64), np.zeros(64), rng.uniform(-0.5, 0.5, 64)])
    up = np.tile([0.0, 1.0, 0.0], (64, 1))
    sun = np.tile(np.array([0.4, 1.0, 0.3]) / np.linalg.norm([0.4, 1.0, 0.3]), (64, 1))
    seen, answers = [], []
    for k, (box, csm) in enumerate(boxes):
        scene.add(csm, trimesh.transformations.translation_matrix([-2.4 + 1.2 * k, 0.0, 0.0]), mesh=box)
        answers.append(scene.visible(pts, sun))
        answers.append(scene.ambient_occlusion(pts, up, sampling=pyshadow.Sampling(8)))
        seen.append({a for a in asked if a[0] == "visibility.cl"})
        asked.clear()
    new = [len(b - seen[1]) for b in seen[2:]]          # as types 3, 4, ... entered: programs 2 types did not use
    assert new == [0] * (TYPES - 2), f"query programs asked anew as types 3..{TYPES} entered: {new}"
    assert all(np.isfinite(a).all() for a in answers)

"""A simulation's frames (helper simloop): bodies moved every frame, far away and back, scenes rebuilt to drop
bodies. The kept tables stay bounded, dropped scenes are freed, and a pair of bodies far from the origin has the
AO it has near it."""
from __future__ import annotations

import gc
import weakref

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import _cl
from pyshadow.scene_arrays import scene_arrays


def _at(x, y, z):
    T = np.eye(4)
    T[:3, 3] = [x, y, z]
    return T


@pytest.fixture(scope="module")
def bodies():
    views = pyshadow.ViewSet.zigzag(4, 8)
    box = trimesh.creation.box((0.2, 0.2, 0.2)).subdivide()
    ball = trimesh.creation.icosphere(1, radius=0.1)
    return [(m, pyshadow.CoherentShadowMap.build(m, views, resolution=16, progress=False)) for m in (box, ball)]


def test_a_pair_travelling_to_1e4_m_keeps_its_ao(bodies):
    """A ball resting on a box, carried from 2 m to 1e4 m from a static box and back: the pair's per-vertex AO
    (the same sampling every frame) stays within one ray of its AO at 2 m, and a floor point by the static box
    keeps its AO once the pair is away."""
    (box, cbox), (ball, cball) = bodies
    scene = pyshadow.Scene(ground=0.0)
    scene.add(cbox, _at(0.0, 0.1, 0.0), mesh=box)
    ids = [scene.add(cbox, _at(2.0, 0.1, 0.0), mesh=box), scene.add(cball, _at(2.0, 0.3, 0.0), mesh=ball)]
    S = pyshadow.Sampling(32, seed=5)
    probe, up = np.array([[0.15, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]])
    first = None
    for x in np.r_[np.geomspace(2.0, 1e4, 9), np.geomspace(1e4, 2.0, 9)]:
        scene.set_transform(ids, np.stack([_at(x, 0.1, 0.0), _at(x, 0.3, 0.0)]))
        got = [scene.vertex_ao(i, sampling=S) for i in ids] + [scene.ambient_occlusion(probe, up, sampling=S)]
        first = got if first is None else first
        for a, b in zip(got, first):
            assert np.abs(a - b).max() <= 1.0 / 32 + 1e-6, x


def test_moves_every_frame_keep_the_tables_bounded(bodies):
    """Forty frames of ten bodies falling onto the floor and onto each other, asked per vertex and at floor points:
    no program is built after the first frames, and the scene keeps one table set (its far anchors are dropped
    with each move)."""
    (box, cbox), _ = bodies
    scene = pyshadow.Scene(ground=0.0)
    ids = scene.add(cbox, np.stack([_at(0.25 * k, 1.0, 0.0) for k in range(10)]), mesh=box)
    S = pyshadow.Sampling(16, seed=1)
    pts = np.c_[np.linspace(-1.0, 3.0, 40), np.zeros(40), np.full(40, 0.3)]
    counts = []
    for f in range(40):
        y = np.maximum(0.1, 1.0 - 0.5 * 9.81 * (f / 30.0) ** 2) + 0.2 * (np.arange(10) % 2) * (f > 20)
        scene.set_transform(ids, np.stack([_at(0.25 * (k // 2), y[k], 0.0) for k in range(10)]))
        scene.vertex_ao(int(ids[f % 10]), sampling=S)
        scene.ambient_occlusion(pts, np.tile([0.0, 1.0, 0.0], (40, 1)), sampling=S, surface_ids=-2)
        counts.append((len(_cl._programs), len(_cl._kernels), len(scene_arrays(scene).get("far_anchors", {}))))
    assert len(set(counts[5:])) == 1 and counts[-1][2] == 0, counts


def test_scenes_rebuilt_to_drop_bodies_are_freed(bodies):
    """Dropping a body by a new scene of the others (as ``Scene.instances`` says), frame after frame: the old
    scenes, asked and rendered, are freed with their kept tables (no module cache holds them)."""
    (box, cbox), (ball, cball) = bodies
    scene = pyshadow.Scene(ground=0.0)
    for k in range(6):
        m, c = bodies[k % 2]
        scene.add(c, _at(0.3 * k, 0.1, 0.0), mesh=m)
    S = pyshadow.Sampling(16, seed=2)
    camera = pyshadow.Camera(eye=[1.0, 1.0, 2.0], target=[0.6, 0.1, 0.0], width=16, height=12)
    dropped = []
    for f in range(5):
        scene.vertex_ao(0, sampling=S)
        scene.render(camera, sampling=S)
        new = pyshadow.Scene(ground=0.0)
        for inst in scene.instances[1:]:
            new.add(inst.csm, inst.transform, mesh=inst.mesh)
        new.add(scene.instances[0].csm, scene.instances[0].transform @ _at(0.0, 0.0, 0.5),
                mesh=scene.instances[0].mesh)
        dropped.append(weakref.ref(scene))
        scene = new
    gc.collect()
    assert [r() for r in dropped] == [None] * 5

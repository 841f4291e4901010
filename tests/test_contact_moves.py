"""Bodies on bodies after moves (pyshadow/contact_bodies.py, ``_SEARCHED``): a body whose pose and whose
neighbours' poses are unchanged keeps its patches; the patches are those a scene built at the final poses
finds, bit for bit, and a move searches the moved body's neighbourhood, not the whole scene."""
from __future__ import annotations

import hashlib

import numpy as np
import pytest
import trimesh
from trimesh.transformations import rotation_matrix

import pyshadow
from pyshadow import contact_bodies
from pyshadow.contact_bodies import body_patches

K = 6                                       # K x K unit boxes side by side: each touches its 2-4 neighbours


@pytest.fixture(scope="module")
def bodies():
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    cyl = trimesh.creation.cylinder(0.5, 1.0, sections=12)
    views = pyshadow.ViewSet.zigzag(4, 8)
    return {id(m): (m, pyshadow.CoherentShadowMap.build(m, views, resolution=16, progress=False)) for m in (box, cyl)}


def _digest(patches):
    d = hashlib.sha1()
    for p in patches:
        for a in p:
            a = np.ascontiguousarray(a)
            d.update(str(a.shape).encode())
            d.update(a.tobytes())
    return d.hexdigest()


def _scene(bodies, poses, kinds):
    s = pyshadow.Scene(ground=0.0)
    for T, (m, csm, casts) in zip(poses, kinds):
        if casts:
            s.add(csm, T, mesh=m)
        else:
            s.add(m, T, casts=False)
    return s


def _row(bodies, seed, k=K):
    meshes = list(bodies.values())
    poses, kinds = [], []
    for i in range(k * k):
        T = np.eye(4)
        T[:3, 3] = [i % k, 0.5 + (1.0 if (i + seed) % 5 == 0 else 0.0), i // k]      # some stacked a layer up
        m, csm = meshes[0] if (i + seed) % 4 else meshes[1]
        poses.append(T)
        kinds.append((m, csm, (i + seed) % 7 != 0))          # a receiver among them closes nothing in
    return poses, kinds


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_patches_after_moves_are_those_of_a_scene_built_there(bodies, seed):
    """A scene moved step by step (0-3 bodies a step: slid a little, a whole place, turned, lifted onto
    another layer, or onto another body's pose) gives the patches a scene built at each step's poses finds,
    bit for bit, and they change as the bodies move (the rule is exercised: touching bodies make patches)."""
    rng = np.random.default_rng(seed)
    poses, kinds = _row(bodies, seed)
    scene = _scene(bodies, poses, kinds)
    counts = [len(body_patches(scene))]
    for step in range(6):
        ids = rng.choice(len(poses), size=int(rng.integers(0, 4)), replace=False)
        for j in ids:
            T = poses[j].copy()
            kind = int(rng.integers(4))
            if kind == 0:
                T[0, 3] += rng.choice([0.25, 1.0, 3.0])
            elif kind == 1:
                T[:3, :3] = rotation_matrix(rng.uniform(0.1, 3.0), [0, 1, 0])[:3, :3]
            elif kind == 2:
                T[1, 3] += 1.0
            else:
                T = poses[int(rng.integers(len(poses)))].copy()
            poses[j] = T
        if len(ids):
            scene.set_transform([int(j) for j in ids], np.array([poses[j] for j in ids]))
        else:
            scene.set_transform(0, poses[0])            # a change that moves nothing
        got = body_patches(scene)
        assert _digest(got) == _digest(body_patches(_scene(bodies, poses, kinds))), step
        counts.append(len(got))
    assert counts[0] > 2 * K * (K - 1) - 20 and len(set(counts)) > 1


def test_a_move_searches_the_moved_body_and_its_neighbours(bodies, monkeypatch):
    """One box slid by 1e-3 among 9 x 9 touching boxes: the search poses the moved box, then the bodies whose
    spheres meet it (its 8 neighbours) with the bodies their spheres meet: 1 + 25 at most, not all 81; nothing
    moved poses none. Was: every change searched every body (one box moved among 3,600 touching boxes: 2.1 s a
    query, now 0.09 s)."""
    k = 9
    poses, kinds = _row(bodies, 3, k)
    scene = _scene(bodies, poses, kinds)
    body_patches(scene)
    posed = []
    world_bodies = contact_bodies._world_bodies
    monkeypatch.setattr(contact_bodies, "_world_bodies", lambda insts: posed.append(len(insts)) or world_bodies(insts))
    j = k * (k // 2) + k // 2                               # a box in the middle
    T = poses[j].copy()
    T[0, 3] += 1e-3
    poses[j] = T
    scene.set_transform(j, T)
    moved = body_patches(scene)
    assert posed[0] == 1 and 9 <= posed[1] <= 25 and len(posed) == 2      # its box; the 5 x 5 boxes around it
    posed.clear()
    scene.set_transform(0, poses[0])
    assert body_patches(scene) is not moved and _digest(body_patches(scene)) == _digest(moved) and posed == []
    monkeypatch.setattr(contact_bodies, "_world_bodies", world_bodies)
    assert _digest(moved) == _digest(body_patches(_scene(bodies, poses, kinds)))

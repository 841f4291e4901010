"""Bodies on bodies after ``Scene.add`` (pyshadow/contact_bodies.py, ``_grown``): a simulation that spawns bodies
keeps the last search for the bodies already placed, so an add searches the new bodies and their neighbours, not
every body (a body added apart from a stack of 400 touching boxes: 3.1 s a query before, 0.06 s after), and the
patches are those a scene built with the same bodies finds, bit for bit."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh
from test_contact_moves import _digest

import pyshadow
from pyshadow import contact_bodies
from pyshadow.contact_bodies import body_patches

K = 9                                       # K x K unit boxes side by side: each touches its 2-4 neighbours


@pytest.fixture(scope="module")
def box():
    m = trimesh.creation.box((1.0, 1.0, 1.0))
    return m, pyshadow.CoherentShadowMap.build(m, pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)


def _at(x, y, z):
    T = np.eye(4)
    T[:3, 3] = [x, y, z]
    return T


def _placed(box, items):
    """A scene of ``items``: (transform, casts) each, a caster with its CSM and mesh, a receiver by its mesh."""
    s = pyshadow.Scene(ground=0.0)
    for T, casts in items:
        s.add(box[1], T, mesh=box[0]) if casts else s.add(box[0], T, casts=False)
    return s


def _row(k=K):
    return [(_at(i % k, 0.5, i // k), i % 5 != 3) for i in range(k * k)]     # a receiver among them


def test_an_add_searches_the_new_bodies_and_their_neighbours(box, monkeypatch):
    """A box added apart from K x K touching boxes poses no body; one added onto a middle box poses it, then the
    boxes whose spheres meet it with theirs: not all K x K. Was: every add searched every body again."""
    items = _row()
    scene = _placed(box, items)
    body_patches(scene)
    posed = []
    world_bodies = contact_bodies._world_bodies
    monkeypatch.setattr(contact_bodies, "_world_bodies", lambda insts: posed.append(len(insts)) or world_bodies(insts))
    items.append((_at(3 * K, 0.5, 3 * K), True))
    scene.add(box[1], items[-1][0], mesh=box[0])
    body_patches(scene)
    assert posed == []
    middle = K * (K // 2) + K // 2
    items.append((_at(K // 2, 1.5, K // 2), True))          # resting on the middle box
    scene.add(box[1], items[-1][0], mesh=box[0])
    got = body_patches(scene)
    assert posed[0] == 1 and max(posed) <= 25 < K * K, posed               # the 5 x 5 boxes around it
    assert items[middle][1]
    monkeypatch.setattr(contact_bodies, "_world_bodies", world_bodies)
    fresh = body_patches(_placed(box, items))
    assert _digest(got) == _digest(fresh) and len(fresh) > len(body_patches(_placed(box, items[:-1])))


@pytest.mark.parametrize("seed", [0, 1])
def test_patches_after_adds_and_moves_are_those_of_a_scene_built_there(box, seed):
    """Adds (one body or a stack of them, casters and receivers, apart, beside, on top, through another) and moves
    in turn give, step by step, the patches of a scene built with the same bodies."""
    rng = np.random.default_rng(seed)
    items = _row(4)
    scene = _placed(box, items)
    body_patches(scene)
    for step in range(8):
        if step % 2 == 0:
            k = int(rng.integers(1, 3))
            new = [(_at(*rng.integers(0, 5, 3) * [1.0, 0.0, 1.0] + [0.0, rng.choice([0.5, 1.5, 2.5]), 0.0]),
                    bool(rng.integers(4))) for _ in range(k)]
            for casts in (True, False):
                T = [t for t, c in new if c is casts]
                if T:
                    scene.add(box[1] if casts else box[0], np.array(T), **({"mesh": box[0]} if casts else
                                                                         {"casts": False}))
            items += [x for c in (True, False) for x in new if x[1] is c]
        else:
            j = int(rng.integers(len(items)))
            T = items[j][0].copy()
            T[0, 3] += rng.choice([1e-3, 1.0])
            items[j] = (T, items[j][1])
            scene.set_transform(j, T)
        assert _digest(body_patches(scene)) == _digest(body_patches(_placed(box, items))), step


def test_a_receiver_changed_in_place_then_an_add_searches_anew(box):
    """A receiver's mesh changed in place (allowed: its sphere is found again) and a body added: the old search
    is not kept for it (its faces moved though its pose did not)."""
    lid = trimesh.creation.box((1.0, 1.0, 1.0))
    scene = pyshadow.Scene(ground=0.0)
    scene.add(box[1], _at(0.0, 0.5, 0.0), mesh=box[0])
    scene.add(lid, _at(0.0, 1.5, 0.0), casts=False)         # resting on the box
    before = body_patches(scene)
    assert before
    lid.vertices = lid.vertices + [0.0, 0.5, 0.0]           # lifted off it, in place
    scene.add(box[1], _at(5.0, 0.5, 0.0), mesh=box[0])
    fresh = pyshadow.Scene(ground=0.0)
    for inst in scene.instances:
        fresh.add(inst.csm, inst.transform, mesh=inst.mesh) if inst.casts else \
            fresh.add(inst.mesh, inst.transform, casts=False)
    assert _digest(body_patches(scene)) == _digest(body_patches(fresh)) != _digest(before)

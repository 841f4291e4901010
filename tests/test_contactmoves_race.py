"""Bodies on bodies queried in one thread while another moves them (pyshadow/contact_bodies.py): the patches kept
for a pose (``_SEARCHED``, the scene's arrays) are those of that pose, whenever the move lands.

The move is made to land at a fixed point of the query (a hook on a function the query calls), as a second
thread's ``set_transform`` would; each test then asks again at the final poses and compares with a scene built
there (bit for bit) and with the AO that Embree gives the lid under the upper box (0)."""
from __future__ import annotations

import hashlib

import numpy as np
import pytest
import trimesh
from trimesh.transformations import translation_matrix

import pyshadow
from pyshadow import contact_bodies
from pyshadow.contact import close_contacts
from pyshadow.contact_bodies import body_patches

BOX = trimesh.creation.box((1.0, 1.0, 1.0))
BASE = [translation_matrix([0.0, 0.0, 0.0]), translation_matrix([1.0, 0.0, 0.0]), translation_matrix([5.0, 0.0, 0.0])]
ON_0, ON_1, AWAY = (translation_matrix(x) for x in ([0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [9.0, 0.0, 0.0]))


@pytest.fixture(scope="module")
def csm():
    return pyshadow.CoherentShadowMap.build(BOX, pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)


def _scene(csm, top):
    """Boxes 0 and 1 side by side on nothing, box 2 at ``top``."""
    s = pyshadow.Scene(ground=None)
    for T in BASE[:2] + [top]:
        s.add(csm, T, mesh=BOX)
    return s


def _digest(patches):
    d = hashlib.sha1()
    for p in patches:
        for a in p:
            d.update(np.ascontiguousarray(a).tobytes())
    return d.hexdigest()


def _lid_ao(scene, x):
    """close_contacts' AO of 50 points on the lid (y = 0.5) of the box at x, normals up."""
    q = np.random.default_rng(0).uniform(-0.45, 0.45, (50, 2))
    p = np.column_stack([x + q[:, 0], np.full(50, 0.5), q[:, 1]])
    n = np.tile([0.0, 1.0, 0.0], (50, 1))
    ao = np.ones(50)
    close_contacts(scene, p, n, ao, n.copy())
    return ao


def _move_at(monkeypatch, name, scene, pose):
    """Move box 2 to ``pose`` when the query first calls contact_bodies' ``name``."""
    f = getattr(contact_bodies, name)

    def hook(*args, **kw):
        monkeypatch.setattr(contact_bodies, name, f)
        scene.set_transform(2, pose)
        return f(*args, **kw)
    monkeypatch.setattr(contact_bodies, name, hook)


def test_a_move_during_the_search_does_not_stay_in_the_patches_kept(csm, monkeypatch):
    """Box 2 lifted onto box 0, asked, moved away by another thread during that query, then put back on box 0.
    Was: the query asked on box 0 searched the faces of the pose away and kept them for the pose on box 0: back
    there, 2 patches instead of 5 (none under box 2), AO 1 on box 0's lid under it (Embree 0), until box 0 or
    box 2 moved again."""
    scene = _scene(csm, BASE[2])
    body_patches(scene)
    scene.set_transform(2, ON_0)
    _move_at(monkeypatch, "_body_pairs", scene, AWAY)
    body_patches(scene)                                     # asked on box 0; box 2 moves away meanwhile
    scene.set_transform(2, ON_0)                            # and back
    fresh = _scene(csm, ON_0)
    assert len(body_patches(fresh)) == 5
    assert _digest(body_patches(scene)) == _digest(body_patches(fresh))
    assert _lid_ao(scene, 0.0).max() == 0.0 and _lid_ao(fresh, 0.0).max() == 0.0


def test_a_move_during_a_contact_query_does_not_mix_the_patches_of_two_poses(csm, monkeypatch):
    """Box 2 on box 0; an AO query runs, and box 2 moves onto box 1 between the query's patches and their
    outlines. Was: the scene's arrays of the new pose kept the outlines of the old pose's patches; the next
    query there (box 2 on box 1) read box 0's outlines for box 1's lid patch: AO 1 on 26 of 50 points of box 1's
    lid under box 2 (a scene built there: 0)."""
    scene = _scene(csm, ON_0)
    body_patches(scene)
    _move_at(monkeypatch, "_slab_pairs", scene, ON_1)
    _lid_ao(scene, 0.0)                                      # box 2 moves onto box 1 during this query
    fresh = _scene(csm, ON_1)
    assert _digest(body_patches(scene)) == _digest(body_patches(fresh))
    assert _lid_ao(fresh, 1.0).max() == 0.0
    np.testing.assert_array_equal(_lid_ao(scene, 1.0), _lid_ao(fresh, 1.0))

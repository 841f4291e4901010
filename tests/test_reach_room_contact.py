"""A body resting inside a closed room (pyshadow/contact_bodies.py): the room's floor and wall under it are
closed in as a slab's top under a resting body is.

A room is a closed box wound inwards (its surface faces the inside); the contact search turns each closed
part outwards by its volume's sign, so the room's floor read as the bottom of a solid box, its normal the
same as the resting box's bottom: "not facing", no contact. Checked against Embree on the same rays.
"""
import numpy as np
import pytest
import trimesh
from trimesh.transformations import rotation_matrix, translation_matrix

import pyshadow
from pyshadow import embree
from pyshadow.contact import occlude_contacts
from pyshadow.contact_bodies import body_patches

VIEWS = pyshadow.ViewSet.zigzag(8, 16)
BOX = trimesh.creation.box((1.0, 1.0, 1.0))


def _room(inwards=True):
    """A closed 10 x 3 x 10 box, its faces wound inwards (a room) or outwards."""
    room = trimesh.creation.box((10.0, 3.0, 10.0))
    return trimesh.Trimesh(room.vertices, room.faces[:, ::-1] if inwards else room.faces, process=False)


def _scene(M, room_casts=False, inwards=True):
    """The room (floor y = 0) under ``M``, a unit box resting on its floor and one in the corner of its floor
    and the wall x = 5."""
    scene = pyshadow.Scene(ground=None, views=VIEWS, resolution=32)
    scene.add(_room(inwards), M @ translation_matrix([0.0, 1.5, 0.0]), casts=room_casts)
    scene.add(BOX, M @ translation_matrix([0.3, 0.5, 0.2]))
    scene.add(BOX, M @ translation_matrix([4.5, 0.5, 0.0]))
    return scene


def _face_points(n, seed):
    """(n, 2) points of a unit square centred at 0, half of them within 2 cm of its edge (but 1e-4 inside)."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-0.5 + 1e-4, 0.5 - 1e-4, (n, 2))
    k, rows = rng.integers(0, 2, n // 2), np.arange(n // 2)
    q[rows, k] = np.sign(q[rows, k]) * (0.5 - rng.uniform(1e-4, 0.02, n // 2))
    return q


MOTIONS = {"at the origin": np.eye(4),
           "turned, 1e4 away": translation_matrix([1e4, 0.0, -1e4]) @ rotation_matrix(0.6, [0.0, 1.0, 0.0])}


@pytest.mark.parametrize("motion", list(MOTIONS))
def test_the_floor_and_wall_under_a_box_in_a_room_are_closed_in(motion):
    """Was: AO up to 0.531 (mean 0.133) on the room's floor under the box (half the points within 2 cm of its
    edge) and 0.594 (mean 0.137) on the wall behind the box in the corner, rays into the box visible 11.7 %
    and 8.3 %, the same turned and 1e4 away; Embree 0 (no contact patch: the room's floor, turned outwards,
    had the box's bottom's normal)."""
    M = MOTIONS[motion]
    scene = _scene(M)
    q = _face_points(400, 1)
    floor = np.column_stack([q[:, 0] + 0.3, np.zeros(len(q)), q[:, 1] + 0.2])
    wall = np.column_stack([np.full(len(q), 5.0), q[:, 0] + 0.5, q[:, 1]])
    s = pyshadow.Sampling(32)
    for p, n in ((floor, [0.0, 1.0, 0.0]), (wall, [-1.0, 0.0, 0.0])):
        p, n = p @ M[:3, :3].T + M[:3, 3], np.tile(M[:3, :3] @ n, (len(p), 1))
        assert embree.ambient_occlusion(scene, p, n, sampling=s).max() == 0.0
        assert scene.ambient_occlusion(p, n, sampling=s, surface_ids=0).max() == 0.0
        w = n + 0.3 * M[:3, 2]
        assert not embree.visible(scene, p, w).any()
        assert not scene.visible(p, w, surface_ids=0).any()


@pytest.mark.parametrize("room_casts", [False, True])
def test_the_rooms_own_floor_is_not_closed_in_by_what_rests_on_it(room_casts):
    """Was: no patch at all (0 of the 3 below). The room is no body resting on the box: its floor (the room's
    own face, the one the box lies on) makes no patch, and finite rays from its floor away from the boxes
    stay open (a patch of the whole floor would close them)."""
    scene = _scene(np.eye(4), room_casts)
    normals = np.array([p[0] for p in body_patches(scene)])
    assert len(normals) == 3 and np.allclose(normals, [[0, 1, 0], [0, 1, 0], [-1, 0, 0]], atol=1e-12)
    rng = np.random.default_rng(2)
    p = np.column_stack([rng.uniform(-4.0, -1.0, 300), np.zeros(300), rng.uniform(-4.0, 4.0, 300)])
    w = np.tile([0.2, 1.0, 0.1], (300, 1))
    assert embree.visible(scene, p, w, max_distance=0.5).all()
    assert scene.visible(p, w, surface_ids=0, max_distance=0.5, straddle="embree").all()


def test_a_box_sunk_flush_into_a_solid_box_closes_nothing_open():
    """Was: no patch (0 of 3; the rule's other side). The room's box wound outwards (a solid block, the unit
    boxes sunk into it flush with its bottom): the sunk boxes' bottoms make patches, which close in only
    rays into the block; its bottom's own points keep their open rays down and out of it."""
    scene = _scene(np.eye(4), True, inwards=False)
    rng = np.random.default_rng(3)
    q = _face_points(300, 3)
    p = np.column_stack([q[:, 0] + 0.3, np.zeros(len(q)), q[:, 1] + 0.2])
    down = np.tile([0.0, -1.0, 0.0], (len(p), 1))
    w = down + rng.uniform(-0.3, 0.3, (len(p), 3)) * [1, 0, 1]
    assert embree.visible(scene, p, w).all()
    assert len(body_patches(scene)) == 3
    assert occlude_contacts(scene, p, w, np.ones(len(p), bool)).all()          # the patches close none of them
    assert not occlude_contacts(scene, p, -w, np.ones(len(p), bool)).any()     # the rays up, into the boxes

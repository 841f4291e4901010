"""Each resting body's footprint with its own tolerance (pyshadow/contact.py ``_face_tolerances``).

A 1 mm box on the ground beside a caster of radius 200: the scene's scale is 200, and 1e-5 of it (2 mm) is
twice the box's height. Each test whose docstring starts "Was:" failed on the code before the fix and says
what happened; the others pin what the fix leaves alone.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import contact, visibility
from pyshadow.scene_arrays import scene_arrays

BOX = 1e-3


def _scene(big_radius, lift=0.0):
    """A box of side 1 mm resting on y = 0 (``lift``: raised that much), and a sphere of ``big_radius`` floating far
    away from it (1 above the ground, 10 radii + 1 along x)."""
    s = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
    big = trimesh.creation.icosphere(2, big_radius)
    s.add(big, trimesh.transformations.translation_matrix([10 * big_radius + 1, big_radius + 1.0, 0]))
    s.add(trimesh.creation.box((BOX, BOX, BOX)), trimesh.transformations.translation_matrix([0, BOX / 2 + lift, 0]))
    return s


def _under(n=300, seed=0):
    """``n`` points of the ground under the box (within 0.4 mm of its axis) and low rays from them (w_y = 0.01)."""
    rng = np.random.default_rng(seed)
    g = rng.uniform(-0.4 * BOX, 0.4 * BOX, (n, 3))
    g[:, 1] = 0.0
    a = rng.uniform(0, 2 * np.pi, n)
    d = np.column_stack([np.cos(a), np.full(n, 0.01), np.sin(a)])
    return g, d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize("backend", ["csm", "numpy"])
def test_the_lid_of_a_small_box_beside_a_large_caster_is_not_ground(backend):
    """Was: the lid (1 mm up) lay within the scene's band of 2 mm, so its points counted as ground under the box: all
    200 rays straight up from it occluded (Embree: 200 open). Now the box's own band (1e-5 of its 0.87 mm radius) holds
    only the plane: 200 open."""
    s = _scene(200.0)
    rng = np.random.default_rng(1)
    lid = rng.uniform(-0.4 * BOX, 0.4 * BOX, (200, 3))
    lid[:, 1] = BOX
    up = np.tile([0.0, 1.0, 0.0], (200, 1))
    assert not contact.contact_mask(s, lid).any()
    assert visibility.visible(s, lid, up, backend=backend, surface_ids=1, normals=up).all()


@pytest.mark.parametrize("backend", ["csm", "numpy"])
def test_a_small_box_lifted_a_tenth_of_its_size_does_not_rest_beside_a_large_caster(backend):
    """Was: a box lifted 0.1 mm counted as resting (its underside within 2 mm), and the ground under it as its
    footprint: all 300 low rays through the gap under it occluded, where Embree has 298 open. Now 298 open on each
    backend."""
    s = _scene(200.0, lift=1e-4)
    g, d = _under()
    assert contact.contact_mask(s, g) is None
    assert int(visibility.visible(s, g, d, backend=backend, surface_ids=-2).sum()) == 298
    assert int(visibility.visible(s, g, d, backend="embree").sum()) == 298


@pytest.mark.parametrize("big_radius", [1e-3, 200.0])
def test_a_resting_box_keeps_its_footprint_whatever_its_neighbour(big_radius):
    """What the fix leaves alone: the ground under a resting box is its footprint beside a neighbour of its own size or
    of 200, and every low ray from it is occluded (the rays enter the box)."""
    s = _scene(big_radius)
    g, d = _under()
    assert contact.contact_mask(s, g).all()
    for backend in ("csm", "numpy"):
        assert not visibility.visible(s, g, d, backend=backend, surface_ids=-2).any()


def test_a_turned_csm_without_its_mesh_reaching_below_the_ground_queries_quietly():
    """Was: a caster added as a CSM without ``mesh=``, turned and reaching below the ground, has no box; its
    lowest height, summed from -inf bounds made finite (-1.8e308 each), overflowed: every query warned
    "overflow encountered in reduce" (an error under this suite's filterwarnings). The answer was right and
    stays so: -inf, no footprint to read, and a ray straight up from the ground 3 radii away is open."""
    csm = pyshadow.CoherentShadowMap.build(trimesh.creation.box((1.0, 1.0, 1.0)), pyshadow.ViewSet.zigzag(4, 8),
                                           resolution=16, progress=False)
    pose = np.eye(4)
    pose[:3, :3] = trimesh.transformations.rotation_matrix(0.5, [1.0, 0.0, 0.0])[:3, :3]
    pose[1, 3] = 0.5 * csm.radius                   # its bounding sphere reaches below the ground
    scene = pyshadow.Scene(ground=0.0)
    scene.add(csm, pose)
    assert scene.visible([[3.0 * csm.radius, 0.0, 0.0]], [[0.0, 1.0, 0.0]]).tolist() == [True]
    assert contact._box_bottom(scene, scene_arrays(scene), np.array([0])).tolist() == [-np.inf]

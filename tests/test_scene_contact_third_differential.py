"""Differential checks of scenes, the ground and contact (pyshadow/scene.py, scene_arrays.py, contact.py, raster.py).

Third pass (audit of 2026-12). Compared: a box resting on the ground against the same box carrying a
vertex no face uses (raw ``trimesh.Trimesh(..., process=False)``, as an OBJ file with stray vertices
loads), the footprint mask against the exact square, and the kernel's, the float64 mirror's and
Embree's ambient occlusion of the ground along the footprint's edge.
"""
import numpy as np
import trimesh

from pyshadow import Sampling, Scene, ViewSet, contact


def _stray_box(stray):
    """A unit box whose vertex list also holds ``stray`` (3,), which no face uses."""
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    return trimesh.Trimesh(np.vstack([box.vertices, stray]), box.faces, process=False)


def test_a_vertex_no_face_uses_below_the_ground_keeps_a_resting_bodys_footprint():
    """A closed box resting on the ground whose mesh also holds an unused vertex 3 below the plane.

    Before: the rest test read every vertex of the mesh, the unused one included, so the box counted
    as sunk into the ground and lost its footprint (``footprints`` empty, ``contact_mask`` None); the
    ground along the footprint's edge, 1e-3 inside it, read AO > 0 on all 400 points from the kernel
    and from its float64 mirror (up to 0.69), where Embree, which sees only the faces, reads 0. Now the footprint is the
    box's bottom square, as without the stray vertex, and every backend reads AO 0 there.
    """
    rng = np.random.default_rng(0)
    t = rng.uniform(-0.5, 0.5, 400)
    side = np.where(rng.random(400) < 0.5, 0.499, -0.499)
    p = np.column_stack([side, np.zeros(400), t])
    p[::2] = p[::2][:, [2, 1, 0]]                       # the four edges of the square
    n = np.tile([0.0, 1.0, 0.0], (400, 1))
    for ground in (0.0, -250.0):
        scene = Scene(ground=ground, views=ViewSet.zigzag(8, 16), resolution=32)
        scene.add(_stray_box([0.0, -3.0, 0.0]), trimesh.transformations.translation_matrix([0.0, ground + 0.5, 0.0]))
        q = p + [0.0, ground, 0.0]
        (tri, outline), = contact.footprints(scene)
        assert tri.shape == (2, 3, 2) and outline.shape == (4, 2, 2)
        np.testing.assert_array_equal(np.sort(np.abs(tri).reshape(-1)), np.full(12, 0.5))
        assert contact.contact_mask(scene, q).all()
        assert not contact.contact_mask(scene, q * [1.003, 1.0, 1.003]).any()    # 1e-3 outside: not under it
        for backend in ("csm", "numpy", "embree"):
            ao = scene.ambient_occlusion(q, n, sampling=Sampling(16), surface_ids=-2, backend=backend)
            np.testing.assert_array_equal(ao, 0.0)

"""Vertex normals of a mesh whose cached normals point against its winding (trimesh's inverted box)."""
import numpy as np
import trimesh

import pyshadow
from pyshadow import embree


def test_vertex_points_of_an_inverted_box_face_into_the_room():
    """Was: ``trimesh.creation.box(...).invert()`` (trimesh 5.2) flips the faces but keeps the face normals it
    was made with, so ``Scene.vertex_points`` gave its 8 corners normals pointing out of the room (0 of 8
    inward), and ``vertex_ao`` asked the hemisphere outside: Embree read every corner open (AO 1) where the
    room closes them (0). Now the normals follow the winding, as those of the same faces built afresh."""
    room = trimesh.creation.box((2.0, 2.0, 2.0))
    room.invert()
    scene = pyshadow.Scene(views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
    scene.add(room)                                              # a caster: its walls close the room
    pts, nrm = scene.vertex_points(0)
    fresh = trimesh.Trimesh(room.vertices, room.faces, process=False).vertex_normals
    np.testing.assert_allclose(nrm, fresh, rtol=0, atol=1e-12)
    assert (np.einsum("ij,ij->i", nrm, pts) < 0).all()          # every corner's normal into the room
    ao = embree.ambient_occlusion(scene, pts, nrm, sampling=pyshadow.Sampling(64))
    assert np.asarray(ao).max() <= 0.05                          # closed all round (a corner's grazing samples)
    box = trimesh.creation.box((2.0, 2.0, 2.0))                  # a box not inverted: its own normals, unchanged
    scene2 = pyshadow.Scene()
    scene2.add(box, casts=False)
    assert np.array_equal(scene2.vertex_points(0)[1], np.asarray(box.vertex_normals, np.float64))

"""A face wholly nearer than the G-buffer's near plane (1e-6 of the farthest geometry in view).

The near plane is documented: a vertex in view nearer than it, or a face it would cut in view, is refused.
A face with every corner nearer than the near plane was culled with the geometry behind the eye, before
those checks: a wall filling the view from closer than the near plane vanished, and its pixels showed the
surfaces behind it.
"""
import numpy as np
import pytest
import trimesh

import pyshadow

BOX = trimesh.creation.box((1.0, 1.0, 1.0))        # faces at +-0.5
GROUND = trimesh.Trimesh([[-50, 0, -50], [50, 0, -50], [50, 0, 50], [-50, 0, 50]], [[0, 2, 1], [0, 3, 2]])
BELOW = np.array([[1, 0, 0, 0], [0, 1, 0, -0.5], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def _head_on(gap, width=16, height=12):
    """The box's +z face seen head-on from ``gap`` in front of it, a 100 m ground under the box."""
    eye = np.array([0.0, 0.0, 0.5 + gap])
    cam = pyshadow.Camera(eye, eye - [0.0, 0.0, 1.0], fov_y=60.0, width=width, height=height)
    return [(BOX, np.eye(4)), (GROUND, BELOW)], cam


def test_a_wall_nearer_than_the_near_plane_is_refused_not_dropped():
    """Was: from 1e-5 before the face (near plane 5e-5: the ground reaches 50 m) the face's two triangles were
    culled whole; all 192 pixels showed the box's other faces from inside, depths 0.86 to 1.18 instead of 1.0e-5
    to 1.4e-5 (about 8e4 times too far)."""
    items, cam = _head_on(1e-5)
    with pytest.raises(ValueError, match=r"face \d+ of item 0 reaches into the view nearer than the near plane 5"):
        pyshadow.render_gbuffer(items, cam)


def test_a_wall_nearer_than_the_near_plane_alone_is_refused():
    """Was: the box alone (near plane 1e-6) seen from 1e-6 before its face gave every pixel the box's other faces
    from inside, depths 0.86 to 1.18 (about 8e5 times too far)."""
    eye = np.array([0.0, 0.0, 0.5 + 1e-6])
    cam = pyshadow.Camera(eye, eye - [0.0, 0.0, 1.0], fov_y=60.0, width=16, height=12)
    with pytest.raises(ValueError, match=r"face \d+ of item 0 reaches into the view nearer than the near plane"):
        pyshadow.render_gbuffer([(BOX, np.eye(4))], cam)


def test_a_wall_beyond_the_near_plane_is_drawn_at_its_distance():
    """Was: as now (the refusal goes no further): from 1e-4 before the face (beyond the near plane 5e-5) every
    pixel sees the face: its distance along the view axis is 1e-4 (float32 depths; Embree's primary rays agree)."""
    items, cam = _head_on(1e-4)
    g = pyshadow.render_gbuffer(items, cam)
    assert (g["object_id"] == 0).all()
    assert np.isin(g["face"], np.flatnonzero(BOX.face_normals[:, 2] > 0.5)).all()     # the +z face's triangles
    along = g["depth"].astype(np.float64) * (cam.ray_directions() @ cam.forward)
    np.testing.assert_allclose(along, 1e-4, rtol=1e-5)
    np.testing.assert_allclose(g["normal"], np.broadcast_to([0, 0, 1], g["normal"].shape), atol=1e-6)


def test_a_sliver_nearer_than_the_near_plane_outside_the_view_is_not_refused():
    """Was: as now (the refusal goes no further): a triangle wholly nearer than the near plane beside the view
    (its box overlaps the view's cross-section, no side of the view holds all its corners) cuts nothing away:
    the box behind it is drawn as without it."""
    items, cam = _head_on(1e-3)
    tx, ty = cam.tan_half * cam.aspect, cam.tan_half
    z = 2e-5                                                   # the near plane is 5e-5
    corners = np.array([[3 * tx * z, 0.5 * ty * z, z], [0.5 * tx * z, 3 * ty * z, z], [3 * tx * z, 3 * ty * z, z]])
    world = cam.eye + corners @ cam.rotation                   # camera space to world
    sliver = trimesh.Trimesh(world, [[0, 1, 2]], process=False)
    want = pyshadow.render_gbuffer(items, cam)
    got = pyshadow.render_gbuffer(items + [(sliver, np.eye(4))], cam)
    for k in ("object_id", "face", "depth"):
        np.testing.assert_array_equal(got[k], want[k])
    assert (want["object_id"] == 0).all()

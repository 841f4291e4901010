"""Differential checks of corner normals near a right-angle crease and of concave_vertices' input.

References: a cube's faces meet at exactly 90 degrees, so every crease angle below 90 keeps each of its
corner normals equal to its face normal (float64 brute force: the faces' unit normals); a zero-area face
has no normal and its corner normals are 0 (module docstring of pyshadow.shading_normals).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from pyshadow.shading_normals import corner_normals
from pyshadow.vertex_points import concave_vertices


@pytest.mark.parametrize("degrees", [89.99995, 89.999999])
@pytest.mark.parametrize("turned", [False, True])
def test_faces_at_a_right_angle_keep_their_crease_just_below_90_degrees(degrees, turned):
    """Was: the crease tolerance (``crease * (1 + 2**-20)``) reached 90 degrees within 8.6e-5 degrees of it:
    at ``radians(89.99995)`` a cube's 12 faces were smoothed together (corner normals 54.74 degrees off their
    faces) and a zero-area face's corners got unit normals (its normal 0 passed ``0 >= cos``)."""
    box = trimesh.creation.box()
    if turned:                                  # normals at 90 degrees but for rounding
        box.apply_transform(trimesh.transformations.rotation_matrix(0.7, [1.0, 2.0, 3.0]))
    v = np.asarray(box.vertices)[np.asarray(box.faces)]
    fn = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
    normals, smooth = corner_normals(box, math.radians(degrees), return_smooth=True)
    assert turned or not smooth.any()           # turned: the two halves of a side differ by rounding (1e-16)
    np.testing.assert_allclose(normals, np.repeat(fn[:, None, :], 3, axis=1), rtol=0, atol=1e-12)

    flat = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], float)    # face 1: zero area
    sheet = trimesh.Trimesh(flat, [[0, 1, 2], [0, 1, 3]], process=False)
    got = corner_normals(sheet, math.radians(degrees))
    np.testing.assert_array_equal(got[1], 0.0)
    np.testing.assert_array_equal(got[0], [[0.0, 0.0, 1.0]] * 3)

    # the cap is at the float below pi/2: faces meeting at 89.9999 degrees are still smoothed (the
    # brute-force angle-weighted sum of their unit normals; both corners at vertex 0 are right angles)
    a = math.radians(89.9999)
    verts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -math.cos(a), math.sin(a)]])
    hinge = trimesh.Trimesh(verts, [[0, 1, 2], [1, 0, 3]], process=False)
    n0, n1 = np.array([0.0, 0.0, 1.0]), np.cross(verts[0] - verts[1], verts[3] - verts[1])
    n1 /= np.linalg.norm(n1)
    assert math.degrees(math.acos(n0 @ n1)) == pytest.approx(89.9999, abs=1e-9)
    np.testing.assert_allclose(corner_normals(hinge, math.radians(degrees))[0, 0],
                               (n0 + n1) / np.linalg.norm(n0 + n1), rtol=0, atol=1e-12)


@pytest.mark.parametrize("points, faces, error, match", [
    (None, [[0, 1, 2, 3], [4, 5, 6, 7], [0, 1, 5, 4]], ValueError, r"faces must have shape \(n, 3\), got \(3, 4\)"),
    ("pairs", None, ValueError, r"points must have shape \(n, 3\), got \(12, 2\)"),
    (None, "float", TypeError, r"faces must be integers, got dtype float64"),
    (None, "negative", ValueError, r"faces: vertex indices must be in \[0, 8\) \(got -1 to 7\)"),
])
def test_concave_vertices_refuses_arrays_not_of_its_shapes(points, faces, error, match):
    """Was: both arrays were reshaped to (n, 3): a room's quads (3, 4) were read as 4 other triangles (none
    of its 8 concave corners found, silently), (12, 2) points as 8 other points, float indices were
    truncated and -1 read the last vertex."""
    room = trimesh.creation.box()
    F = np.asarray(room.faces)[:, ::-1]
    P = np.asarray(room.vertices)
    assert len(concave_vertices(P, F)[0]) == 8                      # the room's corners, as given
    if isinstance(points, str):
        P = P.reshape(-1)[:24].reshape(12, 2)
        F = F[:4] % 8
    if isinstance(faces, str):
        F = F + 0.25 if faces == "float" else np.vstack([F, [[-1, 0, 1]]])
    elif faces is not None:
        F = np.asarray(faces)
    with pytest.raises(error, match=match):
        concave_vertices(P, F)

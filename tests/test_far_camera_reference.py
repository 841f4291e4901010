"""Embree's reference render from a camera far from the scene (pyshadow/gbuffer.py ``on_face_planes``,
pyshadow/render.py ``_points_at``, pyshadow/embree.py ``gbuffer``).

Each test whose docstring starts "Was:" failed on the code before the fix and says what happened; the others pin
what the fix leaves alone.
"""
from __future__ import annotations

import numpy as np
import pytest

import pyshadow
from conftest import far_camera, far_sphere_scene
from pyshadow import embree
from pyshadow.gbuffer import on_face_planes


@pytest.fixture(scope="module")
def scene():
    return far_sphere_scene()


def _mean_ao(frame) -> float:
    return float(frame.ao[frame.object_id != -1].mean())


@pytest.fixture(scope="module")
def near_ao(scene):
    """Embree's mean AO over the covered pixels (every one) from 300 radii: 0.8233 (the CSM's 0.8238)."""
    return _mean_ao(embree.render(scene, far_camera(300.0), sampling=pyshadow.Sampling(16)))


@pytest.mark.parametrize("distance", [1e4, 1e5])
def test_embree_reference_keeps_its_ao_from_far_away(scene, near_ao, distance):
    """Was: the surface points were the eye plus the G-buffer's float32 depth, off their surface by about 6e-8 of
    the distance, and Embree's primary rays met triangles rounded to float32 relative to the eye; Embree lifts a
    point 2e-5 of the scene's scale, so its AO rays started behind their surface: mean AO 0.823 from 300 radii,
    0.509 from 1e4 and 0.601 from 1e5. Now each point lies on its face's plane in float64 and the primary rays
    start by the scene: the mean moves by less than 0.005 (one ray in 200)."""
    far = _mean_ao(embree.render(scene, far_camera(distance), sampling=pyshadow.Sampling(16)))
    assert abs(far - near_ao) < 0.005, (far, near_ao)


def test_far_csm_render_keeps_its_ground(scene, near_ao):
    """Was: the CSM's render darkened from far away too, on the ground: a point of the ground plane off it by a
    float32 spacing of its depth lay below the plane's tolerance (1e-5 of the scene's scale) and its rays up met
    the ground: mean AO 0.506 from 1e4 radii, where Embree's from 300 radii is 0.823. Now the
    frame's points lie on their faces' planes once 16 float32 spacings of the farthest depth exceed that
    tolerance: from 1e4 radii the CSM's mean is within 0.005 of Embree's from 300 (0.8236 against 0.8233)."""
    csm = _mean_ao(scene.render(far_camera(1e4), sampling=pyshadow.Sampling(16)))
    assert abs(csm - near_ao) < 0.005, (csm, near_ao)


def test_on_face_planes_put_points_on_their_faces(scene):
    """From 1e6 radii, eye + depth * ray lies on its face's plane to float64 rounding of the distance (4e-10 here,
    asserted below 1e-14 of it), where the float32 depth leaves it up to 0.1 off (0.025 the median); pixels without
    a face keep their depth."""
    cam = far_camera(1e6)
    items = scene.draw_items()[0]
    g = pyshadow.render_gbuffer(items, cam)
    index = np.flatnonzero(g["object_id"].reshape(-1) == 0)
    assert len(index) > 200
    covered = g["object_id"] != -1
    depth = on_face_planes(items, g, cam, covered)["depth"].reshape(-1)[index]
    assert on_face_planes(items, g, cam, covered, tolerance=2.0) is g        # 16 float32 spacings of 1.2e6: 2.0
    assert on_face_planes(items, g, cam, covered, tolerance=1.9) is not g
    dirs = cam.ray_directions().reshape(-1, 3)[index]
    mesh = items[0][0]
    tri = np.asarray(mesh.vertices)[np.asarray(mesh.faces)[g["face"].reshape(-1)[index]]]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)

    def off(d):
        return np.abs(np.einsum("ij,ij->i", cam.eye + d[:, None] * dirs - tri[:, 0], n))
    assert off(depth).max() < 1e-14 * 1e6
    assert off(g["depth"].reshape(-1)[index].astype(np.float64)).max() > 0.01
    no_face = {k: v for k, v in g.items() if k != "face"}
    assert on_face_planes(items, no_face, cam, covered) is no_face

"""The render stage (pyshadow/render.py) against independent computations of the same answers, third pass: a
frame's smooth shading normals and mesh colours against their float64 interpolation at the exact point where each
pixel's ray meets its face; the AO of ``ao_scale`` > 1 against the full-resolution render's.

Each test whose docstring starts "Was:" failed on the code before the fix and says what happened; the others pin
what the fix leaves alone.
"""
from __future__ import annotations

import numpy as np
import pytest

import pyshadow
from conftest import far_camera, far_sphere_scene
from pyshadow.gbuffer import face_corners
from pyshadow.materials import barycentrics
from pyshadow.shading_normals import corner_normals, pixel_surface, shading_gbuffer


@pytest.fixture(scope="module")
def scene():
    return far_sphere_scene()


def _exact_shading_normals(scene, camera, frame):
    """(K,) sphere pixels of ``frame`` and their shading normals interpolated in float64 at the exact intersection
    of each pixel's ray with its face's plane (the module docstring of pyshadow.shading_normals), turned to the
    frame's geometric normal."""
    items = scene.draw_items()[0]
    idx = np.flatnonzero(frame.object_id.reshape(-1) == 0)
    face = pyshadow.render_gbuffer(items, camera)["face"].reshape(-1)[idx]
    tri = face_corners(items, 0, face, camera.eye)
    d = camera.ray_directions().reshape(-1, 3)[idx]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    t = np.einsum("ij,ij->i", tri[:, 0], n) / np.einsum("ij,ij->i", d, n)
    ns = np.einsum("nk,nkj->nj", barycentrics(t[:, None] * d, tri), corner_normals(items[0][0])[face])
    ns /= np.linalg.norm(ns, axis=1, keepdims=True)
    ns *= np.sign(np.einsum("ij,ij->i", ns, frame.geometric_normal.reshape(-1, 3)[idx]))[:, None]
    return idx, ns


@pytest.mark.parametrize("distance", [1e5, 1e6])
def test_far_camera_smooth_normals_are_interpolated_on_the_faces(scene, distance):
    """Was: render(normals="smooth") took each pixel's barycentrics at ``eye + depth * ray`` with the G-buffer's
    float32 depth, which misses the face by about 6e-8 of the distance: from 1e5 radii the sphere's shading
    normals were off their float64 interpolation by up to 0.22 degrees (83 of 316 pixels by more than 0.1), from
    1e6 radii by up to 3.5 degrees (mean 1.2, 300 of 316 pixels beyond 0.1), while the frame's AO points (and its
    geometric normals) were already exact there. Now the barycentrics are taken at the points on the faces' planes
    once the depth's rounding reaches 100 times the ground's tolerance: 4e-8 radians off (float32 rounding)."""
    camera = far_camera(distance)
    frame = pyshadow.render.render(scene, camera, sampling=pyshadow.Sampling(4), normals="smooth")
    idx, exact = _exact_shading_normals(scene, camera, frame)
    assert len(idx) == 316
    off = np.linalg.norm(frame.normal.reshape(-1, 3)[idx] - exact, axis=1)
    assert off.max() <= 1e-6, off.max()


def test_near_camera_smooth_normals_keep_the_float32_depths(scene):
    """What the fix leaves alone: from 10 radii 16 float32 spacings of the farthest depth stay within 100 times
    the ground's tolerance, and the frame's shading normals are those interpolated at the G-buffer's own float32
    depths, bit for bit (within 1e-5 radians of the float64 interpolation: 2.7e-6 measured)."""
    camera = far_camera(10.0)
    items = scene.draw_items()[0]
    frame = pyshadow.render.render(scene, camera, sampling=pyshadow.Sampling(4), normals="smooth")
    g = pyshadow.render_gbuffer(items, camera)
    own = shading_gbuffer(items, g, camera, surface=pixel_surface(items, g, camera))
    np.testing.assert_array_equal(frame.normal, own["normal"])
    idx, exact = _exact_shading_normals(scene, camera, frame)
    off = np.linalg.norm(frame.normal.reshape(-1, 3)[idx] - exact, axis=1)
    assert 1e-8 < off.max() <= 1e-5, off.max()


def test_far_camera_vertex_colours_are_interpolated_on_the_faces(monkeypatch):
    """Was: a lit render took the pixels' mesh colours at the same float32-depth points as their smooth normals:
    a sphere whose vertex colours vary over it, seen from 1e6 radii, had colours off their interpolation at the
    exact ray-face points by up to 0.148 (280 of its 316 pixels by more than 1/255; 0.009 and 29 pixels from
    1e5 radii). Now they are taken at the points on the faces' planes: within float32 rounding."""
    import trimesh

    from pyshadow import materials

    mesh = trimesh.creation.icosphere(3, radius=1.0)
    v = mesh.vertices
    rgb = np.stack([0.5 + 0.5 * np.sin(7 * v[:, 0]), 0.5 + 0.5 * np.cos(5 * v[:, 1]), 0.5 + 0.5 * v[:, 2]], 1)
    mesh.visual = trimesh.visual.ColorVisuals(mesh, vertex_colors=np.round(255 * rgb).astype(np.uint8))
    scene = pyshadow.Scene(ground=-0.9, views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
    scene.add(pyshadow.load_mesh(mesh))
    seen, colours = [], materials.surface_colours

    def spy(items, item, face, bary):           # what the render stage reads the colours at
        seen.append((item, face, bary))
        return colours(items, item, face, bary)

    monkeypatch.setattr(materials, "surface_colours", spy)
    camera = far_camera(1e6)
    pyshadow.render.render(scene, camera, sampling=pyshadow.Sampling(4), lighting=pyshadow.lighting.Lighting())
    (item, face, bary), = seen
    items = scene.draw_items()[0]
    on = item == 0
    idx = np.flatnonzero(pyshadow.render_gbuffer(items, camera)["object_id"].reshape(-1) >= 0)[on]
    tri = face_corners(items, 0, face[on], camera.eye)
    d = camera.ray_directions().reshape(-1, 3)[idx]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    t = np.einsum("ij,ij->i", tri[:, 0], n) / np.einsum("ij,ij->i", d, n)
    exact = barycentrics(t[:, None] * d, tri)
    assert on.sum() == 316
    got = colours(items, item[on], face[on], bary[on])
    want = colours(items, item[on], face[on], exact)
    assert np.abs(got - want).max() <= 1e-6, np.abs(got - want).max()


@pytest.mark.parametrize("ao_scale, was", [(2, 8), (4, 11)])
def test_ao_scale_computes_a_thin_pole_before_the_ground(ao_scale, was):
    """Was: with ao_scale > 1 a covered pixel got its own AO only where its upsampling window held no covered
    low-res pixel at all. A pole one pixel wide (column 15 of 33: never a sample's column) standing on the ground
    has ground samples in every window, none on it, so joint bilateral upsampling fell back to the ground's AO:
    ``was`` of its 11 pixels read 1.0 (the ground's) where the full-resolution render reads 0.5 (half its
    hemisphere below the ground). Now a pixel whose window holds no sample of its own instance gets its own AO
    and bent normal, the full render's exactly."""
    import trimesh

    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    pose = np.eye(4)
    pose[1, 3] = 0.75
    scene.add(trimesh.creation.box((0.08, 1.5, 0.08)), pose)
    camera = pyshadow.Camera([0.15, 0.9, 4.0], [0.15, 0.6, 0.0], width=33, height=24)
    full = scene.render(camera, sampling=pyshadow.Sampling(8))
    pole = full.object_id == 0
    assert pole.sum() == 11 and set(np.nonzero(pole)[1]) == {15}
    np.testing.assert_array_equal(full.ao[pole], 0.5)
    frame = scene.render(camera, sampling=pyshadow.Sampling(8), ao_scale=ao_scale)
    np.testing.assert_array_equal(frame.ao[pole], full.ao[pole])
    np.testing.assert_array_equal(frame.bent_normal[pole], full.bent_normal[pole])
    ground = (full.object_id == pyshadow.scene.GROUND_ID) & (frame.object_id == full.object_id)
    assert np.abs(frame.ao - full.ao)[ground].max() <= 0.25         # the rest is upsampled as before

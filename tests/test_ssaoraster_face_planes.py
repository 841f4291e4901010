"""Differential tests of pyshadow.gbuffer.on_face_planes / face_corners for items drawn from a path or a
trimesh.Scene (render_gbuffer loads those with pyshadow.load_mesh)."""
import numpy as np
import pytest
import trimesh

from pyshadow import load_mesh
from pyshadow.camera import Camera
from pyshadow.gbuffer import face_corners, on_face_planes, render_gbuffer

FAR = 1e4


def _setup():
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    T = np.eye(4)
    T[0, 3] = FAR
    cam = Camera((FAR + 0.3, 0.4, 3.0), (FAR, 0.0, 0.0), width=12, height=9)
    return box, T, cam


def _exact_depth(box, T, cam, g):
    """float64 distance along each covered pixel's ray to its face's plane (reference)."""
    w = np.asarray(box.vertices) @ T[:3, :3].T + T[:3, 3] - cam.eye
    tri = w[np.asarray(box.faces)][g["face"][g["object_id"] >= 0]]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    d = cam.ray_directions()[g["object_id"] >= 0]
    return np.einsum("ij,ij->i", tri[:, 0], n) / np.einsum("ij,ij->i", d, n)


@pytest.mark.parametrize("form", ["path", "scene"])
def test_on_face_planes_takes_the_items_render_gbuffer_takes(form, tmp_path):
    """Was: render_gbuffer drew an item given as a path (or a trimesh.Scene), but on_face_planes on the same
    items raised AttributeError: 'str' object has no attribute 'faces' (face_corners read ``mesh.faces`` of the
    item as given). Now the item is loaded as render_gbuffer loads it, and the depths are the float64
    distances to the faces' planes (within 1e-12 relative; the float32 depths 1e4 away were off by up to 1.3e-7)."""
    box, T, cam = _setup()
    if form == "path":
        src = str(tmp_path / "box.stl")
        box.export(src)
    else:
        src = trimesh.Scene([box])
    items = [(src, T)]
    g = render_gbuffer(items, cam)
    cov = g["object_id"] >= 0
    assert cov.sum() > 10
    out = on_face_planes(items, g, cam, cov)
    ref = _exact_depth(load_mesh(src), T, cam, g)
    np.testing.assert_allclose(out["depth"][cov], ref, rtol=1e-12)
    corners = face_corners(items, 0, g["face"][cov][:3])
    assert corners.shape == (3, 3, 3)
    # the same as the loaded Trimesh drawn directly
    loaded = [(load_mesh(src), T)]
    np.testing.assert_array_equal(on_face_planes(loaded, render_gbuffer(loaded, cam), cam, cov)["depth"], out["depth"])

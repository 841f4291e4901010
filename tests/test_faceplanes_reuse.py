"""The pixels' points on their faces' planes place only the corners of the pixels' faces.

``on_face_planes`` (``Scene.render``, ``surface_points``) and ``pixel_surface`` (smooth normals, surface colours)
used to place every vertex of every drawn item again after the G-buffer pass (116 ms of a frame of 100 bunnies, as
long as the G-buffer's own placing), to read three corners a pixel; ``face_corners`` now places only the rows of
the faces asked, each the same bit for bit.
"""
import tracemalloc

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.gbuffer import face_corners, on_face_planes, render_gbuffer
from pyshadow.shading_normals import pixel_surface

CAM = pyshadow.Camera((0.0, 1.0, 4.0), (0.0, 0.0, 0.0), fov_y=40.0, width=24, height=16)


def _turned(rng, scale=1.0, at=(0.0, 0.0, 0.0)):
    T = np.eye(4)
    T[:3, :3] = trimesh.transformations.random_rotation_matrix(rng.random(3))[:3, :3] * scale
    T[:3, 3] = at
    return T


def _peak(f):
    """Bytes allocated at the peak of ``f()`` beyond what was held before."""
    f()                                     # (caches: the camera's rays)
    tracemalloc.start()
    try:
        f()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_on_face_planes_places_only_the_pixels_corners():
    mesh = trimesh.creation.icosphere(subdivisions=6, radius=0.8)           # 40,962 vertices, 60 pixels
    items = [(mesh, _turned(np.random.default_rng(1)))]
    g = render_gbuffer(items, CAM)
    hit = g["object_id"] >= 0
    assert 30 < hit.sum() < 400
    every_vertex = 24 * len(mesh.vertices)                                  # one float64 (V, 3) array
    assert _peak(lambda: on_face_planes(items, g, CAM, hit, 0.0)) < every_vertex / 2
    assert _peak(lambda: pixel_surface(items, g, CAM)) < every_vertex / 2


def _every_vertex(items, item, face, origin):
    """face_corners as it was: every vertex of the item placed, then the faces' corners read."""
    mesh, T = items[item]
    T = np.asarray(T, dtype=np.float64)
    w = np.asarray(mesh.vertices, dtype=np.float64) @ T[:3, :3].T + (T[:3, 3] - np.asarray(origin, np.float64))
    return w[np.asarray(mesh.faces)[face]]


@pytest.mark.parametrize("seed", range(4))
def test_face_corners_are_every_vertex_placed_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    meshes = [trimesh.creation.icosphere(subdivisions=3), trimesh.creation.box((1e-3, 2.0, 3e3)),
              pyshadow.data.bunny()]
    items = [(m, _turned(rng, 10 ** rng.uniform(-4, 4), rng.normal(size=3) * 10 ** rng.uniform(-2, 6)))
             for m in meshes]
    for i, (mesh, _) in enumerate(items):
        for k in (1, 2, 5, 300, len(mesh.faces) // 3, 3 * len(mesh.faces)):    # fewer corners than vertices, more
            face = rng.integers(0, len(mesh.faces), k)
            for origin in ((0.0, 0.0, 0.0), rng.normal(size=3) * 1e3):
                got, want = face_corners(items, i, face, origin), _every_vertex(items, i, face, origin)
                assert got.shape == (k, 3, 3) and got.tobytes() == want.tobytes()
        assert face_corners(items, i, np.zeros(0, np.int64)).shape == (0, 3, 3)
        with pytest.raises(ValueError, match="rendered from other items"):
            face_corners(items, i, [len(mesh.faces)])


def test_on_face_planes_and_pixel_surface_as_before():
    """On a frame of several items and meshes (the ground's quad: more corners than vertices), bit for bit."""
    rng = np.random.default_rng(5)
    s = pyshadow.Scene(ground=0.0)
    for k in range(8):
        m = trimesh.creation.icosphere(subdivisions=2, radius=0.3) if k % 2 else trimesh.creation.box((0.4, 0.3, 0.5))
        s.add(m, _turned(rng, rng.uniform(0.5, 1.5), (rng.uniform(-1.5, 1.5), 0.6, rng.uniform(-1.5, 1.5))),
              casts=False)
    cam = pyshadow.Camera((0.0, 300.0, 400.0), (0.0, 0.0, 0.0), fov_y=0.6, width=96, height=72)
    items = s.draw_items()[0]
    g = render_gbuffer(items, cam)
    hit = g["object_id"] >= 0
    index = np.flatnonzero(hit)
    item, face = g["object_id"].reshape(-1)[index], g["face"].reshape(-1)[index]
    corners = np.empty((len(index), 3, 3))
    for i in np.unique(item):
        corners[item == i] = _every_vertex(items, i, face[item == i], cam.eye)
    a, b, c = np.moveaxis(corners, 1, 0)
    n = np.cross(b - a, c - a)
    dirs = cam._rays().reshape(-1, 3)[index]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.einsum("ij,ij->i", a, n) / np.einsum("ij,ij->i", dirs, n)
    want = g["depth"].astype(np.float64).reshape(-1)
    d = want[index]
    want[index] = np.where(np.abs(t - d) <= 1e-3 * d, t, d)
    got = on_face_planes(items, g, cam, hit)["depth"]
    assert got.tobytes() == want.reshape(got.shape).tobytes()
    assert not np.array_equal(got, g["depth"])                  # (the far camera: the depths were placed)
    _, item2, face2, bary = pixel_surface(items, g, cam)
    p = cam.eye + g["depth"].reshape(-1)[index, None].astype(np.float64) * cam.ray_directions().reshape(-1, 3)[index]
    from pyshadow.materials import barycentrics
    for i in np.unique(item2):
        sel = item2 == i
        assert bary[sel].tobytes() == barycentrics(p[sel], _every_vertex(items, i, face2[sel], (0, 0, 0))).tobytes()


def test_pixels_by_item_is_the_loop_over_unique_items():
    from pyshadow.gbuffer_items import pixels_by_item

    item = np.random.default_rng(0).integers(0, 9, 1000)
    got = [(int(i), sel.tolist()) for i, sel in pixels_by_item(item)]
    assert got == [(int(i), np.flatnonzero(item == i).tolist()) for i in np.unique(item)]
    assert list(pixels_by_item(np.zeros(0, np.int64))) == []

"""The G-buffer's host fast paths (pyshadow.gbuffer_frame: per-item boxes, triangles whose corners share one pixel
column or row left out, float32 corners gathered per vertex) at the extremes: bodies far from the origin (1e4 to
1e7), of 1e-4 and 1e5, float32 transforms and vertices, a grazing camera, a camera inside or touching a body,
duplicated bodies, degenerate faces, 3,000 tiny bodies, a body parked at 1e7. Each G-buffer is that of every
triangle tested one by one and every triangle rasterised, bit for bit, and frame_triangles' triangles are
gbuffer_triangles'; non-finite transforms are refused by both."""
import numpy as np
import pytest
import trimesh
from test_gbufspeed_frame import _exhaustive

import pyshadow
from pyshadow import gbuffer_frame
from pyshadow.gbuffer import gbuffer_triangles

ICO = trimesh.creation.icosphere(3, radius=0.3)
BOX = trimesh.creation.box([0.4, 0.3, 0.5])
T = trimesh.transformations.translation_matrix


def _bodies(off=0.0, k=1.0, n=30, eye=(0.0, 9.0, 14.0), fov=55.0, dtype=np.float64):
    rng = np.random.default_rng(0)
    items = []
    for i in range(n):
        q = rng.normal(size=4)
        A = trimesh.transformations.quaternion_matrix(q / np.linalg.norm(q))
        A[:3, :3] *= rng.uniform(0.5, 2.0) * k
        A[:3, 3] = k * np.array([rng.uniform(-8, 8), 0.4, rng.uniform(-8, 8)]) + off
        items.append((ICO if i % 3 else BOX, A.astype(dtype)))
    h = 40.0 * k
    ground = trimesh.Trimesh(np.array([[-h, 0, -h], [h, 0, -h], [h, 0, h], [-h, 0, h]]) + off, [[0, 2, 1], [0, 3, 2]],
                             process=False)
    cam = pyshadow.Camera(k * np.asarray(eye) + off, np.full(3, off), fov_y=fov, width=96, height=72)
    return items + [(ground, np.eye(4))], cam


def _case(name):
    if name.startswith("offset"):
        return _bodies(off=float(name.split()[1]))
    if name.startswith("scale"):
        k = float(name.split()[1])
        return _bodies(k=k, off=1e3 * k)
    if name == "float32":
        items, cam = _bodies(dtype=np.float32)
        return items + [(trimesh.Trimesh(ICO.vertices.astype(np.float32), ICO.faces, process=False), T([0, 1, 0]))], cam
    if name == "grazing":
        return _bodies(off=1e6, eye=(0.0, 1e-3, 30.0), fov=30.0)
    if name == "tiny pixels":
        return _bodies(off=1e7, eye=(0.0, 900.0, 1500.0), fov=3.0)
    items, cam = _bodies(n=6)
    if name == "inside a body":
        return items, pyshadow.Camera(items[1][1][:3, 3], [0, 0, 0], width=96, height=72)
    if name == "on a face":
        return [(trimesh.creation.box([2, 2, 2]), np.eye(4))], pyshadow.Camera([0, 0, 1], [0.3, 0.2, -3], width=64,
                                                                               height=48)
    if name == "duplicated":
        return items + items[:6] + items[:6], cam
    if name == "degenerate faces":
        deg = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [0, 1, 0]],
                              [[0, 1, 2], [0, 3, 4], [0, 0, 0], [1, 3, 0]], process=False)
        return items + [(deg, T([0, 1, 0]))], cam
    if name == "parked at 1e7":
        big = np.diag([1e5, 1e5, 1e5, 1.0]) @ np.eye(4)
        big[:3, 3] = [0.0, 0.0, -1e7]
        return items + [(ICO, T([1e7, 0, 0])), (BOX, big)], cam
    rng = np.random.default_rng(1)                          # 3,000 bodies of 1 mm
    tiny = trimesh.creation.icosphere(1, radius=5e-4)
    ground = trimesh.Trimesh([[-2, 0, -2], [2, 0, -2], [2, 0, 2], [-2, 0, 2]], [[0, 2, 1], [0, 3, 2]], process=False)
    items = [(tiny, T([rng.uniform(-1, 1), 5e-4, rng.uniform(-1, 1)])) for _ in range(3000)] + [(ground, np.eye(4))]
    return items, pyshadow.Camera([0, 1.5, 2], [0, 0, 0], width=96, height=72)


CASES = ["offset 1e4", "offset 1e7", "scale 1e-4", "scale 1e5", "float32", "grazing", "tiny pixels", "inside a body",
         "on a face", "duplicated", "degenerate faces", "parked at 1e7", "3000 tiny bodies"]


@pytest.mark.parametrize("name", CASES)
def test_fast_paths_answer_as_every_triangle_tested_and_rasterised(name, monkeypatch):
    from pyshadow.gbuffer_frame import frame_triangles

    items, cam = _case(name)
    tris, obj, face, near = gbuffer_triangles(items, cam)
    ft = frame_triangles(items, cam)
    every = np.arange(ft.n)
    assert ft.n == len(tris) and ft.near == near
    np.testing.assert_array_equal(ft.corners(every), tris)
    np.testing.assert_array_equal(ft.ids(every)[0], obj)
    for cull in (gbuffer_frame.CULL_PIXELS, 1e9):           # the items tested for triangles missing every centre
        monkeypatch.setattr(gbuffer_frame, "CULL_PIXELS", cull)
        fast = pyshadow.render_gbuffer(items, cam)
        with monkeypatch.context() as m:
            _exhaustive(m)
            slow = pyshadow.render_gbuffer(items, cam)
        for key, v in slow.items():
            np.testing.assert_array_equal(fast[key], v, err_msg=f"{key} ({name}, {cull})")
    assert (fast["object_id"] >= 0).any() or name == "on a face"


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("entry", [(0, 3), (1, 1), (3, 0), (3, 3)])
def test_non_finite_transforms_are_refused_by_name(bad, entry):
    items, cam = _bodies(n=4)
    A = np.eye(4)
    A[entry] = bad
    items.append((ICO, A))
    for f in (gbuffer_triangles, pyshadow.render_gbuffer):
        with pytest.raises(ValueError, match="transform of item 5 has non-finite entries"):
            f(items, cam)


def test_sub_pixel_bodies_of_few_faces_leave_out_their_triangles(monkeypatch):
    """3,000 bodies of 1 mm (80 faces), each within one pixel: nearly every triangle shares one pixel column or row
    with its corners, yet all were rasterised (239,362 of 239,602 triangles): raster_rows measured an item's pixels
    on span's box grown by two pixels a side (36-49 for a sub-pixel body), so bodies under ~150 faces were never
    tested."""
    items, cam = _case("3000 tiny bodies")
    kept = []
    rows = gbuffer_frame.FrameTriangles.raster_rows

    def spy(self, *a):
        src, out = rows(self, *a)
        kept.append((self.n, self.n if src is None else len(src)))
        return src, out
    monkeypatch.setattr(gbuffer_frame.FrameTriangles, "raster_rows", spy)
    pyshadow.render_gbuffer(items, cam)
    n, k = kept[-1]
    assert k < n // 4, f"{k} of {n} triangles rasterised"

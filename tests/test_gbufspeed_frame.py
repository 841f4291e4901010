"""render_gbuffer's host stage holds a frame's triangles with their items' vertices (pyshadow.gbuffer_frame).

It used to build every triangle's float64 camera-space corners ((N, 3, 3), gbuffer_triangles) and pass over them
a dozen times (guard band, sizes, the float32 copy, screen boxes), then copy the float32 triangles to the device
twice: 100 bunnies (6.9 M triangles) on a ground spent seconds a frame on the host. Now each per-triangle test is
first made for a whole item on a box around its vertices, only the items that do not pass are tested triangle by
triangle, the float32 corners are gathered from the vertices' and handed to the device without a copy, and the
triangles whose corners share one pixel column or row (no pixel centre in their screen box, in float64 and in the
kernels' float32) are not rasterised. Every answer is the same, bit for bit: these tests compare the triangles with
gbuffer_triangles' and the G-buffer with the one every triangle tested one by one gives.
"""
from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import gbuffer
from pyshadow.gbuffer import gbuffer_triangles

ICO = trimesh.creation.icosphere(3, radius=0.3)
BOX = trimesh.creation.box([0.4, 0.3, 0.5])


def _rot(rng):
    q = rng.normal(size=4)
    return trimesh.transformations.quaternion_matrix(q / np.linalg.norm(q))


def _ground(h=40.0):
    return trimesh.Trimesh([[-h, 0, -h], [h, 0, -h], [h, 0, h], [-h, 0, h]], [[0, 2, 1], [0, 3, 2]], process=False)


def _scene(name, seed=0):
    """(items, camera) of an ordinary scene: bodies of two meshes, interleaved, on a ground."""
    rng = np.random.default_rng(seed)
    k = {"tiny": 1e-9, "huge": 1e7}.get(name, 1.0)
    items = []
    for i in range(40):
        T = _rot(rng)
        T[:3, :3] *= rng.uniform(0.5, 2.0) * k
        if name == "sheared":
            T[:3, :3] = T[:3, :3] @ (np.eye(3) + 0.3 * rng.normal(size=(3, 3)))
        T[:3, 3] = k * np.array([rng.uniform(-8, 8), 0.4, rng.uniform(-8, 8)])
        items.append((ICO if i % 3 else BOX, T))
    ground = _ground()
    ground.vertices *= k
    items.append((ground, np.eye(4)))
    eye, target, fov = {"among": ([0.5, 0.3, 0.2], [3.0, 0.2, -4.0], 75.0),
                        "edges": ([-12.0, 2.0, 0.0], [-4.0, 0.0, -6.0], 35.0),
                        "far": ([0.0, 900.0, 1500.0], [0.0, 0.0, 0.0], 0.8),
                        "closeup": ([0.0, 0.45, 0.05], [0.0, 0.4, -1.0], 90.0)}.get(
        name, ([0.0, 9.0, 14.0], [0.0, 0.0, 0.0], 55.0))
    if name == "closeup":
        items = [(ICO, trimesh.transformations.translation_matrix([0.0, 0.4, -0.4]))] + items
    return items, pyshadow.Camera(k * np.array(eye), k * np.array(target), fov_y=fov, width=160, height=120)


SCENES = ["above", "among", "edges", "far", "sheared", "tiny", "huge", "closeup"]


@pytest.mark.parametrize("name", SCENES)
def test_frame_triangles_are_those_of_gbuffer_triangles(name):
    """The same triangles, items, faces and near plane, bit for bit and in the same order."""
    from pyshadow.gbuffer_frame import frame_triangles

    items, cam = _scene(name)
    tris, obj, face, near = gbuffer_triangles(items, cam)
    ft = frame_triangles(items, cam)
    assert ft.n == len(tris) and ft.near == near
    every = np.arange(ft.n)
    np.testing.assert_array_equal(ft.corners(every), tris)
    o, f = ft.ids(every)
    np.testing.assert_array_equal(o, obj)
    np.testing.assert_array_equal(f, face)


def _exhaustive(monkeypatch):
    """render_gbuffer as it was: every triangle tested one by one, every triangle rasterised."""
    from pyshadow import gbuffer_frame

    every = (lambda self, *a, **k: np.arange(self.n))
    for name in ("guard_candidates", "wide_candidates", "large_candidates", "small_candidates"):
        monkeypatch.setattr(gbuffer_frame.FrameTriangles, name, every)
    monkeypatch.setattr(gbuffer_frame, "CELL_REACH", 0.0)


@pytest.mark.parametrize("name", SCENES)
def test_the_g_buffer_is_that_of_every_triangle_tested_and_rasterised(name, monkeypatch):
    """Item bounds, candidates and the triangles left out change no bit of any G-buffer array, on the kernels' one
    and two passes, whichever items are tested for triangles that hold no pixel centre (all of them: CULL_PIXELS
    1e9)."""
    from pyshadow import gbuffer_frame

    items, cam = _scene(name)
    for one_pass, cull in ((True, gbuffer_frame.CULL_PIXELS), (False, gbuffer_frame.CULL_PIXELS), (True, 1e9)):
        monkeypatch.setattr(gbuffer, "ONE_PASS", one_pass)
        monkeypatch.setattr(gbuffer_frame, "CULL_PIXELS", cull)
        fast = pyshadow.render_gbuffer(items, cam)
        with monkeypatch.context() as m:
            _exhaustive(m)
            slow = pyshadow.render_gbuffer(items, cam)
        assert (fast["object_id"] >= 0).any()
        for key, v in slow.items():
            np.testing.assert_array_equal(fast[key], v, err_msg=f"{key} ({name}, one pass {one_pass}, {cull})")


@pytest.mark.parametrize("name", SCENES)
def test_candidates_hold_every_triangle_its_test_picks(name):
    """Each per-triangle test of render_gbuffer, made on gbuffer_triangles' corners, picks only candidates."""
    from pyshadow.gbuffer_frame import frame_triangles

    items, cam = _scene(name)
    tris = gbuffer_triangles(items, cam)[0]
    ft = frame_triangles(items, cam)
    W, H = cam.width, cam.height
    fx, fy = (float(np.float32(W / (2.0 * cam.tan_half * cam.aspect))), float(np.float32(H / (2.0 * cam.tan_half))))
    gx, gy = gbuffer.GUARD_BAND * cam.tan_half * cam.aspect, gbuffer.GUARD_BAND * cam.tan_half
    size, first = gbuffer._size_first(tris)
    x, y, z = tris[..., 0], tris[..., 1], tris[..., 2]
    picked = {"guard": ((np.abs(x) > gx * z) | (np.abs(y) > gy * z)).any(axis=1),
              "large": size > gbuffer.PLANE_SIZE * first, "small": first > gbuffer.FAR_NORMAL_RATIO * size,
              "wide": gbuffer._wide_rows(tris, W, H, fx, fy)[0].astype(bool)}
    cand = {"guard": ft.guard_candidates(gx, gy), "large": ft.large_candidates(gbuffer.PLANE_SIZE),
            "small": ft.small_candidates(gbuffer.FAR_NORMAL_RATIO),
            "wide": ft.wide_candidates(W, H, fx, fy, gbuffer.WIDE_PIXELS, gbuffer._span)}
    for key, c in cand.items():
        assert set(np.flatnonzero(picked[key])) <= set(c.tolist()), key
    assert len(cand["guard"]) < max(ft.n, 10) or name == "closeup"


def test_many_bodies_rasterise_only_triangles_that_may_cover_a_pixel(monkeypatch):
    """60 spheres of 20,480 faces, each a few pixels wide: the kernels are given the triangles that may hold a pixel
    centre (before: all 1.2 M), and the host keeps no per-triangle float64 copy (before: 88 MB of corners)."""
    rng = np.random.default_rng(3)
    ball = trimesh.creation.icosphere(5, radius=0.25)
    items = [(ball, trimesh.transformations.translation_matrix([rng.uniform(-6, 6), 0.25, rng.uniform(-6, 6)]))
             for _ in range(60)] + [(_ground(), np.eye(4))]
    cam = pyshadow.Camera([0.0, 10.0, 16.0], [0.0, 0.0, 0.0], width=320, height=240)
    n = 60 * len(ball.faces) + 2
    launched = []
    kernel = pyshadow._cl.kernel

    def spy(source, name, defines=None):
        k = kernel(source, name, defines)
        if name != "gbuffer_raster":
            return k
        return lambda q, size, *a: (launched.append(size[0]), k(q, size, *a))[1]
    monkeypatch.setattr(pyshadow._cl, "kernel", spy)
    pyshadow.render_gbuffer(items, cam)                 # (kernels built)
    tracemalloc.start()
    g = pyshadow.render_gbuffer(items, cam)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert (g["object_id"][g["object_id"] >= 0] < 60).sum() > 2000
    assert 0 < launched[-1] < n // 4
    assert peak < 32 * n, f"{peak / n:.1f} bytes a triangle"


def test_meshes_edited_in_place_and_items_added_or_removed_between_frames():
    """Nothing is kept between frames: a mesh edited in place (through its tracked array, or a plain view of it),
    and items added or removed, give the G-buffer of fresh copies."""
    items, cam = _scene("above")
    mesh = ICO.copy()
    items = [(mesh, T) for _, T in items[:10]] + items[10:]

    def same(a, b):
        for key in a:
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)

    def fresh(its):
        return pyshadow.render_gbuffer([(m.copy(), np.array(T)) for m, T in its], cam)
    pyshadow.render_gbuffer(items, cam)
    mesh.vertices[:, 1] *= 1.7                          # tracked
    same(pyshadow.render_gbuffer(items, cam), fresh(items))
    np.asarray(mesh.vertices)[:, 0] += 0.2              # a plain view: no tracking
    same(pyshadow.render_gbuffer(items, cam), fresh(items))
    mesh.faces = mesh.faces[::2]
    same(pyshadow.render_gbuffer(items, cam), fresh(items))
    for its in (items[3:], items + items[:4], items[:1]):
        same(pyshadow.render_gbuffer(its, cam), fresh(its))


@pytest.mark.parametrize("case", ["vertex nearer than near", "face cut in view", "nan transform", "beyond float32",
                                  "not a pair"])
def test_errors_are_those_of_gbuffer_triangles(case):
    """A scene gbuffer_triangles refuses is refused with the same error, naming the same item and face."""
    cam = pyshadow.Camera([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], width=64, height=48)
    far = trimesh.transformations.translation_matrix([0.0, 0.0, -1e7])
    items = [(ICO, trimesh.transformations.translation_matrix([0.0, 0.0, -3.0])), (ICO, far)]
    if case == "vertex nearer than near":
        items.append((ICO, trimesh.transformations.translation_matrix([0.0, 0.0, -0.31])))
    elif case == "face cut in view":
        wall = trimesh.Trimesh([[-5, -5, -1e-3], [5, -5, -1e-3], [0, 5, 5.0]], [[0, 1, 2]], process=False)
        items.append((wall, np.eye(4)))
    elif case == "nan transform":
        items.append((BOX, np.full((4, 4), np.nan)))
    elif case == "beyond float32":
        items.append((BOX, trimesh.transformations.translation_matrix([0.0, 0.0, -1e39])))
    else:
        items.append((BOX,))
    with pytest.raises(Exception) as want:
        gbuffer_triangles(items, cam)
    with pytest.raises(type(want.value)) as got:
        pyshadow.render_gbuffer(items, cam)
    assert str(got.value) == str(want.value)


def test_tiny_triangles_at_pixel_centres_are_rasterised_as_before(monkeypatch):
    """Triangles of a hundredth of a pixel down to 1e-7 pixels, each around a pixel centre with its corners at
    random offsets (some just inside, some just outside): the triangles left out hold no pixel centre in the
    kernels' float32 either, so the G-buffer is that of every triangle rasterised, bit for bit."""
    from pyshadow import gbuffer_frame

    monkeypatch.setattr(gbuffer_frame, "CULL_PIXELS", 1e9)          # one item across the view: tested too
    rng = np.random.default_rng(11)
    cam = pyshadow.Camera([0.2, 0.1, 0.3], [1.0, -0.4, -5.0], width=96, height=64, fov_y=50)
    W, H = cam.width, cam.height
    fx, fy = W / (2.0 * cam.tan_half * cam.aspect), H / (2.0 * cam.tan_half)
    n = 3000
    col, row = rng.integers(0, W, n).astype(float), rng.integers(0, H, n).astype(float)
    eps = 10.0 ** rng.uniform(-7, -2, n)
    shape = np.array([[-1.0, -1.0], [1.0, -0.5], [0.0, 1.0]])              # holds (0, 0) inside
    shift = rng.normal(size=(n, 1, 2)) * eps[:, None, None] * rng.uniform(0, 1.5, n)[:, None, None]
    shift[::2] = rng.uniform(0.1, 0.9, (n - n // 2, 1, 2))                  # half of them inside a pixel's cell
    off = shape[None] * eps[:, None, None] + shift
    z = rng.uniform(2.0, 8.0, n)[:, None]
    sx, sy = col[:, None] + off[..., 0], row[:, None] + off[..., 1]
    c = np.stack([(sx - (0.5 * W - 0.5)) / fx * z, ((0.5 * H - 0.5) - sy) / fy * z, np.broadcast_to(z, sx.shape)], -1)
    world = c.reshape(-1, 3) @ cam.rotation + cam.eye
    mesh = trimesh.Trimesh(world, np.arange(3 * n).reshape(n, 3), process=False)
    items = [(mesh, np.eye(4))]
    fast = pyshadow.render_gbuffer(items, cam)
    with monkeypatch.context() as m:
        _exhaustive(m)
        slow = pyshadow.render_gbuffer(items, cam)
    assert 200 < (slow["object_id"] >= 0).sum() < n
    for key, v in slow.items():
        np.testing.assert_array_equal(fast[key], v, err_msg=key)
    from pyshadow.gbuffer_frame import frame_triangles

    g = (gbuffer.GUARD_BAND * cam.tan_half * cam.aspect, gbuffer.GUARD_BAND * cam.tan_half)
    src = frame_triangles(items, cam).raster_rows(1.0, 0, (W, H, float(np.float32(fx)), float(np.float32(fy)), *g),
                                                  gbuffer._span)[0]
    assert n // 2 <= n - len(src) < 0.6 * n         # those inside a cell left out, most at a pixel centre kept


def test_item_boxes_hold_their_placed_vertices():
    """Each item's box (the mesh's box through its transform, with the rounding bound) holds every camera-space
    vertex gbuffer_items computes, whatever the scale, shear, distance from the origin or from the eye."""
    from pyshadow import gbuffer_items
    from pyshadow.gbuffer_frame import _bounds

    rng = np.random.default_rng(4)
    for trial in range(40):
        k = 10.0 ** rng.uniform(-8, 8)
        items = []
        for _ in range(5):
            T = _rot(rng)
            T[:3, :3] = T[:3, :3] @ (np.eye(3) + 0.5 * rng.normal(size=(3, 3))) * 10.0 ** rng.uniform(-3, 3) * k
            T[:3, 3] = rng.normal(size=3) * k * 10.0 ** rng.uniform(-2, 6)
            items.append((ICO if trial % 2 else BOX, T))
        cam = pyshadow.Camera(rng.normal(size=3) * k * 1e3, rng.normal(size=3) * k, width=32, height=24)
        for groups in (gbuffer_items._placed_by_mesh(items, cam), gbuffer_items._placed_one_by_one(items, cam)):
            for g in groups:
                lo, hi, err = _bounds(g, cam)
                assert (lo[:, None] <= g.c).all() and (g.c <= hi[:, None]).all()
                assert np.isfinite(err).all()


def test_edge_bounds_kept_between_frames_follow_the_mesh(monkeypatch):
    """A mesh's edge bounds (which pick the candidates for small and large triangles) are kept between frames while
    its vertices and faces are unchanged: shrunk in place through a plain view (untracked: its triangles become
    small for their distance), scaled back through trimesh, its faces replaced, the bounds are made anew and the
    G-buffer is that of every triangle tested; the kept meshes stay within their count and bytes."""
    from pyshadow import gbuffer_frame

    ball = trimesh.creation.icosphere(5, radius=0.3)          # 20,480 faces: kept
    assert len(ball.faces) >= gbuffer_frame.EDGE_HELD_FACES
    cam = pyshadow.Camera([0.0, 0.0, 60.0], [0.0, 0.0, 0.0], fov_y=0.05, width=64, height=48)
    items = [(ball, trimesh.transformations.translation_matrix([x, 0.0, 0.0])) for x in (-0.004, 0.0, 0.004)]

    def check():
        fast = pyshadow.render_gbuffer(items, cam)
        with monkeypatch.context() as m:
            _exhaustive(m)
            slow = pyshadow.render_gbuffer(items, cam)
        for key, v in slow.items():
            np.testing.assert_array_equal(fast[key], v, err_msg=key)
        v, f = np.asarray(ball.vertices, np.float64), np.asarray(ball.faces)
        got, want = gbuffer_frame.mesh_edges(ball, v, f), gbuffer_frame._edge_bounds(v, f)
        np.testing.assert_array_equal(got[0], want[0])
        assert got[1] == want[1]
        return (fast["object_id"] >= 0).sum()

    assert check() == 64 * 48
    np.asarray(ball.vertices)[:] *= 0.01                        # a plain view, untracked: small triangles now
    assert 20 < check() < 64 * 48
    ball.vertices = ball.vertices * 100.0
    assert check() == 64 * 48
    ball.faces = ball.faces[:, [0, 2, 1]]                       # other first corners
    check()
    for _ in range(3 * gbuffer_frame.EDGE_HELD_MESHES):
        m = trimesh.creation.icosphere(5)
        gbuffer_frame.mesh_edges(m, np.asarray(m.vertices, np.float64), np.asarray(m.faces))
    held = gbuffer_frame._held_edges
    assert len(held) <= gbuffer_frame.EDGE_HELD_MESHES
    assert sum(h[4] for h in held.values()) <= gbuffer_frame.EDGE_HELD_BYTES

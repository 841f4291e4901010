"""The G-buffer's items taken together by mesh (pyshadow.gbuffer_items) against the one-item-at-a-time path.

gbuffer_triangles and on_face_planes used to check, move and cut every item on its own (10,000 instances
of one box: 0.96 s and 0.69 s of a 2.3 s frame). They now take the items sharing a mesh object together;
every triangle, face, item index, depth and error must stay what the per-item loop below gives, bit for bit.
"""
import re
import sys
import warnings

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.gbuffer import _clip_near, face_corners, gbuffer_triangles, on_face_planes

ITEMS = sys.modules[gbuffer_triangles.__module__]      # the module that holds the host stage
BOX = trimesh.creation.box((0.3,) * 3)
ICO = trimesh.creation.icosphere(1, radius=0.25)
CYL = trimesh.creation.cylinder(0.15, 0.5, sections=8)


def quad(h, y=0.0, n=1):
    """A square of half-side ``h`` at height ``y``, ``n`` x ``n`` cells of two triangles."""
    u = np.linspace(-h, h, n + 1)
    X, Z = np.meshgrid(u, u)
    v = np.stack([X.ravel(), np.full(X.size, y), Z.ravel()], 1)
    i = (np.arange(n)[:, None] * (n + 1) + np.arange(n)).ravel()
    f = np.concatenate([np.stack([i, i + n + 1, i + 1], 1), np.stack([i + 1, i + n + 1, i + n + 2], 1)])
    return trimesh.Trimesh(v, f, process=False)


def place(p, s=1.0, angle=0.0):
    T = trimesh.transformations.rotation_matrix(angle, [0.3, 1, 0.2])
    T[:3, :3] *= s
    T[:3, 3] = p
    return T


def per_item_triangles(items, camera):
    """gbuffer_triangles one item at a time, as pyshadow did before items were grouped (valid items)."""
    R, tx, ty = camera.rotation, camera.tan_half * camera.aspect, camera.tan_half
    per, far = [], 0.0
    for oid, (mesh, T) in enumerate(items):
        T = np.asarray(T, np.float64)
        v = np.asarray(mesh.vertices, np.float64)
        c = (v @ T[:3, :3].T + T[:3, 3] - camera.eye) @ R.T
        x, y, z = c[:, 0], c[:, 1], c[:, 2]
        if not ((z <= 0).all() or (x > tx * z).all() or (x < -tx * z).all() or (y > ty * z).all()
                or (y < -ty * z).all()):
            far = max(far, float(np.abs(c).max()))
        per.append((c, np.asarray(mesh.faces), oid))
    near = max(far * 1e-6, 1e-30)
    out = []
    for c, faces, oid in per:
        x, y, z = c[:, 0], c[:, 1], c[:, 2]
        side = (z < near).astype(np.uint8)
        for bit, test in enumerate((x > tx * z, x < -tx * z, y > ty * z, y < -ty * z), 1):
            side |= test.astype(np.uint8) << bit
        corner = side[faces]
        keep = np.flatnonzero((corner[:, 0] & corner[:, 1] & corner[:, 2]) == 0)
        tri = c[faces[keep]]
        edge_on = ITEMS._edge_on_crossing(tri, near)
        if edge_on is not None:
            tri, keep = tri[~edge_on], keep[~edge_on]
        assert ITEMS._cut_in_view(tri, near, tx, ty) is None
        clipped, src = _clip_near(tri, near)
        out.append((clipped, np.full(len(clipped), oid, np.int32), keep[src]))
    return [np.concatenate(a) for a in zip(*out)], near


def per_item_depths(items, g, camera, covered):
    """on_face_planes' depths (tolerance 0) one item at a time, as before items were grouped."""
    index = np.flatnonzero(covered.reshape(-1))
    out = g["depth"].astype(np.float64).reshape(-1)
    item, face = g["object_id"].reshape(-1)[index], g["face"].reshape(-1)[index]
    dirs = camera._rays().reshape(-1, 3)[index]
    for i in np.unique(item):
        sel = np.flatnonzero(item == i)
        a, b, c = np.moveaxis(face_corners(items, i, face[sel], camera.eye), 1, 0)
        n = np.cross(b - a, c - a)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.einsum("ij,ij->i", a, n) / np.einsum("ij,ij->i", dirs[sel], n)
        d = out[index[sel]]
        out[index[sel]] = np.where(np.abs(t - d) <= 1e-3 * d, t, d)
    return out.reshape(g["depth"].shape)


def interleaved_scene(offset=0.0):
    """Bodies of three meshes in the order A, B, A, C, B, ..., two fine grounds and a coarse one crossing the near
    plane (the eye stands over them: each is clipped into pieces), a body behind the eye and one off to the side."""
    rng = np.random.default_rng(5)
    meshes = [BOX, ICO, BOX, CYL, ICO]
    o = np.array([offset, 0.0, offset])
    items = [(meshes[i % 5], place(o + [rng.uniform(-2, 2), 0.3, -rng.uniform(1, 6)], rng.uniform(0.5, 2),
                                   rng.uniform(0, 6))) for i in range(40)]
    fine = quad(100.0, n=6)
    items[3:3] = [(fine, place(o))]
    items[17:17] = [(quad(80.0, -0.01), place(o)), (BOX, place(o + [0, 0.3, 4]))]
    items[30:30] = [(fine, place(o + [0, -0.02, 0])), (ICO, place(o + [40, 0.3, -3]))]
    return items, pyshadow.Camera(o + [5, 0.6, 3], o + [0, 0, -5], width=64, height=48)


@pytest.mark.parametrize("chunk, part_faces", [(None, None), (24, 16), (1, 1), (10 ** 9, 10 ** 9)])
@pytest.mark.parametrize("offset", [0.0, 1e4])
def test_triangles_and_depths_are_those_of_the_per_item_loop(monkeypatch, chunk, part_faces, offset):
    """Was: every item moved, culled, clipped on its own. Taken together by mesh (stacked transforms moved in
    chunks, big meshes' items as parts of their own, groups interleaved A, B, A, C, B merged back into item
    order, near-plane pieces of several items put back after each item's whole triangles), the triangles,
    items, faces and on_face_planes' depths are bit for bit those of the per-item loop."""
    if chunk is not None:
        monkeypatch.setattr(ITEMS, "CHUNK_VERTICES", chunk, raising=False)
        monkeypatch.setattr(ITEMS, "PART_FACES", part_faces, raising=False)
    items, cam = interleaved_scene(offset)
    (tri, obj, face), near = per_item_triangles(items, cam)
    got = gbuffer_triangles(items, cam)
    assert len(np.unique(obj[tri[:, :, 2].min(axis=1) <= near * (1 + 1e-9)])) >= 3     # pieces of 3 grounds
    for a, b in zip(got, (tri, obj, face, near)):
        assert np.asarray(a).dtype == np.asarray(b).dtype
        np.testing.assert_array_equal(a, b)
    g = pyshadow.render_gbuffer(items, cam)
    covered = g["object_id"] != -1
    assert len(np.unique(g["object_id"][covered])) >= 10
    depth = on_face_planes(items, g, cam, covered)["depth"]
    np.testing.assert_array_equal(depth, per_item_depths(items, g, cam, covered))


def test_items_sharing_a_mesh_check_it_once(monkeypatch):
    """Was: 300 boxes sharing one mesh object ran check_mesh 300 times and check_transform 300 times (one
    item at a time; 10,000 boxes: 0.96 s in gbuffer_triangles). Now the mesh is checked once and the
    transforms as one stack (check_transform only for a matrix that fails the stacked test)."""
    calls = {"check_mesh": 0, "check_transform": 0}
    for name in calls:
        original = getattr(ITEMS, name)

        def counted(*a, _f=original, _n=name, **k):
            calls[_n] += 1
            return _f(*a, **k)
        monkeypatch.setattr(ITEMS, name, counted)
    T = np.tile(np.eye(4), (300, 1, 1))
    T[:, 0, 3], T[:, 2, 3] = np.arange(300) % 20 - 10.0, -(np.arange(300) // 20) - 2.0
    items = [(BOX, T[i]) for i in range(300)] + [(quad(30.0, -0.15), np.eye(4))]
    cam = pyshadow.Camera([0, 4, 4], [0, 0, -6], width=32, height=24)
    tri, obj, face, _ = gbuffer_triangles(items, cam)
    assert calls == {"check_mesh": 2, "check_transform": 0}
    assert len(set(obj.tolist())) > 100 and 300 in obj


def _raises(items, cam, kind, message):
    with pytest.raises(kind, match="^" + re.escape(message)) as err:
        gbuffer_triangles(items, cam)
    assert err.value.__context__ is None or err.value.__suppress_context__     # no internal error chained


def test_errors_name_the_first_failing_item():
    """Was: the items checked one at a time named the first item that fails, whatever fails. Taken together by
    mesh the messages stay the same: a mesh shared by items 2 and 4 named at item 2 before item 3's transform,
    a transform before a later bad mesh, a bool transform among floats (stacked it would pass as 0 and 1)."""
    nan = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [np.nan, 1, 0]], [[0, 1, 2]], process=False)
    cam = pyshadow.Camera([0, 3, 6], [0, 0, 0], width=16, height=12)
    ok = [(BOX if i % 2 else ICO, place([i * 0.4 - 2, 0.2, 0])) for i in range(10)]
    sing = np.eye(4)
    sing[0, 0] = 0.0
    items = list(ok)
    items[2], items[3], items[4] = (nan, np.eye(4)), (BOX, sing), (nan, np.eye(4))
    _raises(items, cam, ValueError, "item 2: 1 of 3 vertices are not finite (NaN or inf)")
    items[1] = (BOX, sing)
    _raises(items, cam, ValueError, "transform of item 1 is singular")
    items = list(ok)
    items[6], items[8] = (BOX, np.eye(4, dtype=bool)), 5
    _raises(items, cam, TypeError, "transform of item 6 must hold real numbers, got dtype bool")
    items[6] = (BOX, np.eye(4)[None])
    _raises(items, cam, ValueError, "transform of item 6 must be a 4x4 matrix, got shape (1, 4, 4)")
    items[6] = (BOX, place([1.7e308] * 3, 1.7e308))
    with warnings.catch_warnings():     # (the check's own sum overflows, before and after)
        warnings.simplefilter("ignore", RuntimeWarning)
        _raises(items, cam, ValueError, "item 6: its transform places vertices beyond float64's range from the camera")
    items[6] = ok[6]
    _raises(items, cam, ValueError, "item 8 must be a (mesh, 4x4 transform) pair")


def test_near_plane_errors_name_the_first_item_and_face():
    """Was: the near-plane checks ran item by item. With groups they still name the first item in order (item 2
    of the second mesh before item 3 of the first) and the face the near plane would cut."""
    cam = pyshadow.Camera([0, 0, 3], [0, 0, -1], width=32, height=24)
    items = [(BOX, place([0, 0, -50])), (ICO, place([0, 0, -10])), (ICO, place([0, 0, 2.95], 1e-3)),
             (BOX, place([0.01, 0, 2.95], 1e-3)), (quad(1e5), place([0, -5, 0]))]
    _raises(items, cam, ValueError, "render_gbuffer: item 2 has a vertex in view 0.0497 from the eye, nearer than "
                                    "the near plane 0.1 (1e-6 of the farthest geometry in view")
    cam = pyshadow.Camera([0.0, 1.5, 0.0], [0.0, 0.0, -2.0], width=16, height=12)
    items = [(BOX, place([0, 0.15, -30]))] + [(quad(1e7), place([0, -0.1 * i, 0])) for i in range(4)]
    _raises(items, cam, ValueError, "render_gbuffer: face 0 of item 1 reaches into the view nearer than the near "
                                    "plane 10 (1e-6 of the farthest geometry in view, 1e+07)")

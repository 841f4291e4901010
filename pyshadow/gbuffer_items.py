"""The items of a G-buffer on the host: their camera-space triangles and their faces' planes.

Part of stage "G-buffer" (:mod:`pyshadow.gbuffer`, which re-exports every name here). A scene of
many instances draws one (mesh, transform) item per instance, most sharing a few mesh objects:
the items sharing one mesh object are taken together, its checks made once, the transforms checked
as one stack and the vertices moved by one stacked ``np.matmul`` (the same arithmetic, bit for bit,
as item by item), and the per-triangle stages run once on the triangles of all items, in the order
item by item, faces in order. Every error is the one the items met one at a time would raise, naming
the same item and face: where the stacked pass fails it is redone item by item.
"""
from __future__ import annotations

import math

import numpy as np
import trimesh

from ._validate import FLOAT32_MAX, check_transform, check_transforms
from .camera import Camera
from .mesh import check_mesh, load_mesh

__all__ = ["gbuffer_triangles", "on_face_planes", "face_corners", "clip_polygon", "through_eye"]

#: Vertices moved by one stacked product (the items of a mesh are moved in chunks of about this many
#: vertices): bounds the temporaries to tens of megabytes whatever the mesh and the number of items.
CHUNK_VERTICES = 1 << 19


def _all3(m: np.ndarray) -> np.ndarray:
    """``m.all(axis=1)`` of an (N, 3) boolean array, by columns (NumPy's reduction over an axis of
    three is slower)."""
    return m[:, 0] & m[:, 1] & m[:, 2]


def _clip_near(tri: np.ndarray, near: float):
    """Clip camera-space triangles (N, 3, 3) to z >= near; returns (M, 3, 3) and source index."""
    z = tri[:, :, 2]
    inside = z >= near
    full = _all3(inside)
    if full.all():                                  # nothing crosses the near plane
        return tri, np.arange(len(tri))
    part = (inside[:, 0] | inside[:, 1] | inside[:, 2]) & ~full
    out = [tri[full]]
    src = [np.flatnonzero(full)]
    for i in np.flatnonzero(part):
        poly = []
        for k in range(3):
            a, b = tri[i, k], tri[i, (k + 1) % 3]
            ina, inb = a[2] >= near, b[2] >= near
            if ina:
                poly.append(a)
            if ina != inb:
                s = (near - a[2]) / (b[2] - a[2])
                p = a + s * (b - a)
                p[2] = near
                poly.append(p)
        for k in range(1, len(poly) - 1):
            out.append(np.stack([poly[0], poly[k], poly[k + 1]])[None])
            src.append(np.array([i]))
    return np.concatenate(out), np.concatenate(src)


def _clip_near_items(tri: np.ndarray, near: float, obj: np.ndarray, face: np.ndarray):
    """:func:`_clip_near` of the triangles ``tri`` (N, 3, 3) of many items (``obj`` (N,), ascending; ``face``
    (N,)) in the order it gives each item's own: item by item, its whole triangles, then the pieces of those
    crossing the near plane; those wholly nearer than it are dropped. Returns the triangles, their items and
    faces."""
    full = _all3(tri[:, :, 2] >= near)
    if full.all():
        return tri, obj, face
    cross = np.flatnonzero(~full)
    pieces, src = _clip_near(tri[cross], near)      # only pieces: none of these is whole
    src = cross[src]
    out = [], [], []
    prev = 0
    for i in np.unique(obj[cross]):                 # the items crossing: few (a ground)
        s, e = np.searchsorted(obj, i, "left"), np.searchsorted(obj, i, "right")
        ps, pe = np.searchsorted(obj[src], i, "left"), np.searchsorted(obj[src], i, "right")
        whole = full[s:e]
        for k, (a, b) in enumerate(((tri, pieces), (obj, obj[src]), (face, face[src]))):
            out[k].extend((a[prev:s], a[s:e][whole], b[ps:pe]))
        prev = e
    return tuple(np.concatenate(o + [a[prev:]]) for o, a in zip(out, (tri, obj, face)))


def clip_polygon(poly, planes) -> list:
    """The convex polygon ``poly`` (a list of 3-vectors, float64) clipped to ``a . p <= b`` for each ``(a, b)``
    of ``planes`` (Sutherland-Hodgman); [] where less than a triangle is left. An edge is cut at the point
    computed from its lexicographically smaller end, so two polygons sharing the edge cut it alike."""
    for a, b in planes:
        cut = []
        for k in range(len(poly)):
            p, q = poly[k], poly[(k + 1) % len(poly)]
            fp, fq = a @ p - b, a @ q - b
            if fp <= 0:
                cut.append(p)
            if (fp <= 0) != (fq <= 0):
                if tuple(p) > tuple(q):
                    p, q, fp, fq = q, p, fq, fp
                cut.append(p + fp / (fp - fq) * (q - p))
        poly = cut
        if len(poly) < 3:
            return []
    return poly


def through_eye(tri) -> np.ndarray:
    """(N,) bool: which eye-relative triangles ``tri`` (N, 3, 3) lie in a plane through the eye, within 1e-12 of
    their farthest corner (float64's rounding of the camera transform): seen edge-on, they cover no pixel."""
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    reach = np.abs(tri).reshape(len(tri), 9).max(axis=1)
    return np.abs(np.einsum("ij,ij->i", n, tri[:, 0])) <= 1e-12 * np.linalg.norm(n, axis=1) * reach


def _edge_on_crossing(tri, near: float):
    """(N,) bool: which camera-space triangles ``tri`` (N, 3, 3) reaching nearer than the near plane lie in a plane
    through the eye (:func:`through_eye`): seen edge-on, they cover no pixel, and are dropped (the ground with the
    eye in it was refused as reaching into the view, or not, by the rounding of its area on screen); None where
    there is none."""
    below = tri[:, :, 2] < near
    part = np.flatnonzero(below[:, 0] | below[:, 1] | below[:, 2])
    if not len(part):
        return None
    flat = through_eye(tri[part])
    if not flat.any():
        return None
    out = np.zeros(len(tri), bool)
    out[part[flat]] = True
    return out


def _cut_in_view(tri, near: float, tx: float, ty: float):
    """Index of the first camera-space triangle of ``tri`` (N, 3, 3) whose part nearer than ``near`` lies
    in the view (half-widths ``tx``, ``ty`` at unit depth) with an area, which :func:`_clip_near` would cut
    from the image (a triangle wholly nearer, such as a wall filling the view from closer than the near plane,
    is cut whole); None if there is none. Only triangles whose box reaches the view's cross-section at
    ``near`` are clipped (in float64, by Sutherland-Hodgman) to the part of the view between 1e-3 ``near``
    (1e-3 of its farthest corner, where that is nearer) and ``near``, and count where that part has an area on
    the screen."""
    below = tri[:, :, 2] < near
    part = np.flatnonzero(below[:, 0] | below[:, 1] | below[:, 2])     # few: by columns first
    x, y = tri[part, :, 0], tri[part, :, 1]
    cand = part[(x.min(axis=1) <= tx * near) & (x.max(axis=1) >= -tx * near)
                & (y.min(axis=1) <= ty * near) & (y.max(axis=1) >= -ty * near)]
    sides = [(np.array(a, np.float64), 0.0) for a in ((1, 0, -tx), (-1, 0, -tx), (0, 1, -ty), (0, -1, -ty))]
    for i in cand:
        low = 1e-3 * min(near, float(tri[i, :, 2].max()))
        planes = [(np.array((0.0, 0.0, -1.0)), -low), (np.array((0.0, 0.0, 1.0)), near)] + sides
        poly = clip_polygon(list(tri[i]), planes)
        if poly:                            # its area on the screen (the view's [-1, 1]^2): an edge-on
            sx = np.array([p[0] / (p[2] * tx) for p in poly])      # plane through the eye has none
            sy = np.array([p[1] / (p[2] * ty) for p in poly])
            if abs(np.dot(sx, np.roll(sy, -1)) - np.dot(np.roll(sx, -1), sy)) > 2e-12:
                return int(i)
    return None


def _outside_view(c, tx, ty) -> np.ndarray:
    """(...) bool: whether the camera-space points ``c`` (..., N, 3) of each body all lie behind the eye or all
    beyond one side of the view (half-widths ``tx``, ``ty`` at unit depth): a body there covers no pixel."""
    x, y, z = c[..., 0], c[..., 1], c[..., 2]
    return ((z <= 0).all(axis=-1) | (x > tx * z).all(axis=-1) | (x < -tx * z).all(axis=-1)
            | (y > ty * z).all(axis=-1) | (y < -ty * z).all(axis=-1))


class _Group:
    """Items sharing one mesh: their indices ``oid`` (n,) ascending, the mesh's faces (F, 3), the items'
    vertices in camera space ``c`` (n, V, 3) float64 (:func:`_move`) and their checked transforms ``T``
    (n, 4, 4) float64 (None where not kept)."""

    def __init__(self, mesh, oid, faces, c, T=None):
        self.mesh, self.oid, self.faces, self.c = mesh, np.asarray(oid, np.int64), np.asarray(faces), c
        self.T = T


def _stack(ts) -> np.ndarray | None:
    """The 4x4 transforms ``ts`` as one (n, 4, 4) stack as given (float64 where their dtypes differ); None
    where one is no real 4x4 array (a bool dtype would pass once stacked with floats): check them one by one."""
    arrays = [np.asarray(t) for t in ts]
    kinds = {(a.dtype, a.shape) for a in arrays}
    if any(d.kind not in "iuf" or s != (4, 4) for d, s in kinds):
        return None
    return np.stack(arrays if len(kinds) == 1 else [a.astype(np.float64) for a in arrays])


def _move(v, T, camera: Camera) -> np.ndarray:
    """Camera-space vertices (n, V, 3) of vertices ``v`` (V, 3) placed by the checked transforms ``T``
    (n, 4, 4) float64: per item ``(v @ A.T + t - eye) @ R.T``, in chunks of :data:`CHUNK_VERTICES` (a
    stacked matmul computes each slice as the product of that slice alone)."""
    step = max(1, CHUNK_VERTICES // max(len(v), 1))
    c = np.empty((len(T), len(v), 3)) if len(T) > step else None
    for s in range(0, len(T), step):
        A = T[s:s + step, :3, :3]
        with np.errstate(over="ignore", invalid="ignore"):
            w = np.matmul(v, A.transpose(0, 2, 1))
            for k in range(3):          # in place, a coordinate at a time (long inner loops): the same sums
                wk = w[..., k]
                wk += T[s:s + step, None, k, 3]
                wk -= camera.eye[k]
            part = np.matmul(w, camera.rotation.T, out=None if c is None else c[s:s + step])
        if c is None:
            return part
    return c


def _spans(g):
    """Slices of the items of group ``g`` of about :data:`CHUNK_VERTICES` vertices in all: the per-vertex tests
    run a chunk at a time (their temporaries stay small whatever the scene)."""
    step = max(1, CHUNK_VERTICES // max(g.c.shape[1], 1))
    return [slice(s, s + step) for s in range(0, len(g.oid), step)]


def _finite(c) -> bool:
    """Whether every entry of ``c`` is finite (its sum, else each entry)."""
    with np.errstate(over="ignore", invalid="ignore"):
        return bool(np.isfinite(np.add.reduce(c, axis=None)) or np.isfinite(c).all())


def _placed_by_mesh(items, camera: Camera) -> list:
    """The items as :class:`_Group`: each mesh object checked once, its items' transforms as one stack.
    Raises (anything) where an item is not as it should be: :func:`_placed_one_by_one` then names it."""
    groups = {}
    for oid, (mesh, T) in enumerate(items):
        if not isinstance(mesh, trimesh.Trimesh):
            mesh = load_mesh(mesh)                  # a path: each item loads its own (load_mesh checks it)
        elif id(mesh) not in groups:                # a mesh object is used as it is: checked, once
            check_mesh(mesh, f"item {oid}")
        g = groups.setdefault(id(mesh), (mesh, [], []))
        g[1].append(oid)
        g[2].append(T)
    out = []
    for mesh, oid, ts in groups.values():
        T = _stack(ts)
        if T is None:
            raise ValueError("a transform is not a real 4x4 array")
        T = check_transforms(T, label=lambda k, oid=oid: f"transform of item {oid[k[0]]}")
        c = _move(np.asarray(mesh.vertices, dtype=np.float64), T, camera)
        if not _finite(c):
            raise ValueError("vertices beyond float64's range")
        out.append(_Group(mesh, oid, mesh.faces, c, T))
    return out


def _placed_one_by_one(items, camera: Camera) -> list:
    """The items as :class:`_Group` of one item each, checked and moved one at a time in order: the first
    item not as it should be raises its error."""
    out = []
    for oid, item in enumerate(items):
        try:
            mesh, T = item
        except (TypeError, ValueError):
            raise ValueError(f"item {oid} must be a (mesh, 4x4 transform) pair") from None
        if not isinstance(mesh, trimesh.Trimesh):
            mesh = load_mesh(mesh)
        else:                   # a mesh object is used as it is: NaN vertices or stray faces would drop triangles
            check_mesh(mesh, f"item {oid}")
        T = check_transform(T, name=f"transform of item {oid}")
        v = np.asarray(mesh.vertices, dtype=np.float64)
        with np.errstate(over="ignore", invalid="ignore"):
            w = v @ T[:3, :3].T + T[:3, 3]
            c = (w - camera.eye) @ camera.rotation.T
        if not np.isfinite(np.add.reduce(c, axis=None)) and not np.isfinite(c).all():
            raise ValueError(f"item {oid}: its transform places vertices beyond float64's range from the camera "
                             f"(largest |vertex| {float(np.abs(v).max()):.3g}, transform scale up to "
                             f"{float(np.abs(T[:3, :3]).max()):.3g})")
        out.append(_Group(mesh, [oid], mesh.faces, c[None], T[None]))
    return out


def _near_cut(groups, near: float, far: float, tx: float, ty: float) -> None:
    """Refuse the first item (in order) with a vertex in view nearer than the near plane: its triangles
    would be cut."""
    first = None
    for g in groups:
        for span in _spans(g):
            c = g.c[span]
            z = c[..., 2]
            cut = (z > 0) & (z < near) & (np.abs(c[..., 0]) <= tx * z) & (np.abs(c[..., 1]) <= ty * z)
            hit = np.flatnonzero(cut.any(axis=1))
            if len(hit):
                if first is None or g.oid[span][hit[0]] < first[0]:
                    first = int(g.oid[span][hit[0]]), float(z[hit[0]][cut[hit[0]]].min())
                break
    if first is None:
        return
    oid, zmin = first
    raise ValueError(f"render_gbuffer: item {oid} has a vertex in view {zmin:.3g} from the eye, "
                     f"nearer than the near plane {near:.3g} " + (
                         f"(1e-6 of the farthest geometry in view, {far:.3g}: the depth range float32's "
                         "rasteriser places in one view); draw the bodies near the camera as a scene of "
                         "their own" if near > 1e-30 else
                         f"(the smallest the G-buffer takes; the farthest geometry in view is {far:.3g} from "
                         "the eye); scale the scene and the camera up"))


#: A mesh of at least this many faces gives each of its items' triangles as a part of their own (the
#: original's per-item gathers, which cost no more there than the stacked index for all items would).
PART_FACES = 1024


def _in_frustum(g: _Group, tx: float, ty: float) -> list:
    """The triangles of group ``g`` not wholly outside one side of the view frustum, as parts: (K, 3, 3) camera
    space, their items (K,) int32 and faces (K,) int64, item by item, faces in order (one part for the group, or
    one for each item of a mesh of :data:`PART_FACES` or more). Each corner's side tests are bits of its vertex
    (the same comparisons of the same values as corner by corner); a triangle is out where its three corners
    share a bit. One wholly nearer than ``near`` but in front of the eye is kept (:func:`_near_stages` refuses
    it where it reaches into the view: dropped here, a wall filling the view from nearer than the near plane
    showed what lies behind it)."""
    side = np.empty(g.c.shape[:2], np.uint8)
    for span in _spans(g):
        x, y, z = g.c[span, :, 0], g.c[span, :, 1], g.c[span, :, 2]
        side[span] = z <= 0
        for bit, test in enumerate((x > tx * z, x < -tx * z, y > ty * z, y < -ty * z), 1):
            side[span] |= test.astype(np.uint8) << bit
    F = len(g.faces)
    if len(g.oid) == 1 or F >= PART_FACES:                  # one item (a ground, a lone body), or large meshes
        parts = []
        for k in range(len(g.oid)):
            corner = np.take(side[k], g.faces)              # (F, 3); indexing is slower
            face = np.flatnonzero((corner[:, 0] & corner[:, 1] & corner[:, 2]) == 0)
            if not len(face) and len(g.oid) > 1:
                continue
            tri = np.take(g.c[k], g.faces if len(face) == F else np.take(g.faces, face, axis=0), axis=0)
            parts.append((tri, np.full(len(face), g.oid[k], np.int32), face))
        return parts
    corner = np.take(side, g.faces, axis=1)                 # (n, F, 3)
    keep = (corner[..., 0] & corner[..., 1] & corner[..., 2]) == 0
    if keep.all():                                          # every item's every face (all in view)
        return [(np.take(g.c, g.faces, axis=1).reshape(-1, 3, 3), np.repeat(g.oid.astype(np.int32), F),
                 np.tile(np.arange(F), len(g.oid)))]
    item, face = np.nonzero(keep)
    V = g.c.shape[1]
    tri = np.take(g.c.reshape(-1, 3), np.take(g.faces, face, axis=0) + (item * V)[:, None], axis=0)
    return [(tri, g.oid[item].astype(np.int32), face)]


def _in_item_order(parts) -> list:
    """The parts (triangles, items, faces) of every group in the order item by item, each part's items before
    the next's: as they are where the groups follow one another (a ground after the bodies), else one part of
    them all in that order (an empty part where there is no triangle)."""
    full = sorted((p for p in parts if len(p[1])), key=lambda p: p[1][0])
    if not full:
        return parts[:1]
    if not any(a[1][-1] > b[1][0] for a, b in zip(full, full[1:])):
        return full
    tri, obj, face = (np.concatenate([p[k] for p in full]) for k in range(3))       # interleaved: A, B, A, ...
    order = np.argsort(obj, kind="stable")
    return [(tri[order], obj[order], face[order])]


def gbuffer_triangles(items, camera: Camera):
    """Camera-space, near-clipped triangles of ``items``.

    Returns
    -------
    tris : ndarray, shape (M, 3, 3), float64
        Corners in camera space (x right, y up, z forward, eye at 0).
    object_id : ndarray, shape (M,), int32
        Index of the item each triangle comes from.
    face : ndarray, shape (M,), int64
        Face index within its item's mesh.
    near : float
        The near-plane distance used.
    """
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a pyshadow.Camera, got {type(camera).__name__}")
    items = list(items)
    tx = camera.tan_half * camera.aspect
    ty = camera.tan_half
    try:
        groups = _placed_by_mesh(items, camera)
    except Exception:           # an item not as it should be: the error of the first, met one at a time
        groups = None           # (raised below, not while handling this one: its traceback is the user's)
    if groups is None:
        groups = _placed_one_by_one(items, camera)
    far = 0.0
    for g in groups:            # an item wholly outside the view sets no near plane
        for c in (g.c[span] for span in _spans(g) if g.c.shape[1]):
            out = _outside_view(c, tx, ty)
            if not out.all():
                far = max(far, float(np.abs(c if not out.any() else c[~out]).max()))
    _check_reach(camera, far)
    near = max(far * 1e-6, 1e-30)
    _near_cut(groups, near, far, tx, ty)
    parts = [p for g in groups if len(g.faces) for p in _in_frustum(g, tx, ty)]
    if not parts:
        return np.zeros((0, 3, 3)), np.zeros(0, np.int32), np.zeros(0, np.int64), near
    done = []
    for tri, obj, face in _in_item_order(parts):
        if not _all3(tri[:, :, 2] >= near).all():          # crossing the near plane (a ground): clipped
            tri, obj, face = _near_stages(tri, obj, face, near, far, tx, ty)
        done.append((tri, obj, face))
    if len(done) == 1:
        return (*done[0], near)
    return (*(np.concatenate([d[k] for d in done]) for k in range(3)), near)


def _check_reach(camera: Camera, far: float) -> None:
    """Refuse geometry in view (``far``: its largest camera-space coordinate) beyond float32's range."""
    reach = float(np.abs(camera.eye).max()) + math.sqrt(3.0) * far
    if not reach <= FLOAT32_MAX:        # the G-buffer's depths and positions are float32
        raise ValueError(f"render_gbuffer: the geometry in view lies up to {reach:.3g} from the world origin "
                         f"(eye {camera.eye.tolist()}, farthest geometry in view {far:.3g} from it); the G-buffer's "
                         f"float32 depths and positions hold at most {FLOAT32_MAX:.3g}")


def _near_stages(tri, obj, face, near: float, far: float, tx: float, ty: float):
    """The triangles ``tri`` (N, 3, 3) of items ``obj`` (N,), ascending, faces ``face`` (N,), as the near plane
    leaves them: those seen edge-on dropped, a face it would cut in view refused, the rest clipped."""
    edge_on = _edge_on_crossing(tri, near)
    if edge_on is not None:
        tri, obj, face = tri[~edge_on], obj[~edge_on], face[~edge_on]
    lost = _cut_in_view(tri, near, tx, ty)
    if lost is not None:
        raise ValueError(f"render_gbuffer: face {int(face[lost])} of item {int(obj[lost])} reaches into the "
                         f"view nearer than the near plane {near:.3g} (1e-6 of the farthest geometry in view, "
                         f"{far:.3g}), which would cut it away there (the pixels would show what lies behind "
                         f"it); draw it smaller (a smaller ground_size for the ground) or far geometry as a "
                         f"scene of its own")
    return _clip_near_items(tri, near, obj, face)


def _drawn_mesh(mesh) -> trimesh.Trimesh:
    """The mesh an item's ``mesh`` draws: a Trimesh as it is, else (a path, a trimesh.Scene) what
    :func:`pyshadow.load_mesh` makes of it, as :func:`gbuffer_triangles` loads it (whose faces a G-buffer's
    ``face`` counts)."""
    return mesh if isinstance(mesh, trimesh.Trimesh) else load_mesh(mesh)


def face_corners(items, item: int, face, origin=(0.0, 0.0, 0.0)) -> np.ndarray:
    """(K, 3, 3) float64 world corners, minus ``origin`` (3,), of the faces ``face`` (K,) of drawn item ``item``
    of ``items``; a ValueError naming a face its mesh does not have (a G-buffer rendered from other items), not
    an IndexError or a face counted from the end.

    Where the faces have fewer corners than the mesh vertices, only theirs are placed: ``v @ A.T + (t - origin)``
    of those rows of the vertices ``v``, each row the same, bit for bit, as where every vertex is placed (a matrix
    product's row is the product of that row).
    """
    mesh, T = items[item]
    mesh = _drawn_mesh(mesh)
    face = np.asarray(face)
    bad = (face < 0) | (face >= len(mesh.faces))
    if bad.any():
        raise ValueError(f"gbuffer['face'] holds face {int(face[bad][0])} of item {int(item)}, whose mesh has "
                         f"{len(mesh.faces)} faces (the G-buffer was rendered from other items)")
    T = np.asarray(T, dtype=np.float64)
    v, vid = np.asarray(mesh.vertices, dtype=np.float64), np.take(mesh.faces, face, axis=0)
    few = vid.size < len(v)
    w = (np.take(v, vid.reshape(-1), axis=0) if few else v) @ T[:3, :3].T     # (3 or more rows: a matrix product)
    shift = T[:3, 3] - np.asarray(origin, np.float64)
    for k in range(3):                              # + shift, a coordinate at a time (long inner loops)
        w[:, k] += shift[k]
    return w.reshape(len(face), 3, 3) if few else np.take(w, vid, axis=0)


def pixels_by_item(item):
    """``(i, sel)`` for each distinct value ``i`` of ``item`` (K,) ints, ascending, ``sel`` the indices where
    ``item == i``, ascending (as ``np.flatnonzero(item == i)``; one sort, not a pass over ``item`` per value)."""
    item = np.asarray(item)
    order = np.argsort(item, kind="stable")
    for sel in np.split(order, np.flatnonzero(np.diff(item[order])) + 1) if len(item) else ():
        yield item[sel[0]], sel


def _corners_one_by_one(items, item, face, origin):
    """(K, 3, 3): :func:`face_corners` of each pixel's item ``item`` (K,) and face ``face`` (K,), item by item."""
    out = np.empty((len(item), 3, 3))
    for i, sel in pixels_by_item(item):
        out[sel] = face_corners(items, i, np.take(face, sel), origin)
    return out


def on_face_planes(items, gbuffer, camera: Camera, covered, tolerance: float = 0.0) -> dict:
    """``gbuffer`` with each covered pixel's point on the plane of its face, where float32 depths could miss it.

    A G-buffer's float32 ``depth`` puts a pixel's point ``eye + depth * ray`` off its surface by about
    a float32 spacing of the depth: from a far camera, more than a ray tracer's lift off a surface or
    the ground plane's tolerance (then rays start behind the surface). The pixel's face (``object_id``,
    ``face``; world corners in float64, relative to the eye) and its ray give the distance to float64
    rounding.

    Parameters
    ----------
    items : sequence of (mesh, transform)
        The drawn items the G-buffer's ``object_id`` indexes (a mesh given as a path or a trimesh.Scene is
        loaded as :func:`render_gbuffer` loads it).
    gbuffer : dict
        :func:`render_gbuffer`'s form; without ``face`` it is returned as it is.
    camera : pyshadow.Camera
    covered : ndarray, shape (H, W), bool
        The pixels to place (``object_id != -1``).
    tolerance : float, optional
        World units: the depths are kept while 16 float32 spacings of the farthest covered depth stay
        within it (0: always placed).

    Returns
    -------
    dict
        ``gbuffer`` itself, or a shallow copy whose ``depth`` is float64 (H, W): along the unit rays
        of :meth:`pyshadow.Camera.ray_directions` to the face's plane on covered pixels, where that is
        within 1e-3 of the float32 depth (not a face seen edge-on); the float32 depth elsewhere.
    """
    depth = np.asarray(gbuffer["depth"])
    keep = np.asarray(covered).reshape(-1)
    if "face" not in gbuffer or not keep.any() or \
            16.0 * float(np.spacing(np.float32(np.max(depth, where=covered, initial=0.0)))) <= tolerance:
        return gbuffer
    index = np.flatnonzero(keep)
    out = depth.astype(np.float64).reshape(-1)
    item = np.take(np.asarray(gbuffer["object_id"]).reshape(-1), index)     # (np.take: indexing is slower)
    face = np.take(np.asarray(gbuffer["face"]).reshape(-1), index)
    dirs = np.take(camera._rays().reshape(-1, 3), index, axis=0)
    corners = _corners_one_by_one(items, item, face, camera.eye)     # only the pixels' faces' corners placed
    a, b, c = np.moveaxis(corners, 1, 0)
    e1, e2 = b - a, c - a
    n = np.empty_like(e1)
    for i, (j, k) in enumerate(((1, 2), (2, 0), (0, 1))):      # np.cross(e1, e2), its products and differences
        np.subtract(e1[:, j] * e2[:, k], e1[:, k] * e2[:, j], out=n[:, i])
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.einsum("ij,ij->i", a, n) / np.einsum("ij,ij->i", dirs, n)
    d = np.take(out, index)
    out[index] = np.where(np.abs(t - d) <= 1e-3 * d, t, d)     # NaN t (a sliver's zero normal) fails
    return {**gbuffer, "depth": out.reshape(depth.shape)}

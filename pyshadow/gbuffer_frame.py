"""The triangles of one G-buffer frame, held with their items' vertices (:func:`pyshadow.render_gbuffer`).

:func:`pyshadow.gbuffer.gbuffer_triangles` gives every triangle's float64 camera-space corners, (N, 3, 3); a frame of
many bodies is millions of triangles, and each of :func:`~pyshadow.gbuffer.render_gbuffer`'s per-triangle passes over
those corners (reaching beyond the guard band, a wide screen box, a large or a small triangle for its distance, the
device's float32 copy) cost as much as the rasterising. :func:`frame_triangles` gives the same triangles, in the same
order, from the same camera-space vertices (placed by :mod:`pyshadow.gbuffer_items`, bit for bit), but a triangle's
corners stay with its item's vertices: the device's float32 corners are gathered from the vertices' float32
coordinates (the same roundings), and every per-triangle test is first made for a whole item on a box that holds its
computed vertices (from the mesh's bounding box and the item's transform, with a margin far above their rounding).
Where the item passes, each of its triangles passes: each test's roundings are monotone in the coordinates, so a
vertex within the box passes wherever the box's bounds do. Only the items that do not pass (a ground, a body across
the view's edge or near the eye) are tested vertex by vertex or triangle by triangle, as before. The triangles whose
corners share one pixel column or row (their screen box holds no pixel centre, by a margin far above the kernels'
float32 roundings: most triangles of a body a few pixels wide) are not handed to the kernels at all, which draw
nothing of them; the others keep their order, so every tie goes as before. Of the items' meshes only their faces' edge
bounds are kept between frames (:func:`mesh_edges`), while each mesh's vertices and faces equal the copies they were
made from: each frame reads its items' meshes and transforms afresh.
"""
from __future__ import annotations

import math
import threading
import weakref
from collections import OrderedDict

import numpy as np

from . import gbuffer_items as _gi
from .camera import Camera

__all__ = ["FrameTriangles", "frame_triangles"]

#: Relative margin of the item bounds (their own roundings are some float64 unit roundings, 1e-16 each).
MARGIN = 1e-9
#: Relative margin of the float32 bounds on a face's edge lengths (and of the mesh's largest coordinate).
EDGE_MARGIN = 1e-5
#: Bound on the rounding of a computed camera-space coordinate, as a fraction of the magnitudes it is made from
#: (``(v A^T + t - eye) R^T``: two 3-term products and two sums, about 24 unit roundings, 2.7e-15).
ROUNDING = 1e-13

_NONE, _ALL, _SOME, _CUT = 0, 1, 2, 3       # an item's triangles: none, every face, some faces, near-clipped


def _bounds(g, camera: Camera):
    """Per item of group ``g``: (lo, hi) (n, 3) holding each computed camera-space vertex, and the bound (n,)
    on each coordinate's rounding (:data:`ROUNDING`)."""
    v = np.asarray(g.mesh.vertices, np.float64)
    vlo, vhi = v.min(axis=0), v.max(axis=0)
    mid, half = 0.5 * vlo + 0.5 * vhi, 0.5 * vhi - 0.5 * vlo
    A, t = g.T[:, :3, :3], g.T[:, :3, 3]
    with np.errstate(over="ignore", invalid="ignore"):
        M = np.matmul(camera.rotation, A)                               # R A
        b = np.matmul(t - camera.eye, camera.rotation.T)                # R (t - eye)
        ctr = np.matmul(M, mid) + b
        ext = np.matmul(np.abs(M), half)
        size = 3.0 * float(np.abs(v).max()) * np.abs(A).max(axis=(1, 2)) + np.abs(t).max(axis=1) \
            + float(np.abs(camera.eye).max())
        err = ROUNDING * size
        slack = err + MARGIN * (np.abs(ctr).max(axis=1) + ext.max(axis=1) + size)
        lo, hi = ctr - ext - slack[:, None], ctr + ext + slack[:, None]
    bad = ~(np.isfinite(lo).all(axis=1) & np.isfinite(hi).all(axis=1) & np.isfinite(err))
    lo[bad], hi[bad], err[bad] = -np.inf, np.inf, np.inf            # tests nothing: every triangle one by one
    return lo, hi, err


def _least_abs(lo, hi):
    """Per coordinate the least absolute value within [lo, hi]: 0 where the range holds 0."""
    return np.where(lo > 0, lo, np.where(hi < 0, -hi, 0.0))


def _side_bits(c, tx: float, ty: float) -> np.ndarray:
    """(n, V) uint8: the frustum side bits of :func:`pyshadow.gbuffer_items._in_frustum` of vertices ``c``
    (n, V, 3) (bit 0 behind the eye, 1-4 beyond a side)."""
    x, y, z = c[..., 0], c[..., 1], c[..., 2]
    side = (z <= 0).astype(np.uint8)
    for bit, test in enumerate((x > tx * z, x < -tx * z, y > ty * z, y < -ty * z), 1):
        side |= test.astype(np.uint8) << bit
    return side


def _ranges(start, count) -> np.ndarray:
    """The indices ``start[k] .. start[k] + count[k] - 1`` of every k, in order (int64)."""
    count = np.asarray(count, np.int64)
    total = int(count.sum())
    if not total:
        return np.zeros(0, np.int64)
    return np.repeat(np.asarray(start, np.int64) - np.cumsum(count) + count, count) + np.arange(total)


def _f32(a, unit: float) -> np.ndarray:
    """float32 of ``a * unit`` (``a`` itself where ``unit`` is 1), as the G-buffer's device corners."""
    return (a if unit == 1.0 else a * unit).astype(np.float32)


#: A vertex's pixel cell is trusted where it lies this fraction of the largest screen coordinate of its chunk (plus
#: the image's size) inside the cell: the kernels' float32 screen coordinates (float32 corners, a division to 2.5
#: ulps) err by below 6e-7 of that, the host's (a reciprocal, then products) by below 1e-15.
CELL_MARGIN = 1e-5
#: Screen coordinates (pixels) beyond which no cell is taken (16-bit cells).
CELL_REACH = 16000.0
#: The items whose screen box holds fewer than this many pixels a triangle have their triangles that hold no pixel
#: centre left out (a triangle of a quarter pixel misses every pixel centre about half the time; of larger ones,
#: too few are left out to pay for the test).
CULL_PIXELS = 0.25
#: Vertices whose cells are taken at a time (the items of a mesh in chunks of about this many vertices): their
#: temporaries stay within a few megabytes, in cache, whatever the scene.
CELL_CHUNK = 1 << 16


def _cells(c, W: int, H: int, fx: float, fy: float, gx: float, gy: float):
    """(..., V) uint32 of camera-space vertices ``c`` (..., V, 3): each one's pixel cell, the column ``floor(sx)`` in
    the low 16 bits and the row ``floor(sy)`` in the high (each plus 2^14, below 2^15), of its screen coordinates as
    ``kernels/gbuffer.cl``'s ``to_screen`` takes them; 0xFFFF in a half where the vertex lies within
    :data:`CELL_MARGIN` of a cell's edge, in both where it lies behind the eye or beyond the guard band (``|x| > gx z``
    or ``|y| > gy z``, as :func:`pyshadow.gbuffer.raster_triangles` tests it). None where a coordinate in the band
    reaches beyond :data:`CELL_REACH`."""
    x, y, z = c[..., 0], c[..., 1], c[..., 2]
    bad = (z <= 0) | (np.abs(x) > gx * z) | (np.abs(y) > gy * z)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        inv = 1.0 / z
        sx = x * inv
        sx *= fx
        sx += 0.5 * W - 0.5
        sy = y * inv
        sy *= -fy
        sy += 0.5 * H - 0.5
    sx[bad], sy[bad] = 0.5, 0.5                      # (untrusted below)
    reach = max(float(np.abs(sx).max(initial=0.0)), float(np.abs(sy).max(initial=0.0)))
    if not reach < CELL_REACH:
        return None
    margin = CELL_MARGIN * (reach + W + H)
    out = np.empty(inv.shape, np.uint32)
    for k, s in enumerate((sx, sy)):
        cell = np.floor(s)
        s -= cell                                   # the place within the cell
        cell += 16384.0
        cell[(s <= margin) | (s >= 1.0 - margin) | bad] = 65535.0
        if k:
            out |= cell.astype(np.uint32) << np.uint32(16)
        else:
            out[...] = cell
    return out


def _covering(cells, faces) -> np.ndarray:
    """(..., F) bool: which faces ``faces`` (F, 3) of vertices of pixel cells ``cells`` (..., V) (:func:`_cells`) may
    hold a pixel centre: not those whose corners share one trusted column or one trusted row (their screen box holds
    no integer column, or no row, in float64 and in the kernels' float32)."""
    a, b, c = (np.take(cells, faces[:, k], axis=-1) for k in range(3))
    d = a ^ b                                           # 0 in each half where the three corners' cells agree
    b ^= c
    d |= b
    a &= np.uint32(0x80008000)                          # and the first corner's is trusted (not 0xFFFF)
    d |= a
    return ((d & np.uint32(0xFFFF)) != 0) & ((d >> np.uint32(16)) != 0)


#: Meshes (of at least :data:`EDGE_HELD_FACES` faces) whose edge bounds (:func:`mesh_edges`) are kept between
#: frames, the most recently used, and the most bytes they may hold in all (their bounds and copies of their
#: vertices and faces, which each frame's mesh is compared with: one edited in place, or another mesh at the same
#: address, gets its bounds anew).
EDGE_HELD_MESHES = 16
EDGE_HELD_BYTES = 64 << 20
EDGE_HELD_FACES = 4096
_held_edges: OrderedDict = OrderedDict()
_held_lock = threading.Lock()


def _edge_bounds(v, faces):
    """(lower (F,), top): per face of vertices ``v`` (V, 3) float64 and ``faces`` (F, 3), the lengths of its edges
    from the first corner summed, a lower bound on each and an upper bound on the largest, from float32 (its
    roundings, below 2e-6 of the largest coordinate and of the lengths, within :data:`EDGE_MARGIN`)."""
    v32 = v.astype(np.float32)
    c = [np.take(v32, faces[:, k], axis=0) for k in range(3)]
    e = np.zeros(len(faces), np.float32)
    for d in (c[1] - c[0], c[2] - c[0]):
        e += np.sqrt(np.einsum("ij,ij->i", d, d))
    slack = EDGE_MARGIN * float(np.abs(v).max(initial=0.0))
    e = e.astype(np.float64)
    return e * (1 - EDGE_MARGIN) - slack, float(e.max(initial=0.0)) * (1 + EDGE_MARGIN) + slack


def mesh_edges(mesh, v, faces):
    """:func:`_edge_bounds` of ``mesh`` (its vertices ``v`` float64, faces ``faces``), kept between frames for a
    mesh of :data:`EDGE_HELD_FACES` faces or more while its vertices and faces are those it was found with."""
    with _held_lock:
        held = _held_edges.get(id(mesh))
    if held is not None and held[0]() is mesh and np.array_equal(held[1], v) and np.array_equal(held[2], faces):
        with _held_lock:
            if id(mesh) in _held_edges:
                _held_edges.move_to_end(id(mesh))
        return held[3]
    out = _edge_bounds(v, faces)
    size = v.nbytes + faces.nbytes + out[0].nbytes
    if len(faces) >= EDGE_HELD_FACES and size <= EDGE_HELD_BYTES:
        with _held_lock:
            _held_edges[id(mesh)] = (weakref.ref(mesh), v.copy(), np.array(faces), out, size)
            _held_edges.move_to_end(id(mesh))
            while len(_held_edges) > EDGE_HELD_MESHES or sum(h[4] for h in _held_edges.values()) > EDGE_HELD_BYTES:
                _held_edges.popitem(last=False)
    return out


def frame_triangles(items, camera: Camera) -> FrameTriangles:
    """The triangles of :func:`pyshadow.gbuffer.gbuffer_triangles`, held per item (:class:`FrameTriangles`).

    The same checks, errors, near plane and triangles in the same order, bit for bit.
    """
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a pyshadow.Camera, got {type(camera).__name__}")
    items = list(items)
    tx, ty = camera.tan_half * camera.aspect, camera.tan_half
    try:
        groups = _gi._placed_by_mesh(items, camera)
    except Exception:           # an item not as it should be: the error of the first, met one at a time
        groups = None
    if groups is None:
        groups = _gi._placed_one_by_one(items, camera)
    groups = [g for g in groups if g.c.shape[1]]
    n_items = len(items)
    lo, hi, err = np.zeros((n_items, 3)), np.zeros((n_items, 3)), np.zeros(n_items)
    out = np.ones(n_items, bool)                # wholly outside the view (_outside_view)
    side = {}                                   # per group: the side bits of its items the box leaves open
    for k, g in enumerate(groups):
        lo[g.oid], hi[g.oid], err[g.oid] = b = _bounds(g, camera)
        (xl, yl, zl), (xh, yh, zh) = b[0].T, b[1].T
        inside = (zl > 0) & (xh <= tx * zl) & (xl >= -tx * zl) & (yh <= ty * zl) & (yl >= -ty * zl)
        outside = (zh <= 0) | (xl > tx * zh) | (xh < -tx * zh) | (yl > ty * zh) | (yh < -ty * zh)
        open_ = np.flatnonzero(~inside & ~outside)
        o = outside.copy()
        if len(open_):
            side[k] = open_, _side_bits(g.c[open_], tx, ty)
            o[open_] = np.bitwise_and.reduce(side[k][1], axis=1) != 0
        out[g.oid] = o
    far = _farthest(groups, out, lo, hi)
    _gi._check_reach(camera, far)
    near = max(far * 1e-6, 1e-30)
    _gi._near_cut([_gi._Group(g.mesh, g.oid[r], g.faces, g.c[r]) for g in groups
                   for r in [np.flatnonzero(lo[g.oid, 2] < near)] if len(r)], near, far, tx, ty)
    return _assemble(groups, n_items, out, side, near, far, tx, ty, (lo, hi, err))


def _farthest(groups, out, lo, hi) -> float:
    """The largest absolute camera-space coordinate of the items not wholly outside the view (0 if none), as
    ``gbuffer_triangles`` takes it: only items whose box reaches beyond the largest coordinate of another's first
    vertex are read whole."""
    best, cand = 0.0, []
    for g in groups:
        keep = np.flatnonzero(~out[g.oid])
        if len(keep):
            best = max(best, float(np.abs(g.c[keep, 0]).max()))
            cand.append((g, keep))
    for g, keep in cand:
        o = g.oid[keep]
        reach = np.maximum(np.abs(lo[o]), np.abs(hi[o])).max(axis=1)
        rows = keep[reach >= best]
        step = max(1, _gi.CHUNK_VERTICES // g.c.shape[1])
        for a in range(0, len(rows), step):
            best = max(best, float(np.abs(g.c[rows[a:a + step]]).max()))
    return best


def _assemble(groups, n_items, out, side, near, far, tx, ty, bounds) -> FrameTriangles:
    """Each item's triangles: its faces in view (every face, some, or none) or, crossing the near plane,
    the triangles :func:`pyshadow.gbuffer_items._near_stages` leaves of them."""
    kind = np.zeros(n_items, np.int8)
    group = np.zeros(n_items, np.int64)
    row = np.zeros(n_items, np.int64)
    count = np.zeros(n_items, np.int64)
    some, some_off = [], np.zeros(n_items, np.int64)
    cut = []                                    # (oid, triangles, faces) of the items crossing the near plane
    at = 0
    lo = bounds[0]
    for k, g in enumerate(groups):
        F = len(g.faces)
        group[g.oid], row[g.oid] = k, np.arange(len(g.oid))
        if not F:
            continue
        kind[g.oid] = np.where(out[g.oid], _NONE, _ALL)
        count[g.oid] = np.where(out[g.oid], 0, F)
        faces_of = {}
        if k in side:
            rows, bits = side[k]
            corner = np.take(bits, g.faces, axis=1)                     # (r, F, 3)
            keep = (corner[..., 0] & corner[..., 1] & corner[..., 2]) == 0
            for r, kp in zip(rows.tolist(), keep):
                if out[g.oid[r]] or kp.all():
                    continue
                f = np.flatnonzero(kp)
                faces_of[r] = f
                kind[g.oid[r]], count[g.oid[r]] = (_SOME, len(f)) if len(f) else (_NONE, 0)
        for r in np.flatnonzero((lo[g.oid, 2] < near) & (kind[g.oid] != _NONE)).tolist():
            f = faces_of.get(r)
            fv = g.faces if f is None else np.take(g.faces, f, axis=0)
            if (g.c[r, :, 2] < near)[fv].any():                          # a triangle across the near plane
                cut.append((int(g.oid[r]), np.take(g.c[r], fv, axis=0), np.arange(F) if f is None else f))
                kind[g.oid[r]] = _CUT
        for r, f in faces_of.items():
            if kind[g.oid[r]] == _SOME:
                some_off[g.oid[r]] = at
                some.append(f)
                at += len(f)
    etri, eface, eoff = np.zeros((0, 3, 3)), np.zeros(0, np.int64), np.zeros(n_items, np.int64)
    if cut:
        cut.sort(key=lambda c: c[0])            # in item order, as one part of gbuffer_triangles
        tri, obj, face = _gi._near_stages(np.concatenate([c[1] for c in cut]),
                                          np.concatenate([np.full(len(c[2]), c[0], np.int32) for c in cut]),
                                          np.concatenate([c[2] for c in cut]), near, far, tx, ty)
        etri, eface = tri, face
        per = np.bincount(obj, minlength=n_items)
        ids = np.array([c[0] for c in cut])
        count[ids] = per[ids]
        eoff[ids] = (np.cumsum(per) - per)[ids]
    some = np.concatenate(some) if some else np.zeros(0, np.int64)
    return FrameTriangles(groups, near, kind, group, row, count, some, some_off, etri, eface, eoff, bounds)


class FrameTriangles:
    """The triangles of a frame (:func:`frame_triangles`): per item in order, its faces in view, in order (with
    its camera-space vertices, ``kind`` 1 every face, 2 some), or the near plane's pieces (``kind`` 3).

    Attributes
    ----------
    n : int
        The number of triangles, N (those of ``gbuffer_triangles``).
    near : float
        The near plane's distance.
    start : ndarray, shape (items + 1,), int64
        Each item's first triangle (the triangles of item k are ``start[k]:start[k + 1]``).
    """

    def __init__(self, groups, near, kind, group, row, count, some, some_off, etri, eface, eoff, bounds):
        self.groups, self.near, self.kind, self.group, self.row = groups, near, kind, group, row
        self.count, self.some, self.some_off = count, some, some_off
        self.etri, self.eface, self.eoff = etri, eface, eoff
        self.lo, self.hi, self.err = bounds
        self.start = np.concatenate([[0], np.cumsum(count)]).astype(np.int64)
        self.n = int(self.start[-1])
        self._held_sizes, self._held_edges, self._held_all = None, {}, None

    def _locate(self, idx):
        oid = np.searchsorted(self.start, idx, "right") - 1
        return oid, idx - self.start[oid]

    def _faces(self, oid, local):
        """The face of the ``local``-th triangle of each item ``oid`` (of kinds 1 and 2)."""
        face = np.asarray(local, np.int64).copy()
        s = self.kind[oid] == _SOME
        face[s] = self.some[self.some_off[oid[s]] + local[s]]
        return face

    def ids(self, idx):
        """The item (int32) and face (int64) of each triangle ``idx`` (k,)."""
        oid, local = self._locate(idx)
        face = np.empty(len(idx), np.int64)
        cut = self.kind[oid] == _CUT
        face[cut] = self.eface[self.eoff[oid[cut]] + local[cut]]
        face[~cut] = self._faces(oid[~cut], local[~cut])
        return oid.astype(np.int32), face

    def corners(self, idx) -> np.ndarray:
        """(k, 3, 3) float64: the camera-space corners of triangles ``idx`` (k,), as ``gbuffer_triangles``'s (of
        every triangle once a frame where many are asked for: a body near the eye is tested triangle by triangle
        for the guard band, wide, large and small triangles); read-only where ``idx`` is every triangle."""
        idx = np.asarray(idx, np.int64)
        if self._held_all is None and 4 * len(idx) >= self.n and len(idx) > 4096:
            every = np.empty((self.n, 9))
            self._fill(every, self.start, None, np.ones(len(self.kind), bool))
            self._held_all = every.reshape(-1, 3, 3)
            self._held_all.flags.writeable = False
        if self._held_all is None:
            return self._corners(idx)
        return self._held_all if len(idx) == self.n else np.take(self._held_all, idx, axis=0)   # (read-only)

    def _corners(self, idx) -> np.ndarray:
        oid, local = self._locate(idx)
        out = np.empty((len(idx), 3, 3))
        cut = self.kind[oid] == _CUT
        out[cut] = self.etri[self.eoff[oid[cut]] + local[cut]]
        whole = np.flatnonzero(~cut)
        o = oid[whole]
        face = self._faces(o, local[whole])
        gi = self.group[o]
        many = len(self.groups) > 1
        for k in np.flatnonzero(np.bincount(gi)) if many else [0] * bool(len(gi)):
            s = (gi == k) if many else slice(None)
            g = self.groups[k]
            vid = np.take(g.faces, face[s], axis=0) + (self.row[o[s]] * g.c.shape[1])[:, None]
            out[whole[s]] = np.take(g.c.reshape(-1, 3), vid, axis=0)
        return out

    def raster_rows(self, unit: float, extra: int, screen, span):
        """(src, rows): ``rows`` (K + extra, 9) float32, ``float32(corners * unit)`` of the triangles that may hold
        a pixel centre, in order, ``src`` (K,) int64 their indices (None: every triangle, K = N); the ``extra``
        rows after them are left to the caller. ``screen`` ``(W, H, fx, fy, gx, gy)``: the triangles whose corners
        lie within the guard band (``gx``, ``gy``: :meth:`guard_candidates`) and share one pixel column or row
        (:func:`_cells`, :func:`_covering`) are left out: the kernels' screen box of each holds no pixel centre.
        Only items ahead of the eye whose screen box (``span``: :meth:`wide_candidates`) holds fewer pixels than
        :data:`CULL_PIXELS` times their triangles are so tested (most of their triangles cover no pixel centre)."""
        W, H, fx, fy, gx, gy = screen
        # the box's own pixels (span grows it by two a side: a body under one pixel counted 36, and bodies of
        # fewer than ~150 faces were never tested: 10,000 such bodies had every triangle rasterised)
        ahead, pixels = self._screen_boxes(W, H, fx, fy, lambda lo, hi, n: span(lo + 2.0, hi - 2.0, n))
        cull = ((self.kind == _ALL) | (self.kind == _SOME)) & ahead & (pixels < CULL_PIXELS * self.count)
        if not cull.any() or max(W, H) > CELL_REACH / 4:
            return None, self.float32_corners(unit, extra)
        kept, masks = self.count.copy(), []
        for k, g in enumerate(self.groups):
            rows = np.flatnonzero(cull[g.oid])
            step = max(1, CELL_CHUNK // g.c.shape[1])
            for a in range(0, len(rows), step):
                r = rows[a:a + step]
                c = g.c[r[0]:r[-1] + 1] if r[-1] - r[0] == len(r) - 1 else g.c[r]     # consecutive items: a view
                cells = _cells(c, W, H, fx, fy, gx, gy)
                cov = np.ones((len(r), len(g.faces)), bool) if cells is None else _covering(cells, g.faces)
                for i in np.flatnonzero(self.kind[g.oid[r]] == _SOME).tolist():
                    drawn = np.zeros(len(g.faces), bool)
                    drawn[self._drawn(g.oid[r[i]])] = True
                    cov[i] &= drawn
                kept[g.oid[r]] = np.count_nonzero(cov, axis=1)
                masks.append((g, r, cov))
        K = int(kept.sum())
        start = np.concatenate([[0], np.cumsum(kept)]).astype(np.int64)
        out, src = np.empty((K + extra, 9), np.float32), np.empty(K, np.int64)
        rest = ~cull & (self.count > 0)
        self._fill(out, start, unit, rest)
        o = np.flatnonzero(rest)
        src[_ranges(start[o], self.count[o])] = _ranges(self.start[o], self.count[o])
        for g, r, cov in masks:
            item, face = np.nonzero(cov)
            if not len(item):
                continue
            o = g.oid[r]
            at = _ranges(start[o], kept[o])                 # item by item, faces in order, as np.nonzero gives them
            vid = np.take(g.faces, face, axis=0) + (r[item] * g.c.shape[1])[:, None]
            out[at] = _f32(np.take(g.c.reshape(-1, 3), vid, axis=0), unit).reshape(-1, 9)
            local = face.copy()
            for i in np.flatnonzero(self.kind[o] == _SOME).tolist():       # its place among the drawn faces
                m = item == i
                local[m] = np.searchsorted(self._drawn(o[i]), face[m])
            src[at] = self.start[o[item]] + local
        return src, out

    def _drawn(self, oid: int) -> np.ndarray:
        """The faces drawn of item ``oid`` of kind 2, ascending."""
        return self.some[self.some_off[oid]:self.some_off[oid] + self.count[oid]]

    def _within(self, gx: float, gy: float) -> np.ndarray:
        """(items,) bool: whose box keeps every vertex in front of the eye with ``|x| <= gx z``, ``|y| <= gy z``."""
        xa = np.maximum(np.abs(self.lo[:, 0]), np.abs(self.hi[:, 0]))
        ya = np.maximum(np.abs(self.lo[:, 1]), np.abs(self.hi[:, 1]))
        z = self.lo[:, 2]
        return (z > 0) & (xa <= gx * z) & (ya <= gy * z)

    def float32_corners(self, unit: float, extra: int = 0) -> np.ndarray:
        """(N + extra, 9) float32: rows :attr:`n` on hold ``float32(corners * unit)`` of every triangle, the
        ``extra`` rows after them are left to the caller."""
        out = np.empty((self.n + extra, 9), np.float32)
        self._fill(out, self.start, unit, np.ones(len(self.kind), bool))
        return out

    def _fill(self, out, start, unit, items) -> None:
        """Write ``float32(corners * unit)`` (``unit`` None: the float64 corners) of every triangle of the items
        where ``items`` (items,) is True into ``out``, item k's from row ``start[k]``."""
        conv = (lambda a: a) if unit is None else (lambda a: _f32(a, unit))
        for g in self.groups:
            F, kinds, sel = len(g.faces), self.kind[g.oid], items[g.oid]
            rows = np.flatnonzero((kinds == _ALL) & sel)
            step = max(1, _gi.CHUNK_VERTICES // g.c.shape[1])
            for run in np.split(rows, np.flatnonzero(np.diff(g.oid[rows]) != 1) + 1) if len(rows) else ():
                for a in range(int(run[0]), int(run[-1]) + 1, step):        # consecutive items, one block
                    b = min(a + step, int(run[-1]) + 1)
                    s = start[g.oid[a]]
                    np.take(conv(g.c[a:b]), g.faces, axis=1, out=out[s:s + (b - a) * F].reshape(b - a, F, 3, 3))
            for r in np.flatnonzero((kinds == _SOME) & sel).tolist():
                o = g.oid[r]
                tri = np.take(g.c[r], np.take(g.faces, self._drawn(o), axis=0), axis=0)
                out[start[o]:start[o] + self.count[o]] = conv(tri).reshape(len(tri), out.shape[1])
        cut = np.flatnonzero((self.kind == _CUT) & items)
        if len(cut):
            tri = conv(self.etri[_ranges(self.eoff[cut], self.count[cut])])
            out[_ranges(start[cut], self.count[cut])] = tri.reshape(len(tri), out.shape[1])

    def _triangles_of(self, items) -> np.ndarray:
        """The triangles (ascending) of the items where ``items`` (n_items,) is True."""
        k = np.flatnonzero(items & (self.count > 0))
        return _ranges(self.start[k], self.count[k])

    def magnitude_range(self):
        """(least, greatest) bounds on the largest absolute corner coordinate, or None where there is no triangle:
        every corner of a whole item's triangles lies beyond the near plane and within its box."""
        whole = (self.kind == _ALL) | (self.kind == _SOME)
        if not self.n:
            return None
        lo = [float(np.abs(self.etri).max())] if len(self.etri) else []
        hi = list(lo)
        if whole.any():
            least = _least_abs(self.lo[whole], self.hi[whole]).max(axis=1)
            lo.append(max(self.near, float(least.max())))
            hi.append(float(np.maximum(np.abs(self.lo[whole]), np.abs(self.hi[whole])).max()))
        return max(lo), max(hi)

    def max_abs(self) -> float:
        """The largest absolute corner coordinate, exactly (every triangle read)."""
        best = float(np.abs(self.etri).max()) if len(self.etri) else 0.0
        for k in np.flatnonzero((self.kind == _ALL) | (self.kind == _SOME)).tolist():
            tri = self.corners(np.arange(self.start[k], self.start[k + 1]))
            best = max(best, float(np.abs(tri).max()))
        return best

    def guard_candidates(self, gx: float, gy: float) -> np.ndarray:
        """The triangles (ascending) that may have a corner with ``|x| > gx z`` or ``|y| > gy z``: those of
        items whose box does not keep every vertex within, and the near plane's pieces."""
        return self._triangles_of(~self._within(gx, gy) | (self.kind == _CUT))

    def wide_candidates(self, W: int, H: int, fx: float, fy: float, wide_pixels: int, span) -> np.ndarray:
        """The triangles (ascending) whose screen box may hold more than ``wide_pixels`` pixels as ``span`` (the
        G-buffer's rule, ``span(lo, hi, n) -> (first, last, on)``) measures it: those of items whose box's
        screen box (its x/z and y/z bounds, in the same roundings) does, and the near plane's pieces."""
        # a box beyond 2^20 pixels spans the whole image, which holds each of its triangles' spans
        ahead, pixels = self._screen_boxes(W, H, fx, fy, span)
        return self._triangles_of(~ahead | (pixels > wide_pixels) | (self.kind == _CUT))

    def _screen_boxes(self, W: int, H: int, fx: float, fy: float, span):
        """Per item: whether its box lies ahead of the eye, and the pixels of its screen box (from its x/z and y/z
        bounds, in the roundings of ``_screen``) as ``span`` grows and clips it (``kernels/gbuffer.cl``'s screen)."""
        (xl, yl, zl), (xh, yh, zh) = self.lo.T, self.hi.T
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            qx = (np.where(xl >= 0, xl / zh, xl / zl), np.where(xh >= 0, xh / zl, xh / zh))
            qy = (np.where(yl >= 0, yl / zh, yl / zl), np.where(yh >= 0, yh / zl, yh / zh))
            c0, c1, _ = span(qx[0] * fx + (0.5 * W - 0.5), qx[1] * fx + (0.5 * W - 0.5), W)
            r0, r1, _ = span((0.5 * H - 0.5) - qy[1] * fy, (0.5 * H - 0.5) - qy[0] * fy, H)
        return zl > 0, (r1 - r0 + 1) * (c1 - c0 + 1)

    def _sizes(self):
        """Per item: bounds (least, greatest) on its corners' sums of absolute coordinates, the bound on its
        coordinates' rounding, and bounds (least, greatest) on its transform's stretch (singular values)."""
        if self._held_sizes is None:
            self._held_sizes = self._item_sizes()
        return self._held_sizes

    def _item_sizes(self):
        small, big = _least_abs(self.lo, self.hi), np.maximum(np.abs(self.lo), np.abs(self.hi))
        sv = np.ones((len(self.kind), 3))
        for g in self.groups:
            with np.errstate(all="ignore"):
                sv[g.oid] = np.linalg.svd(g.T[:, :3, :3], compute_uv=False)
        smax = sv[:, 0] * (1 + MARGIN)
        smin = np.maximum(sv[:, 2] * (1 - MARGIN) - MARGIN * smax, 0.0)
        return (small[:, 0] + small[:, 1]) + small[:, 2], (big[:, 0] + big[:, 1]) + big[:, 2], self.err, smin, smax

    def _edge_sums(self, g):
        """:func:`mesh_edges` of ``g``'s mesh, once a frame."""
        if id(g) not in self._held_edges:
            self._held_edges[id(g)] = mesh_edges(g.mesh, np.asarray(g.mesh.vertices, np.float64), g.faces)
        return self._held_edges[id(g)]

    def large_candidates(self, ratio: float) -> np.ndarray:
        """The triangles (ascending) whose size (the sum of their edges' absolute coordinates from the first
        corner) may exceed ``ratio`` times the sum of their first corner's: those of items whose bounds allow it."""
        least, _, err, _, smax = self._sizes()
        cand = self.kind == _CUT
        for g in self.groups:
            emax = self._edge_sums(g)[1]
            o = g.oid
            with np.errstate(all="ignore"):
                top = (math.sqrt(3.0) * smax[o] * emax + 12.0 * err[o]) * (1 + MARGIN)
                cand[o] |= ~(top <= ratio * least[o] * (1 - MARGIN))
        return self._triangles_of(cand)

    def small_candidates(self, ratio: float) -> np.ndarray:
        """The triangles whose first corner's sum of absolute coordinates may exceed ``ratio`` times their size:
        of each item, the faces whose edges its bounds allow that."""
        _, greatest, err, smin, _ = self._sizes()
        out = [self._triangles_of(self.kind == _CUT)]
        for g in self.groups:
            o = g.oid[np.isin(self.kind[g.oid], (_ALL, _SOME))]
            if not len(o):
                continue
            with np.errstate(all="ignore"):
                thr = (greatest[o] * (1 + MARGIN) / ratio + 12.0 * err[o]) / (smin[o] * (1 - MARGIN)) * (1 + MARGIN)
            thr = np.where(np.isnan(thr), np.inf, thr)
            e = self._edge_sums(g)[0]
            cols = np.flatnonzero(e <= thr.max())
            if not len(cols):
                continue
            for k, t in zip(o.tolist(), thr.tolist()):
                f = cols[e[cols] <= t]
                if not len(f):
                    continue
                if self.kind[k] == _SOME:
                    kept = self.some[self.some_off[k]:self.some_off[k] + self.count[k]]
                    f = np.flatnonzero(np.isin(kept, f))
                out.append(self.start[k] + f)
        return np.sort(np.concatenate(out))

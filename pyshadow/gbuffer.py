"""G-buffer: per-pixel position, normal, object id and depth of a scene.

Stage "G-buffer" of the pipeline (README.md, the table of stages). Triangles of every item are
moved into camera space on the host in float64 (relative to the eye, so a
scene far from the world origin keeps its precision), clipped against the
near plane and, those reaching far outside the view, against a guard band
twice the view's width (:func:`raster_triangles`), then rasterised by
``kernels/gbuffer.cl``: nearest depth, then the id of the triangle holding
it, then the exact distance along each eye ray to the plane of the triangle
it comes from. A scene far from unit size is rasterised
scaled by a power of two (:func:`pyshadow.mesh.float32_unit`), which moves
no pixel; the near plane is 1e-6 of the farthest geometry in view, and a
vertex in view nearer than that, or a face whose part nearer than that lies in view (a wall filling the
view from closer), is refused rather than cut away. The items' triangles and their faces'
planes come from :mod:`pyshadow.gbuffer_items` (re-exported here), which takes the items sharing a mesh
object together; :func:`render_gbuffer` holds them with their items' vertices (:mod:`pyshadow.gbuffer_frame`:
each per-triangle test made first per item, the triangles that hold no pixel centre not rasterised).
"""
from __future__ import annotations

import numpy as np
import pyopencl as cl

from . import _cl
from ._cl.launch import fill
from ._validate import check_transform
from .camera import Camera, points_on_rays
from . import gbuffer_items as _items
from .gbuffer_frame import _f32, frame_triangles
from .gbuffer_items import clip_polygon, face_corners, gbuffer_triangles, on_face_planes, through_eye
from .mesh import UNIT_BAND, float32_unit

__all__ = ["render_gbuffer", "render_gbuffer_reference", "gbuffer_triangles", "raster_triangles", "on_face_planes",
           "check_transform", "face_corners", "clip_polygon", "through_eye"]

_clip_near = _items._clip_near      # re-exported: pyshadow.lighting.shadow_map_cube imports it from here


#: Triangles reaching beyond this many half-widths of the view (at their depth) are rasterised clipped to
#: it, in float64 on the host (a guard band): a triangle crossing the near plane outside the view keeps
#: corners at 1e-6 of the scene's depth whose screen coordinates reach 1e9 pixels, and the kernel's float32
#: edge functions and depths at such corners moved the ground's far edge by up to 5 pixels at 640x480 and
#: let a ground quad reaching behind the camera win the depth test over a plate 1 cm above it.
GUARD_BAND = 2.0


def _guard_pieces(tris: np.ndarray, camera: Camera):
    """The triangles of ``tris`` (near-clipped, camera space, (N, 3, 3)) reaching beyond :data:`GUARD_BAND`
    half-widths of the view, clipped to it in float64: (their indices (P,), their first pieces (P, 3, 3),
    the further pieces (E, 3, 3) and the source of each (E,)), or None where none reaches that far. A
    triangle clipped away whole keeps a piece of no area (its first corner thrice), which covers nothing."""
    gx, gy = GUARD_BAND * camera.tan_half * camera.aspect, GUARD_BAND * camera.tan_half
    x, y, z = tris[..., 0], tris[..., 1], tris[..., 2]
    beyond = (np.abs(x) > gx * z) | (np.abs(y) > gy * z)
    idx = np.flatnonzero(beyond[:, 0] | beyond[:, 1] | beyond[:, 2])
    if not len(idx):
        return None
    planes = [(np.array(a, np.float64), 0.0) for a in ((1, 0, -gx), (-1, 0, -gx), (0, 1, -gy), (0, -1, -gy))]
    first, extra, extra_src = np.repeat(tris[idx, :1], 3, axis=1), [], []
    for j, i in enumerate(idx):
        poly = clip_polygon(list(tris[i]), planes)
        if poly:
            first[j] = poly[:3]
            extra += [np.stack([poly[0], poly[k], poly[k + 1]]) for k in range(2, len(poly) - 1)]
            extra_src += [i] * (len(poly) - 3)
    return idx, first, np.array(extra, np.float64).reshape(-1, 3, 3), np.array(extra_src, np.int64)


def raster_triangles(tris: np.ndarray, camera: Camera):
    """The triangles to rasterise of near-clipped camera-space triangles ``tris`` (N, 3, 3): those reaching
    beyond :data:`GUARD_BAND` half-widths of the view clipped to it (each replaced by its first piece, the
    further pieces after all of ``tris``); returns (M, 3, 3) float64 and the source triangle of each (M,),
    or ``tris`` and None where none reaches that far. Each pixel's distance and normal still come from its
    source triangle's plane."""
    pieces = _guard_pieces(tris, camera)
    if pieces is None:
        return tris, None
    idx, first, extra, extra_src = pieces
    raster = np.concatenate([tris, extra])
    raster[idx] = first
    return raster, np.concatenate([np.arange(len(tris)), extra_src])


def _finish(camera, t, n_cam, obj, face):
    """Assemble the output dict from per-pixel distance, camera normal and ids."""
    H, W = camera.height, camera.width
    hit = np.isfinite(t)
    obj = np.asarray(obj).reshape(H, W)
    face = np.asarray(face).reshape(H, W)
    dirs = camera._rays()
    every = bool(hit.all())                 # a surface behind every pixel: nothing to mask
    pos = points_on_rays(camera.eye, t if every else np.where(hit, t, 0.0), dirs, np.float32)
    normal = n_cam @ camera.rotation
    if not every:
        pos[~hit] = np.nan
        normal[~hit] = 0.0
    return {
        "position": pos,
        "normal": normal.astype(np.float32),
        "object_id": (obj if every else np.where(hit, obj, -1)).astype(np.int32).reshape(H, W),
        "face": (face if every else np.where(hit, face, -1)).astype(np.int32).reshape(H, W),
        "depth": (t if every else np.where(hit, t, np.inf)).astype(np.float32),
    }


#: Triangles whose screen box holds more pixels than this are rasterised a row to a work-item
#: (``gbuffer_raster_rows``): one such triangle (a ground plane, a wall) covers as many pixel
#: centres as thousands of a mesh's small triangles, and would leave one core to walk them all.
WIDE_PIXELS = 4096


def _screen(tri, W: int, H: int, fx: float, fy: float):
    """Screen coordinates (column, row; pixel centres at integers) of camera-space corners
    ``tri[..., 3]``: ``x/z fx + W/2 - 1/2`` and ``H/2 - 1/2 - y/z fy``, as ``kernels/gbuffer.cl``'s
    ``to_screen`` (in float64 here)."""
    return tri[..., 0] / tri[..., 2] * fx + (0.5 * W - 0.5), (0.5 * H - 0.5) - tri[..., 1] / tri[..., 2] * fy


def _span(lo, hi, n: int):
    """The rows (or columns) ``first, last`` (int64) of the screen boxes from ``lo`` to ``hi`` (float64) grown by two
    pixels and clipped to ``0 .. n - 1``, the whole image where a bound lies beyond 2^20 (or is NaN), and whether each
    reaches the image. Monotone: a box within another gets rows within its rows."""
    rough = ~((lo >= -2.0 ** 20) & (hi <= 2.0 ** 20))
    on = rough | ((hi >= -2) & (lo <= n + 1))
    lo = np.where(rough, 0, np.clip(np.floor(lo) - 2, 0, n - 1))
    hi = np.where(rough, n - 1, np.clip(np.ceil(hi) + 2, 0, n - 1))
    return lo.astype(np.int64), hi.astype(np.int64), on


def _wide_rows(tris, W: int, H: int, fx: float, fy: float):
    """Which of ``tris`` (camera space, (T, 3, 3)) are wide, as uint8 (T,), and their rows as int32 (n, 2)
    pairs (triangle, row): each wide triangle's screen box in float64, grown by two pixels (the kernel
    passes over the rows outside its own float32 box), the whole image along an axis where a corner's
    screen coordinate is too large for float32 to place within a pixel (beyond 2^20)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        sx, sy = _screen(tris, W, H, fx, fy)

    def span(s, n):                     # by corners: NumPy's reductions over an axis of 3 are slow
        a, b, c = s[:, 0], s[:, 1], s[:, 2]
        return _span(np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c), n)

    c0, c1, on_x = span(sx, W)
    r0, r1, on_y = span(sy, H)
    wide = on_x & on_y & ((r1 - r0 + 1) * (c1 - c0 + 1) > WIDE_PIXELS)
    t = np.flatnonzero(wide)
    n = r1[t] - r0[t] + 1
    rows = np.empty((int(n.sum()), 2), np.int32)
    rows[:, 0] = np.repeat(t, n)
    rows[:, 1] = np.repeat(r0[t], n) + np.arange(len(rows)) - np.repeat(np.cumsum(n) - n, n)
    return wide.astype(np.uint8), rows


#: Whether the G-buffer may rasterise in one pass where the device has 64-bit atomics (False: the
#: two passes everywhere; the tests compare the two).
ONE_PASS = True


def _one_pass() -> bool:
    """One raster pass (``GBUFFER_ATOMIC64``): the device has ``cl_khr_int64_extended_atomics``."""
    return ONE_PASS and "cl_khr_int64_extended_atomics" in _cl.device().extensions.split()


def render_gbuffer(items, camera: Camera) -> dict:
    """Rasterise a scene of rigidly placed meshes into a G-buffer.

    Parameters
    ----------
    items : sequence of (mesh, transform)
        ``mesh`` a trimesh.Trimesh (or a path for :func:`pyshadow.load_mesh`),
        ``transform`` a 4x4 affine matrix from mesh to world coordinates.
        The item's position in the sequence is its object id.
    camera : Camera

    Returns
    -------
    dict of ndarray, each (H, W, ...)
        ``'position'`` float32 (H, W, 3): world position of the visible
        surface (NaN where none). ``'normal'`` float32 (H, W, 3): unit
        geometric (face) normal in world space, turned to face the camera
        (0 where none). ``'object_id'`` int32 (H, W): item index, -1 for
        background. ``'face'`` int32 (H, W): face index within that item's
        mesh, -1 for background. ``'depth'`` float32 (H, W): distance from
        the eye along the pixel's ray, in world units (inf for background).

    Notes
    -----
    Pixel centres are sampled with the watertight edge rule of the depth-map
    rasteriser, so no pixel falls between two triangles of a closed mesh.
    Distances come from intersecting each pixel's exact ray with the plane of
    the visible triangle, so positions match a ray tracer's primary hits.
    """
    ft = frame_triangles(items, camera)
    H, W = camera.height, camera.width
    npix = H * W
    ids = np.full(npix, np.iinfo(np.int32).max, np.int32)
    t, n_cam, far = np.full(npix, np.inf, np.float32), np.zeros((npix, 3), np.float32), np.zeros(npix, np.uint8)
    unit, small, source = 1.0, np.zeros(0, np.int64), None
    if ft.n:
        unit, small, source = _rasterise(ft, camera, ids, t, n_cam, far)
    hit = ids != np.iinfo(np.int32).max
    tri_idx = np.where(hit, ids, 0)
    if source is not None:                  # the raster triangles' own: their source triangles
        tri_idx = source(tri_idx)
    o, f = ft.ids(tri_idx) if ft.n else (np.zeros(npix, np.int32), np.zeros(npix, np.int64))
    t64 = np.where(hit, t.astype(np.float64) / unit, np.inf).reshape(H, W)
    n64 = n_cam.astype(np.float64).reshape(H, W, 3)
    if ft.n:
        _far_corner_distances(ft, small, tri_idx, hit, far.view(bool), t64, camera, n64)
    return _finish(camera, t64, n64, o, f)


def _rasterise(ft, camera: Camera, ids, t, n_cam, far):
    """Rasterise the triangles of ``ft`` (:func:`frame_triangles`) into the per-pixel raster triangle ``ids``,
    distances ``t``, camera-space normals ``n_cam`` and far-corner flags ``far`` (the kernels' buffers, filled
    here); returns the scale ``unit``, the small triangles (:data:`FAR_NORMAL_RATIO`) and the map from raster
    triangles to ``ft``'s (None where they are the same). The raster triangles: those that may hold a pixel
    centre (:meth:`FrameTriangles.raster_rows`), in order, each reaching beyond the guard band replaced by its
    first piece, the further pieces after them (:func:`raster_triangles`)."""
    H, W = camera.height, camera.width
    npix = H * W
    idx, first, extra, extra_src = _frame_guard(ft, camera)
    # the kernels multiply up to three coordinates: a scene of any size is rasterised scaled by a
    # power of two (float32_unit; 1 near unit size), which moves no pixel; distances scale back below
    unit = _frame_unit(ft)
    fx = np.float32(W / (2.0 * camera.tan_half * camera.aspect))
    fy = np.float32(H / (2.0 * camera.tan_half))
    gx, gy = GUARD_BAND * camera.tan_half * camera.aspect, GUARD_BAND * camera.tan_half
    src, rows32 = ft.raster_rows(unit, len(extra), (W, H, float(fx), float(fy), gx, gy), _span)
    n_kept = ft.n if src is None else len(src)
    n_raster = n_kept + len(extra)
    if n_raster >= 2**31 - 1:
        raise ValueError("too many triangles for one G-buffer")
    at = None if idx is None else (idx if src is None else np.searchsorted(src, idx))     # their raster rows
    sources = []                # rows the raster pass reads as pieces, the resolve pass as their sources
    if idx is not None:
        sources = [(at, rows32[at].copy()),
                   (np.arange(n_kept, n_raster), rows32[extra_src if src is None else np.searchsorted(src, extra_src)])]
        rows32[at] = _f32(first, unit).reshape(-1, 9)
        rows32[n_kept:] = _f32(extra, unit).reshape(-1, 9)
    q = _cl.queue()
    tb = _cl.host_buffer(rows32)            # no copy on CPU devices: the array lives to the end
    try:
        one_pass = _one_pass()
        defines = {"GBUFFER_ATOMIC64": int(one_pass)}
        zbuf = _cl.empty((8 if one_pass else 4) * npix)
        idbuf = _cl.empty(4 * npix)
        fill(q, zbuf, np.uint32(0xFFFFFFFF), (8 if one_pass else 4) * npix)
        fill(q, idbuf, np.int32(np.iinfo(np.int32).max), 4 * npix)
        wide, rows = _frame_wide_rows(ft, src, n_kept, idx, at, first, extra, W, H, float(fx), float(fy))
        wb = _cl.host_buffer(wide)
        k = _cl.kernel("gbuffer.cl", "gbuffer_raster", defines)
        kr = _cl.kernel("gbuffer.cl", "gbuffer_raster_rows", defines) if len(rows) else None
        rb = _cl.host_buffer(rows) if len(rows) else None
        for p in ((0,) if one_pass else (0, 1)) if n_raster else ():
            k(q, (n_raster,), None, tb, np.int32(n_raster), wb, np.int32(W), np.int32(H),
              fx, fy, np.int32(p), zbuf, idbuf)
            if kr is not None:
                kr(q, (len(rows),), None, tb, rb, np.int32(len(rows)), np.int32(W), np.int32(H),
                   fx, fy, np.int32(p), zbuf, idbuf)
        if one_pass and n_raster:
            _cl.kernel("gbuffer.cl", "gbuffer_ids", defines)(q, (npix,), None, zbuf, np.int32(npix), idbuf)
        t_buf, n_buf, far_buf = _cl.empty(4 * npix), _cl.empty(12 * npix), _cl.empty(npix)
        cand = ft.large_candidates(PLANE_SIZE)        # while the kernels run
        tri = ft.corners(cand)
        size, first_abs = _size_first(tri)
        big = size > PLANE_SIZE * first_abs
        planes = _float64_planes(ft.n, cand[big], tri[big], unit)
        if planes is not None:
            planes = np.concatenate([planes if src is None else planes[src]] + [planes[extra_src]] * (idx is not None))
        cand = ft.small_candidates(FAR_NORMAL_RATIO)
        size, first_abs = _size_first(ft.corners(cand))
        small = cand[first_abs > FAR_NORMAL_RATIO * size]
        for rows_at, values in sources:               # each piece's plane: its source triangle's corners
            _write_rows(q, tb, rows_at, values)
        _cl.kernel("gbuffer.cl", "gbuffer_resolve", defines)(
            q, (npix,), None, tb, _cl.to_device(np.zeros(4, np.float32)) if planes is None else _cl.host_buffer(planes),
            np.int32(planes is not None), np.int32(W), np.int32(H),
            np.float32(camera.tan_half * camera.aspect), np.float32(camera.tan_half), np.float32(FAR_CORNER_RATIO),
            idbuf, t_buf, n_buf, far_buf)
        for host, buf in ((ids, idbuf), (t, t_buf), (n_cam, n_buf), (far, far_buf)):
            cl.enqueue_copy(q, host, buf)       # (blocking: every kernel has finished with the host buffers)
    finally:                                # (an error above: no kernel may outlive the host arrays it reads)
        q.finish()
    if src is None and idx is None:
        return unit, small, None

    def source(r):                          # (0 for a pixel no triangle covers)
        r = r.astype(np.int64)
        out, piece = np.zeros_like(r), r >= n_kept
        out[~piece] = r[~piece] if src is None else src[r[~piece]]
        if idx is not None:
            out[piece] = extra_src[r[piece] - n_kept]
        return out
    return unit, small, source


def _write_rows(q, buf, at, values) -> None:
    """Write the float32 rows ``values`` (k, 9) into ``buf`` at rows ``at`` (k,) ascending, after the queue's
    kernels (a run of consecutive rows at a time)."""
    cut = np.flatnonzero(np.diff(at) != 1) + 1
    for a, v in zip(np.split(at, cut), np.split(values, cut)):
        if len(a):
            cl.enqueue_copy(q, buf, np.ascontiguousarray(v, np.float32), dst_offset=int(a[0]) * 36)


def _size_first(tri):
    """Each triangle's size (the sum of its edges' absolute coordinates from its first corner) and the sum of its
    first corner's absolute coordinates, of camera-space corners ``tri`` (K, 3, 3) float64."""
    size = sum(np.abs(tri[:, k, j] - tri[:, 0, j]) for k in (1, 2) for j in range(3))   # by columns: faster
    return size, np.abs(tri[:, 0, 0]) + np.abs(tri[:, 0, 1]) + np.abs(tri[:, 0, 2])


def _frame_guard(ft, camera: Camera):
    """:func:`raster_triangles`'s clipping of a frame's triangles ``ft`` (:func:`frame_triangles`) to the guard band:
    (the triangles clipped (P,), their first pieces (P, 3, 3), the further pieces (E, 3, 3), their sources (E,)),
    ``(None, None, empty, None)`` where none reaches beyond it. Only the triangles of items whose box reaches
    beyond the band are tested."""
    gx, gy = GUARD_BAND * camera.tan_half * camera.aspect, GUARD_BAND * camera.tan_half
    cand = ft.guard_candidates(gx, gy)
    pieces = _guard_pieces(ft.corners(cand), camera) if len(cand) else None
    if pieces is None:
        return None, None, np.zeros((0, 3, 3)), None
    idx, first, extra, extra_src = pieces
    return cand[idx], first, extra, cand[extra_src]


def _frame_unit(ft) -> float:
    """:func:`pyshadow.mesh.float32_unit` of the largest absolute corner coordinate of ``ft``'s triangles: 1 where
    its bounds lie within the band that is not scaled, else from every corner."""
    least, greatest = ft.magnitude_range()
    if 2.0 ** -UNIT_BAND <= least and greatest <= 2.0 ** UNIT_BAND:
        return 1.0
    return float32_unit(ft.max_abs())


def _frame_wide_rows(ft, src, n_kept: int, idx, at, first, extra, W: int, H: int, fx: float, fy: float):
    """:func:`_wide_rows` of the raster triangles (:func:`_rasterise`: of ``ft``'s, ``src`` (None: all), each of
    ``idx`` (rows ``at``) replaced by its first piece ``first``, the pieces ``extra`` after them): only those whose
    item's box is wide on the screen are measured."""
    n_raster = n_kept + len(extra)
    cand = ft.wide_candidates(W, H, fx, fy, WIDE_PIXELS, _span)
    if idx is not None and len(cand) < ft.n:
        cand = np.union1d(cand, idx)
    if src is None:
        row = cand
    else:                                   # those rasterised: each in its raster row
        row = np.minimum(np.searchsorted(src, cand), max(len(src) - 1, 0))
        keep = (src[row] == cand) if len(src) else np.zeros(len(cand), bool)
        cand, row = cand[keep], row[keep]
    tri = np.concatenate([ft.corners(cand), extra])
    if idx is not None:
        tri[np.searchsorted(cand, idx)] = first
    rows_of = np.concatenate([row, np.arange(n_kept, n_raster)])
    w, rows = _wide_rows(tri, W, H, fx, fy)
    wide = np.zeros(n_raster, np.uint8)
    wide[rows_of] = w
    rows[:, 0] = rows_of[rows[:, 0]]
    return wide, rows


#: A pixel whose triangle has a corner farther from the eye than this many times the distance of the triangle's
#: plane from the eye gets its distance from float64 on the host (``kernels/gbuffer.cl`` marks them). The kernel
#: reads the corners in float32 and the plane's offset from them: their rounding (6e-8 of each corner's distance)
#: moves the plane by up to about 1.5 times that much of the corner's distance, which errs the distance along the
#: ray by that over the plane's distance from the eye, relative error about 1e-7 times the ratio (below 2.5e-5
#: here; a ground quad of side 2e5 seen from 1.5 m put points 4 mm off the ground, half of them below it, and
#: their AO came out 0; with the pixel's own distance in place of the plane's, a ground of side 2e3 seen from
#: 5 cm above it had distances off by 4e-4 of theirs, 2.8 mm at 7 m, where it is seen at a grazing angle).
FAR_CORNER_RATIO = 256.0
#: A large triangle (:data:`PLANE_SIZE`) reaching beyond this many times its plane's distance from the eye gets
#: its plane from float64 on the host (rounded once to float32): from its float32 corners, the plane's offset
#: would move by up to about 1.5 float32 roundings of its farthest corner (1e-7 of it), more than the 16
#: float32 spacings of the depth :func:`on_face_planes` takes a kept depth to be within (a ground of side 760
#: seen from 1.5 m put points 1.6e-5 below it, beyond the ground's tolerance 1e-5, and their AO came out 0).
FAR_PLANE_RATIO = 16.0
#: Large triangles: those whose size (the sum of their edges' absolute coordinates) exceeds this fraction of
#: the sum of their first corner's absolute coordinates (a ground, a wall; a mesh's triangles are far smaller
#: than their distance, and their planes' offsets err by about a float32 rounding of the pixels' own distance).
PLANE_SIZE = 0.25
#: A pixel whose triangle lies farther from the eye than this many times its size (sums of absolute coordinates)
#: gets its normal from float64 too: float32 corners tilt the kernel's by up to 1e-7 times the ratio.
FAR_NORMAL_RATIO = 16384.0


def _float64_planes(n: int, cand, tri, unit):
    """(n, 4) float32: for each of ``n`` triangles the unit normal and offset (``n . a``, scaled by ``unit``) of its
    plane, from float64, where it is large (:data:`PLANE_SIZE`: those ``cand`` (K,) ascending, camera-space corners
    ``tri`` (K, 3, 3)) and reaches beyond :data:`FAR_PLANE_RATIO` times the plane's distance from the eye; a NaN
    offset elsewhere (the kernel's corners). None where no triangle is such (a frame's usual case)."""
    reach = np.abs(tri.reshape(len(tri), 9)).max(axis=1)
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(nrm, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        nrm /= length[:, None]
        off = np.einsum("ij,ij->i", nrm, tri[:, 0])
    use = (length > 0) & (reach > FAR_PLANE_RATIO * np.abs(off))
    if not use.any():
        return None
    planes = np.full((n, 4), np.nan, np.float32)
    planes[cand[use], :3] = nrm[use]
    planes[cand[use], 3] = off[use] * unit
    return planes


def _far_corner_distances(ft, small, tri_idx, hit, far, t, camera, normal) -> None:
    """Replace in ``t`` (H, W) float64 the distances, and in ``normal`` (H, W, 3) the camera-space normals, of the
    covered pixels (``hit``) that the kernel marks ``far`` (their triangle reaches beyond :data:`FAR_CORNER_RATIO`
    times the distance of its plane from the eye), or whose triangle (of ``ft``, :func:`frame_triangles`, index
    ``tri_idx`` per pixel) lies beyond :data:`FAR_NORMAL_RATIO` times its size from the eye (those ``small`` (S,)),
    by the float64 intersection of their ray with that triangle's plane and its normal (as the kernel's)."""
    flat = t.reshape(-1)
    if not len(small) and not far.any():
        return                              # no corner so far (a frame's usual case: no temporaries)
    mark = far
    if len(small):
        is_small = np.zeros(ft.n, bool)
        is_small[small] = True
        mark = far | np.take(is_small, tri_idx)
    sel = np.flatnonzero(hit & mark)
    tri = ft.corners(tri_idx[sel])
    d = camera._rays().reshape(-1, 3)[sel] @ camera.rotation.T
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        exact = np.einsum("ij,ij->i", n, tri[:, 0]) / np.einsum("ij,ij->i", n, d)
    ok = np.isfinite(exact) & (exact > 0)
    flat[sel[ok]] = exact[ok]
    n = n[ok] / np.linalg.norm(n[ok], axis=1, keepdims=True)     # turned to face the eye, as the kernel's
    normal.reshape(-1, 3)[sel[ok]] = np.where((np.einsum("ij,ij->i", n, d[ok]) > 0)[:, None], -n, n)


def render_gbuffer_reference(items, camera: Camera) -> dict:
    """NumPy version of :func:`render_gbuffer` for small images (same rules, float64).

    Loops over triangles; for each, tests the pixel centres of its bounding
    box with the canonical edge functions and top-left rule of the kernel,
    keeps the nearest view-space depth per pixel (lowest triangle index on
    ties) and intersects the pixel ray with the winning triangle's plane.
    """
    from .raster import covered_samples

    tris, obj, face, _near = gbuffer_triangles(items, camera)
    raster, src = raster_triangles(tris, camera)
    H, W = camera.height, camera.width
    fx = W / (2.0 * camera.tan_half * camera.aspect)
    fy = H / (2.0 * camera.tan_half)
    zbest = np.full((H, W), np.inf)
    win = np.full((H, W), -1, np.int64)
    for i, tri in enumerate(raster):
        s = np.stack(_screen(tri, W, H, fx, fy), axis=1)
        p0, p1, p2 = s
        lo = np.maximum(np.ceil(s.min(0)).astype(int), 0)
        hi = np.minimum(np.floor(s.max(0)).astype(int), [W - 1, H - 1])
        if (lo > hi).any():
            continue
        cov = covered_samples(p0, p1, p2, lo, hi)
        if cov is None:
            continue
        rr, cc, w = cov
        z = 1.0 / (w[0] / tri[0, 2] + w[1] / tri[1, 2] + w[2] / tri[2, 2])
        better = z < zbest[rr, cc]
        zbest[rr[better], cc[better]] = z[better]
        win[rr[better], cc[better]] = i
    dirs_cam = camera.ray_directions() @ camera.rotation.T
    t = np.full((H, W), np.inf)
    n_cam = np.zeros((H, W, 3))
    if src is not None:
        win = np.where(win >= 0, src[np.maximum(win, 0)], -1)
    hit = win >= 0
    tri = tris[win[hit]]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    d = dirs_cam[hit]
    dn = np.einsum("ij,ij->i", n, d)
    t[hit] = np.einsum("ij,ij->i", n, tri[:, 0]) / dn
    n_cam[hit] = np.where((dn > 0)[:, None], -n, n)
    wi = np.where(hit, win, 0)
    return _finish(camera, t, n_cam, obj[wi] if len(obj) else wi, face[wi] if len(face) else wi)

"""G-buffer: per-pixel position, normal, object id and depth of a scene.

Stage "G-buffer" of the pipeline (DESIGN.md). Triangles of every item are
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
object together.
"""
from __future__ import annotations

import numpy as np
import pyopencl as cl

from . import _cl
from ._cl.launch import fill
from ._validate import check_transform
from .camera import Camera, points_on_rays
from . import gbuffer_items as _items
from .gbuffer_items import clip_polygon, face_corners, gbuffer_triangles, on_face_planes, through_eye
from .mesh import float32_unit

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


def _source_planes(tris, src, unit):
    """(M, 9) float32: the corners of each raster triangle's source (``src`` from :func:`raster_triangles`:
    the first ``len(tris)`` are each its own) scaled by ``unit``, read by the kernels for its plane."""
    out = np.empty((len(src), 9), np.float32)
    n = len(tris)
    out[:n] = (tris if unit == 1.0 else tris * unit).reshape(n, 9)
    out[n:] = (tris[src[n:]] * unit).reshape(-1, 9)
    return out


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


def _wide_rows(tris, W: int, H: int, fx: float, fy: float):
    """Which of ``tris`` (camera space, (T, 3, 3)) are wide, as uint8 (T,), and their rows as int32 (n, 2)
    pairs (triangle, row): each wide triangle's screen box in float64, grown by two pixels (the kernel
    passes over the rows outside its own float32 box), the whole image along an axis where a corner's
    screen coordinate is too large for float32 to place within a pixel (beyond 2^20)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        sx, sy = _screen(tris, W, H, fx, fy)

    def span(s, n):                     # by corners: NumPy's reductions over an axis of 3 are slow
        a, b, c = s[:, 0], s[:, 1], s[:, 2]
        lo, hi = np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)
        rough = ~((lo >= -2.0 ** 20) & (hi <= 2.0 ** 20))
        on = rough | ((hi >= -2) & (lo <= n + 1))
        lo = np.where(rough, 0, np.clip(np.floor(lo) - 2, 0, n - 1))
        hi = np.where(rough, n - 1, np.clip(np.ceil(hi) + 2, 0, n - 1))
        return lo.astype(np.int64), hi.astype(np.int64), on

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
    tris, obj, face, _near = gbuffer_triangles(items, camera)
    raster, src = raster_triangles(tris, camera)
    size = sum(np.abs(tris[:, k, j] - tris[:, 0, j]) for k in (1, 2) for j in range(3))   # by columns: faster
    first = np.abs(tris[:, 0, 0]) + np.abs(tris[:, 0, 1]) + np.abs(tris[:, 0, 2])         # |first corner|_1
    H, W = camera.height, camera.width
    npix = H * W
    unit = 1.0
    t = np.full(npix, np.inf, np.float32)
    n_cam = np.zeros((npix, 3), np.float32)
    ids = np.full(npix, np.iinfo(np.int32).max, np.int32)
    far = np.zeros(npix, np.uint8)
    if len(raster):
        if len(raster) >= 2**31 - 1:
            raise ValueError("too many triangles for one G-buffer")
        q = _cl.queue()
        # the kernels multiply up to three coordinates: a scene of any size is rasterised scaled by a
        # power of two (float32_unit; 1 near unit size), which moves no pixel; distances scale back below
        unit = float32_unit(max(abs(float(tris.max())), abs(float(tris.min()))))
        tb = _cl.to_device((raster if unit == 1.0 else raster * unit).reshape(-1, 9), np.float32)
        # each piece's plane: its source triangle's corners (the raster's own where nothing is clipped)
        pb = tb if src is None else _cl.to_device(_source_planes(tris, src, unit), np.float32)
        one_pass = _one_pass()
        defines = {"GBUFFER_ATOMIC64": int(one_pass)}
        zbuf = _cl.empty((8 if one_pass else 4) * npix)
        idbuf = _cl.empty(4 * npix)
        fill(q, zbuf, np.uint32(0xFFFFFFFF), (8 if one_pass else 4) * npix)
        if not one_pass:
            fill(q, idbuf, np.int32(np.iinfo(np.int32).max), 4 * npix)
        fx = np.float32(W / (2.0 * camera.tan_half * camera.aspect))
        fy = np.float32(H / (2.0 * camera.tan_half))
        wide, rows = _wide_rows(raster, W, H, float(fx), float(fy))
        wb = _cl.to_device(wide)
        k = _cl.kernel("gbuffer.cl", "gbuffer_raster", defines)
        kr = _cl.kernel("gbuffer.cl", "gbuffer_raster_rows", defines) if len(rows) else None
        rb = _cl.to_device(rows) if len(rows) else None
        for p in (0,) if one_pass else (0, 1):
            k(q, (len(raster),), None, tb, np.int32(len(raster)), wb, np.int32(W), np.int32(H),
              fx, fy, np.int32(p), zbuf, idbuf)
            if kr is not None:
                kr(q, (len(rows),), None, tb, rb, np.int32(len(rows)), np.int32(W), np.int32(H),
                   fx, fy, np.int32(p), zbuf, idbuf)
        if one_pass:
            _cl.kernel("gbuffer.cl", "gbuffer_ids", defines)(q, (npix,), None, zbuf, np.int32(npix), idbuf)
        t_buf = _cl.empty(4 * npix)
        n_buf = _cl.empty(12 * npix)
        far_buf = _cl.empty(npix)
        planes = _float64_planes(tris, size, first, src, unit)
        _cl.kernel("gbuffer.cl", "gbuffer_resolve", defines)(
            q, (npix,), None, pb, _cl.to_device(np.zeros(4, np.float32) if planes is None else planes),
            np.int32(planes is not None), np.int32(W), np.int32(H),
            np.float32(camera.tan_half * camera.aspect), np.float32(camera.tan_half), np.float32(FAR_CORNER_RATIO),
            idbuf, t_buf, n_buf, far_buf)
        cl.enqueue_copy(q, ids, idbuf)
        cl.enqueue_copy(q, t, t_buf)
        cl.enqueue_copy(q, n_cam, n_buf)
        cl.enqueue_copy(q, far, far_buf)
    hit = ids != np.iinfo(np.int32).max
    tri_idx = np.where(hit, ids, 0)
    if src is not None:
        tri_idx = np.take(src, tri_idx)
    o = np.take(obj, tri_idx) if len(obj) else np.zeros(npix, np.int32)      # np.take: indexing is slower
    f = np.take(face, tri_idx) if len(face) else np.zeros(npix, np.int64)
    t64 = np.where(hit, t.astype(np.float64) / unit, np.inf).reshape(H, W)
    n64 = n_cam.astype(np.float64).reshape(H, W, 3)
    if len(tris):
        _far_corner_distances(tris, first > FAR_NORMAL_RATIO * size, tri_idx, hit, far.view(bool), t64, camera, n64)
    return _finish(camera, t64, n64, o, f)


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


def _float64_planes(tris, size, first, src, unit):
    """(M, 4) float32: for each raster triangle (``src`` from :func:`raster_triangles`) the unit normal and offset
    (``n . a``, scaled by ``unit``) of its source triangle's plane, from float64, where that triangle of ``tris``
    (camera space, (N, 3, 3); sizes ``size`` (N,), sums of absolute coordinates of their first corners ``first``
    (N,)) is large (:data:`PLANE_SIZE`) and reaches beyond :data:`FAR_PLANE_RATIO` times the plane's distance
    from the eye; a NaN offset elsewhere (the kernel's corners). None where no triangle is such (a frame's usual
    case)."""
    cand = np.flatnonzero(size > PLANE_SIZE * first)             # few: a ground, walls, their clipped pieces
    tri = tris[cand]
    reach = np.abs(tri.reshape(len(tri), 9)).max(axis=1)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(n, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        n /= length[:, None]
        off = np.einsum("ij,ij->i", n, tri[:, 0])
    use = (length > 0) & (reach > FAR_PLANE_RATIO * np.abs(off))
    if not use.any():
        return None
    planes = np.full((len(tris), 4), np.nan, np.float32)
    planes[cand[use], :3] = n[use]
    planes[cand[use], 3] = off[use] * unit
    return planes if src is None else planes[src]


def _far_corner_distances(tris, small, tri_idx, hit, far, t, camera, normal) -> None:
    """Replace in ``t`` (H, W) float64 the distances, and in ``normal`` (H, W, 3) the camera-space normals, of the
    covered pixels (``hit``) that the kernel marks ``far`` (their triangle reaches beyond :data:`FAR_CORNER_RATIO`
    times the distance of its plane from the eye), or whose triangle (``tris`` camera space, float64, index
    ``tri_idx`` per pixel) lies beyond :data:`FAR_NORMAL_RATIO` times its size from the eye (``small`` (N,)), by
    the float64 intersection of their ray with that triangle's plane and its normal (as the kernel's)."""
    flat = t.reshape(-1)
    if not small.any() and not far.any():
        return                              # no corner so far (a frame's usual case: no temporaries)
    sel = np.flatnonzero(hit & (far | np.take(small, tri_idx)))
    tri = np.take(tris, tri_idx[sel], axis=0)
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

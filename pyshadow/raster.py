"""Layered orthographic depth maps (depth peeling) of a mesh for a view set.

Stage "rasterise depth maps" of the pipeline (README.md, the table of stages);
thesis 000, section 5.2.2. One OpenCL work-item renders one whole map: it walks every
triangle and keeps, per texel, the ``layers`` nearest depths in sorted order.

Convention (relied on by every later stage): in the object's normalised frame
(see :func:`pyshadow.bounding_sphere`) texel ``(row r, column c)`` of map
``k`` is the ray with origin ``x*u_k + y*v_k + d_k``,
``x = 2(c+0.5)/R - 1``, ``y = 2(r+0.5)/R - 1``, direction ``-d_k``; a surface
point ``p`` hit by it has depth ``(1 - p.d_k)/2`` in [0, 1]. Layer 1 is the
nearest surface, layer 2 the next one behind it, layer 3 the one after;
``+inf`` where there is none.
"""
from __future__ import annotations

import numpy as np
import pyopencl as cl
import trimesh

from . import _cl
from ._cl import launch
from ._validate import check_int, flag, squared_lengths
from ._compat import keyword_only
from .mesh import bounding_sphere, load_mesh, referenced_mesh
from .views import ViewSet

__all__ = ["render_depth", "render_depth_reference", "DepthRenderer", "texel_rays", "covered_samples"]

MAX_RESOLUTION = 4096


def _check_args(views, resolution, layers):
    if not isinstance(views, ViewSet):
        raise TypeError(f"views must be a pyshadow.ViewSet, got {type(views).__name__}")
    if len(views) == 0:
        raise ValueError("the view set is empty: nothing to render")
    _check_resolution_layers(resolution, layers)


def _check_resolution_layers(resolution, layers):
    if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)):
        raise TypeError(f"resolution must be an int, got {resolution!r}")
    if not 1 <= int(resolution) <= MAX_RESOLUTION:
        raise ValueError(f"resolution must be in 1..{MAX_RESOLUTION}, got {resolution}")
    if isinstance(layers, bool) or not isinstance(layers, (int, np.integer)) or layers not in (1, 2, 3):
        raise ValueError(f"layers must be 1, 2 or 3, got {layers!r}")


def _check_bases(bases) -> np.ndarray:
    """``bases`` as (B, 3, 3) float64: finite, right-handed orthonormal rows ``(u, v, d)`` to
    :data:`pyshadow.views.BASIS_TOL` (a ViewSet's rule); others gave every texel ``+inf`` (NaN) or depths
    outside [0, 1] (a scaled basis), without a word."""
    from .views import BASIS_TOL

    b = np.asarray(bases)
    if b.dtype.kind not in "iuf":
        raise TypeError(f"bases must hold real numbers, got dtype {b.dtype}")
    if b.size % 9:
        raise ValueError(f"bases must have shape (B, 3, 3), got {b.shape}")
    b = b.astype(np.float64).reshape(-1, 3, 3)
    if not np.isfinite(b).all():
        raise ValueError(f"bases: {int((~np.isfinite(b)).any(axis=(1, 2)).sum())} bases are not finite")
    with np.errstate(over="ignore", invalid="ignore"):
        err = np.abs(np.einsum("nij,nkj->nik", b, b) - np.eye(3)).max(axis=(1, 2)) if len(b) else np.zeros(0)
        bad = ~(err <= BASIS_TOL) | ~(np.linalg.det(b) > 0 if len(b) else np.zeros(0, bool))
    if bad.any():
        k = int(np.argmax(bad))
        raise ValueError(f"bases: {int(bad.sum())} are not right-handed orthonormal (rows u, v, d; tolerance "
                         f"{BASIS_TOL:g}), first: basis {k}, {b[k].tolist()}")
    return b


def _both_sides(both_sides, n_faces: int, facing: bool) -> np.ndarray:
    """``both_sides`` checked: bool (n_faces,), given with ``facing``."""
    if not facing:
        raise ValueError("both_sides needs facing=True: it marks faces in the facing flags")
    flags = np.asarray(both_sides)
    if flags.dtype != bool or flags.shape != (n_faces,):
        raise ValueError(f"both_sides must be a bool array of shape ({n_faces},), got {flags.dtype} {flags.shape}")
    return flags


def _prepare_mesh(mesh, frame):
    if not isinstance(mesh, trimesh.Trimesh):
        mesh = load_mesh(mesh)
    verts = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces)
    if len(faces) == 0:
        raise ValueError("the mesh has no faces")
    if not np.isfinite(verts).all():
        raise ValueError("the mesh has non-finite vertices (use pyshadow.load_mesh)")
    if faces.min() < 0 or faces.max() >= len(verts):
        raise ValueError("a face refers to a vertex that does not exist")
    if len(faces) >= 2**31 or len(verts) >= 2**31:
        raise ValueError("meshes beyond 2^31 faces or vertices are not supported")
    centre, radius = (check_frame(np.asarray(referenced_mesh(mesh).vertices, np.float64), frame)   # faces' vertices
                      if frame is not None else bounding_sphere(mesh))
    vn = (verts - np.asarray(centre, dtype=np.float64)) / float(radius)
    return vn, faces.astype(np.int32)


def check_frame(verts, frame):
    """``frame = (centre, radius)`` as (3,) float64 and float: finite, radius > 0, every vertex within the
    radius (else depths leave [0, 1] and geometry is clipped) -- the CSM build's rule."""
    try:
        centre, radius = frame
        centre = np.asarray(centre, dtype=np.float64)
        radius = float(radius)
    except (TypeError, ValueError) as e:
        raise ValueError(f"frame must be (centre, radius), got {frame!r}") from e
    if centre.shape != (3,) or not np.isfinite(centre).all():
        raise ValueError(f"frame: the centre must be 3 finite numbers, got {centre!r}")
    if not (np.isfinite(radius) and radius > 0):
        raise ValueError(f"frame: the radius must be finite and > 0, got {radius!r}")
    far = float(np.sqrt(squared_lengths(verts - centre).max()))
    if not far <= radius * (1 + 1e-6):
        raise ValueError(f"frame: a vertex lies {far:.6g} from the centre, outside the radius {radius:.6g}")
    return centre, radius


def texel_rays(basis, resolution: int):
    """Origins and direction of the rays through every texel centre of one map.

    Parameters
    ----------
    basis : ndarray, shape (3, 3)
        Rows ``(u, v, d)`` of the map.
    resolution : int

    Returns
    -------
    origins : ndarray, shape (R, R, 3), float64
        ``x*u + y*v + d`` in the normalised frame, indexed ``[row, col]``.
    direction : ndarray, shape (3,), float64
        ``-d``.
    """
    basis = np.asarray(basis, dtype=np.float64)
    R = int(resolution)
    s = 2.0 * (np.arange(R) + 0.5) / R - 1.0
    y, x = np.meshgrid(s, s, indexing="ij")
    origins = x[..., None] * basis[0] + y[..., None] * basis[1] + basis[2]
    return origins, -basis[2]


class DepthRenderer:
    """Device-resident mesh that renders blocks of depth maps.

    Used by :func:`render_depth` and by the streaming CSM build, which keeps
    each block on the device. Construct once per mesh; :meth:`render` may be
    called for any number of blocks.

    Parameters
    ----------
    mesh : trimesh.Trimesh or path
    resolution : int
    layers : {1, 2, 3}
    frame : (centre, radius), optional
        Normalised frame; default :func:`pyshadow.bounding_sphere` of the mesh.
    facing : bool, optional
        Also record, per layer, whether the surface faces the map's light
        (see :meth:`render`).
    both_sides : ndarray, shape (F,), bool, optional
        With ``facing``: faces recorded as facing the light from either side
        (:func:`pyshadow.csm.exposure.exposed_back_faces`). Default none.
    """

    def __init__(self, mesh, resolution: int = 128, layers: int = 2, *, frame=None, facing: bool = False,
                 both_sides=None):

        _check_resolution_layers(resolution, layers)
        self.resolution = int(resolution)
        self.layers = int(layers)
        self.facing = flag(facing, "facing")        # the string "no" was true
        verts, faces = _prepare_mesh(mesh, frame)
        self.n_faces = len(faces)
        pad = launch.TRIANGLE_PAD
        tpad = -(-len(faces) // pad) * pad
        soa = np.zeros((9 + self.facing, tpad), dtype=np.float32)
        soa[:9, : len(faces)] = verts.astype(np.float32)[faces].reshape(len(faces), 9).T
        if both_sides is not None:
            soa[9, : len(faces)] = _both_sides(both_sides, len(faces), self.facing)
        self._tpad = tpad
        self._tris = _cl.to_device(soa)
        self._kernel = _cl.kernel(
            "raster.cl", "render_depth_layers",
            {"RES": self.resolution, "LAYERS": self.layers, "FACING": int(self.facing)},
        )

    @property
    def bytes_per_map(self) -> int:
        return 4 * self.layers * self.resolution**2

    @property
    def facing_bytes_per_map(self) -> int:
        return self.layers * self.resolution**2

    def render(self, bases: np.ndarray, out: cl.Buffer | None = None,
               front: cl.Buffer | None = None) -> cl.Buffer:
        """Render maps with ``bases`` (B, 3, 3) into a device buffer (B, layers, R, R) float32.

        With ``facing=True``, ``front`` (a device buffer of at least B *
        :attr:`facing_bytes_per_map` bytes) receives (B, layers, R, R) uint8:
        1 where the layer's surface faces the light (its normal, from the
        triangle's winding, has a positive component along the map's ``d``,
        or it is one of ``both_sides``), else 0 (also where there is no
        surface).
        """
        bases = _check_bases(bases)
        n = len(bases)
        if n == 0:
            raise ValueError("no views to render")
        nbytes = n * self.bytes_per_map
        fbytes = n * self.facing_bytes_per_map
        if out is not None and out.size < nbytes:
            raise ValueError(f"output buffer holds {out.size} bytes, {nbytes} needed")
        if self.facing and (front is None or front.size < fbytes):     # before `out` is overwritten
            raise ValueError(f"facing=True needs a front buffer of {fbytes} bytes")
        if out is None:
            out = _cl.empty(nbytes)
        q = _cl.queue()
        launch.fill(q, out, np.float32(np.inf), nbytes)
        if self.facing:
            launch.fill(q, front, np.uint8(0), fbytes)
        bases_buf = _cl.to_device(bases.reshape(n, 9), np.float32)
        group = launch.shape().raster_group      # why: pyshadow._cl.launch
        local = None if group is None else (group,)
        global_size = (n if group is None else -(-n // group) * group,)
        self._kernel(
            q, global_size, local, self._tris, np.int32(self.n_faces), np.int32(self._tpad),
            bases_buf, np.int32(n), out, front if self.facing else out,
        )
        return out


@keyword_only("pyshadow.render_depth", old=2)
def render_depth(mesh, views: ViewSet, *, resolution: int = 128, layers: int = 2,
                 frame=None, block: int | None = None, progress: bool = False, facing: bool = False,
                 both_sides=None):
    """Layered depth maps of ``mesh`` for every view of ``views``.

    Parameters
    ----------
    mesh : trimesh.Trimesh or path
        Anything :func:`pyshadow.load_mesh` accepts (a Trimesh is used as is).
    views : ViewSet
        ``D`` views, at least one.
    resolution : int, optional
        Texels per side ``R``, 1 .. 4096.
    layers : {1, 2, 3}, optional
        Depth layers kept per texel.
    frame : (centre, radius), optional
        Normalised frame; default :func:`pyshadow.bounding_sphere` of the mesh.
    block : int, optional
        Maps per kernel launch; default keeps a launch's output near 64 MiB
        (or the device's largest buffer, where less).
    progress : bool, optional
        Show a progress bar over the blocks.
    facing : bool, optional
        Also return which surfaces face the light.
    both_sides : ndarray, shape (F,), bool, optional
        With ``facing``: faces that face the light from either side.

    Returns
    -------
    depth : ndarray, shape (D, layers, R, R), float32
        Depth in [0, 1] of the ``layers`` nearest surfaces per texel, nearest
        first; ``+inf`` where the ray meets fewer surfaces. See the module
        docstring for the exact texel and depth convention.
    front : ndarray, shape (D, layers, R, R), bool
        Only with ``facing=True``: the surface of that layer faces the light
        (the map's ``d``): its normal, by the triangle's winding
        (counter-clockwise seen from the side it points to), has a positive
        component along ``d``, or it is one of ``both_sides``. False where
        there is no surface.

    Raises
    ------
    ValueError
        Empty view set, resolution outside 1..4096, layers not in {1, 2, 3},
        block below 1, or an invalid mesh. Nothing is launched.
    TypeError
        A resolution or block that is no int; progress or facing not True or False.

    Examples
    --------
    >>> import trimesh
    >>> d = render_depth(trimesh.creation.icosphere(), ViewSet.zigzag(2, 4), resolution=8)
    >>> d.shape
    (8, 2, 8, 8)
    """
    _check_args(views, resolution, layers)
    progress = flag(progress, "progress")           # the string "no" showed a bar
    if block is not None:                           # checked before the kernel is built
        block = check_int(block, "block", 1)
    renderer = DepthRenderer(mesh, resolution, layers, frame=frame, facing=facing, both_sides=both_sides)
    facing = renderer.facing
    D = len(views)
    if block is None:
        block = max(1, min(D, launch.block_budget(64 << 20) // renderer.bytes_per_map))
    out = np.empty((D, renderer.layers, renderer.resolution, renderer.resolution), np.float32)
    buf = _cl.empty(min(block, D) * renderer.bytes_per_map)
    fout = np.empty(out.shape, np.uint8) if facing else None
    fbuf = _cl.empty(min(block, D) * renderer.facing_bytes_per_map) if facing else None
    starts = range(0, D, block)
    if progress:
        from tqdm.auto import tqdm

        starts = tqdm(starts, desc="depth maps", unit="block")
    q = _cl.queue()
    for s in starts:
        e = min(D, s + block)
        renderer.render(views.bases[s:e], buf, fbuf)
        cl.enqueue_copy(q, out[s:e], buf)
        if facing:
            cl.enqueue_copy(q, fout[s:e], fbuf)
    return (out, fout.view(bool)) if facing else out


# ---------------------------------------------------------------------------
# NumPy reference (small inputs only)
# ---------------------------------------------------------------------------
def _edge(a, b, p):
    """cross(b - a, p - a) from the canonical endpoint, as in raster_common.h."""
    swap = (b[0] < a[0]) or (b[0] == a[0] and b[1] < a[1])
    if swap:
        return -((a[0] - b[0]) * (p[..., 1] - b[1]) - (a[1] - b[1]) * (p[..., 0] - b[0]))
    return (b[0] - a[0]) * (p[..., 1] - a[1]) - (b[1] - a[1]) * (p[..., 0] - a[0])


def _owns(a, b):
    dx, dy = b[0] - a[0], b[1] - a[1]
    return dy > 0 or (dy == 0 and dx < 0)


def covered_samples(p0, p1, p2, lo, hi):
    """Sample points of a screen triangle's box that it covers (NumPy, float64).

    The canonical edge functions and top-left rule of ``raster_common.h``:
    ``lo``, ``hi`` the integer box (inclusive). Returns ``(rows, cols, w)``
    of the covered samples and their barycentric weights (3, n), or ``None``
    when the triangle is degenerate or covers nothing.
    """
    area = _edge(p0, p1, p2)
    if area == 0 or not np.isfinite(area):
        return None
    cols, rows = np.meshgrid(np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1))
    p = np.stack([cols, rows], axis=-1).astype(np.float64)
    e = np.stack([_edge(p1, p2, p), _edge(p2, p0, p), _edge(p0, p1, p)])
    if area > 0:
        owns = [_owns(p1, p2), _owns(p2, p0), _owns(p0, p1)]
    else:
        e = -e
        owns = [_owns(p2, p1), _owns(p0, p2), _owns(p1, p0)]
    inside = (e >= 0).all(axis=0)
    for i in range(3):
        inside &= (e[i] > 0) | owns[i]
    if not inside.any():
        return None
    return rows[inside], cols[inside], e[:, inside] / e[:, inside].sum(axis=0)


@keyword_only("pyshadow.raster.render_depth_reference", old=2)
def render_depth_reference(mesh, views: ViewSet, *, resolution: int = 32, layers: int = 2,
                           frame=None, facing: bool = False, both_sides=None):
    """NumPy version of :func:`render_depth` (same rules, float64; slow).

    For each view and each triangle the texel centres inside the triangle's
    bounding box are tested with the same canonical edge functions and
    top-left rule as the kernel; every covered texel collects the depth, and
    the ``layers`` smallest depths per texel are kept. With ``facing`` also
    the flags of :func:`render_depth`: a triangle faces the light when its
    screen-space area (counter-clockwise positive) is positive, or it is one
    of ``both_sides`` (:class:`DepthRenderer`).
    """

    _check_args(views, resolution, layers)
    facing = flag(facing, "facing")
    verts, faces = _prepare_mesh(mesh, frame)
    both = np.zeros(len(faces), bool) if both_sides is None else _both_sides(both_sides, len(faces), facing)
    R = int(resolution)
    out = np.full((len(views), layers, R, R), np.inf)
    front = np.zeros(out.shape, bool)
    for k, B in enumerate(views.bases):
        scr = (verts @ B[:2].T + 1.0) * (0.5 * R) - 0.5  # (V, 2) screen coords
        z = (1.0 - verts @ B[2]) * 0.5
        hits = [[[] for _ in range(R)] for _ in range(R)]
        for f, two in zip(faces, both):
            p0, p1, p2 = scr[f[0]], scr[f[1]], scr[f[2]]
            lo = np.ceil(np.minimum(np.minimum(p0, p1), p2)).astype(int)
            hi = np.floor(np.maximum(np.maximum(p0, p1), p2)).astype(int)
            lo = np.maximum(lo, 0)
            hi = np.minimum(hi, R - 1)
            if (lo > hi).any():
                continue
            cov = covered_samples(p0, p1, p2, lo, hi)
            if cov is None:
                continue
            rows, cols, w = cov
            zz = w[0] * z[f[0]] + w[1] * z[f[1]] + w[2] * z[f[2]]
            faces_light = _edge(p0, p1, p2) > 0 or two
            for r, c, d in zip(rows, cols, zz):
                hits[r][c].append((d, faces_light))
        for r in range(R):
            for c in range(R):
                h = sorted(hits[r][c], key=lambda hit: hit[0])[:layers]
                out[k, : len(h), r, c] = [d for d, _ in h]
                front[k, : len(h), r, c] = [f for _, f in h]
    out = out.astype(np.float32)
    return (out, front) if facing else out

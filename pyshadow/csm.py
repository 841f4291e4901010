"""Coherent Shadow Maps: streaming compression, stored-depth queries, .csm files.

Stage "compress" of the pipeline (DESIGN.md "CSM compression"; thesis 000,
sections 4.2.1, 5.2.1-5.2.3; Ritschel et al. 2007).

For every texel ``t`` the maps are visited in view-set order ``i = 0..D-1``.
Map ``i`` allows a set of stored depths that still gives the right shadow
test along the texel's ray:

* hit at least twice: ``[z1, z2)``; where the surface at ``z2`` faces the
  light (a second sheet of an open mesh, in the first one's shadow) only up
  to ``z2`` less a margin of ``FRONT_MARGIN_TEXELS`` texels, and just ``z1``
  when that leaves nothing; with ``layers=3`` up to ``z3`` less the margin
  where the ray leaves the object at ``z2`` and re-enters at ``z3``, see
  :meth:`CoherentShadowMap.build`. The margin exists because such a surface
  is asked with a self-bias (1.5 texels by default, see
  :meth:`pyshadow.Scene.visible`): a stored depth within the bias of it
  would light it;
* hit once (a hole behind the first surface): only ``z1``;
* missed: only ``+inf`` (a miss meets nothing but other misses).

A run of consecutive maps whose sets still intersect is stored as one segment
``(z, i_end)`` with ``z`` inside the intersection and ``i_end`` the run's last
map; greedy extension gives the fewest segments for the order. Per texel the
segments are sorted by ``i_end``; ``offsets[t] .. offsets[t+1]`` is texel
``t``'s list. The build streams: a block of maps is rendered, folded into the
per-texel run state on the device and dropped, so memory does not grow with
the number of maps.

Depth storage: 16 bit fixed point ``k / 65534`` (``k = 65535`` is a miss) or
32 bit float (``+inf`` a miss). Quantised values obey the same rule: each
map's set becomes a set of integer keys (``[ceil(z1*Q), ceil(z2*Q) - 1]``)
and runs intersect those exactly, so a stored 16-bit depth always lies inside
the interval of every map of its run -- except where a single map's
``[z1, z2)`` holds no quantum at all (surfaces closer than 1/65534); such a
map stands alone with the smallest quantum at or above ``z1``.
"""
from __future__ import annotations

import hashlib
import json
import os
import time
from pathlib import Path

import numpy as np
import pyopencl as cl
import trimesh

from . import _cl
from ._files import atomic_path
from ._version import __version__
from .mesh import bounding_sphere, load_mesh, mesh_hash
from .raster import DepthRenderer, _check_resolution_layers
from .views import ViewSet

__all__ = ["CoherentShadowMap", "CSMFormatError", "DEPTH_Q", "MISS16", "FRONT_MARGIN_TEXELS",
           "compress_reference", "front_margin", "corner_frame", "footprint_corners", "footprint_interval",
           "footprint_scale"]

DEPTH_Q = 65534          # 16-bit depth k means k / DEPTH_Q
SEARCH_BLOCK = 16        # segments per block of the device search summary
MISS16 = 65535           # 16-bit stored value of a miss (+inf)
MAGIC = b"PYSHCSM\x00"
FORMAT_VERSION = 1
# a run's depth stays this many texels (of depth, 1/R each) in front of a
# surface behind the first one that faces the light (z2 of an open mesh, z3 of
# layers=3): twice the visibility kernel's default self-bias, so points on that
# surface stay in shadow under the bias (module docstring)
FRONT_MARGIN_TEXELS = 3.0
ALIGN = 64
_LAYOUTS = ("zigzag", "hilbert")


class CSMFormatError(ValueError):
    """A .csm file is truncated, corrupted, foreign or inconsistent."""


def _defines(resolution, layers, rule, block, depth_bits, iend_dtype):
    return {
        "RES": int(resolution),
        "MARGIN": float(front_margin(resolution)).hex() + "f",   # exact float32, as a hex literal
        "LAYERS": int(layers),
        "LAYER_RULE": int(rule),
        "BLOCK": int(block),
        "DEPTH_BITS": int(depth_bits),
        "IEND_T": "ushort" if np.dtype(iend_dtype) == np.uint16 else "uint",
    }


def front_margin(resolution) -> np.float32:
    """The margin in normalised depth: ``FRONT_MARGIN_TEXELS / R`` as float32."""
    return np.float32(FRONT_MARGIN_TEXELS / int(resolution))


def _keys_at_or_above(z, depth_bits):
    """Smallest depth key >= z (z >= 0, float32), as csm_common.h; int64."""
    z = np.asarray(z, np.float32)
    if depth_bits == 16:
        # float64 holds z * Q exactly (24 + 16 bits): its ceiling is the exact one
        return np.minimum(np.ceil(np.minimum(z, 1).astype(np.float64) * DEPTH_Q), DEPTH_Q).astype(np.int64)
    return np.maximum(z, np.float32(0)).view(np.uint32).astype(np.int64)


def _keys_below(z, depth_bits):
    """Largest depth key < z, -1 when there is none (the kernel's (uint)-1)."""
    k = _keys_at_or_above(z, depth_bits) - 1
    if depth_bits == 16:
        k = np.where(np.asarray(z, np.float32) > 1, DEPTH_Q, k)
    return k


def footprint_scale(resolution) -> np.float32:
    """``(R + 1) / R`` as float32: corner depth ``z'`` -> ``0.5 - s (0.5 - z')``.

    The corner maps of a footprint build are rendered at ``R + 1`` texels
    over a frame ``(R + 1) / R`` times as wide (same centre): their texel
    centres are the corners of the ``R x R`` grid.
    """
    return np.float32((int(resolution) + 1) / int(resolution))


def corner_frame(frame, resolution):
    """The frame of a footprint build's corner maps: ``frame`` widened ``(R + 1) / R`` times.

    Maps of ``R + 1`` texels over it have their texel centres on the corners
    of the ``R x R`` grid of ``frame = (centre, radius)``.
    """
    centre, radius = frame
    R = int(resolution)
    return centre, radius * (R + 1) / R


def footprint_corners(mesh, views: ViewSet, resolution: int, layers: int, frame):
    """The corner maps a footprint build folds in, for :func:`compress_reference`.

    ``render_depth(mesh, views, R + 1, layers, frame=corner_frame(frame, R),
    facing=True)``: depth (D, layers, R+1, R+1) float32 in the corner frame,
    and the facing flags.
    """
    from .raster import render_depth

    return render_depth(mesh, views, int(resolution) + 1, layers, frame=corner_frame(frame, resolution),
                        facing=True)


def footprint_interval(z1, hic, c1, c2, c2_front, margin, scale):
    """NumPy version of ``footprint_keys`` (csm.cl) before the keys, float32.

    Parameters
    ----------
    z1, hic : ndarray, shape (T,), float32
        The centre's first depth and upper end ``z2'`` (finite).
    c1, c2 : ndarray, shape (T, 4), float32
        First and second depth at the texel's corners, corner-grid entries
        ``(row, col), (row, col+1), (row+1, col), (row+1, col+1)``, in the
        corner frame; ``+inf`` for none.
    c2_front : ndarray, shape (T, 4), bool
        The second corner surface faces the light.
    margin : float
        :func:`front_margin` (normalised depth): a second corner surface
        that faces the light bounds the interval this far in front of it.
    scale : float
        :func:`footprint_scale` of ``R``.

    Returns
    -------
    lo, hi : ndarray, shape (T,), float32
        The footprint interval ``[lo, hi)``: ``lo`` is the largest of ``z1``
        and the corners' first depths below ``hic``; ``hi`` the smallest of
        ``hic`` and the corners' second depths above ``lo``. So ``z1 <= lo
        <= hi <= hic``; where no depth key lies in ``[lo, hi)`` the build
        keeps the centre's interval.
    """
    f = np.float32
    half = f(0.5)
    with np.errstate(invalid="ignore"):
        d1 = np.where(np.isfinite(c1), half - f(scale) * (half - c1), np.inf).astype(f)
        d2 = np.where(np.isfinite(c2), half - f(scale) * (half - c2), np.inf).astype(f)
        d2 = np.where(np.isfinite(d2) & c2_front, np.maximum(d2 - f(margin), d1), d2).astype(f)
    lo = np.maximum(z1, np.where(d1 < hic[:, None], d1, -np.inf).max(axis=1)).astype(f)
    hi = np.minimum(hic, np.where(np.isfinite(d2) & (d2 > lo[:, None]), d2, np.inf).min(axis=1)).astype(f)
    return lo, hi


def compress_reference(layers, front, rule: int = 2, depth_bits: int = 16, margin_depth=None,
                       corners=None, corner_front=None):
    """NumPy version of the compression kernel: greedy runs per texel, in map order.

    Parameters
    ----------
    layers : ndarray, shape (D, L, R, R), float32
        Depth layers in view-set order (:func:`pyshadow.render_depth` with
        ``L >= rule``; ``+inf`` where a ray has fewer hits).
    front : ndarray, shape (D, L, R, R), bool
        Which layers face the light (``render_depth(..., facing=True)``).
    rule : {2, 3}
        Interval rule, as ``layers`` of :meth:`CoherentShadowMap.build`.
    depth_bits : {16, 32}
    margin_depth : float, optional
        The margin in front of a surface facing the light (normalised
        depth); default :func:`front_margin` of ``R``, as the build uses.
    corners, corner_front : ndarray, shape (D, L, R+1, R+1), optional
        The footprint build's corner maps (:func:`footprint_corners`);
        given, each map's interval is narrowed as in
        ``CoherentShadowMap.build(..., footprint=True)``.

    Returns
    -------
    offsets : ndarray, shape (R*R + 1,), int64
    iend : ndarray, shape (S,), int64
    depth : ndarray, shape (S,), uint16 or float32
        The arrays of :meth:`CoherentShadowMap.build` for the same maps,
        bit for bit.
    """
    layers = np.asarray(layers, np.float32)
    front = np.asarray(front, bool)
    D, L, R = layers.shape[0], layers.shape[1], layers.shape[2]
    if corners is not None:
        corners = np.asarray(corners, np.float32)
        corner_front = np.asarray(corner_front, bool)
        if corners.shape[:2] != (D, L) or corners.shape[2:] != (R + 1, R + 1) or corner_front.shape != corners.shape:
            raise ValueError(f"corners must have shape {(D, L, R + 1, R + 1)}, got {corners.shape}")
    if L < rule:
        raise ValueError(f"rule {rule} needs {rule} layers, got {L}")
    if front.shape != layers.shape:
        raise ValueError(f"front has shape {front.shape}, layers {layers.shape}")
    margin = front_margin(R) if margin_depth is None else np.float32(margin_depth)
    miss_key = 65535 if depth_bits == 16 else int(np.float32(np.inf).view(np.uint32))
    T = R * R
    lo = hi2 = hi3 = np.zeros(T, np.int64)
    started = False
    emitted = []                                    # (texels, i_end, stored values) per emission

    def value(lo, hi2, hi3):
        hi = np.where(lo <= hi2, hi2, hi3)
        if depth_bits == 16:
            return ((lo + hi) >> 1).astype(np.uint16)
        a = lo.astype(np.uint32).view(np.float32)
        b = hi.astype(np.uint32).view(np.float32)
        with np.errstate(invalid="ignore"):
            m = (a + (b - a) * np.float32(0.5)).view(np.uint32).astype(np.int64)
        m = np.where(lo == miss_key, lo, np.clip(m, lo, hi))
        return m.astype(np.uint32).view(np.float32)

    for i in range(D):
        z1, z2 = layers[i, 0].ravel(), layers[i, 1].ravel()
        hit, two = np.isfinite(z1), np.isfinite(z2)
        mlo = np.where(hit, _keys_at_or_above(np.where(hit, z1, 0), depth_bits), miss_key)
        front2 = front[i, 1].ravel()
        z2b = np.where(front2, np.maximum(z2 - margin, z1), z2)      # float32, as the kernel
        k2 = _keys_below(np.where(two, z2b, 0), depth_bits)
        mhi2 = np.where(two & (k2 >= mlo), k2, mlo)   # hit once, or no key below the bound: {z1}
        if corners is not None:
            c1, c2, cf = (np.stack([a[i, layer, r:r + R, c:c + R].ravel() for r in (0, 1) for c in (0, 1)], 1)
                          for a, layer in ((corners, 0), (corners, 1), (corner_front, 1)))
            use = hit & two
            flo, fhi = footprint_interval(np.where(use, z1, 0), np.where(use, z2b, 1), c1, c2, cf, margin,
                                          footprint_scale(R))
            klo = _keys_at_or_above(flo, depth_bits)
            khi = _keys_below(fhi, depth_bits)
            use &= khi >= klo
            mlo = np.where(use, klo, mlo)
            mhi2 = np.where(use, khi, mhi2)
        mhi3 = mhi2
        if rule == 3:
            z3 = layers[i, 2].ravel()
            z3m = z3 - margin
            re_enter = two & ~front2 & np.isfinite(z3) & (z3m > z2)
            mhi3 = np.where(re_enter, np.maximum(_keys_below(np.where(re_enter, z3m, 0), depth_bits), mhi2),
                            mhi2)
        if started:
            nlo, nhi3 = np.maximum(lo, mlo), np.minimum(hi3, mhi3)
            join = nlo <= nhi3
            out = np.flatnonzero(~join)
            emitted.append((out, i - 1, value(lo[out], hi2[out], hi3[out])))
            lo = np.where(join, nlo, mlo)
            hi2 = np.where(join, np.minimum(hi2, mhi2), mhi2)
            hi3 = np.where(join, nhi3, mhi3)
        else:
            lo, hi2, hi3, started = mlo, mhi2, mhi3, True
    emitted.append((np.arange(T), D - 1, value(lo, hi2, hi3)))
    texel = np.concatenate([e[0] for e in emitted])
    iend = np.concatenate([np.full(len(e[0]), e[1], np.int64) for e in emitted])
    depth = np.concatenate([e[2] for e in emitted])
    order = np.lexsort((iend, texel))
    offsets = np.zeros(T + 1, np.int64)
    np.cumsum(np.bincount(texel, minlength=T), out=offsets[1:])
    return offsets, iend[order], depth[order]


def _check_frame(mesh, frame):
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
    far = float(np.linalg.norm(np.asarray(mesh.vertices, np.float64) - centre, axis=1).max())
    if far > radius * (1 + 1e-6):
        raise ValueError(f"frame: a vertex lies {far:.6g} from the centre, outside the radius {radius:.6g}")
    return centre, radius


def _depth_dtype(bits):
    return np.dtype(np.uint16) if bits == 16 else np.dtype(np.float32)


def _iend_dtype(maps):
    return np.dtype(np.uint16) if maps <= 65536 else np.dtype(np.uint32)


def _offsets_dtype(segments):
    return np.dtype(np.uint32) if segments < 2**32 else np.dtype(np.uint64)


class CoherentShadowMap:
    """Compressed visibility of one rigid object from every map direction.

    Build with :meth:`build` or read with :meth:`load`. All geometry lives in
    the object's normalised frame (``centre``, ``radius``).

    Attributes
    ----------
    views : ViewSet
        The ``D`` map directions in compression order.
    resolution : int
        Texels per map side ``R``.
    depth_bits : {16, 32}
    layer_rule : {2, 3}
        2: runs intersect ``[z1, z2)``; 3: up to ``z3`` (closed meshes); both
        keep a margin in front of surfaces that face the light (module
        docstring).
    centre : ndarray, shape (3,), float64
    radius : float
    mesh_hash : str
        SHA-256 of the mesh the maps were rendered from.
    offsets : ndarray, shape (R*R + 1,), uint32 or uint64
        Texel ``t = row*R + col`` owns segments ``offsets[t]:offsets[t+1]``.
    iend : ndarray, shape (S,), uint16 (D <= 65536) or uint32
        Last map index of each segment, strictly increasing within a list,
        the last of every list ``D - 1``.
    depth : ndarray, shape (S,), uint16 or float32
        Stored depth (see module docstring for the encoding).
    front_margin_texels : float
        How far (in texels of depth, ``1/R`` each) a stored depth stays in
        front of a surface behind the first one that faces the light; 0 for
        files written before the margin existed.
    footprint : bool
        Built with ``footprint=True`` (intervals over each texel's corners);
        False for files written before the option existed.
    stats : dict
        See :attr:`stats`.
    """

    def __init__(self, *, views, resolution, depth_bits, layer_rule, centre, radius, mesh_hash,
                 offsets, iend, depth, build_seconds=float("nan"), peak_bytes=0, front_margin_texels=0.0,
                 footprint=False):
        self.views = views
        self.resolution = int(resolution)
        self.depth_bits = int(depth_bits)
        self.layer_rule = int(layer_rule)
        self.front_margin_texels = float(front_margin_texels)
        self.footprint = bool(footprint)
        self.centre = np.asarray(centre, dtype=np.float64)
        self.radius = float(radius)
        self.mesh_hash = str(mesh_hash)
        self.offsets = offsets
        self.iend = iend
        self.depth = depth
        self._build_seconds = float(build_seconds)
        self._peak_bytes = int(peak_bytes)
        self._device = None

    # ------------------------------------------------------------------
    # build
    # ------------------------------------------------------------------
    @classmethod
    def build(cls, mesh, views: ViewSet, resolution: int = 128, depth_bits: int = 16,
              layers="auto", block: int | None = None, progress: bool = True,
              frame=None, footprint: bool = False) -> "CoherentShadowMap":
        """Render and compress the depth maps of ``mesh`` for ``views``.

        Parameters
        ----------
        mesh : trimesh.Trimesh or path
            Anything :func:`pyshadow.load_mesh` accepts.
        views : ViewSet
            A ``zigzag`` or ``hilbert`` view set (their nearest-map lookup is
            what the query kernels implement).
        resolution : int, optional
            Texels per side, 1 .. 4096.
        depth_bits : {16, 32}, optional
            Stored depth precision.
        layers : {'auto', 2, 3}, optional
            Which surfaces bound a map's interval of valid depths.
            ``2``: ``[z1, z2)`` -- every shadow query along a texel's ray is
            exact (up to the depth quantum and the map discretisation), for
            points anywhere: on this object, on other objects, on the ground
            -- on a closed mesh. On an open one, a point in the air between
            two sheets (inside an open box, say) may be reported lit; points
            on the second sheet, where it faces the light, stay in shadow:
            the interval there ends ``m`` (below) in front of it, or is just
            ``z1``.
            ``3``: ``[z1, z3 - m)`` with ``m = FRONT_MARGIN_TEXELS / R`` (3
            texels of depth) where the texel's ray leaves the object at
            ``z2`` and re-enters it at ``z3`` and ``z3 - m > z2``, ``[z1,
            z2)`` elsewhere; closed meshes only (the freedom of Ritschel et al.;
            thesis 4.2.1, footnote 2). Fewer segments. Exact for points on
            this object's own surface whose normal faces the light, tested
            with a self-bias up to ``m`` (the back face at ``z2`` is never
            asked: its hemisphere excludes the light; the default self-bias
            of :meth:`pyshadow.Scene.visible` is 1.5 texels plus an angle
            term), and for every other point except those inside a
            concavity of the object along the ray, between its exit ``z2``
            and re-entry ``z3``: such a point (on another body, say, tucked
            under an arch of this one) may be reported lit where it is in
            shadow. Without the margin a stored depth can sit within the
            self-bias of ``z3`` and light the re-entry surface: on homer,
            the fandisk and featuretype that cost 0.3-0.9 % of visibility
            agreement with Embree; the margin wins it back and keeps half to
            two thirds of the size saving (benchmarks/README.md). The stored
            depth is taken inside ``[z1, z2)`` of every map of the run
            whenever that is possible. (Leaving ``[z1, inf)`` to rays with no third surface
            would compress further -- 38:1 instead of 26:1 for the filled
            bunny at 64x128 -- but then a body drops its shadows on everything
            behind it, the ground included: AO 0.60 instead of 0 under a box.)
            ``'auto'``: 3 for watertight meshes, else 2.
        block : int, optional
            Maps rendered and folded per step; default keeps the device
            working set near 96 MiB. Peak memory depends on ``block`` and
            ``resolution``, not on ``len(views)``.
        progress : bool, optional
            Progress bar over the blocks (shown only on a terminal).
        frame : (centre, radius), optional
            The sphere the maps frame, in the mesh's units: centre shape (3,),
            radius > 0; it must hold every vertex. Default: the minimal
            bounding sphere (:func:`pyshadow.bounding_sphere`), which puts the
            most texels on the object. A wider sphere leaves empty texels
            around it, which cost one segment each: the ratio rises and the
            detail per texel falls. The sphere around the bunny's bounding
            box (1.25x its minimal radius) gives its 64x128 @ 128^2 CSM
            24.2:1 instead of 15.4:1, for visibility agreement with Embree
            on AO rays of 99.44 instead of 99.52 % (benchmarks/README.md,
            ``compression.py``).
        footprint : bool, optional
            Take each map's interval over the texel's whole footprint, not
            only along its centre ray: where the centre ray meets two
            surfaces, the first surface's depth at the texel's four corners
            raises the lower end (a point anywhere in the texel on the
            surface nearest the light then stays lit without a larger
            self-bias) and the second surface's depth at the corners lowers
            the upper end. Corner depths come from a second rendering at
            ``R + 1`` texels (:func:`footprint_interval`); the result always
            lies inside the centre's interval, so every guarantee above
            holds, and where the corners leave no depth the centre's
            interval stands. Narrower intervals mean more segments, and the
            second rendering makes the build about 2x slower. Bunny, 64x128
            @ 128^2: visibility agreement with Embree on uniform hemisphere
            rays 98.67 -> 98.84 %, on AO rays 99.52 -> 99.56 %, ratio 15.4 ->
            13.0:1, build 6.3 -> 12.3 s on 2 CPU cores; every bundled mesh gains 0.1-0.4
            points on uniform rays for 8-25 % of its ratio
            (benchmarks/accuracy.py, section 7). ``R <= 4095``.

        Returns
        -------
        CoherentShadowMap
        """
        t0 = time.perf_counter()
        if not isinstance(views, ViewSet):
            raise TypeError(f"views must be a pyshadow.ViewSet, got {type(views).__name__}")
        if views.layout not in _LAYOUTS:
            raise ValueError(f"a CSM needs a 'zigzag' or 'hilbert' view set, got {views.layout!r}")
        if len(views) == 0:
            raise ValueError("the view set is empty")
        if len(views) >= 2**32 - 1:
            raise ValueError("too many maps")
        if depth_bits not in (16, 32) or isinstance(depth_bits, bool):
            raise ValueError(f"depth_bits must be 16 or 32, got {depth_bits!r}")
        _check_resolution_layers(resolution, 2)
        if not isinstance(mesh, trimesh.Trimesh):
            mesh = load_mesh(mesh)
        if layers == "auto":
            rule = 3 if mesh.is_watertight else 2
        elif layers in (2, 3) and not isinstance(layers, bool):
            rule = int(layers)
            if rule == 3 and not mesh.is_watertight:
                raise ValueError("layers=3 ([z1, z3) intervals) needs a watertight mesh; "
                                 "this one has boundary edges (use layers=2 or fill_holes=True)")
        else:
            raise ValueError(f"layers must be 'auto', 2 or 3, got {layers!r}")
        R = int(resolution)
        D = len(views)
        if not isinstance(footprint, (bool, np.bool_)):
            raise TypeError(f"footprint must be True or False, got {footprint!r}")
        footprint = bool(footprint)
        if footprint and R >= 4096:
            raise ValueError("footprint=True renders the corners at resolution + 1: resolution must be <= 4095")
        centre, radius = bounding_sphere(mesh) if frame is None else _check_frame(mesh, frame)
        dtype_z = _depth_dtype(depth_bits)
        dtype_i = _iend_dtype(D)
        per_map = rule * R * R * 5 + R * R * (dtype_z.itemsize + 4)
        if footprint:
            per_map += rule * (R + 1) ** 2 * 5
        if block is None:
            block = max(1, min(D, (96 << 20) // per_map))
        block = int(block)
        if block < 1:
            raise ValueError(f"block must be >= 1, got {block}")
        block = min(block, D)

        renderer = DepthRenderer(mesh, R, rule, frame=(centre, radius), facing=True)
        defs = _defines(R, rule, rule, block, depth_bits, dtype_i)
        corner_args = ()
        if footprint:
            scale = footprint_scale(R)
            corners = DepthRenderer(mesh, R + 1, rule, frame=corner_frame((centre, radius), R), facing=True)
            cdepth_buf = _cl.empty(block * corners.bytes_per_map)
            cfront_buf = _cl.empty(block * corners.facing_bytes_per_map)
            corner_args = (cdepth_buf, cfront_buf, scale)
            defs["FOOTPRINT"] = 1
        k_fold = _cl.kernel("csm.cl", "csm_fold", defs)
        k_compact = _cl.kernel("csm.cl", "csm_compact", defs)
        q = _cl.queue()
        T = R * R
        depth_buf = _cl.empty(block * renderer.bytes_per_map)
        front_buf = _cl.empty(block * renderer.facing_bytes_per_map)
        state = _cl.empty(T * 16)
        cl.enqueue_fill_buffer(q, state, np.uint32(0), 0, T * 16)
        slots = block + 1          # a block emits at most one segment per map, plus the last
        seg_z = _cl.empty(T * slots * dtype_z.itemsize)
        seg_i = _cl.empty(T * slots * 4)
        count_buf = _cl.empty(T * 4)
        device_bytes = (block * (renderer.bytes_per_map + renderer.facing_bytes_per_map) + T * 16 + T * slots * (dtype_z.itemsize + 4)
                        + T * 8 + 36 * renderer.n_faces)
        if footprint:
            device_bytes += block * (corners.bytes_per_map + corners.facing_bytes_per_map) + 36 * corners.n_faces
        counts = np.empty(T, np.uint32)
        blocks = []
        host_bytes = 0
        starts = range(0, D, block)
        bar = None
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=D, desc="CSM build", unit="map", disable=None, leave=False)
        try:
            for s in starts:
                e = min(D, s + block)
                renderer.render(views.bases[s:e], depth_buf, front_buf)
                if footprint:
                    corners.render(views.bases[s:e], cdepth_buf, cfront_buf)
                k_fold(q, (T,), None, depth_buf, front_buf, *corner_args, np.int32(e - s), np.int32(s),
                       np.int32(e == D), state, seg_z, seg_i, count_buf)
                cl.enqueue_copy(q, counts, count_buf)
                total = int(counts.sum(dtype=np.int64))
                start = np.zeros(T, np.uint32)
                np.cumsum(counts[:-1], out=start[1:])
                zb = np.empty(total, dtype_z)
                ib = np.empty(total, dtype_i)
                if total:
                    out_z = _cl.empty(total * dtype_z.itemsize)
                    out_i = _cl.empty(total * dtype_i.itemsize)
                    k_compact(q, (T,), None, seg_z, seg_i, count_buf, _cl.to_device(start),
                              out_z, out_i)
                    cl.enqueue_copy(q, zb, out_z)
                    cl.enqueue_copy(q, ib, out_i)
                blocks.append((counts.copy(), zb, ib))
                host_bytes += zb.nbytes + ib.nbytes + counts.nbytes
                if bar is not None:
                    bar.update(e - s)
        finally:
            if bar is not None:
                bar.close()
        # assemble the per-texel lists (blocks arrive in map order)
        per_texel = np.zeros(T, np.int64)
        for c, _, _ in blocks:
            per_texel += c
        S = int(per_texel.sum())
        offsets = np.zeros(T + 1, _offsets_dtype(S))
        np.cumsum(per_texel, out=offsets[1:])
        zs = np.empty(S, dtype_z)
        ie = np.empty(S, dtype_i)
        cursor = offsets[:-1].astype(np.int64)
        for c, zb, ib in blocks:
            if len(zb) == 0:
                continue
            texel = np.repeat(np.arange(T), c)
            first = np.cumsum(c, dtype=np.int64) - c
            pos = cursor[texel] + (np.arange(len(zb)) - first[texel])
            zs[pos] = zb
            ie[pos] = ib
            cursor += c
        peak = device_bytes + host_bytes + zs.nbytes + ie.nbytes + offsets.nbytes
        return cls(views=views, resolution=R, depth_bits=depth_bits, layer_rule=rule,
                   centre=centre, radius=radius, mesh_hash=mesh_hash(mesh), offsets=offsets,
                   iend=ie, depth=zs, build_seconds=time.perf_counter() - t0, peak_bytes=peak,
                   front_margin_texels=FRONT_MARGIN_TEXELS, footprint=footprint)

    # ------------------------------------------------------------------
    # sizes and statistics
    # ------------------------------------------------------------------
    @property
    def maps(self) -> int:
        return len(self.views)

    @property
    def segments(self) -> int:
        return int(len(self.depth))

    @property
    def stats(self) -> dict:
        """Sizes and build figures.

        Returns
        -------
        dict
            ``maps`` (D), ``resolution`` (R), ``segments`` (S), ``bytes``
            (segments plus offset table, as stored), ``uncompressed_bytes``
            (``D * R^2 * depth_bits / 8``), ``ratio`` (uncompressed / bytes),
            ``build_seconds``, ``peak_bytes`` (device and host working set of
            the build), ``depth_bits``, ``layer_rule``, ``front_margin_texels``,
            ``footprint``, ``layout``.
        """
        nbytes = int(self.depth.nbytes + self.iend.nbytes + self.offsets.nbytes)
        unc = self.maps * self.resolution**2 * self.depth_bits // 8
        return {
            "maps": self.maps,
            "resolution": self.resolution,
            "segments": self.segments,
            "bytes": nbytes,
            "uncompressed_bytes": unc,
            "ratio": unc / nbytes,
            "build_seconds": self._build_seconds,
            "peak_bytes": self._peak_bytes,
            "depth_bits": self.depth_bits,
            "layer_rule": self.layer_rule,
            "front_margin_texels": self.front_margin_texels,
            "footprint": self.footprint,
            "layout": self.views.layout,
        }

    def texel_segment_counts(self) -> np.ndarray:
        """Segments per texel, (R, R) int64, indexed ``[row, col]``."""
        return np.diff(self.offsets.astype(np.int64)).reshape(self.resolution, self.resolution)

    def stored_to_depth(self, stored) -> np.ndarray:
        """Decode stored depth values to float64 normalised depth (+inf for a miss)."""
        s = np.asarray(stored)
        if self.depth_bits == 16:
            return np.where(s == MISS16, np.inf, s.astype(np.float64) / DEPTH_Q)
        return s.astype(np.float64)

    # ------------------------------------------------------------------
    # device side
    # ------------------------------------------------------------------
    @property
    def pair_wide(self) -> bool:
        """Whether the device pairs need 32-bit fields (32-bit depth or i_end)."""
        return self.depth_bits == 32 or self.iend.dtype != np.uint16

    @property
    def defines(self) -> dict:
        """Compile-time macros that describe this CSM's storage to a kernel."""
        return {"RES": self.resolution, "DEPTH_BITS": self.depth_bits,
                "IEND_T": "ushort" if self.iend.dtype == np.uint16 else "uint",
                "PAIR_WIDE": int(self.pair_wide), "SEARCH_BLOCK": SEARCH_BLOCK}

    def search_arrays(self, wide: bool | None = None, padded: bool = False) -> dict:
        """The device layout the search kernels read (kernels/csm_search.h).

        Parameters
        ----------
        wide : bool, optional
            Pair layout (default :attr:`pair_wide`).
        padded : bool, optional
            Pad every list with copies of its last pair to a whole number of
            ``SEARCH_BLOCK`` (16) pairs, so that each block is one aligned
            run of 16 pairs (one cache line when pairs are 4 bytes): the
            layout of the scene kernels (kernels/visibility.cl). The copies
            have i_end = D - 1, so counting the i_end below a map index over
            a whole block gives the same answer.

        Returns
        -------
        dict
            ``offsets`` uint32 (R*R+1); ``soff`` uint32 (R*R+1), each texel's
            range in ``summary``; ``summary`` (iend dtype), the last i_end of
            every block of ``SEARCH_BLOCK`` segments of a list; ``pairs``
            each segment's i_end and stored depth side by side: uint32
            ``depth << 16 | iend`` or, when ``wide``, uint32 (S, 2)
            ``(iend, depth bits)``; ``segment`` int64, the index into
            :attr:`iend` / :attr:`depth` of every pair.
        """
        wide = self.pair_wide if wide is None else bool(wide)
        if self.offsets.dtype != np.uint32:
            raise ValueError("CSMs with 2^32 or more segments are not supported on the device")
        off = np.asarray(self.offsets, dtype=np.int64)
        iend = np.asarray(self.iend)
        lens = np.diff(off)
        nblocks = -(-lens // SEARCH_BLOCK)
        soff = np.zeros(len(off), np.int64)
        np.cumsum(nblocks, out=soff[1:])
        texel = np.repeat(np.arange(len(lens)), nblocks)
        j = np.arange(int(soff[-1])) - soff[:-1][texel]
        last = np.minimum(off[:-1][texel] + SEARCH_BLOCK * j + SEARCH_BLOCK - 1, off[1:][texel] - 1)
        summary = iend[last]
        if padded:
            starts = SEARCH_BLOCK * soff            # every list starts on a block boundary
            owner = np.repeat(np.arange(len(lens)), SEARCH_BLOCK * nblocks)
            within = np.arange(int(starts[-1])) - starts[:-1][owner]
            segment = off[:-1][owner] + np.minimum(within, lens[owner] - 1)
            off = starts
        else:
            segment = np.arange(len(iend), dtype=np.int64)
        if wide:
            pairs = np.empty((len(segment), 2), np.uint32)
            pairs[:, 0] = iend[segment]
            depth = np.asarray(self.depth)[segment]
            pairs[:, 1] = depth.view(np.uint32) if self.depth_bits == 32 else depth
        else:
            pairs = ((np.asarray(self.depth, np.uint32) << 16) | np.asarray(iend, np.uint32))[segment]
        return {"offsets": off.astype(np.uint32), "soff": soff.astype(np.uint32),
                "summary": summary, "pairs": pairs, "segment": segment}

    def device_buffers(self):
        """(offsets, soff, summary, pairs) as device buffers, uploaded once per context and kept."""
        ctx = _cl.context()
        if self._device is None or self._device[0] is not ctx:
            a = self.search_arrays()
            self._device = (ctx, tuple(_cl.to_device(a[k]) for k in ("offsets", "soff", "summary", "pairs")))
        return self._device[1]

    def segment_index(self, map_index, rows, cols) -> np.ndarray:
        """Index of the segment holding (map, texel), by the kernels' search (csm_find)."""
        m, r, c = np.broadcast_arrays(np.asarray(map_index), np.asarray(rows), np.asarray(cols))
        shape = m.shape
        m, r, c = (np.asarray(a, dtype=np.int64).reshape(-1) for a in (m, r, c))
        R, D = self.resolution, self.maps
        if len(m) and (m.min() < 0 or m.max() >= D):
            raise ValueError(f"map index outside 0..{D - 1}")
        if len(r) and (min(r.min(), c.min()) < 0 or max(r.max(), c.max()) >= R):
            raise ValueError(f"row/column outside 0..{R - 1}")
        out = np.empty(len(m), np.uint32)
        if len(m):
            k = _cl.kernel("csm_query.cl", "csm_lookup", self.defines)
            buf = _cl.empty(out.nbytes)
            k(_cl.queue(), (len(m),), None, *self.device_buffers(), np.int32(len(m)),
              _cl.to_device(m, np.int32), _cl.to_device(r * R + c, np.int32), buf)
            cl.enqueue_copy(_cl.queue(), out, buf)
        return out.reshape(shape)

    def depth_for(self, map_index, rows, cols) -> np.ndarray:
        """Stored depth of texels ``(rows, cols)`` of map ``map_index``.

        Parameters
        ----------
        map_index : int or array_like of int
            Map index in view-set order, 0 .. D-1.
        rows, cols : array_like of int
            Texel coordinates, 0 .. R-1; broadcast against ``map_index``.

        Returns
        -------
        ndarray, float64
            Normalised depth the shadow test compares against (``+inf`` where
            the texel's ray misses the object), found by the counting search of
            kernels/csm_search.h (block summary, then block), which lands on
            the same segment as the visibility kernel's search (tested).
        """
        return self.stored_to_depth(self.depth[self.segment_index(map_index, rows, cols)])

    def segment_index_reference(self, map_index, rows, cols) -> np.ndarray:
        """NumPy version of :meth:`segment_index` (searchsorted per texel)."""
        m, r, c = (np.asarray(a, dtype=np.int64).reshape(-1)
                   for a in np.broadcast_arrays(np.asarray(map_index), np.asarray(rows), np.asarray(cols)))
        t = r * self.resolution + c
        out = np.empty(len(m), np.int64)
        for i, (tt, mm) in enumerate(zip(t, m)):
            a, b = int(self.offsets[tt]), int(self.offsets[tt + 1])
            out[i] = a + np.searchsorted(self.iend[a:b], mm, side="left")
        return out

    # ------------------------------------------------------------------
    # files
    # ------------------------------------------------------------------
    def _header(self) -> dict:
        return {
            "format": "pyshadow-csm",
            "version": FORMAT_VERSION,
            "writer": f"pyshadow {__version__}",
            "resolution": self.resolution,
            "maps": self.maps,
            "layout": self.views.layout,
            "layout_params": self.views.params,
            "centre": [float(x) for x in self.centre],
            "radius": self.radius,
            "depth_bits": self.depth_bits,
            "layer_rule": self.layer_rule,
            "front_margin_texels": self.front_margin_texels,
            "footprint": self.footprint,
            "mesh_hash": self.mesh_hash,
            "segments": self.segments,
            "offsets_dtype": self.offsets.dtype.str,
            "build_seconds": self._build_seconds if np.isfinite(self._build_seconds) else None,
        }

    @staticmethod
    def _array_layout(start: int, resolution: int, maps: int, segments: int, depth_bits: int,
                      offsets_dtype) -> list:
        """(name, dtype, count, byte offset) of each array, 64-byte aligned from ``start``."""
        specs = [
            ("offsets", np.dtype(offsets_dtype), resolution * resolution + 1),
            ("iend", _iend_dtype(maps), segments),
            ("depth", _depth_dtype(depth_bits), segments),
        ]
        out, pos = [], start
        for name, dt, n in specs:
            pos = -(-pos // ALIGN) * ALIGN
            out.append((name, dt.newbyteorder("<"), n, pos))
            pos += dt.itemsize * n
        return out, pos

    def save(self, path) -> Path:
        """Write the CSM to ``path`` atomically (temporary file, then rename).

        File layout (little-endian, version 1):

        ========  =====================================================
        bytes     content
        ========  =====================================================
        0-7       magic ``b"PYSHCSM\\0"``
        8-11      uint32 format version (1)
        12-15     uint32 length H of the JSON header
        16-       JSON header (UTF-8): resolution, maps, layout and
                  layout_params, centre, radius, depth_bits, layer_rule,
                  mesh_hash, segments, offsets_dtype, writer; optional
                  front_margin_texels (default 0), footprint (default
                  false), build_seconds
        aligned   arrays at 64-byte boundaries after the header, in order:
                  offsets (R*R+1, uint32 or uint64), iend (S, uint16 when
                  D <= 65536 else uint32), depth (S, uint16 or float32)
        last 32   SHA-256 of every byte before it
        ========  =====================================================

        16-bit depth ``k`` means ``k / 65534``, ``65535`` a miss; float32
        depth ``+inf`` is a miss. Never pickled.
        """
        path = Path(path)
        head = json.dumps(self._header(), sort_keys=True).encode()
        start = 16 + len(head)
        layout, end = self._array_layout(start, self.resolution, self.maps, self.segments,
                                         self.depth_bits, self.offsets.dtype)
        arrays = {"offsets": self.offsets, "iend": self.iend, "depth": self.depth}
        h = hashlib.sha256()
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            def put(b):
                h.update(b)
                f.write(b)

            put(MAGIC + np.uint32(FORMAT_VERSION).tobytes() + np.uint32(len(head)).tobytes() + head)
            pos = start
            for name, dt, n, off in layout:
                put(b"\x00" * (off - pos))
                data = np.ascontiguousarray(arrays[name], dtype=dt)
                assert data.size == n
                put(memoryview(data).cast("B"))
                pos = off + data.nbytes
            f.write(h.digest())
            f.flush()
            os.fsync(f.fileno())
        return path

    @classmethod
    def load(cls, path, mmap: bool = True) -> "CoherentShadowMap":
        """Read and validate a .csm file written by :meth:`save`.

        Parameters
        ----------
        path : str or os.PathLike
        mmap : bool, optional
            Map the arrays from the file instead of reading them into memory.

        Raises
        ------
        FileNotFoundError
            If the file does not exist.
        CSMFormatError
            If the file is truncated, its checksum does not match, its header
            is not a pyshadow CSM of a known version, or its arrays break a
            rule the kernels rely on (offsets monotone and in bounds, every
            list non-empty with strictly increasing i_end ending at D - 1,
            depths finite or the miss value).
        """
        path = Path(path)
        size = path.stat().st_size
        if size < 16 + 32:
            raise CSMFormatError(f"{path}: {size} bytes is too short for a CSM file")
        with open(path, "rb") as f:
            pre = f.read(16)
            if pre[:8] != MAGIC:
                raise CSMFormatError(f"{path}: not a pyshadow CSM file (magic {pre[:8]!r})")
            version = int(np.frombuffer(pre[8:12], "<u4")[0])
            if version != FORMAT_VERSION:
                raise CSMFormatError(f"{path}: format version {version} is not supported "
                                     f"(this pyshadow reads version {FORMAT_VERSION})")
            hlen = int(np.frombuffer(pre[12:16], "<u4")[0])
            if 16 + hlen + 32 > size:
                raise CSMFormatError(f"{path}: header length {hlen} runs past the end of the file")
            # checksum over everything but the trailing digest
            h = hashlib.sha256(pre)
            remaining = size - 32 - 16
            while remaining > 0:
                chunk = f.read(min(remaining, 1 << 24))
                if not chunk:
                    raise CSMFormatError(f"{path}: truncated")
                h.update(chunk)
                remaining -= len(chunk)
            digest = f.read(32)
        if digest != h.digest():
            raise CSMFormatError(f"{path}: checksum mismatch (corrupted or truncated file)")
        with open(path, "rb") as f:
            f.seek(16)
            head_bytes = f.read(hlen)
        try:
            head = json.loads(head_bytes.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise CSMFormatError(f"{path}: unreadable header ({exc})") from None
        return cls._from_header(path, head, 16 + hlen, size, mmap)

    @classmethod
    def _from_header(cls, path, head, start, size, mmap):
        def need(key, kind):
            if not isinstance(head, dict) or key not in head:
                raise CSMFormatError(f"{path}: header lacks {key!r}")
            val = head[key]
            if kind is int and (isinstance(val, bool) or not isinstance(val, int)):
                raise CSMFormatError(f"{path}: header {key!r} must be an integer, got {val!r}")
            if kind is not int and not isinstance(val, kind):
                raise CSMFormatError(f"{path}: header {key!r} has the wrong type")
            return val

        if head.get("format") != "pyshadow-csm" or head.get("version") != FORMAT_VERSION:
            raise CSMFormatError(f"{path}: header is not a pyshadow-csm version {FORMAT_VERSION}")
        R = need("resolution", int)
        D = need("maps", int)
        S = need("segments", int)
        bits = need("depth_bits", int)
        rule = need("layer_rule", int)
        layout = need("layout", str)
        params = need("layout_params", dict)
        centre = need("centre", list)
        radius = need("radius", (int, float))
        mh = need("mesh_hash", str)
        odt = need("offsets_dtype", str)
        if not 1 <= R <= 4096:
            raise CSMFormatError(f"{path}: resolution {R} outside 1..4096")
        if bits not in (16, 32):
            raise CSMFormatError(f"{path}: depth_bits {bits} is not 16 or 32")
        if rule not in (2, 3):
            raise CSMFormatError(f"{path}: layer_rule {rule} is not 2 or 3")
        margin = head.get("front_margin_texels", 0.0)       # absent in files from before the margin
        if isinstance(margin, bool) or not isinstance(margin, (int, float)) or not (
                np.isfinite(margin) and margin >= 0):
            raise CSMFormatError(f"{path}: front_margin_texels must be a finite number >= 0, got {margin!r}")
        footprint = head.get("footprint", False)             # absent in files from before the option
        if not isinstance(footprint, bool):
            raise CSMFormatError(f"{path}: footprint must be true or false, got {footprint!r}")
        if layout not in _LAYOUTS:
            raise CSMFormatError(f"{path}: unknown view layout {layout!r}")
        if odt not in ("<u4", "<u8"):
            raise CSMFormatError(f"{path}: offsets dtype {odt!r} not supported")
        if len(centre) != 3 or not all(isinstance(x, (int, float)) and np.isfinite(x) for x in centre):
            raise CSMFormatError(f"{path}: centre must be 3 finite numbers")
        if not (np.isfinite(radius) and radius > 0):
            raise CSMFormatError(f"{path}: radius must be finite and positive, got {radius}")
        try:
            if layout == "zigzag":
                ok = set(params) == {"theta", "phi"} and all(
                    isinstance(params[k], int) and 1 <= params[k] <= 1 << 16 for k in params)
            else:
                ok = (set(params) in ({"level"}, {"level", "hemispheres"})
                      and isinstance(params["level"], int) and 0 <= params["level"] <= 10
                      and params.get("hemispheres", True) is True)
            if not ok:
                raise ValueError
        except (ValueError, KeyError, TypeError):
            raise CSMFormatError(f"{path}: invalid {layout} parameters {params!r}") from None
        # the layout's map count from its parameters, and the sizes against the
        # file's, before anything as large as the header claims is built
        layout_maps = ViewSet.maps_for(layout, params)
        if layout_maps != D:
            raise CSMFormatError(f"{path}: {D} maps in the header but the {layout} layout has {layout_maps}")
        if not D <= S or S > 2**40:
            raise CSMFormatError(f"{path}: {S} segments cannot cover {D} maps")
        if S < R * R:
            raise CSMFormatError(f"{path}: {S} segments for {R * R} texels (every texel needs one)")
        arrays, end = cls._array_layout(start, R, D, S, bits, odt)
        if end + 32 != size:
            raise CSMFormatError(f"{path}: size {size} bytes does not match the header "
                                 f"({end + 32} expected)")
        views = ViewSet.from_params(layout, params)
        data = {}
        for name, dt, n, off in arrays:
            if mmap:
                data[name] = np.memmap(path, dtype=dt, mode="r", offset=off, shape=(n,))
            else:
                with open(path, "rb") as f:
                    f.seek(off)
                    data[name] = np.frombuffer(f.read(dt.itemsize * n), dtype=dt).copy()
        cls._validate_arrays(path, data, R, D, S, bits)
        return cls(views=views, resolution=R, depth_bits=bits, layer_rule=rule,
                   centre=np.array(centre, dtype=np.float64), radius=float(radius), mesh_hash=mh,
                   offsets=data["offsets"], iend=data["iend"], depth=data["depth"],
                   build_seconds=head.get("build_seconds") or float("nan"), front_margin_texels=margin,
                   footprint=footprint)

    @staticmethod
    def _validate_arrays(path, data, R, D, S, bits):
        off = np.asarray(data["offsets"]).astype(np.int64)
        if off[0] != 0 or off[-1] != S:
            raise CSMFormatError(f"{path}: offset table does not span 0..{S}")
        lengths = np.diff(off)
        if (lengths < 1).any():
            t = int(np.argmax(lengths < 1))
            raise CSMFormatError(f"{path}: segment list of texel {t} is empty or offsets decrease")
        iend = np.asarray(data["iend"]).astype(np.int64)
        if (iend >= D).any():
            raise CSMFormatError(f"{path}: an i_end is beyond the last map {D - 1}")
        if (iend[off[1:] - 1] != D - 1).any():
            t = int(np.argmax(iend[off[1:] - 1] != D - 1))
            raise CSMFormatError(f"{path}: segment list of texel {t} does not end at map {D - 1}")
        inc = np.diff(iend) > 0
        inc[off[1:-1] - 1] = True          # list boundaries may go down
        if not inc.all():
            raise CSMFormatError(f"{path}: i_end values of a segment list are not strictly increasing")
        if bits == 32:
            z = np.asarray(data["depth"])
            bad = ~(np.isposinf(z) | (np.isfinite(z) & (z >= 0) & (z <= 2)))
            if bad.any():
                raise CSMFormatError(f"{path}: stored depth {z[np.argmax(bad)]!r} is neither finite "
                                     "in [0, 2] nor the miss value +inf")

    def __repr__(self) -> str:
        s = self.stats
        return (f"<CoherentShadowMap {s['layout']} {s['maps']} maps {s['resolution']}^2, "
                f"{s['segments']} segments, {s['bytes'] / 1e6:.2f} MB, {s['ratio']:.1f}:1>")

"""The streaming CSM builder: render a block of maps, fold it into per-texel runs, drop it.

See :mod:`pyshadow.csm` for the intervals each map allows and the encoding;
:func:`build_csm` is :meth:`CoherentShadowMap.build`.
"""
from __future__ import annotations

import time

import numpy as np
import pyopencl as cl
import trimesh

from .. import _cl
from .._cl.launch import fill
from .._validate import FLOAT32_MAX, real_scalar
from ..mesh import bounding_sphere, check_mesh, load_mesh, mesh_hash, normalised_bounds, referenced_mesh
from ..raster import DepthRenderer, _check_resolution_layers, check_frame
from ..views import ViewSet
from . import core
from .core import (_LAYOUTS, _depth_dtype, _iend_dtype, _offsets_dtype,
                   front_margin, slope_slack)
from .exposure import both_sided_faces, is_auto, open_sheet

__all__ = ["build_csm", "check_arguments", "check_depth_bits", "check_float32_frame", "corner_frame",
           "footprint_corners", "footprint_scale"]


def _defines(resolution, layers, rule, block, depth_bits, iend_dtype, two_sided=False, open_air=False):
    return {
        "OPEN_AIR": int(bool(open_air)),
        "RES": int(resolution),
        "MARGIN": float(front_margin(resolution)).hex() + "f",   # exact float32, as a hex literal
        "SLACK": float(slope_slack()).hex() + "f",
        "TWO_SIDED": int(bool(two_sided)),
        "LAYERS": int(layers),
        "LAYER_RULE": int(rule),
        "BLOCK": int(block),
        "DEPTH_BITS": int(depth_bits),
        "IEND_T": "ushort" if np.dtype(iend_dtype) == np.uint16 else "uint",
    }



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


def footprint_corners(mesh, views: ViewSet, resolution: int, layers: int, frame, both_sides=None):
    """The corner maps a footprint build folds in, for :func:`compress_reference`.

    ``render_depth(mesh, views, R + 1, layers, frame=corner_frame(frame, R),
    facing=True, both_sides=both_sides)``: depth (D, layers, R+1, R+1)
    float32 in the corner frame, and the facing flags (``both_sides``: the
    build's, :func:`pyshadow.csm.exposure.both_sided_faces`).
    """
    from ..raster import render_depth

    return render_depth(mesh, views, resolution=int(resolution) + 1, layers=layers,
                        frame=corner_frame(frame, resolution), facing=True, both_sides=both_sides)


def check_arguments(views, resolution, depth_bits, layers="auto") -> None:
    """The checks of :meth:`CoherentShadowMap.build` that need no mesh (the cache's, before a hit):
    ``views`` a zigzag or hilbert :class:`ViewSet` of 1 .. 2^32-2 maps, ``resolution`` an int
    1 .. 4096, ``depth_bits`` 16 or 32, ``layers`` 'auto', 2 or 3; TypeError or ValueError naming it."""
    if not isinstance(views, ViewSet):
        raise TypeError(f"views must be a pyshadow.ViewSet, got {type(views).__name__}")
    if views.layout not in _LAYOUTS:
        raise ValueError(f"a CSM needs a 'zigzag' or 'hilbert' view set, got {views.layout!r}")
    if len(views) == 0:
        raise ValueError("the view set is empty")
    if len(views) >= 2**32 - 1:
        raise ValueError("too many maps")
    check_depth_bits(depth_bits)
    _check_resolution_layers(resolution, 2)
    layer_rule(layers)


def check_depth_bits(depth_bits) -> None:
    """ValueError naming ``depth_bits`` unless it is 16 or 32 (an array, a complex or a bool is neither)."""
    if not (real_scalar(depth_bits) and depth_bits in (16, 32)):
        raise ValueError(f"depth_bits must be 16 or 32, got {depth_bits!r}")


def check_float32_frame(centre, radius) -> None:
    """ValueError unless the frame ``(centre, radius)`` (object units) lies within float32's range, which
    the lookup and the .csm file work in."""
    if not (radius <= FLOAT32_MAX and (np.abs(centre) <= FLOAT32_MAX).all()):
        raise ValueError(f"the mesh's bounding sphere (centre {np.asarray(centre).tolist()}, radius {radius:.6g}) "
                         "lies beyond float32's range, which the lookup and the .csm file work in: "
                         "scale the mesh down")


def layer_rule(layers, mesh=None):
    """The layer rule ``layers`` asks for: 2 or 3, 'auto' 3 for a watertight ``mesh`` (None: 'auto'
    is only checked, 0 returned); ValueError for anything else."""
    if isinstance(layers, str) and layers == "auto":
        return 0 if mesh is None else 3 if mesh.is_watertight else 2
    if real_scalar(layers) and layers in (2, 3):
        return int(layers)
    raise ValueError(f"layers must be 'auto', 2 or 3, got {layers!r}")


def _stage(bar, what: str) -> None:
    """Name on the progress bar ``bar`` (None: none shown) the step of the build under way before the maps."""
    if bar is not None:
        bar.set_postfix_str(what)


def available_memory():
    """Bytes of memory the machine can still give without swapping (``MemAvailable`` of Linux's
    /proc/meminfo), or None where unknown (another system)."""
    try:
        with open("/proc/meminfo", "rb") as f:
            for line in f:
                if line.startswith(b"MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _check_room(seg_bytes, done, maps, resolution) -> None:
    """MemoryError where the segments of the first ``done`` of ``maps`` maps (``seg_bytes``, held) can no longer
    be assembled: the assembly copies them into the CSM's arrays, and less memory than they take is left. Said
    then, not after the remaining maps' work as the system's out-of-memory kill (which gives no reason)."""
    free = available_memory()
    if free is not None and seg_bytes > free:
        raise MemoryError(f"CoherentShadowMap.build: after {done} of {maps} maps of {resolution}^2 texels the "
                          f"segments hold {seg_bytes / 2**30:.2f} GiB and {free / 2**30:.2f} GiB of memory is "
                          "left: the CSM's arrays need as much again, and the maps left more; ask fewer maps or a "
                          "lower resolution (the CSM's size grows with both)")


def _compact_starts(counts, maps):
    """A block's segment count and each texel's first place in its packed output (uint32, as ``csm_compact``
    takes them); ValueError where the block emitted more than 2^32 segments, whose places uint32 would wrap
    (the kernel then writing outside its output): possible with a ``block`` of about a thousand maps at
    2048^2 on a device allowing 17 GB buffers."""
    total = int(counts.sum(dtype=np.int64))
    if total > 1 << 32:
        raise ValueError(f"a block of {maps} maps emitted {total:,} segments, more than the 2^32 that csm_compact "
                         "addresses: build with a smaller block (or leave block to pyshadow)")
    start = np.zeros(len(counts), np.uint32)
    np.cumsum(counts[:-1], out=start[1:])
    return total, start


def _block_counts(counts, maps):
    """A block's segments per texel kept for the assembly, in what the block emitted rather than one
    number per texel: ``(None, counts)`` narrowed to the least unsigned dtype holding ``maps + 1`` (what a
    block of ``maps`` maps emits at most per texel), or ``(texels, counts)`` of the texels that emitted
    (uint32, and counts as narrow) where that is smaller. A block of maps of high resolution emits few
    segments: R^2 4-byte counts a block held more than the CSM itself (benchmarks/README.md, bigjob)."""
    dt = np.dtype(np.uint8 if maps < 255 else np.uint16 if maps < 65535 else np.uint32)
    texels = np.flatnonzero(counts)
    if len(texels) * (4 + dt.itemsize) < len(counts) * dt.itemsize:
        return texels.astype(np.uint32), counts[texels].astype(dt)
    return None, counts.astype(dt)


def build_csm(cls, mesh, views: ViewSet, resolution: int = 128, depth_bits: int = 16,
              layers="auto", block: int | None = None, progress: bool = True,
              frame=None, footprint: bool = False, two_sided="auto"):
    """:meth:`CoherentShadowMap.build` (which documents it) for the class ``cls``; MemoryError where the
    segments of the maps built so far outgrow the memory left (:func:`_check_room`)."""
    t0 = time.perf_counter()
    check_arguments(views, resolution, depth_bits)
    if not isinstance(mesh, trimesh.Trimesh):
        mesh = load_mesh(mesh)
    check_mesh(mesh, "CoherentShadowMap.build")
    digest = mesh_hash(mesh)        # of the mesh as given; the maps, frame and box see the vertices its faces use
    mesh = referenced_mesh(mesh)    # (a far vertex no face used widened the sphere: spot 15x, 8.7 % of AO rays wrong)
    rule = layer_rule(layers, mesh)
    if rule == 3 and not mesh.is_watertight:          # (only asked: "auto" gives 3 to closed meshes)
        raise ValueError("layers=3 ([z1, z3) intervals) needs a watertight mesh; "
                         "this one has boundary edges (use layers=2 or fill_holes=True)")
    R = int(resolution)
    D = len(views)
    if not isinstance(footprint, (bool, np.bool_)):
        raise TypeError(f"footprint must be True or False, got {footprint!r}")
    footprint = bool(footprint)
    if not (isinstance(two_sided, (bool, np.bool_)) or is_auto(two_sided)):
        raise TypeError(f"two_sided must be True, False or 'auto', got {two_sided!r}")
    both_every = not is_auto(two_sided) and bool(two_sided)     # True: the fold's TWO_SIDED
    if both_every and rule == 3:
        raise ValueError("two_sided=True is for open meshes (layers=2): a closed mesh's back faces are never asked")
    if footprint and R >= 4096:
        raise ValueError("footprint=True renders the corners at resolution + 1: resolution must be <= 4095")
    # the bar from here: the bounding sphere and the exposed backs of a mesh of 10^6 faces take seconds
    # (benchmarks/README.md, bigjob) before the first map
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=D, desc="CSM build", unit="map", disable=None, leave=False)
    try:
        _stage(bar, "bounding sphere")
        centre, radius = (bounding_sphere(mesh) if frame is None
                          else check_frame(np.asarray(mesh.vertices, np.float64), frame))
        check_float32_frame(centre, radius)             # as a .csm file holds them
        dtype_z = _depth_dtype(depth_bits)
        dtype_i = _iend_dtype(D)
        per_map = rule * R * R * 5 + R * R * (dtype_z.itemsize + 4)
        if footprint:
            per_map += rule * (R + 1) ** 2 * 5
        if block is None:
            block = max(1, min(D, _cl.launch.block_budget(96 << 20) // per_map))
        elif isinstance(block, (bool, np.bool_)) or not isinstance(block, (int, np.integer)):
            raise TypeError(f"block must be an int, got {block!r}")
        block = int(block)
        if block < 1:
            raise ValueError(f"block must be >= 1, got {block}")
        block = min(block, D)

        # 'auto': the faces whose back is open to the outside keep the margin from either side (.exposure)
        _stage(bar, "exposed backs" if is_auto(two_sided) and rule == 2 else "")
        both = both_sided_faces(mesh, (centre, radius), rule, two_sided,
                                progress=lambda done, total: _stage(bar, f"exposed backs {done}/{total}"))
        n_both = len(mesh.faces) if both_every else 0 if both is None else int(np.count_nonzero(both))
        renderer = DepthRenderer(mesh, R, rule, frame=(centre, radius), facing=True, both_sides=both)
        defs = _defines(R, rule, rule, block, depth_bits, dtype_i, both_every, open_sheet(mesh, both))
        corner_args = ()
        if footprint:
            scale = footprint_scale(R)
            corners = DepthRenderer(mesh, R + 1, rule, frame=corner_frame((centre, radius), R), facing=True,
                                    both_sides=both)
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
        fill(q, state, np.uint32(0), T * 16)
        slots = block + 1          # a block emits at most one segment per map, plus the last
        seg_z = _cl.empty(T * slots * dtype_z.itemsize)
        seg_i = _cl.empty(T * slots * 4)
        count_buf = _cl.empty(T * 4)
        device_bytes = (block * (renderer.bytes_per_map + renderer.facing_bytes_per_map) + T * 16
                        + T * slots * (dtype_z.itemsize + 4)
                        + T * 8 + 36 * renderer.n_faces)
        if footprint:
            device_bytes += block * (corners.bytes_per_map + corners.facing_bytes_per_map) + 36 * corners.n_faces
        counts = np.empty(T, np.uint32)
        per_texel = np.zeros(T, np.int64)
        blocks = []
        host_bytes = seg_bytes = 0
        starts = range(0, D, block)
        _stage(bar, "")
        for s in starts:
            e = min(D, s + block)
            renderer.render(views.bases[s:e], depth_buf, front_buf)
            if footprint:
                corners.render(views.bases[s:e], cdepth_buf, cfront_buf)
            k_fold(q, (T,), None, depth_buf, front_buf, *corner_args, np.int32(e - s), np.int32(s),
                   np.int32(e == D), state, seg_z, seg_i, count_buf)
            cl.enqueue_copy(q, counts, count_buf)
            total, start = _compact_starts(counts, e - s)
            zb = np.empty(total, dtype_z)
            ib = np.empty(total, dtype_i)
            if total:
                out_z = _cl.empty(total * dtype_z.itemsize)
                out_i = _cl.empty(total * dtype_i.itemsize)
                k_compact(q, (T,), None, seg_z, seg_i, count_buf, _cl.to_device(start),
                          out_z, out_i)
                cl.enqueue_copy(q, zb, out_z)
                cl.enqueue_copy(q, ib, out_i)
            per_texel += counts
            kept = (_block_counts(counts, e - s), zb, ib)
            blocks.append(kept)
            host_bytes += sum(a.nbytes for a in (*kept[0], zb, ib) if a is not None)
            seg_bytes += zb.nbytes + ib.nbytes
            _check_room(seg_bytes, e, D, R)
            if bar is not None:
                bar.update(e - s)
    finally:
        if bar is not None:
            bar.close()
    # assemble the per-texel lists (blocks arrive in map order)
    S = int(per_texel.sum())
    offsets = np.zeros(T + 1, _offsets_dtype(S))
    np.cumsum(per_texel, out=offsets[1:])
    del per_texel
    zs = np.empty(S, dtype_z)
    ie = np.empty(S, dtype_i)
    peak = device_bytes + host_bytes + zs.nbytes + ie.nbytes + offsets.nbytes + 16 * T
    cursor = offsets[:-1].astype(np.int64)
    blocks.reverse()
    while blocks:                       # each block dropped once placed: the lists' bytes are held once
        (texels, c), zb, ib = blocks.pop()
        if len(zb) == 0:
            continue
        if texels is None:              # dense counts (every texel's, narrow)
            texels = np.flatnonzero(c)
            c = c[texels]
        c = c.astype(np.int64)
        pos = np.repeat(cursor[texels] - (np.cumsum(c) - c), c)     # a segment's place less its index
        pos += np.arange(len(zb))
        zs[pos] = zb
        ie[pos] = ib
        cursor[texels] += c
    return cls(views=views, resolution=R, depth_bits=depth_bits, layer_rule=rule,
               centre=centre, radius=radius, mesh_hash=digest, offsets=offsets,
               iend=ie, depth=zs, build_seconds=time.perf_counter() - t0, peak_bytes=peak,
               front_margin_texels=core.FRONT_MARGIN_TEXELS, footprint=footprint,
               box=normalised_bounds(mesh, centre, radius),
               two_sided="auto" if is_auto(two_sided) else bool(two_sided), both_sided_faces=n_both)

"""The device layout of a CSM: block summaries and paired segment lists for the search kernels.

``kernels/csm_search.h`` searches these arrays; :func:`scene_atlas` packs the
CSMs of every caster type of a scene into one set of tables
(``kernels/scene_types.h``).
"""
from __future__ import annotations

import numpy as np
import pyopencl as cl

from .. import _cl
from .._cl.tables import CSM_TYPE
from .core import DEPTH_Q, SEARCH_BLOCK, decode_depth, lookup_box, query_indices

__all__ = ["search_arrays", "device_buffers", "segment_index", "scene_atlas", "empty_words", "empty_bits",
           "empty_table", "EMPTY_BYTES"]

#: bytes of empty-map bits a CSM type may take (``empty_words``): an eighth of a CPU core's 2 MiB L2
EMPTY_BYTES = 256 * 1024

#: padded slots :func:`search_arrays` lays out at once: its temporaries stay a few times this many 8-byte
#: words (tens of MB), whatever the CSM's size (the whole CSM at once took ten times its bytes)
SEARCH_CHUNK = 1 << 21

_LAYOUT_CODE = {"zigzag": 0, "hilbert": 1}


def search_arrays(csm, wide: bool | None = None, padded: bool = False, segment: bool = True) -> dict:
    """The device layout the search kernels read (kernels/csm_search.h) for ``csm``.

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
    segment : bool, optional
        Return ``segment`` too (8 bytes a pair, twice the CSM's own 4 a
        segment; the device tables do not need it).

    Returns
    -------
    dict
        ``offsets`` uint32 (R*R+1); ``soff`` uint32 (R*R+1), each texel's
        range in ``summary``; ``summary`` (uint16 where :attr:`iend` is uint16,
        else uint32: the kernels' ``IEND_T``), the last i_end of
        every block of ``SEARCH_BLOCK`` segments of a list; ``pairs``
        each segment's i_end and stored depth side by side: uint32
        ``depth << 16 | iend`` or, when ``wide``, uint32 (S, 2)
        ``(iend, depth bits)``; with ``segment``, ``segment`` int64, the
        index into :attr:`iend` / :attr:`depth` of every pair.
        Laid out :data:`SEARCH_CHUNK` pairs at a time: beside its output it
        holds a few tens of MB, whatever the CSM's size.
    """
    wide = csm.pair_wide if wide is None else bool(wide)
    if csm.offsets.dtype != np.uint32:
        raise ValueError("CSMs with 2^32 or more segments are not supported on the device")
    offsets, iend, depth = _resident(csm)
    off = offsets.astype(np.int64)
    lens = np.diff(off)
    nblocks = -(-lens // SEARCH_BLOCK)
    soff = np.zeros(len(off), np.int64)
    np.cumsum(nblocks, out=soff[1:])
    starts = SEARCH_BLOCK * soff if padded else off        # padded: every list starts on a block boundary
    # in the kernels' IEND_T (CoherentShadowMap.defines): ushort for uint16 i_end, else uint (values < D <= 2^21)
    summary = np.empty(int(soff[-1]), np.uint16 if iend.dtype == np.uint16 else np.uint32)
    pairs = np.empty((int(starts[-1]), 2) if wide else int(starts[-1]), np.uint32)
    seg = np.empty(int(starts[-1]), np.int64) if segment else None
    depth_word = depth.view(np.uint32) if csm.depth_bits == 32 else depth     # the pairs' depth half, as stored
    t0, T = 0, len(lens)
    while t0 < T:           # texels t0 .. t1 - 1: about SEARCH_CHUNK pairs (a longer list alone)
        t1 = max(t0 + 1, min(T, int(np.searchsorted(starts, starts[t0] + SEARCH_CHUNK, side="right")) - 1))
        tex = np.arange(t0, t1)
        b0, b1 = int(soff[t0]), int(soff[t1])
        texel = np.repeat(tex, nblocks[t0:t1])
        j = np.arange(b0, b1) - soff[:-1][texel]
        last = np.minimum(off[:-1][texel] + SEARCH_BLOCK * j + SEARCH_BLOCK - 1, off[1:][texel] - 1)
        summary[b0:b1] = iend[last]
        s0, s1 = int(starts[t0]), int(starts[t1])
        if padded:
            owner = np.repeat(tex, SEARCH_BLOCK * nblocks[t0:t1])
            within = np.arange(s0, s1) - starts[:-1][owner]
            part = off[:-1][owner] + np.minimum(within, lens[owner] - 1)
        else:
            part = np.arange(s0, s1, dtype=np.int64)
        if wide:
            pairs[s0:s1, 0] = iend[part]
            pairs[s0:s1, 1] = depth_word[part]
        else:
            pairs[s0:s1] = (depth[part].astype(np.uint32) << 16) | iend[part].astype(np.uint32)
        if segment:
            seg[s0:s1] = part
        t0 = t1
    out = {"offsets": starts.astype(np.uint32), "soff": soff.astype(np.uint32), "summary": summary,
           "pairs": pairs}
    if segment:
        out["segment"] = seg
    return out


def _resident(csm):
    """``csm``'s offsets, iend and depth, in memory: those of a mapped file (``load(mmap=True)``), which
    may have changed since it was checked, copied and checked again, so that the device gets what was
    checked."""
    return _resident_arrays(csm.offsets, csm.iend, csm.depth, csm.resolution, csm.maps, csm.depth_bits)


def _resident_arrays(offsets, iend, depth, resolution, maps, depth_bits):
    """:func:`_resident` of a CSM's arrays and sizes."""
    arrays = {"offsets": offsets, "iend": iend, "depth": depth}
    if any(isinstance(a, np.memmap) for a in arrays.values()):
        from .fileformat import _validate_arrays

        arrays = {k: np.array(a) for k, a in arrays.items()}
        _validate_arrays("a mapped CSM file (changed since it was loaded)", arrays, resolution, maps,
                         len(arrays["depth"]), depth_bits)
    return tuple(np.asarray(arrays[k]) for k in ("offsets", "iend", "depth"))


def device_buffers(csm):
    """(offsets, soff, summary, pairs) as device buffers, uploaded once per context and kept while the CSM's
    arrays (the same objects: an array changed in place is not seen), resolution, depth precision and view
    set stay; any of them set anew is checked and uploaded again (the kernels are compiled for the CSM's
    ``defines`` of the moment: buffers kept from other arrays or sizes would be read out of bounds)."""
    ctx = _cl.context()
    held = (csm.offsets, csm.iend, csm.depth, csm.views, csm.resolution, csm.depth_bits)
    kept = csm._device
    if kept is None or kept[0] is not ctx or not all(
            a is b or (isinstance(a, int) and isinstance(b, int) and a == b) for a, b in zip(kept[1], held)):
        a = csm.search_arrays(segment=False)
        csm._device = (ctx, held, tuple(_cl.to_device(a[k]) for k in ("offsets", "soff", "summary", "pairs")))
    return csm._device[2]


def empty_words(resolution: int, maps: int, budget: int = EMPTY_BYTES) -> int:
    """uint32 words of :func:`empty_bits` per texel: a bit per map where ``budget`` bytes hold them, else
    as many words as it holds (at least one)."""
    return max(1, min(-(-maps // 32), budget // (4 * resolution * resolution)))


def _empty_shift(maps: int, words) -> int:
    """The smallest shift that cuts ``maps`` maps into at most ``32 * words`` runs of ``2**shift``."""
    if isinstance(words, bool) or not isinstance(words, (int, np.integer)) or words < 1:
        raise ValueError(f"words must be an integer >= 1, got {words!r}")
    shift = 0
    while maps > (32 * words) << shift:
        shift += 1
    return shift


def empty_table(atlas: dict, used) -> "cl.Buffer":
    """The device buffer of :func:`empty_bits` of every type of a :func:`scene_atlas`, each at its row's
    ``empty_base``: built on first ``used`` (the kernels compiled with ``EMPTY_RUNS``) and kept in the atlas,
    from the arrays and sizes the atlas was built from (a CSM's attributes set since change neither the
    table's size nor its bits); one word, never read, where not ``used``."""
    held = atlas["empty"]
    if not used:
        if "unused" not in held:
            held["unused"] = _cl.to_device(np.zeros(1, np.uint32))
        return held["unused"]
    if "bits" not in held:
        bits = [_empty_bits(*source)[0].reshape(-1) for source in held["sources"]]
        held["bits"] = _cl.to_device(np.concatenate(bits) if bits else np.zeros(1, np.uint32))
    return held["bits"]


def empty_bits(csm, words: int) -> tuple[np.ndarray, int]:
    """Per texel, the runs of maps whose every map misses the mesh there: the lookups they answer need no search.

    The maps ``0 .. D-1`` are cut into runs of ``2**shift`` consecutive maps, ``shift`` the smallest that
    leaves at most ``32 * words`` runs. Bit ``c`` of texel ``t`` (word ``c // 32``, bit ``c % 32``) is set
    where every map ``k`` with ``k >> shift == c`` stores a miss (+inf) at ``t``: a lookup there is
    answered open whatever its depth and bias, as the search would answer it. Neighbouring maps look
    along neighbouring directions (both layouts order them along a curve), so a run is mostly either
    empty or not. With a bit for every map (``shift`` 0), a clear bit says that map ``k`` stores a surface
    at ``t``: a lookup from behind every surface of the caster (depth 2) is then answered occluded
    without a search where the largest stored depth plus its bias stays below 2.

    Returns
    -------
    bits : ndarray of uint32, shape (R*R, words)
    shift : int
    """
    return _empty_bits(csm.offsets, csm.iend, csm.depth, csm.depth_bits, csm.resolution, csm.maps, words)


def _empty_bits(offsets, iend, depth, depth_bits, R, D, words):
    """:func:`empty_bits` of a CSM's arrays and sizes (those of a mapped file copied and checked first)."""
    shift = _empty_shift(D, words)
    offsets, iend, depth = _resident_arrays(offsets, iend, depth, R, D, depth_bits)
    runs = 32 * words
    off = offsets.astype(np.int64)
    end = iend.astype(np.int64)
    start = np.r_[0, end[:-1] + 1]          # each segment's maps: start .. end (lists are never empty:
    start[off[:-1]] = 0                     # every list's first segment starts at map 0)
    texel = np.repeat(np.arange(R * R, dtype=np.int64), np.diff(off))
    hit = ~np.isinf(decode_depth(depth, depth_bits))
    # the runs a surface segment touches: +1 at its first run, -1 after its last, summed along the runs
    lo, hi = texel[hit] * (runs + 1) + (start[hit] >> shift), texel[hit] * (runs + 1) + (end[hit] >> shift) + 1
    marks = (np.bincount(lo, minlength=R * R * (runs + 1)) - np.bincount(hi, minlength=R * R * (runs + 1)))
    touched = np.cumsum(marks.reshape(R * R, runs + 1)[:, :runs], axis=1) > 0
    empty = ~touched & (np.arange(runs) < -(-D >> shift))     # runs past the last map: never asked
    packed = np.packbits(empty, axis=1, bitorder="little")    # bit c of byte c // 8
    return np.ascontiguousarray(packed).view("<u4").astype(np.uint32), shift


def segment_index(csm, map_index, rows, cols) -> np.ndarray:
    """:meth:`CoherentShadowMap.segment_index`: the kernels' search (``csm_find``) on the device."""
    m, r, c, shape = query_indices(csm, map_index, rows, cols)     # int64 (N,), within the maps and texels
    R = csm.resolution
    out = np.empty(len(m), np.uint32)
    if len(m):
        k = _cl.kernel("csm_query.cl", "csm_lookup", csm.defines)
        buf = _cl.empty(out.nbytes)
        k(_cl.queue(), (len(m),), None, *csm.device_buffers(), np.int32(len(m)),
          _cl.to_device(m, np.int32), _cl.to_device(r * R + c, np.int32), buf)
        cl.enqueue_copy(_cl.queue(), out, buf)
    return out.reshape(shape)


def scene_atlas(types) -> dict:
    """The CSMs of a scene's caster types packed into one set of device tables.

    Parameters
    ----------
    types : list of CoherentShadowMap
        The distinct CSMs of the casters, in type-index order.

    Returns
    -------
    dict
        ``bits`` (16 unless a CSM stores 32-bit depth: then every type's
        pairs hold float32 depth), ``iend_t``, ``pair_wide``, ``ntypes``,
        ``layouts`` (set of layout names), ``quantum`` (normalised depth of
        one 16-bit step, 0 for 32-bit) and ``buffers``: the device buffers
        of the ``CSM_TYPE`` rows (``kernels/scene_types.h``), texel offsets,
        block-summary offsets, summaries, pairs, view bases and Hilbert
        cells, each type's tables following the previous type's; ``empty``:
        what :func:`empty_table` builds the empty runs' bits from.
    """
    bits = 16 if all(c.depth_bits == 16 for c in types) else 32
    wide_iend = any(c.iend.dtype != np.uint16 for c in types)
    wide = bits == 32 or wide_iend
    di = np.uint32 if wide_iend else np.uint16
    trow = np.zeros(max(1, len(types)), CSM_TYPE)
    offs, soffs, summ, pairs, bases, cells, sources = [], [], [], [], [], [], []
    seg = blk = view = cell = tex = ebase = 0
    for ti, c in enumerate(types):
        R, D = c.resolution, c.maps
        a = c.search_arrays(wide=wide, padded=True, segment=False)
        if len(a["pairs"]) + seg >= 2**32:
            raise ValueError("the scene's CSMs hold 2^32 or more segments together")
        layout = _LAYOUT_CODE[c.views.layout]
        p = c.views.params
        if c.views.layout == "zigzag":
            p1, p2 = p["theta"], p["phi"]
        else:
            p1, p2 = p["level"], 0
            if p.get("hemispheres"):
                layout = 2
            cells.append(c.views._hilbert_cells().reshape(-1).astype(np.int32))
        # zigzag grid steps' cos and sin: the kernel's angle addition
        steps = ([np.cos(np.pi / p1), np.sin(np.pi / p1), np.cos(2 * np.pi / p2),
                  np.sin(2 * np.pi / p2)] if c.views.layout == "zigzag" else [0.0] * 4)
        box = lookup_box(c)
        offset = p.get("row_offset", 0.0) if c.views.layout == "zigzag" else 0.0
        words = empty_words(R, D)         # the bits themselves: empty_table, where a kernel reads them
        trow[ti] = (R, D, layout, p1, p2, tex, view, cell, np.array(steps, np.float32), offset, box[0], box[1],
                    ebase, words, _empty_shift(D, words))
        ebase += R * R * words
        sources.append((c.offsets, c.iend, c.depth, c.depth_bits, R, D, words))    # as search_arrays read them
        offs.append(a["offsets"][:-1].astype(np.int64) + seg)
        soffs.append(a["soff"][:-1].astype(np.int64) + blk)
        summ.append(a["summary"].astype(di))
        pr = a["pairs"]
        if bits == 32 and c.depth_bits == 16:     # a 32-bit atlas stores float depths
            pr[:, 1] = c.stored_to_depth(pr[:, 1]).astype(np.float32).view(np.uint32)   # from the 16-bit
        pairs.append(pr)
        bases.append(c.views.bases.reshape(-1, 9).astype(np.float32))
        seg += len(a["pairs"])
        blk += len(a["summary"])
        view += D
        tex += R * R
        cell += len(cells[-1]) if c.views.layout == "hilbert" else 0
    # every type's tables end where the next type's begin; the last entries
    # close the final type (offsets[tex_base + R*R], soff[...] as the search needs)
    offs.append(np.array([seg], dtype=np.int64))
    soffs.append(np.array([blk], dtype=np.int64))

    def cat(parts, dtype, empty):       # one type's table as it is: no copy beside the device's
        if not parts:
            return np.asarray(empty, dtype)
        return (parts[0] if len(parts) == 1 else np.concatenate(parts)).astype(dtype, copy=False)

    atlas = {
        "bits": bits,
        "iend_t": "uint" if wide_iend else "ushort",
        "pair_wide": int(wide),
        "ntypes": len(types),
        "layouts": {c.views.layout for c in types},
        "quantum": 1.0 / DEPTH_Q if bits == 16 else 0.0,
        "buffers": [
            _cl.to_device(trow),
            _cl.to_device(cat(offs, np.uint32, [0])),
            _cl.to_device(cat(soffs, np.uint32, [0])),
            _cl.to_device(cat(summ, di, [0])),
            _cl.to_device(cat(pairs, np.uint32, [0, 0] if wide else [0])),
            _cl.to_device(cat(bases, np.float32, np.zeros(9))),
            _cl.to_device(cat(cells, np.int32, [0])),
        ],
        "empty": {"sources": sources},
    }
    return atlas

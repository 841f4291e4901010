"""The query kernels over points that lie in several anchor groups: one upload, a launch per group.

:func:`pyshadow.scene_arrays.anchor_groups` splits the points of a query
that lie far from the scene's anchor, beside casters tiny against that
distance, into groups. Each group is asked relative to an anchor of its own,
with that anchor's instance tables. Each group used to be a query of its
own: its rows copied out, uploaded, its outputs allocated, and a blocking
copy back, which made the host's work per group most of such a query's time
(``benchmarks/README.md``, "Many anchor groups uploaded together").

Here the groups' rows go into one array a window, each group starting at a
multiple of the rows a work-item asks (``AO_POINTS`` points of
``scene_ao``, ``BATCH`` rays of ``scene_visible``). Each group's points are
rounded relative to its own anchor as before. The window is uploaded once,
each group launches onto its own rows (a global offset: the number of its
first work-item) with its anchor's tables, and the answers come back after
one wait. Each work-item reads and writes the same rows with the same
arguments as in a launch of its group alone, so the answers are the same to
the bit (``tests/test_grouped_launch.py``).
"""
from __future__ import annotations

import numpy as np
import pyopencl as cl

from .. import _cl
from .._cl import launch
from .held import FAR_BYTES

__all__ = ["ao_grouped", "visible_grouped"]

#: Bytes of device tables that one upload's launches may hold at once (the anchors' instance tables and
#: their grid or tree; the atlas counted once): the far anchors' cache (:data:`.held.FAR_BYTES`) holds
#: twice this, so the upload of many anchors' points keeps no more tables alive than the cache would.
WINDOW_TABLE_BYTES = FAR_BYTES // 2


def _windows(groups, count, unit, window, args_of):
    """The rows of ``groups`` (``anchor_groups``; ``count`` rows in all) packed into windows of at most ``window``
    rows and :data:`WINDOW_TABLE_BYTES` of tables: yields ``(pieces, size)``, each piece ``(anchor, args, extra,
    rows, first, offset)`` -- its group's anchor, ``args_of(rows, anchor)`` (``(args, extra)``: the kernel's table
    arguments and what the caller keeps with them), at most ``window`` of its group's rows from ``offset`` on,
    placed from row ``first`` of the window (a multiple of ``unit``, the rows a work-item asks)."""
    pieces, size, held, seen = [], 0, 0, {}
    for rows, anchor in groups:
        rows = np.arange(count) if rows is None else rows
        args, extra = args_of(rows, anchor)
        for s in range(0, len(rows), window):
            piece = rows[s:s + window]
            padded = -(-len(piece) // unit) * unit
            tables = {id(a): a for a in args if isinstance(a, cl.MemoryObject) and id(a) not in seen}
            grown = held + sum(int(a.size) for a in tables.values())
            if pieces and (size + padded > window or grown > WINDOW_TABLE_BYTES):
                yield pieces, size
                pieces, size, seen = [], 0, {}
                tables = {id(a): a for a in args if isinstance(a, cl.MemoryObject)}
                grown = sum(int(a.size) for a in tables.values())
            seen.update(tables)         # (the objects kept, so their ids stay theirs)
            held = grown
            pieces.append((anchor, args, extra, piece, size, s))
            size += padded
    if pieces:
        yield pieces, size


def ao_grouped(backend, scene, k, defines, table, groups, bias, p, n, pidx, own, tmax, sky_env, outs, bent_normals,
               transfer, extent):
    """The AO kernel ``k`` over the points of every group of ``groups`` (``anchor_groups``: (rows, anchor)),
    their answers written into ``outs`` (ao, bent, tr, sky: the whole query's arrays, or None).

    ``backend._scene_args`` gives each anchor's table arguments (``extent(points, anchor)``: the bound it sizes the
    margins with); the other arguments are those of ``CSMVisibility._ao_launch`` for all the query's rows. The rows
    go up in windows of at most a launch's chunk (``ao_chunk_samples`` over the samples).
    """
    P, S = int(defines["AO_POINTS"]), int(defines["SAMPLES"])
    window = max(P, launch.shape().ao_chunk_samples // S // P * P)

    def args_of(rows, anchor):
        pg = p[rows]
        return backend._scene_args(scene, anchor, bias, extent(pg, anchor), defines)[1], pg
    for pieces, size in _windows(groups, len(p), P, window, args_of):
        _ao_window(k, P, table, pieces, size, n, pidx, own, tmax, sky_env, outs, bent_normals, transfer)


def _gathered(pieces, size, *arrays):
    """Each of ``arrays`` (None stays None) as a window's rows: every piece's rows at its place, zeros between."""
    out = [None if a is None else np.zeros((size, *a.shape[1:]), a.dtype) for a in arrays]
    for _, _, _, rows, start, _ in pieces:
        for o, a in zip(out, arrays):
            if o is not None:
                o[start:start + len(rows)] = a[rows]
    return out


def _ao_window(k, P, table, pieces, size, n, pidx, own, tmax, sky_env, outs, bent_normals, transfer):
    """One window of :func:`ao_grouped`: its rows gathered and uploaded, a launch per piece, one copy back of
    each output (the rows between pieces are never read)."""
    rel = np.zeros((size, 3), np.float32)
    for anchor, _, pg, rows, start, s in pieces:        # anchor-relative in float64, rounded once
        np.subtract(pg[s:s + len(rows)], anchor, out=rel[start:start + len(rows)])
    nrm, pid, ows, tms = _gathered(pieces, size, n, pidx, own, tmax)
    ins = [_cl.to_device(rel), _cl.to_device(nrm), _cl.to_device(pid, np.int32), _cl.to_device(ows)]
    ins += [] if tms is None else [_cl.to_device(tms, np.float32)]
    ao_buf = _cl.empty(4 * size)
    bent_buf = _cl.empty(12 * size if bent_normals else 4)
    tr_buf = _cl.empty(36 * size if transfer else 4)
    sky = [] if sky_env is None else [*sky_env, _cl.empty(12 * size)]
    q = _cl.queue()
    group = launch.shape().query_group
    for _, args, _, rows, start, _ in pieces:
        k(q, *launch.grid(-(-len(rows) // P), group, k), *args, np.int32(start + len(rows)), *ins, table, ao_buf,
          bent_buf, tr_buf, *sky, global_offset=(start // P,))
    ao, bent, tr, sky_out = outs
    got = [(ao, ao_buf, ())]
    got += [(bent, bent_buf, (3,))] if bent_normals else []
    got += [(tr, tr_buf, (9,))] if transfer else []
    got += [(sky_out, sky[-1], (3,))] if sky_env is not None else []
    for out, buf, tail in got:
        host = np.empty((size, *tail), np.float32)
        cl.enqueue_copy(q, host, buf)
        for _, _, _, rows, start, _ in pieces:
            out[rows] = host[start:start + len(rows)]


def visible_grouped(backend, scene, k, defines, groups, p, w, own, m, tmax, bias, fp64, out, extent):
    """``Scene.visible``'s kernel ``k`` over the rows of every group of ``groups`` (``anchor_groups``), answers
    written into ``out`` (N,) bool: as the query of each group alone would make them (``_visible_kernel`` with
    the group's anchor), the rows gathered a window (at most ``query_chunk`` of them).

    ``fp64``: the kernel subtracts each group's anchor in double (its rows as given); otherwise the host does,
    rounding once to float32 (``w`` already as ``_visible_kernel`` gives it to a float-only device).
    """
    B = int(defines["BATCH"])
    window = max(B, launch.shape().query_chunk // B * B)

    def args_of(rows, anchor):
        pg = p[rows] if fp64 else (p[rows] - anchor).astype(np.float32)
        a = [np.float64(x) for x in anchor] if fp64 else [np.float32(0.0)] * 3
        return backend._scene_args(scene, anchor, bias, extent(pg, anchor), defines)[1], (pg, a)
    for pieces, size in _windows(groups, len(p), B, window, args_of):
        _visible_window(k, B, pieces, size, p, w, own, m, tmax, fp64, out)


def _visible_window(k, B, pieces, size, p, w, own, m, tmax, fp64, out):
    """One window of :func:`visible_grouped`: its rows gathered, a launch per piece, one wait."""
    pw = np.zeros((size, 3), p.dtype if fp64 else np.float32)
    for _, _, (pg, _), rows, start, s in pieces:        # (each group's rows as args_of placed them)
        pw[start:start + len(rows)] = pg[s:s + len(rows)]
    ww, ow, mw, tw = _gathered(pieces, size, w, own, m, tmax)
    res = np.zeros(size, np.uint8)
    hb = _cl.host_buffer
    ins = [hb(pw), hb(ww)]
    tail = [hb(ow), *([] if mw is None else [hb(mw)]), *([] if tw is None else [hb(tw)])]
    buf = hb(res, writable=True)
    q = _cl.queue()
    group = launch.shape().query_group
    try:
        for _, args, (_, a), rows, start, _ in pieces:
            k(q, *launch.grid(-(-len(rows) // B), group, k), *args, np.int32(start + len(rows)), *ins, *a, *tail,
              buf, global_offset=(start // B,))
    except BaseException:           # (a launch refused, Ctrl-C): those enqueued end before the rows they read go
        q.finish()
        raise
    _cl.sync_host_buffer(buf, res)
    for _, _, _, rows, start, _ in pieces:
        out[rows] = res[start:start + len(rows)].view(np.bool_)

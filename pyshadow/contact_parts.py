"""Points against many flat parts at once, for the contact rules (:mod:`pyshadow.contact`: the footprints of
bodies resting on the ground; :mod:`pyshadow.contact_bodies`: the patches of bodies resting on bodies).

A part is a set of triangles in its own plane's 2D coordinates and the
outline of their union (segments). A point of a part is closed in where it
lies inside or on one of the part's triangles and farther than the part's
tolerance from every segment of its outline. The parts of a scene are
tested together: (point, part) candidate pairs from a uniform grid over the
points (parts in the ground's plane: :func:`_grid_pairs`) or from one sort
of the points along an axis (:func:`_slab_pairs`), then (pair, triangle) and
(pair, segment) pairs in runs of about ``_CHUNK``, with the same operations
on each pair as one part tested alone (the same answers to the bit).
"""
from __future__ import annotations

import numpy as np

_CHUNK = 1 << 16            # (point, triangle) or (point, segment) pairs a run


def _ragged(counts):
    """(group of each item, item's index within its group) for groups of ``counts`` items, group by group."""
    g = np.repeat(np.arange(len(counts)), counts)
    return g, np.arange(len(g)) - np.repeat(np.cumsum(counts) - counts, counts)


def _expanded(counts):
    """Items with ``counts`` parts each, in runs of about ``_CHUNK`` (item, part) pairs: (first item, end,
    each pair's item from the first, its part's number in its item)."""
    end = np.cumsum(counts)
    cut = np.searchsorted(end, np.arange(_CHUNK, end[-1] + _CHUNK, _CHUNK) if len(end) else [], side="right")
    for s, e in zip(np.r_[0, cut[:-1]].astype(np.intp), cut):
        if e > s:
            yield (s, e, *_ragged(counts[s:e]))


def _ragged_parts(parts):
    """The arrays ``parts`` end to end, each one's first row and its row count."""
    count = np.array([len(x) for x in parts], np.intp)
    return np.concatenate(parts), np.cumsum(count) - count, count


def _inside(a, b, c, x):
    """bool: points ``x`` inside or on triangles ``a, b, c`` (corners; all (..., 2), broadcast)."""
    def side(u, v):
        return (v[..., 0] - u[..., 0]) * (x[..., 1] - u[..., 1]) - (v[..., 1] - u[..., 1]) * (x[..., 0] - u[..., 0])

    s0, s1, s2 = side(a, b), side(b, c), side(c, a)
    return ((s0 >= 0) & (s1 >= 0) & (s2 >= 0)) | ((s0 <= 0) & (s1 <= 0) & (s2 <= 0))


def _square_distance(x, a, b):
    """Squared distance of points ``x`` to segments ``a``-``b`` (all (..., 2), broadcast)."""
    d, x = b - a, x - a
    t = np.clip(np.sum(x * d, axis=-1) / np.maximum(np.sum(d * d, axis=-1), 1e-300), 0.0, 1.0)
    r = x - t[..., None] * d
    return np.sum(r * r, axis=-1)


def _slab_pairs(p, lo, hi, cap=None):
    """(part, row) pairs, by part, of the points ``p`` (N, D) within each part's box ``lo``, ``hi`` (P, D) along
    the axis whose slab of that box holds the fewest points (candidates: the other axes are not tested);
    (None, None) where they would be more than ``cap``."""
    order = np.argsort(p, axis=0, kind="stable")
    ends = np.stack([[np.searchsorted(p[order[:, j], j], lo[:, j]),
                      np.searchsorted(p[order[:, j], j], hi[:, j], side="right")] for j in range(p.shape[1])], axis=2)
    slab = np.argmin(ends[1] - ends[0], axis=1)
    a, b = ends[:, np.arange(len(lo)), slab]
    if cap is not None and int((b - a).sum()) > cap:
        return None, None
    pid = np.repeat(np.arange(len(lo)), b - a)
    return pid, order[np.arange(len(pid)) + np.repeat(a - (np.cumsum(b - a) - (b - a)), b - a), slab[pid]]


_GRID_SPAN = 4              # a part spanning more cells than this along an axis: _slab_pairs


def _grid_pairs(p, lo, hi):
    """(part, row) candidate pairs, by part, of the points ``p`` (N, 2) within each part's box ``lo``, ``hi``
    (P, 2): the points in the cells of a uniform grid (as wide as the parts' median box) that the part's box
    meets. Every pair within a box is among them (the cell of a coordinate is monotonic in it); parts wider
    than ``_GRID_SPAN`` cells, or all where no such grid fits in int64 keys, through :func:`_slab_pairs`.
    Among many parts spread over both axes (10,000 boxes on a floor), the slab of one axis gave each part a
    strip of the points: 30x the pairs the boxes hold."""
    empty = np.zeros(0, np.intp)
    if not len(p) or not len(lo):
        return empty, empty
    origin = np.minimum(p.min(axis=0), lo.min(axis=0))
    h = float(np.median((hi - lo).max(axis=1)))
    with np.errstate(over="ignore", invalid="ignore"):
        reach = (np.maximum(p.max(axis=0), hi.max(axis=0)) - origin) / h if h > 0 else np.full(2, np.inf)
    if not (np.isfinite(reach).all() and reach.max() < 2.0 ** 30):
        return _slab_pairs(p, lo, hi)

    def cell(x):
        return np.floor((x - origin) / h).astype(np.int64)

    a, b = cell(lo), cell(hi)
    span = b - a + 1
    small = (span <= _GRID_SPAN).all(axis=1)
    width = int(cell(np.maximum(p.max(axis=0), hi.max(axis=0)))[1]) + 1
    key = cell(p) @ np.array([width, 1], np.int64)
    order = np.argsort(key, kind="stable")
    sk = key[order]
    part = np.flatnonzero(small)                        # each small part's cells: (part, cell key) pairs
    g, k = _ragged(span[part, 0] * span[part, 1])
    part = part[g]
    k = (a[part, 0] + k // span[part, 1]) * width + a[part, 1] + k % span[part, 1]
    s = np.searchsorted(sk, k)
    n = np.searchsorted(sk, k, side="right") - s
    pid = np.repeat(part, n)
    rows = order[np.repeat(s, n) + _ragged(n)[1]]
    if not small.all():
        big = np.flatnonzero(~small)
        bp, br = _slab_pairs(p, lo[big], hi[big])
        pid, rows = np.concatenate([pid, big[bp]]), np.concatenate([rows, br])
    o = np.argsort(pid, kind="stable")
    return pid[o], rows[o]


def _kept_parts(held, key, make):
    """(triangles, outline segments, the parts' boxes' corners lo, hi (P, 2), tolerances) of the parts that
    ``make()`` gives as (triangles [(K, 3, 2)], outlines [(E, 2, 2)] or None, tolerances (P,) or None),
    :func:`_ragged_parts` each; made once and kept in ``held`` (a scene's arrays, dropped when it changes)
    as ``key``, not per query (``make`` is called only then)."""
    got = held.get(key)                 # (what is stored is returned: another query may drop the key meanwhile)
    if got is None:
        tris, segs, tols = make()
        tri = _ragged_parts(tris)
        lo = np.minimum.reduceat(tri[0].min(axis=1), tri[1]) if len(tri[0]) else np.zeros((len(tri[1]), 2))
        hi = np.maximum.reduceat(tri[0].max(axis=1), tri[1]) if len(tri[0]) else np.zeros((len(tri[1]), 2))
        got = held[key] = (tri, None if segs is None else _ragged_parts(segs), lo, hi,
                           None if tols is None else np.array(tols, np.float64))
    return got


def _in_triangles_of(q, pid, tris):
    """(M,) bool: points ``q`` (M, 2), each asked of part ``pid``, inside or on one of its triangles ``tris``
    (:func:`_ragged_parts`)."""
    tri, first, count = tris
    out = np.zeros(len(q), bool)
    for s, e, c, j in _expanded(count[pid]):
        a, b, v = np.moveaxis(tri[first[pid[c + s]] + j], 1, 0)
        out[s:e] = np.bincount(c, _inside(a, b, v, q[c + s]), minlength=e - s) > 0
    return out


def _in_parts(q, pid, parts, tol):
    """(M,) bool: points ``q`` (M, 2), each asked of part ``pid``, in the part's triangles' box, inside or on
    one of them and farther than ``tol[pid]`` from every segment of its outline (``parts``: :func:`_kept_parts`)."""
    tris, (seg, seg_first, seg_count), lo, hi, _ = parts
    out = np.zeros(len(q), bool)
    live = np.flatnonzero(np.all((q >= lo[pid]) & (q <= hi[pid]), axis=1))
    live = live[_in_triangles_of(q[live], pid[live], tris)]
    ok = np.ones(len(live), bool)
    for s, e, c, j in _expanded(seg_count[pid[live]]):
        k = live[c + s]
        ends, t = seg[seg_first[pid[k]] + j], tol[pid[k]]
        ok[s:e] = np.bincount(c, ~(_square_distance(q[k], ends[:, 0], ends[:, 1]) > t * t), minlength=e - s) == 0
    out[live[ok]] = True
    return out


def _outlines(faces, item, n):
    """The edges of ``n`` items' faces that one face only has (the outline of each item's faces' union): (E, 2)
    in each item's order of vertex numbers, and where each item's start (n + 1,). ``faces`` (M, 3) sorted rows,
    ``item`` (M,) each face's item."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [0, 2]]]).astype(np.int64)
    key, item = e[:, 0] * (int(e.max(initial=0)) + 1) + e[:, 1], np.tile(item, 3)
    o = np.lexsort((key, item))
    item, key, e = item[o], key[o], e[o]
    new = np.r_[True, (item[1:] != item[:-1]) | (key[1:] != key[:-1])] if len(key) else np.zeros(0, bool)
    once = np.diff(np.r_[np.flatnonzero(new), len(key)]) == 1
    edge, owner = e[new][once], item[new][once]
    return edge, np.searchsorted(owner, np.arange(n + 1))

"""A uniform grid over the casters' bounding spheres, for scenes of many instances spread evenly.

The instance tree (:mod:`.bvh`) lets a work-item's batch of rays enter a node
when any of its rays meets the node's box. Among casters spread over a
ground plane every box of the tree spans the same thin layer, so a ray from
the ground starts inside the boxes of all the nodes above its point, and
visits tens of them to meet the two or three spheres near it. A grid of cells
about two casters wide answers the same question by walking each ray through
the few cells it crosses (a 3D-DDA, ``kernels/grid.h``, the rays of a lane
group side by side): a cell lists the casters whose sphere, grown by a
margin, overlaps it.

As with the tree, the grid only decides which instances are asked; each is
still asked through its sphere test and its CSM exactly as without it, so
answers are bit-identical (an OR over the same instances, in another order).
The margin covers the float32 rounding of the walk: a ray that meets a
sphere passes, within the rounding, through a cell listing it.

The cell size follows the scene: one cell for every two casters over the
spheres' bounding box, no smaller than the median diameter nor than twice
the margin (so that a sphere grown by it meets at most 4 cells an axis,
where queries far away make the margin dwarf the casters). The kernels
read a cell's list four spheres at a time (:func:`grid_packets`: one test
of four), so a cell listing three or four spheres costs a ray little more
than one listing a single sphere, while every cell crossed costs a step of
the walk and a test: cells of about two casters each (a typical sphere
overlapping two to four of them) keep both few. A sphere is listed in the
cells it meets (grown by the margin), not in every cell of its box. A sphere wider than a
cell would fill many cells; such casters (``big``) are asked by every ray
instead, as without an acceleration structure; so are casters lying apart
from the others (:func:`isolated_casters`: a body parked far away), which
would otherwise stretch the grid's box and every cell with it. :func:`instance_grid`
declines (returns None) when the grid would be unbalanced -- more than
:data:`MAX_BIG` big casters, or a cell listing more than :data:`MAX_CELL`
-- and the tree is used instead.
"""
from __future__ import annotations

import numpy as np

from .._cl.tables import GRID, GRID_PACKET
from .bvh import spheres

__all__ = ["CELLS_PER_CASTER", "GRID_ITEM", "MAX_BIG", "MAX_CELL", "MAX_CELLS_PER_CASTER", "instance_grid",
           "grid_margin", "grid_packets", "isolated_casters"]

#: One entry of a cell's list as :func:`instance_grid` gives it: the caster and a copy of its
#: sphere (the instance record's float32 centre and radius); :func:`grid_packets` packs them.
GRID_ITEM = np.dtype([("centre", "<f4", (3,)), ("radius", "<f4"), ("instance", "<i4")])

#: Cells per caster the grid aims at (the cell's edge: the cube root of the spheres' box volume over this
#: many; 0.5: a cell for every two casters, its list about one packet of four).
CELLS_PER_CASTER = 0.5
#: Upper bound on cells per caster (plus 64): a larger count widens the cells.
MAX_CELLS_PER_CASTER = 8
#: Casters wider than a cell that the grid leaves to every ray; with more, the tree is used.
MAX_BIG = 16
#: Most casters one cell may list; with more, the tree is used.
MAX_CELL = 64


def grid_margin(points_extent: float, boxes_extent: float) -> float:
    """Margin (world units) by which each sphere is grown before it is listed in cells.

    The walk's float32 rounding (relative 1.2e-7 of the coordinates involved,
    a few operations deep) stays far inside ``1e-5 * (largest |coordinate| of
    the points + of the spheres' box)``, the rule of :func:`.bvh.box_pad`;
    rounded up to a power of two, so that grids can be kept per margin.
    """
    m = 1e-5 * (float(points_extent) + float(boxes_extent))
    return float(2.0 ** np.ceil(np.log2(m))) if m > 0 else 0.0


def _cell_size(lo: np.ndarray, hi: np.ndarray, r: np.ndarray) -> float:
    n = len(r)
    ext = np.maximum(hi - lo, 1e-30)
    h = max(float(np.cbrt(np.prod(ext) / (CELLS_PER_CASTER * n))), 2.0 * float(np.median(r)))
    cap = MAX_CELLS_PER_CASTER * n + 64
    while np.prod(np.maximum(np.ceil(ext / h), 1.0)) > cap:     # flat or spread scenes: fewer, wider cells
        h *= 1.25
    return h


def instance_grid(centres, radii, margin: float = 0.0, balanced_only: bool = True):
    """The grid over spheres (anchor-relative centres, radii), or None.

    :func:`grid_packets` packs its lists as the kernels read them.

    Parameters
    ----------
    centres : ndarray, shape (N, 3)
    radii : ndarray, shape (N,)
        N >= 1; world units, anchor-relative (float32 rows of the instance table).
    margin : float
        Growth of every sphere before listing (:func:`grid_margin`).
    balanced_only : bool
        False: the grid even where it is unbalanced (the caller has decided).

    Returns
    -------
    header : ndarray of GRID, shape (1,)
        ``origin`` (the grid's low corner), ``cell`` (edge per axis),
        ``inv_cell``, ``dims`` (cells per axis), ``big`` (casters asked by
        every ray: radius above the target edge).
    cells : ndarray, uint32, shape (prod(dims) + 1,)
        Cell ``(x * dims[1] + y) * dims[2] + z`` lists ``items[cells[k] :
        cells[k + 1]]``; the big casters follow at ``items[cells[-1]:]``.
    items : ndarray of GRID_ITEM
        Instance indices, each with its sphere (``centres``, ``radii`` as float32).
    None
        When the grid would be unbalanced (see the module's notes).
    """
    c, r = spheres(centres, radii, "instance_grid")
    if not (margin >= 0 and np.isfinite(margin)):
        raise ValueError(f"instance_grid: margin must be finite and >= 0, got {margin}")
    apart = isolated_casters(c, r)
    if len(apart):
        g = _grid(c, r, margin, balanced_only, apart)
        if g is not None or not balanced_only:
            return g
    return _grid(c, r, margin, balanced_only, apart[:0])


def isolated_casters(centres, radii, most: int = MAX_BIG) -> np.ndarray:
    """Casters lying apart from the others, which :func:`instance_grid` asks of every ray (with the big ones).

    A body parked far away, or fallen below the others, would stretch the
    grid's box: its cells, sized to hold about two casters each over that
    box, would each list hundreds of the others (or the tree be taken). On
    each side of each axis, the fewest casters (at most half, at most
    ``most`` in all) whose spheres are separated from all the others' by a
    gap wider than the others' own extent along that axis are set apart;
    repeated until none is. A scene spread evenly, or in clusters of more than
    ``most`` casters, sets none apart.

    Parameters
    ----------
    centres : ndarray, shape (N, 3)
    radii : ndarray, shape (N,)
        Validated spheres (float64, world units).
    most : int
        The most casters set apart.

    Returns
    -------
    ndarray of int64
        Indices of the casters set apart, ascending.
    """
    c, r = np.asarray(centres, np.float64), np.asarray(radii, np.float64)
    inside = np.ones(len(c), bool)
    keep = np.arange(len(c))
    moved = True
    while moved:
        moved = False
        for a in range(3):
            for side in (1.0, -1.0):            # the low side, then the high side (the axis mirrored)
                budget = min(most - (len(c) - len(keep)), (len(keep) - 1) // 2)
                if budget < 1:
                    break
                low = _low_strays(side * c[keep, a], r[keep], budget)
                if len(low):
                    inside[keep[low]] = False
                    keep = np.flatnonzero(inside)
                    moved = True
    return np.flatnonzero(~inside)


def _low_strays(x, r, budget: int) -> np.ndarray:
    """Positions of the fewest (1 to ``budget``) spheres of lowest centre ``x`` whose extent along the axis lies
    apart from the others' by more than the others' own extent, or none: the ``budget + 1`` lowest taken
    by a partition, the others' bounds once (linear in the spheres, not a sort of them all)."""
    m = budget + 1
    cand = np.argpartition(x, m - 1)[:m] if m < len(x) else np.arange(len(x))
    cand = cand[np.argsort(x[cand], kind="stable")]
    lo, hi = x - r, x + r
    others = np.ones(len(x), bool)
    others[cand] = False
    base_lo, base_hi = lo[others].min(initial=np.inf), hi[others].max(initial=-np.inf)
    rest_lo = np.minimum(np.minimum.accumulate(lo[cand][::-1])[::-1], base_lo)      # of all but the first k
    rest_hi = np.maximum(np.maximum.accumulate(hi[cand][::-1])[::-1], base_hi)
    first_hi = np.maximum.accumulate(hi[cand])                                      # of the first k
    k = np.arange(1, min(budget, len(cand) - 1) + 1)
    wide = np.flatnonzero(rest_lo[k] - first_hi[k - 1] > rest_hi[k] - rest_lo[k])
    return cand[:k[wide[0]]] if len(wide) else cand[:0]


def _grid(c, r, margin, balanced_only, apart):
    """:func:`instance_grid` with the casters ``apart`` left out of the box and its cells, asked by every ray."""
    inside = np.ones(len(c), bool)
    inside[apart] = False
    inside = np.flatnonzero(inside)
    lo = (c[inside] - r[inside, None]).min(axis=0) - 2.0 * margin
    hi = (c[inside] + r[inside, None]).max(axis=0) + 2.0 * margin
    # no narrower than twice the margin: a sphere grown by a margin that dwarfs it (queries far from the
    # casters) would fill hundreds of cells (10,000 casters asked from 1e6 m: a grid of 57 MB, 0.7 GB to build)
    target = max(_cell_size(lo, hi, r[inside]), 2.0 * margin)
    origin = lo.astype(np.float32)
    origin = np.where(origin > lo, np.nextafter(origin, np.float32(-np.inf)), origin)     # at or below lo
    # cells of about the target edge, each axis's fitted to the box: a thin layer of casters gets one
    # layer of cells as thick as it is, so that a ray leaves the cells where it leaves the layer
    dims = np.maximum(np.ceil((hi - origin) / target).astype(np.int64), 1)
    h32 = ((hi - origin) / dims).astype(np.float32)
    h32 = np.where(origin + dims * h32.astype(np.float64) < hi, np.nextafter(h32, np.float32(np.inf)), h32)
    h32 = np.maximum(h32, np.float32(np.finfo(np.float32).tiny))
    h, inv32 = h32.astype(np.float64), (1.0 / h32.astype(np.float64)).astype(np.float32)
    big = np.union1d(inside[r[inside] > target], apart)
    if len(big) > MAX_BIG and balanced_only:
        return None
    small = inside[r[inside] <= target]
    a = np.clip(np.floor((c[small] - r[small, None] - margin - origin) / h).astype(np.int64), 0, dims - 1)
    b = np.clip(np.floor((c[small] + r[small, None] + margin - origin) / h).astype(np.int64), 0, dims - 1)
    span = b - a + 1                                        # cells per axis of each sphere (1 to 5)
    count = span.prod(axis=1)
    inst = np.repeat(small, count)
    k = np.arange(len(inst)) - np.repeat(np.cumsum(count) - count, count)     # index within the sphere's block
    sp = np.repeat(span, count, axis=0)
    off = np.stack([k // (sp[:, 1] * sp[:, 2]), (k // sp[:, 2]) % sp[:, 1], k % sp[:, 2]], axis=1)
    cell = np.repeat(a, count, axis=0) + off
    # keep the cells the grown sphere meets (not only its box): the corner cells of its box often miss it
    lo_c = origin + cell * h
    gap = np.maximum(np.maximum(lo_c - c[inst], c[inst] - (lo_c + h)), 0.0)
    keep = (gap * gap).sum(axis=1) <= (r[inst] + margin) ** 2
    inst, cell = inst[keep], cell[keep]
    cid = (cell[:, 0] * dims[1] + cell[:, 1]) * dims[2] + cell[:, 2]
    ncells = int(np.prod(dims))
    per = np.bincount(cid, minlength=ncells)
    if per.max(initial=0) > MAX_CELL and balanced_only:
        return None
    order = np.argsort(cid, kind="stable")                  # within a cell: ascending instance (inst is)
    cells = np.zeros(ncells + 1, np.uint32)
    cells[1:] = np.cumsum(per)
    which = np.concatenate([inst[order], big])
    items = np.zeros(len(which), GRID_ITEM)
    items["instance"] = which
    items["centre"], items["radius"] = c[which].astype(np.float32), r[which].astype(np.float32)
    header = np.zeros(1, GRID)
    header["origin"], header["cell"], header["inv_cell"] = origin, h32, inv32
    header["dims"], header["big"] = dims.astype(np.int32), len(big)
    return header, cells, items


def grid_packets(dims, cells, items):
    """The cells' lists as the kernels read them: spheres four to a packet (``GRID_PACKET``).

    Cell ``k``'s list starts in ``packets[k]``, so that a ray's walk finds
    it from the cell's number alone. A packet holds up to four entries,
    unused slots marked by instance -1; a list longer than four fills three
    slots of each packet but its last, whose slot 3 holds ``-2 - i`` (no
    sphere), ``i`` the index of the packet that goes on. The big casters
    follow the cells' packets, four to a packet from ``packets[prod(dims)]``;
    the lists' continuations come after them. A ray's walk tests the spheres
    of a packet at once (``kernels/grid.h``).

    Parameters
    ----------
    dims : sequence of 3 int
        The grid's cells per axis (``header["dims"][0]`` of :func:`instance_grid`).
    cells, items
        As :func:`instance_grid` returns them.

    Returns
    -------
    packets : ndarray of GRID_PACKET, shape (prod(dims) + ceil(big / 4) + continuations,)
    """
    cells = np.asarray(cells, np.int64)
    ncells = int(np.prod(dims))
    if len(cells) != ncells + 1:
        raise ValueError(f"grid_packets: {len(cells) - 1} lists for {ncells} cells")
    per = np.diff(cells)
    nbig = len(items) - int(cells[-1])
    chain = np.maximum(1, (per + 1) // 3)                    # packets of a list of n: ceil((n - 1) / 3), at least 1
    more = np.zeros(ncells + 1, np.int64)                   # its continuations, from ncells + ceil(nbig / 4) + more[k]
    more[1:] = np.cumsum(chain - 1)
    start = ncells + (nbig + 3) // 4
    packets = np.zeros(start + int(more[-1]), GRID_PACKET)
    packets["instance"] = -1
    owner = np.repeat(np.arange(ncells), per)
    t = np.arange(int(cells[-1])) - cells[owner]            # place within its cell's list
    link = np.minimum(t // 3, chain[owner] - 1)             # which packet of the chain: the last takes 4
    lane = t - 3 * link

    def packet(k, j):                                        # index of packet j (0: the cell's own) of cell k's chain
        return np.where(j == 0, k, start + more[k] + j - 1)

    pk = np.concatenate([packet(owner, link), ncells + np.arange(nbig) // 4])
    lane = np.concatenate([lane, np.arange(nbig) % 4])
    for k, field in enumerate(("cx", "cy", "cz")):
        packets[field][pk, lane] = items["centre"][:, k]
    packets["radius"][pk, lane] = items["radius"]
    packets["instance"][pk, lane] = items["instance"]
    for j in range(1, int(chain.max(initial=1))):            # slot 3 of packet j - 1 of each longer chain: the link
        k = np.flatnonzero(chain > j)
        packets["instance"][packet(k, j - 1), 3] = -2 - packet(k, j)
    return packets

"""Segment lists shared by neighbouring texels (thesis 000 section 7; issue 25 item 2): the bytes they would save.

A CSM keeps one segment list per texel: runs of consecutive maps that can
store one depth, because the intervals of their maps at that texel
(``pyshadow.csm.map_intervals``: ``[lo, hi3]``, depth keys) intersect. Thesis
section 7 (Fig. 7.1) proposes runs shared by a block of coherent texels:
one stored depth valid for every texel of the block over the run's maps,
while the intersection of all their intervals stays non-empty. Each texel
keeps the guarantee its own list is built for (the stored depth lies in
each of its maps' intervals: lit at the first surface the texel sees,
shadowed from the second on); other points may be answered otherwise.

Neighbouring lists are seldom identical ("repeated": the segments of lists
that equal an earlier texel's, mostly texels that see nothing in any map;
"left": the share of run ends that also end a run of the left neighbour's
list, "same": and with the same stored depth), so sharing has to be by
intervals. The script renders the CSM's own maps (``pyshadow.render_depth``,
the build's frame and layers), takes every map's intervals, and counts in
map order, greedily, for 2x2 blocks:

* a **shared run** while the block's intersection over its maps stays
  non-empty (one pair: 4 bytes, as a segment today);
* a map where the four texels' intervals do not intersect (a silhouette or
  a step in depth across the block) starts a **split region** (one marker
  pair), in which each texel keeps runs of its own (a pair each), until a
  map where the block intersects again and one of the texels' runs ends;
  then the four runs end and a shared run starts.

Each block may also keep whichever is smaller, its shared lists or its
four own lists (one bit a block says which; "chosen": the greedy scheme
can cost more pairs than the lists it replaces where the block's texels
disagree often). Against it: the CSM as built (the same count per texel,
checked against its segments), and the CSM built at half the resolution (what the same
saving costs without sharing: coarser maps). Bytes are those of the pairs
(4 per segment; offsets and summaries come on top of both). How fast a
lookup could read such lists is not measured: it would need the block's
list and, in split regions, the texel's own.

    python benchmarks/texel_blocks.py [--meshes all] [--maps 32x64] [--resolution 64] [--json]
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from _common import check_meshes, emit, environment, load_mesh, parse_grid


#: maps rendered at a time (64 MiB of float32 depths at 128^2 texels, 2 layers)
CHUNK = 512


def block_indices(R: int) -> np.ndarray:
    """(B, 4) int64: the texels of each 2x2 block (row-major blocks; texel r * R + c)."""
    b = np.arange(R // 2)
    r, c = np.meshgrid(b, b, indexing="ij")
    top = (2 * r * R + 2 * c).reshape(-1)
    return np.stack([top, top + 1, top + R, top + R + 1], axis=1)


def count_runs(intervals, R: int, miss: int) -> dict:
    """Pairs of the per-texel lists and of the 2x2 block scheme, greedy in map order (module docstring), and
    the share of (block, map) where a texel of the block sees the mesh and the four intervals do not meet.
    ``chosen_pairs``: each block's fewer of the two (its four own lists or its shared ones), ``blocks_sharing``:
    the blocks whose shared lists are fewer; ``floor_pairs``: the least any scheme of shared and own runs
    could keep, each block its largest own list (a texel's own list is the fewest runs its intervals allow,
    and every run that covers it, shared or not, is one of its runs).

    ``intervals``: an iterator of ``(lo, hi2, hi3)`` per map (``map_intervals``); R even; ``miss``: the miss
    key (``lo`` where a texel sees nothing).
    """
    idx = block_indices(R)
    texel_lo = texel_hi = None
    texel_runs = np.ones(R * R, np.int64)            # each texel's list: its first run, then one a run it ends
    seen = apart = 0
    for i, (lo, _, hi3) in enumerate(intervals):
        l, h = lo[idx], hi3[idx]
        blo, bhi = l.max(axis=1), h.min(axis=1)
        share = blo <= bhi
        some = l.min(axis=1) != miss
        seen += int(some.sum())
        apart += int((some & ~share).sum())
        if i == 0:
            texel_lo, texel_hi = lo, hi3
            split = ~share
            slo, shi, tlo, thi = blo, bhi, l, h
            shared_runs, marks, split_runs = np.zeros(len(idx), np.int64), split.astype(np.int64), \
                np.zeros(len(idx), np.int64)                 # per block
            continue
        # the per-texel lists (as compress_reference joins them)
        nlo, nhi = np.maximum(texel_lo, lo), np.minimum(texel_hi, hi3)
        join = nlo <= nhi
        texel_runs += ~join
        texel_lo, texel_hi = np.where(join, nlo, lo), np.where(join, nhi, hi3)
        # the blocks
        nslo, nshi = np.maximum(slo, blo), np.minimum(shi, bhi)
        s_join = ~split & share & (nslo <= nshi)
        s_end = ~split & ~s_join
        ntlo, nthi = np.maximum(tlo, l), np.minimum(thi, h)
        t_join = ntlo <= nthi
        leave = split & share & ~t_join.all(axis=1)          # back to a shared run: the four runs end
        stay = split & ~leave
        enter = s_end & ~share                               # a split region starts
        shared_runs += s_end
        split_runs += 4 * leave + (~t_join & stay[:, None]).sum(axis=1)
        marks += enter
        start = (s_end & share) | leave
        slo = np.where(s_join, nslo, np.where(start, blo, slo))
        shi = np.where(s_join, nshi, np.where(start, bhi, shi))
        keep = stay[:, None] & t_join
        tlo, thi = np.where(keep, ntlo, l), np.where(keep, nthi, h)
        split = stay | enter
    shared_runs += ~split
    split_runs += 4 * split
    block = shared_runs + marks + split_runs
    own = texel_runs[idx].sum(axis=1)                    # the block's four lists as they are
    return {"texel_segments": int(texel_runs.sum()), "shared_runs": int(shared_runs.sum()),
            "split_markers": int(marks.sum()), "split_runs": int(split_runs.sum()), "block_pairs": int(block.sum()),
            "chosen_pairs": int(np.minimum(block, own).sum()), "blocks_sharing": int((block < own).sum()),
            "floor_pairs": int(texel_runs[idx].max(axis=1).sum()),
            "blocks_apart": apart / max(seen, 1)}


def measure(name: str, maps, R: int) -> dict:
    import pyshadow
    from pyshadow.csm import both_sided_faces, map_intervals, open_sheet
    from pyshadow.csm.reference import miss_key

    mesh = load_mesh(name)
    views = pyshadow.ViewSet.zigzag(*maps)
    t0 = time.perf_counter()
    csm = pyshadow.CoherentShadowMap.build(mesh, views, resolution=R, progress=False)
    half = pyshadow.CoherentShadowMap.build(mesh, views, resolution=R // 2, progress=False)
    frame = (csm.centre, csm.radius)
    both = both_sided_faces(mesh, frame, csm.layer_rule, "auto")
    open_air = open_sheet(mesh, both)

    def intervals():            # the maps rendered CHUNK at a time (each map's intervals are its own)
        for s in range(0, len(views), CHUNK):
            layers, front = pyshadow.render_depth(mesh, views[s:s + CHUNK], resolution=R, layers=csm.layer_rule,
                                                  frame=frame, facing=True, both_sides=both)
            yield from map_intervals(layers, front, csm.layer_rule, csm.depth_bits, open_air=open_air)
    runs = count_runs(intervals(), R, miss_key(csm.depth_bits))
    if runs["texel_segments"] != len(csm.iend):
        raise RuntimeError(f"{name}: {runs['texel_segments']} runs counted, the CSM has {len(csm.iend)} segments "
                           "(the intervals are not the build's)")
    off, iend, depth = np.asarray(csm.offsets, np.int64), np.asarray(csm.iend), np.asarray(csm.depth)
    lists = {(iend[a:b].tobytes(), depth[a:b].tobytes()) for a, b in zip(off[:-1], off[1:])}
    repeated = len(csm.iend) - sum(len(k[0]) // iend.itemsize for k in lists)   # segments of lists seen before
    ends = same = 0                     # run ends also ending a run of the left neighbour's list (same depth)
    for t in range(1, R * R):
        if t % R:
            a, b = slice(off[t], off[t + 1]), slice(off[t - 1], off[t])
            k = np.searchsorted(iend[b], iend[a])
            hit = iend[b][np.minimum(k, len(iend[b]) - 1)] == iend[a]
            ends += int(hit.sum())
            same += int((depth[b][k[hit]] == depth[a][hit]).sum())
    full, blocks, halved = 4 * len(csm.iend), 4 * runs["block_pairs"], 4 * len(half.iend)
    chosen = 4 * runs["chosen_pairs"] + (R * R // 4 + 7) // 8          # and a bit per block
    return {"mesh": name, "maps": f"{maps[0]}x{maps[1]}", "resolution": R, **runs,
            "repeated_list_segments": int(repeated), "left_shared_ends": ends / len(iend),
            "left_same_depth": same / len(iend),
            "pair_bytes": full, "block_pair_bytes": blocks, "half_resolution_pair_bytes": halved,
            "chosen_pair_bytes": chosen, "blocks_over_texels": blocks / full, "chosen_over_texels": chosen / full,
            "floor_over_texels": runs["floor_pairs"] / len(csm.iend),
            "half_over_full": halved / full,
            "seconds": time.perf_counter() - t0}


def main(argv=None) -> int:
    import pyshadow

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--meshes", default="all", help="comma-separated bundled meshes or files (default: all "
                                                     "bundled: pyshadow.data.MESHES)")
    ap.add_argument("--maps", default="32x64", help="zigzag THETAxPHI (default: %(default)s)")
    ap.add_argument("--resolution", type=int, default=64, help="texels per side, even (default: %(default)s)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    maps = parse_grid(ap, args.maps)
    if args.resolution < 2 or args.resolution % 2:
        ap.error(f"--resolution must be an even number >= 2, got {args.resolution}")
    names = list(pyshadow.data.MESHES) if args.meshes == "all" else [m for m in args.meshes.split(",") if m]
    check_meshes(ap, "--meshes", names)
    rows = []
    for name in names:
        rows.append(measure(name, maps, args.resolution))
        print(f"{name} done ({rows[-1]['seconds']:.1f} s)", file=sys.stderr, flush=True)
    if args.json:
        emit({"benchmark": "texel_blocks", **environment(), "rows": rows}, True)
        return 0
    print(f"zigzag {args.maps} maps at {args.resolution}^2: pair bytes of the per-texel lists, of 2x2 blocks "
          f"sharing runs (greedy), each block's smaller of the two with its bit (chosen), the least any such scheme "
          f"could keep (floor), and of the CSM at {args.resolution // 2}^2")
    print(f"{'mesh':<20} {'per texel':>11} {'2x2 blocks':>11} {'ratio':>6} {'chosen':>6} {'floor':>5} "
          f"{'shared runs':>11} {'split':>9} {'markers':>8} {'apart':>6} {'half res':>11} {'ratio':>6} "
          f"{'repeated':>8} {'left':>5} {'same':>5}")
    for r in rows:
        print(f"{r['mesh']:<20} {r['pair_bytes']:>11,} {r['block_pair_bytes']:>11,} {r['blocks_over_texels']:>6.3f} "
              f"{r['chosen_over_texels']:>6.3f} {r['floor_over_texels']:>5.3f} "
              f"{r['shared_runs']:>11,} {r['split_runs']:>9,} {r['split_markers']:>8,} {r['blocks_apart']:>6.3f} "
              f"{r['half_resolution_pair_bytes']:>11,} {r['half_over_full']:>6.3f} {r['repeated_list_segments']:>8,} "
              f"{r['left_shared_ends']:>5.2f} {r['left_same_depth']:>5.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

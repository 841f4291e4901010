"""pyshadow.csm.map_intervals (the intervals compress_reference joins) and benchmarks/texel_blocks.py's count of
runs shared by 2x2 texels."""
from __future__ import annotations

import sys

import numpy as np
import pytest

import pyshadow
from conftest import REPO
from pyshadow.csm import both_sided_faces, map_intervals, open_sheet

sys.path.insert(0, str(REPO / "benchmarks"))


def test_block_runs_counted_by_hand():
    """One 2x2 block over four maps: a shared run of maps 0-1 ([5, 10] for all), map 2 with texel 0 apart (a
    split region: its marker, four runs of their own), map 3 back together (the four runs end, a shared run).
    Per texel: two runs each."""
    from texel_blocks import count_runs

    a, b, c = (0, 10), (5, 15), (20, 30)
    maps = [[a] * 4, [b] * 4, [c, a, a, a], [c] * 4]
    seq = [(np.array([t[0] for t in m]), None, np.array([t[1] for t in m])) for m in maps]
    got = count_runs(iter(seq), 2, miss=65535)
    assert got == {"texel_segments": 8, "shared_runs": 2, "split_markers": 1, "split_runs": 4, "block_pairs": 7,
                   "chosen_pairs": 7, "blocks_sharing": 1, "floor_pairs": 2, "blocks_apart": 0.25}


def test_a_block_keeps_its_own_lists_where_sharing_costs_more():
    """Texel 0 leaves its neighbours every other map: the greedy scheme pays two shared runs, two markers and
    eight split runs (12 pairs) where the four own lists hold 4 + 1 + 1 + 1; the block keeps those (7)."""
    from texel_blocks import count_runs

    a, c = (0, 10), (20, 30)
    maps = [[a] * 4, [c, a, a, a], [a] * 4, [c, a, a, a]]
    seq = [(np.array([t[0] for t in m]), None, np.array([t[1] for t in m])) for m in maps]
    got = count_runs(iter(seq), 2, miss=65535)
    assert got == {"texel_segments": 7, "shared_runs": 2, "split_markers": 2, "split_runs": 8, "block_pairs": 12,
                   "chosen_pairs": 7, "blocks_sharing": 0, "floor_pairs": 4, "blocks_apart": 0.5}


def test_intervals_hold_the_stored_depths_and_give_the_segments():
    """Every stored depth key lies in the interval of each map of its run (the CSM's guarantee), and joining
    the intervals greedily gives the build's segments, texel by texel."""
    from texel_blocks import count_runs

    mesh = pyshadow.data.mesh("spot")
    views = pyshadow.ViewSet.zigzag(4, 8)
    R = 16
    csm = pyshadow.CoherentShadowMap.build(mesh, views, resolution=R, progress=False)
    frame = (csm.centre, csm.radius)
    both = both_sided_faces(mesh, frame, csm.layer_rule, "auto")
    layers, front = pyshadow.render_depth(mesh, views, resolution=R, layers=csm.layer_rule, frame=frame,
                                          facing=True, both_sides=both)
    ivs = list(map_intervals(layers, front, csm.layer_rule, csm.depth_bits, open_air=open_sheet(mesh, both)))
    assert len(ivs) == len(views)
    t = np.arange(R * R)
    hit = 0
    for k, (lo, hi2, hi3) in enumerate(ivs):
        assert lo.shape == hi3.shape == (R * R,) and np.all(lo <= hi2) and np.all(hi2 <= hi3)
        seg = np.asarray(csm.segment_index(np.full(R * R, k), t // R, t % R), np.int64)
        key = np.asarray(csm.depth)[seg].astype(np.int64)
        assert np.all((lo <= key) & (key <= hi3)), k
        hit += int((lo != 65535).sum())
    assert hit > len(views) * R * R // 10                 # the body covers the maps, not only misses
    assert count_runs(iter(ivs), R, 65535)["texel_segments"] == len(csm.iend)


def test_map_intervals_refuses_at_the_call():
    """Bad arguments are refused when map_intervals is called, not when its first map is asked for."""
    layers = np.zeros((2, 2, 4, 4), np.float32)
    front = np.ones(layers.shape, bool)
    with pytest.raises(ValueError, match="rule must be 2 or 3"):
        map_intervals(layers, front, rule=5)
    with pytest.raises(ValueError, match="front has shape"):
        map_intervals(layers, front[:, :, :2])

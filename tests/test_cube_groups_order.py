"""``scene_arrays.cube_groups``: the far points' cubes in lexicographic order of (side, cell), each one's
rows in their order -- the groups of ``np.unique(rows, axis=0)`` with a stable sort of its inverse."""
import numpy as np
import pytest

from pyshadow.scene_arrays import cube_groups


def _unique_groups(points, anchor, reach):
    """The grouping written with np.unique over the (side, cell) rows (every point's reach ``reach``)."""
    extent = np.abs(points - anchor).max(axis=1)
    rows = np.flatnonzero(extent > reach)
    far = np.zeros(len(points), bool)
    far[rows] = True
    side = np.ldexp(1.0, np.frexp(np.full(len(rows), reach))[1])      # the widest power of two within 2 reach
    cells = np.floor(points[rows] / side[:, None])
    keys, inverse = np.unique(np.column_stack([side, cells]), axis=0, return_inverse=True)
    order = np.argsort(inverse.reshape(-1), kind="stable")
    bounds = np.searchsorted(inverse.reshape(-1)[order], np.arange(len(keys) + 1))
    groups = [(np.flatnonzero(~far), anchor)] if (~far).any() else []
    return groups + [(rows[order[bounds[k]:bounds[k + 1]]], (keys[k, 1:] + 0.5) * keys[k, 0])
                     for k in range(len(keys))]


@pytest.mark.parametrize("reach", [0.37, 5.0, 300.0])
def test_cube_groups_equal_the_unique_rows_grouping(reach):
    """50,000 points from 1e-3 to 1e6 from the anchor, with -0.0 and 0.0 coordinates and points on cube
    faces: the same groups, in the same order, with the same rows and anchors, bit for bit."""
    rng = np.random.default_rng(int(reach * 100))
    p = rng.normal(size=(50000, 3)) * 10.0 ** rng.uniform(-3, 6, (50000, 1))
    p[:500] = np.round(p[:500] / reach) * reach          # on cube faces
    p[500:600, 0] = -0.0
    p[600:700, 0] = 0.0
    anchor = np.array([0.25, -1.0, 3.0])
    got, want = cube_groups(p, anchor, reach), _unique_groups(p, anchor, reach)
    assert len(got) == len(want) > 10
    for (gr, ga), (wr, wa) in zip(got, want):
        assert np.array_equal(gr, wr) and np.array_equal(np.asarray(ga), np.asarray(wa))


@pytest.mark.parametrize("reach", [0.37, 300.0])
def test_runs_of_equal_rows_are_grouped_as_every_row_would_be(reach):
    """Points repeated in runs (a point's AO directions come as one; cube_groups sorts the runs, not the
    rows), equal points also apart, runs of -0.0 beside 0.0: the unique-rows grouping, bit for bit."""
    rng = np.random.default_rng(7)
    base = rng.normal(size=(3000, 3)) * 10.0 ** rng.uniform(-1, 4, (3000, 1))
    base[:40, 1] = -0.0
    base[40:80, 1] = 0.0
    base[80:120] = base[200:240]                         # equal points far apart in the order
    p = np.repeat(base, rng.integers(1, 20, len(base)), axis=0)
    anchor = np.array([1.0, 0.0, -2.0])
    got, want = cube_groups(p, anchor, reach), _unique_groups(p, anchor, reach)
    assert len(got) == len(want) > 10
    for (gr, ga), (wr, wa) in zip(got, want):
        assert np.array_equal(gr, wr) and np.array_equal(np.asarray(ga), np.asarray(wa))


def test_reach_bound_asks_each_run_once_with_every_row_s_answer():
    """``reach_bound`` of points repeated in runs: each row's bound is that of its point asked alone."""
    from pyshadow.anchor_reach import caster_buckets, reach_bound, run_starts

    rng = np.random.default_rng(11)
    centres = rng.uniform(-50, 50, (40, 3))
    radii = 10.0 ** rng.uniform(-3, -1, 40)
    base = rng.uniform(-60, 60, (2000, 3))
    base[:100] = centres[rng.integers(0, 40, 100)] + rng.normal(size=(100, 3)) * 0.05     # beside the casters
    assert run_starts(base).all()
    counts = rng.integers(1, 9, len(base))
    p = np.repeat(base, counts, axis=0)
    extent = np.abs(p - 3.0).max(axis=1)
    got = reach_bound(p, extent, caster_buckets(centres, radii), 512.0)
    want = reach_bound(base, np.abs(base - 3.0).max(axis=1), caster_buckets(centres, radii), 512.0)
    assert np.isfinite(want).sum() > 100
    np.testing.assert_array_equal(got, np.repeat(want, counts))

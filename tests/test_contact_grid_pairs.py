"""The contact rules' (point, part) candidates from a uniform grid (``contact_parts._grid_pairs``): every point
within a part's box is among a part's candidates, whatever the parts' sizes, places and scales."""
import numpy as np
import pytest

from pyshadow.contact_parts import _GRID_SPAN, _grid_pairs, _slab_pairs


def _in_box(p, lo, hi):
    """The (part, row) pairs with the point inside or on the part's box, brute force, sorted."""
    inside = np.all((p[None] >= lo[:, None]) & (p[None] <= hi[:, None]), axis=2)
    return set(zip(*np.nonzero(inside)))


def _kept(pid, rows, p, lo, hi):
    ok = np.all((p[rows] >= lo[pid]) & (p[rows] <= hi[pid]), axis=1)
    return set(zip(pid[ok].tolist(), rows[ok].tolist()))


def _boxes(rng, n, size, spread, offset):
    lo = offset + rng.uniform(-spread, spread, (n, 2))
    return lo, lo + rng.uniform(0, 1, (n, 2)) * size


@pytest.mark.parametrize("offset", [0.0, 1e4, -3e5])
@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
def test_grid_pairs_hold_every_point_in_a_box(offset, scale):
    """Small boxes scattered over a field, a few boxes 40x wider (through the slab path), points on box
    corners and edges (the boundary is inside) and at random: the same in-box pairs as brute force, each
    once, grouped by part."""
    rng = np.random.default_rng(3)
    lo, hi = _boxes(rng, 300, 0.3 * scale, 10 * scale, offset * scale)
    blo, bhi = _boxes(rng, 4, 12 * scale, 10 * scale, offset * scale)
    lo, hi = np.concatenate([lo, blo]), np.concatenate([hi, bhi])
    corners = np.concatenate([lo, hi, np.column_stack([lo[:, 0], hi[:, 1]])])
    p = np.concatenate([offset * scale + rng.uniform(-11 * scale, 11 * scale, (3000, 2)), corners])
    pid, rows = _grid_pairs(p, lo, hi)
    assert np.all(np.diff(pid) >= 0)
    assert len(set(zip(pid.tolist(), rows.tolist()))) == len(pid)
    want = _in_box(p, lo, hi)
    assert _kept(pid, rows, p, lo, hi) == want
    n = len(lo)                                         # each corner point lies on its own box
    assert all((i % n, 3000 + i) in want for i in range(3 * n))
    # the wide boxes went through the slab path and the rest through the grid: both kinds present
    h = np.median((hi - lo).max(axis=1))
    assert ((hi - lo) / h > _GRID_SPAN).any() and ((hi - lo) / h < 1).any()


def test_grid_pairs_fewer_candidates_than_slabs():
    """2,500 boxes of 0.3 on a 1 m lattice, 5,000 points over the field: the grid's candidates stay
    within a small multiple of the pairs the boxes hold; one axis's slabs give each box a strip."""
    rng = np.random.default_rng(0)
    k = np.arange(2500)
    lo = np.column_stack([k % 50, k // 50]) - 25.15
    hi = lo + 0.3
    p = rng.uniform(-25, 25, (5000, 2))
    want = _in_box(p, lo, hi)
    g = _grid_pairs(p, lo, hi)
    s = _slab_pairs(p, lo, hi)
    assert _kept(*g, p, lo, hi) == want == _kept(*s, p, lo, hi)
    assert len(g[0]) < 8 * len(want) < len(s[0])


@pytest.mark.parametrize("case", ["empty points", "no parts", "zero-size boxes", "one point"])
def test_grid_pairs_degenerate(case):
    """No points, no parts, boxes of zero size (all on points: the median width 0 goes to the slabs) and a
    single point: the same in-box pairs as brute force."""
    rng = np.random.default_rng(1)
    p = rng.uniform(0, 1, (50, 2))
    lo, hi = _boxes(rng, 20, 0.2, 1.0, 0.0)
    if case == "empty points":
        p = p[:0]
    elif case == "no parts":
        lo, hi = lo[:0], hi[:0]
    elif case == "zero-size boxes":
        lo = hi = p[:20].copy()
    else:
        p = lo[:1].copy()
    pid, rows = _grid_pairs(p, lo, hi)
    assert _kept(pid, rows, p, lo, hi) == _in_box(p, lo, hi)
    if case == "zero-size boxes":
        assert len(_in_box(p, lo, hi)) >= 20

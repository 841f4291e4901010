"""Casters set apart from the instance grid (pyshadow.visibility.grid.isolated_casters): a body parked
far away, or fallen below the others, is asked by every ray instead of stretching the grid's box, so
the scene keeps the grid; answers stay bit-identical to the tree and to visiting every caster."""
import numpy as np
import pytest
from test_instance_bvh import _answers, _scene

import pyshadow
from pyshadow.visibility import csm as csm_backend, grid


def _layer(n, seed=0):
    rng = np.random.default_rng(seed)
    k = int(np.ceil(np.sqrt(n)))
    c = np.c_[np.arange(n) % k + rng.uniform(-0.2, 0.2, n), np.full(n, 0.3), np.arange(n) // k]
    return c.astype(np.float64), np.full(n, 0.3)


def test_an_evenly_spread_layer_or_two_large_clusters_set_none_apart():
    c, r = _layer(400)
    assert len(grid.isolated_casters(c, r)) == 0
    two = np.concatenate([c[:40], c[:40] + [1e4, 0.0, 0.0]])     # 40 and 40, far apart: clusters, not strays
    assert len(grid.isolated_casters(two, np.full(80, 0.3))) == 0


def test_strays_on_any_side_are_set_apart_and_at_most_most():
    c, r = _layer(400)
    c[[5, 17, 300]] = [[1e4, 0.3, 0.0], [3.0, -1e3, 4.0], [2.0, 0.3, -50.0]]
    c[[41, 42]] = [[-1e5, 0.3, 0.0], [-1e5 + 1.0, 0.3, 0.0]]           # two strays together
    assert grid.isolated_casters(c, r).tolist() == [5, 17, 41, 42, 300]
    assert len(grid.isolated_casters(c, r, most=3)) <= 3
    c[:20, 1] = np.arange(20) * 100.0                                  # 20 strays up a column: at most MAX_BIG
    got = grid.isolated_casters(c, r)
    assert 0 < len(got) <= grid.MAX_BIG


def test_a_caster_touching_the_others_is_not_a_stray():
    c, r = _layer(100)
    c[7] = [4.0, 0.9, 4.0]                                    # resting on another's top: no gap
    c[8] = [0.0, 0.3, -0.6]                                   # just beyond the row, touching it
    assert len(grid.isolated_casters(c, r)) == 0


def test_the_grid_asks_the_strays_of_every_ray_and_fits_its_cells_to_the_others():
    c, r = _layer(400)
    c[9] = [1e4, 0.3, 0.0]
    header, cells, items = grid.instance_grid(c, r, 1e-3)
    assert 9 in items["instance"][cells[-1]:].tolist() and header["big"][0] == 1
    assert 9 not in items["instance"][:cells[-1]].tolist()
    assert header["origin"][0][0] < 0.0 and header["origin"][0][0] + header["dims"][0][0] * header["cell"][0][0] < 30


def answers_three_ways(s, rng, k, where, m, n_ids, monkeypatch):
    """``_answers`` of ``m`` random queries over the ``k`` m square, every 7th near ``where`` and every 9th aimed
    at it, on the grid, the tree and every caster: asserted bit-identical; the grid's answers."""
    P = np.c_[rng.uniform(-k / 2, k / 2, m), rng.uniform(0.0, 0.8, m), rng.uniform(-k / 2, k / 2, m)]
    D = rng.normal(size=(m, 3))
    P[::7] = np.asarray(where) + rng.normal(0, 1.0, (len(P[::7]), 3))   # rays near and at the stray
    D[::9] = np.asarray(where) - P[::9]
    N = rng.normal(size=(m, 3))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    ids = rng.integers(-1, n_ids, m)
    got = _answers(s, P, D, N, ids)
    monkeypatch.setattr(csm_backend, "USE_GRID", False)
    tree = _answers(s, P, D, N, ids)
    monkeypatch.setattr(csm_backend, "BVH_MIN_INSTANCES", 10 ** 9)
    flat = _answers(s, P, D, N, ids)
    for g, t, f in zip(got, tree, flat):
        assert np.array_equal(g, f) and np.array_equal(t, f)
    return got


@pytest.mark.parametrize("where", [(1e4, 0.3, 0.0), (0.0, -1e3, 0.0), (2.0, 40.0, 1.0)])
def test_a_parked_caster_keeps_the_grid_with_answers_bit_identical(monkeypatch, where):
    rng = np.random.default_rng(5)
    s, k = _scene(60, rng)
    spot = pyshadow.data.mesh("spot")
    T = np.eye(4)
    T[:3, :3] *= 0.4
    T[:3, 3] = where
    a = pyshadow.CoherentShadowMap.build(spot, pyshadow.ViewSet.zigzag(8, 16), resolution=32, progress=False)
    s.add(a, T, mesh=spot)
    assert csm_backend.instance_accel(s) == "grid"
    rows = csm_backend._instance_data(s, s.anchor(), "nearest")[0]
    header, cells, items = grid.instance_grid(rows["centre"], rows["radius"])
    assert items["instance"][cells[-1]:].tolist() == [len(rows) - 1]     # the stray, asked by every ray
    assert np.diff(cells).max() <= 8                          # before: cells stretched to list up to 60
    got = answers_three_ways(s, rng, k, where, 3000, 61, monkeypatch)
    assert not all(np.all(v) for v in got[::4])               # something occludes
    assert not got[0][::63].any()                             # the rays from near the stray, aimed at it: it does

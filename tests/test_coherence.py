"""Coherent ray order (pyshadow.visibility.order): the key against a float64 reference, the
permutation and its inverse, and answers of ``visible`` bit-identical with the reorder on and off."""
import hashlib

import numpy as np
import pytest

from pyshadow.visibility import order, visible
from pyshadow.visibility.csm import CSMVisibility

from conftest import surface_queries


@pytest.fixture
def reorder(monkeypatch):
    """A function ``set(on)`` forcing the reorder on or off for every batch size."""
    monkeypatch.setattr(order, "MIN_RAYS", 0)
    real = order.coherent_order
    calls = []
    monkeypatch.setattr(order, "coherent_order", lambda p, w: calls.append(len(p)) or real(p, w))

    def set_(on):
        monkeypatch.setattr(order, "COHERENT", on)
        set_.calls = calls
        calls.clear()
    return set_


def digest(a) -> str:
    return hashlib.sha256(np.ascontiguousarray(a, np.bool_).tobytes()).hexdigest()


def rays(scene, rng):
    """AO rays of both bodies (with surface ids and normals) and random rays above the ground."""
    ps, ws, ids, ns = [], [], [], []
    for i in (0, 1):
        p, w = surface_queries(scene, i, 300, 12, rng)
        ps.append(p), ws.append(w), ids.append(np.full(len(p), i))
        ns.append(w)                        # a normal in the ray's hemisphere: the surface rule applies
    m = 3000
    ps.append(rng.uniform((-1.5, 0.01, -1.5), (3.0, 2.0, 2.0), (m, 3)))
    ws.append(rng.normal(size=(m, 3)))
    ids.append(np.full(m, -1))
    ns.append(rng.normal(size=(m, 3)))
    return np.concatenate(ps), np.concatenate(ws), np.concatenate(ids), np.concatenate(ns)


def _octahedral_reference(w, bins):
    """float64 octahedral cell (u major) and the distance of (u, v) to the nearest cell edge."""
    w = np.asarray(w, np.float64)
    u, v = w[:, 0] / np.abs(w).sum(1), w[:, 2] / np.abs(w).sum(1)
    low = w[:, 1] < 0
    u, v = (np.where(low, np.copysign(1 - np.abs(v), u), u), np.where(low, np.copysign(1 - np.abs(u), v), v))
    fu, fv = (u + 1) * bins / 2, (v + 1) * bins / 2
    cell = np.clip(fu.astype(int), 0, bins - 1) * bins + np.clip(fv.astype(int), 0, bins - 1)
    edge = np.minimum(np.abs(fu - np.round(fu)), np.abs(fv - np.round(fv)))
    return cell, edge


def test_key_matches_float64_reference(rng):
    w = rng.normal(size=(20000, 3)) * rng.uniform(1e-3, 1e3, (20000, 1))
    p = rng.uniform(-5, 5, (20000, 3))
    key = order.ray_key(p, w)
    assert key.dtype == (np.uint16 if order.DIR_BINS ** 2 * order.CELLS ** 3 <= 1 << 16 else np.uint32)
    cell, edge = _octahedral_reference(w, order.DIR_BINS)
    clear = edge > 1e-4                # float32 arithmetic may round across a cell edge only there
    assert clear.mean() > 0.99
    np.testing.assert_array_equal(key[clear] // order.CELLS ** 3, cell[clear])
    # the poles and the axes: closed form
    B, C3 = order.DIR_BINS, order.CELLS ** 3
    axes = np.array([[0, 1, 0], [0, -1, 0], [1, 0, 0], [-1, 0, 0], [0, 0, 2], [0, 0, -1]], np.float64)
    half = B // 2
    expect = [half * B + half, (B - 1) * B + (B - 1), (B - 1) * B + half, half, half * B + (B - 1), half * B]
    np.testing.assert_array_equal(order.ray_key(np.zeros((6, 3)), axes) // C3, expect)
    # origin cells: the corners of the box are the first and the last cell
    q = np.array([[0.0, 0, 0], [1, 1, 1], [0.5, 0.5, 0.5]])
    oc = order.ray_key(q, np.ones((3, 3))) % C3
    c = order.CELLS
    assert oc[0] == 0 and oc[1] == C3 - 1 and oc[2] == ((c // 2) * c + c // 2) * c + c // 2
    # extreme scales (overflow, subnormals, zero rows): some cell in range (only the order depends on
    # it), without warnings
    big = np.array([[1e300, -1e300, 1e-320], [5e-324, 0.0, -5e-324], [0.0, 0.0, 0.0], [np.inf, 1.0, 0.0]])
    k = order.ray_key(np.array([[1e300, 0, 0], [-1e300, 1, 1], [0, 0, 0], [1, 2, 3]]), big)
    assert (k.astype(np.int64) < B * B * C3).all()
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        order.ray_key(np.zeros((3, 3)), np.zeros((2, 3)))


def test_permutation_inverts(rng):
    p, w = rng.uniform(-1, 1, (5000, 3)), rng.normal(size=(5000, 3))
    w[::7] = w[0]                                              # ties: the sort must keep their order
    perm = order.coherent_order(p, w)
    n = len(p)
    np.testing.assert_array_equal(np.sort(perm), np.arange(n))
    key = order.ray_key(p, w)[perm]
    assert (np.diff(key.astype(np.int64)) >= 0).all()
    same = np.flatnonzero(np.diff(key.astype(np.int64)) == 0)
    assert (perm[same + 1] > perm[same]).all()                  # stable
    inv = order.inverse_permutation(perm)
    np.testing.assert_array_equal(inv[perm], np.arange(n))
    np.testing.assert_array_equal(perm[inv], np.arange(n))
    a = rng.random(n) < 0.5
    np.testing.assert_array_equal(a[perm][inv], a)
    # reordered: the answer sees sorted rows (None passed through) and comes back in the given order
    seen = []

    def answer(pp, ww, ids, none):
        seen.append((pp, ww, ids, none))
        return ids * 2
    ids = np.arange(n, dtype=np.int32)
    np.testing.assert_array_equal(order.reordered(answer, p, w, ids, None), ids * 2)
    np.testing.assert_array_equal(seen[0][2], perm)
    np.testing.assert_array_equal(seen[0][0], p[perm])
    np.testing.assert_array_equal(seen[0][1], w[perm])
    assert seen[0][3] is None
    assert order.coherent_order(np.zeros((0, 3)), np.zeros((0, 3))).shape == (0,)
    np.testing.assert_array_equal(order.coherent_order(p[:1], w[:1]), [0])


def test_enabled(monkeypatch):
    monkeypatch.setattr(order, "MIN_RAYS", 100)
    monkeypatch.setattr(order, "COHERENT", None)
    monkeypatch.delenv("PYSHADOW_COHERENT", raising=False)
    assert order.enabled() == order.DEFAULT
    monkeypatch.setenv("PYSHADOW_COHERENT", "1")
    assert order.enabled() and order.enabled(100) and not order.enabled(99)
    monkeypatch.setenv("PYSHADOW_COHERENT", "0")
    assert not order.enabled(10 ** 9)
    monkeypatch.setattr(order, "COHERENT", True)               # the switch wins over the environment
    assert order.enabled(100)
    monkeypatch.setattr(order, "COHERENT", None)
    monkeypatch.setenv("PYSHADOW_COHERENT", "yes")
    with pytest.raises(ValueError, match="PYSHADOW_COHERENT"):
        order.enabled()


def test_small_batches_keep_their_order(two_bodies, monkeypatch):
    monkeypatch.setattr(order, "COHERENT", True)
    monkeypatch.setattr(order, "MIN_RAYS", 50)

    def boom(*a):
        raise AssertionError("reordered")
    monkeypatch.setattr(order, "coherent_order", boom)
    visible(two_bodies, np.ones((49, 3)), np.ones((49, 3)))
    with pytest.raises(AssertionError, match="reordered"):
        visible(two_bodies, np.ones((50, 3)), np.ones((50, 3)))


@pytest.mark.parametrize("backend", ["csm", "csm-vote"])
def test_answers_identical_on_off(two_bodies, reorder, rng, backend):
    P, W, ids, N = rays(two_bodies, rng)
    T = rng.uniform(0.05, 3.0, len(P))
    T[::5] = np.inf
    runs = {
        "plain": lambda: visible(two_bodies, P, W, backend=backend),
        "ids+normals": lambda: visible(two_bodies, P, W, backend=backend, surface_ids=ids, normals=N),
        "float32": lambda: visible(two_bodies, P.astype(np.float32), W.astype(np.float32), backend=backend,
                                   surface_ids=ids),
        "finite": lambda: visible(two_bodies, P, W, backend=backend, surface_ids=ids, max_distance=T,
                                  straddle="embree"),
    }
    for name, fn in runs.items():
        reorder(False)
        off = fn()
        assert reorder.calls == []
        reorder(True)
        on = fn()
        assert reorder.calls and max(reorder.calls) == len(P), name       # the reorder ran
        assert 0.05 < off.mean() < 0.95, name                # answers of both kinds
        assert digest(on) == digest(off), name


@pytest.mark.parametrize("backend", ["csm", "csm-vote"])
def test_edge_cases(two_bodies, reorder, rng, backend):
    csm = CSMVisibility("vote" if backend == "csm-vote" else "nearest")
    cases = {
        "empty": (np.zeros((0, 3)), np.zeros((0, 3))),
        "one": (np.array([[0.3, 0.05, 0.1]]), np.array([[0.2, 1.0, 0.1]])),
        "same direction": (rng.uniform((-1.5, 0.0, -1.5), (3.0, 1.5, 2.0), (3000, 3)),
                           np.tile([[0.4, 0.6, -0.2]], (3000, 1))),
        "same ray": (np.tile([[0.3, 0.02, 0.1]], (100, 1)), np.tile([[-1.0, 0.3, 0.2]], (100, 1))),
    }
    for name, (p, w) in cases.items():
        reorder(False)
        off = csm.visible(two_bodies, p, w)
        reorder(True)
        on = csm.visible(two_bodies, p, w)
        assert reorder.calls == ([] if len(p) == 0 else [len(p)]), name
        assert on.shape == off.shape == (len(p),) and on.dtype == np.bool_, name
        assert digest(on) == digest(off), name
        if name == "same direction":
            assert 0.02 < off.mean() < 0.98

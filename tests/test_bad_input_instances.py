"""Scenes of many instances at the extremes: the grid over the casters' spheres
(pyshadow.visibility.grid) where the queries lie far from the casters."""
import numpy as np

import pyshadow
from pyshadow.scene_arrays import scene_arrays
from pyshadow.visibility import csm as csm_backend, grid


def _lattice(k, rng):
    x, z = np.meshgrid(np.arange(k) - k / 2, np.arange(k) - k / 2)
    n = k * k
    return np.c_[x.ravel() + rng.uniform(-0.2, 0.2, n), np.full(n, 0.3), z.ravel() + rng.uniform(-0.2, 0.2, n)]


def _spot_lattice(k, rng):
    """A ground-plane scene of k x k small Spots (bounding radius 0.3) on the jittered 1 m lattice."""
    spot = pyshadow.data.mesh("spot")
    a = pyshadow.CoherentShadowMap.build(spot, pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)
    s = pyshadow.Scene(ground=0.0)
    sc = 0.3 / a.radius
    for p in _lattice(k, rng):
        T = np.eye(4)
        T[:3, :3] *= sc
        T[:3, 3] = p - sc * a.centre
        s.add(a, T, mesh=spot)
    return s


def test_grid_for_far_queries_lists_each_sphere_in_few_cells():
    """Before: the cells were sized by the casters alone, so the margin far queries grow every sphere
    by (about 1e-5 of their distance: 32 m at 1e6 m) made each sphere of a 1 m lattice fill hundreds
    of cells: 50 x 50 casters were listed 294,000 times (118 a caster; 10,000 casters: a grid of
    57 MB, 0.7 GB while building it and 5 s for 16 rays from 1e6 m). Now a cell is at least twice
    the margin wide, a grown sphere meets at most 4 cells an axis, and every cell it meets lists it."""
    rng = np.random.default_rng(0)
    c = _lattice(50, rng)
    n = len(c)
    r = np.full(n, 0.3)
    for margin in (4.0, 32.0):
        header, cells, items = grid.instance_grid(c, r, margin, balanced_only=False)
        assert len(items) <= 64 * n
        o, h, dims = header["origin"][0].astype(float), header["cell"][0].astype(float), header["dims"][0]
        owner = np.repeat(np.arange(int(np.prod(dims))), np.diff(cells.astype(np.int64)))
        ijk = np.stack(np.unravel_index(owner, dims), axis=1)
        inst = items["instance"][: int(cells[-1])]
        ids = np.stack(np.meshgrid(*[np.arange(d) for d in dims], indexing="ij"), -1).reshape(-1, 3)
        for j in rng.choice(n, 25, replace=False):
            gap = np.maximum(np.maximum(o + ids * h - c[j], c[j] - (o + (ids + 1) * h)), 0.0)
            d = np.sqrt((gap * gap).sum(axis=1))
            need = set(np.flatnonzero(d < (r[j] + margin) * (1 - 1e-9)).tolist())
            got = set(np.ravel_multi_index(tuple(ijk[inst == j].T), dims).tolist())
            assert need <= got and len(got) <= 64


def test_far_queries_keep_a_small_grid_and_answer_as_every_caster(monkeypatch):
    """Before: rays from 1e6 m away among 400 casters on a 1 m lattice kept a grid of 0.53 MB with
    the scene for each far anchor (7 x 6 x 7 cells, every sphere grown by a 32 m margin in most of
    them), 18 times the grid of the queries near the casters; now 0.13 MB (3 x 3 x 3 cells). The
    answers, by the grid and by every caster, agreed before and still do."""
    rng = np.random.default_rng(1)
    s = _spot_lattice(20, rng)
    assert csm_backend.instance_accel(s) == "grid"
    C = scene_arrays(s)["world_centre"]
    m = 64
    P = np.c_[np.full(m, 1e6), rng.uniform(0.0, 0.6, m), rng.uniform(-1e3, 1e3, m)]
    D = C[rng.integers(0, len(C), m)] - P
    D[::4, 1] = 0.0
    by_grid = s.visible(P, D)
    held = scene_arrays(s)
    kept = [v[1].nbytes for d in (held, *held.get("far_anchors", {}).values()) for k, v in d.items()
            if isinstance(k, tuple) and k[0] == "instance_grid"]
    assert max(kept) <= 5 * 80 * len(C)            # at most 5 packets (80 bytes) a caster
    monkeypatch.setattr(csm_backend, "BVH_MIN_INSTANCES", 10 ** 9)
    np.testing.assert_array_equal(by_grid, s.visible(P, D))
    assert (~by_grid).sum() >= 16


def test_a_transform_edited_in_place_cannot_leave_the_scene_stale():
    """Before: ``scene.instances[i].transform`` was the scene's writeable copy. A caster moved by
    editing it in place (not by set_transform) after a query left the kept instance table and grid
    stale: a ray down onto its old place was still blocked, where a scene built with it moved was
    open. Now the copy is read-only (the edit raises) and set_transform moves it."""
    import pytest

    spot = pyshadow.data.mesh("spot")
    a = pyshadow.CoherentShadowMap.build(spot, pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)
    s = pyshadow.Scene()
    for i in range(20):
        T = np.eye(4)
        T[:3, 3] = [3.0 * (i % 5), 0.0, 3.0 * (i // 5)] - a.centre
        s.add(a, T, mesh=spot)
    p, d = np.array([[0.0, 2.0 * a.radius, 0.0]]), np.array([[0.0, -1.0, 0.0]])
    assert csm_backend.instance_accel(s) == "grid" and not s.visible(p, d)[0]
    with pytest.raises(ValueError, match="read-only"):
        s.instances[0].transform[1, 3] += 50.0
    with pytest.raises(ValueError, match="read-only"):
        s.instances[0].transform[:] = s.transform(1)
    assert not s.visible(p, d)[0]                           # unchanged, as the scene holds it
    T = s.transform(0)
    T[1, 3] += 50.0
    s.set_transform(0, T)
    assert s.visible(p, d)[0] and not s.instances[0].transform.flags.writeable


def test_tables_of_far_anchors_are_kept_for_the_last_few_only(monkeypatch):
    """Before: every anchor of far query points (one per region of about 128 m here) kept its instance
    table, grid and their device copies with the scene until it changed: 100 points scattered over
    +-1e5 m among 10,000 casters kept 809 MB. Now the scene's own anchor and the most recently used
    others up to FAR_BYTES (here set to two or three anchors' tables) are kept, and the answers are those
    of a scene that keeps nothing."""
    from pyshadow.visibility import held as held_mod

    rng = np.random.default_rng(2)
    s = _spot_lattice(6, rng)
    assert csm_backend.instance_accel(s) == "grid"
    m = 40
    P = np.c_[rng.uniform(-1e5, 1e5, m), rng.uniform(0.0, 0.6, m), rng.uniform(-1e5, 1e5, m)]
    C = scene_arrays(s)["world_centre"]
    D = C[rng.integers(0, len(C), m)] - P
    D[1::2, 1] += 5.0                                   # every other ray passes 5 m above its caster
    # a Spot 2 m beyond each point (behind its ray): the points lie within its reach only from an
    # anchor of their own (pyshadow.anchor_reach); far from every caster, they would keep the scene's
    inst = s.instances[0]
    for q in P:
        T = inst.transform.copy()
        T[[0, 2], 3] += q[[0, 2]] * (1.0 + 2.0 / np.hypot(q[0], q[2]))
        s.add(inst.csm, T, mesh=inst.mesh)
    near = np.c_[rng.uniform(-3, 3, 64), np.zeros(64), rng.uniform(-3, 3, 64)]
    up = np.tile([0.0, 1.0, 0.0], (64, 1))
    S = pyshadow.Sampling(8, seed=1)
    got = [s.visible(P[i:i + 1], D[i:i + 1])[0] for i in range(3)]
    far = scene_arrays(s)["far_anchors"]
    assert len(far) == 3                                 # three regions, each its anchor's tables
    budget = 2.5 * max(held_mod._bytes(t) for t in far.values())
    monkeypatch.setattr(held_mod, "FAR_BYTES", budget)   # two or three anchors' tables
    got += [s.visible(P[i:i + 1], D[i:i + 1])[0] for i in range(3, m)]
    got_ao = s.ambient_occlusion(near, up, sampling=S)
    last = next(reversed(far.values()))
    assert 2 <= len(far) <= 4 and held_mod._bytes(far) - held_mod._bytes(last) <= budget
    assert not any(isinstance(k, tuple) and k[0] == "instance_data" and k[1] != s.anchor().tobytes()
                   for k in scene_arrays(s))            # far anchors' tables only among the last few
    monkeypatch.setattr(held_mod, "FAR_BYTES", 0)        # keep only the last asked: every far query builds its own
    want = [s.visible(P[i:i + 1], D[i:i + 1])[0] for i in range(m)]
    assert got == want and len(scene_arrays(s)["far_anchors"]) == 1
    np.testing.assert_array_equal(got_ao, s.ambient_occlusion(near, up, sampling=S))
    assert sum(got) >= 8 and sum(got) <= m - 8

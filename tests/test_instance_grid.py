"""The uniform grid over the casters' bounding spheres (pyshadow.visibility.grid, INSTANCE_GRID
in kernels/batch.h and kernels/grid.h): its cells, when it declines, and answers bit-identical
to the instance tree and to visiting every caster."""
import numpy as np
import pytest
from test_instance_bvh import _answers, _scene

import pyshadow
from pyshadow.scene_arrays import scene_arrays
from pyshadow.visibility import csm as csm_backend, grid


@pytest.mark.parametrize("n, spread, margin", [(17, 1.0, 0.0), (400, 30.0, 1e-3), (2000, 1e4, 0.5)])
def test_grid_lists_every_sphere_in_every_cell_it_overlaps(n, spread, margin):
    rng = np.random.default_rng(n)
    c = rng.uniform(-spread, spread, (n, 3)) * [1.0, 0.05, 1.0]
    r = rng.uniform(0.2, 1.0, n) * spread / np.sqrt(n)
    r[:3] *= 30.0                                          # wider than a cell: asked of every ray
    header, cells, items = grid.instance_grid(c, r, margin)
    h, o, dims = header["cell"][0].astype(float), header["origin"][0].astype(float), header["dims"][0]
    ncells = int(np.prod(dims))
    assert len(cells) == ncells + 1 and cells[-1] + header["big"][0] == len(items)
    big = items["instance"][cells[-1]:]
    lo_s, hi_s = (c - r[:, None]).min(axis=0) - 2 * margin, (c + r[:, None]).max(axis=0) + 2 * margin
    target = grid._cell_size(lo_s, hi_s, r)                # the cells' edge before each axis is fitted
    assert sorted(big.tolist()) == np.flatnonzero(r > target).tolist()
    assert (h <= target * (1 + 1e-6)).all() and (dims * h >= (hi_s - o) * (1 - 1e-7)).all()
    assert (o <= (c - r[:, None]).min(axis=0)).all() and (o + dims * h >= (c + r[:, None]).max(axis=0)).all()
    listed = {}
    for k in range(ncells):
        for it in items[cells[k]:cells[k + 1]]:
            listed.setdefault(int(it["instance"]), set()).add(k)
            j = int(it["instance"])
            assert (it["centre"] == c[j].astype(np.float32)).all() and it["radius"] == np.float32(r[j])
    ids = np.stack(np.meshgrid(*[np.arange(d) for d in dims], indexing="ij"), -1).reshape(-1, 3)
    lo, hi = o + ids * h, o + (ids + 1) * h
    for j in np.flatnonzero(r <= target):
        # the cells whose box the sphere grown by the margin meets, and no others
        gap = np.maximum(np.maximum(lo - c[j], c[j] - hi), 0.0)
        d = np.sqrt((gap * gap).sum(axis=1))
        clipped = (c[j] + r[j] + margin > o + dims * h) | (c[j] - r[j] - margin < o)
        want = set(np.flatnonzero(d <= (r[j] + margin) * (1 + 1e-9)).tolist())
        if not clipped.any():
            assert listed[j] >= set(np.flatnonzero(d < (r[j] + margin) * (1 - 1e-9)).tolist())
        assert listed[j] <= want and len(listed[j]) <= 125     # at most 5 cells an axis (each over target / 2)


def _chain(packets, k):
    """Cell k's entries read as the kernel does: from packet k, following slot 3's links."""
    out, i = [], k
    while True:
        pk = packets[i]
        out += [(int(pk["instance"][q]), *(float(pk[f][q]) for f in ("cx", "cy", "cz", "radius")))
                for q in range(4) if pk["instance"][q] >= 0]
        link = int(pk["instance"][3])
        if link >= -1:
            assert (pk["instance"][:4][pk["instance"] < 0] == -1).all()
            return out
        assert (pk["instance"][:3] >= 0).all()           # a packet that goes on is full
        i = -2 - link


@pytest.mark.parametrize("n, spread, per_cell", [(17, 1.0, 0), (400, 30.0, 0), (300, 30.0, 12)])
def test_grid_packets_hold_each_cells_list_in_order(n, spread, per_cell):
    rng = np.random.default_rng(n)
    c = rng.uniform(-spread, spread, (n, 3)) * [1.0, 0.05, 1.0]
    if per_cell:                                           # clusters: lists of up to 60, chains of 20 packets
        c = np.repeat(c[: n // per_cell], per_cell, axis=0) + rng.normal(0, 0.01, (n // per_cell * per_cell, 3))
        n = len(c)
    r = rng.uniform(0.2, 1.0, n) * spread / np.sqrt(n)
    r[:3] *= 30.0                                          # the big casters
    header, cells, items = grid.instance_grid(c, r, balanced_only=False)
    dims = header["dims"][0]
    packets = grid.grid_packets(dims, cells, items)
    ncells = int(np.prod(dims))
    longest = 0
    for k in range(ncells):
        want = items[cells[k]:cells[k + 1]]
        got = _chain(packets, k)
        assert [g[0] for g in got] == want["instance"].tolist()
        np.testing.assert_array_equal(np.array([g[1:] for g in got]).reshape(-1, 4),
                                      np.c_[want["centre"], want["radius"]])
        longest = max(longest, len(want))
    big = items[cells[-1]:]
    nb = len(big)
    tail = packets[ncells:ncells + (nb + 3) // 4]["instance"].reshape(-1)
    assert tail[:nb].tolist() == big["instance"].tolist() and (tail[nb:] == -1).all()
    assert longest >= max(per_cell, 1)                    # chains of several packets where clustered
    links = packets["instance"][:, 3]
    assert ((links[links < -1] <= -2 - ncells)).all()     # links lead past the cells' own packets
    with pytest.raises(ValueError, match="lists for"):
        grid.grid_packets(dims + 1, cells, items)


def test_grid_long_cell_lists_answer_as_every_caster(monkeypatch):
    """Casters in tight clusters: cells list up to 24 spheres (chains of packets); rays from one
    point (the lanes share a cell: one sphere at a time against the lane vector) and from
    scattered points (each lane its own cell) answer as every caster does."""
    spot = pyshadow.data.mesh("spot")
    a = pyshadow.CoherentShadowMap.build(spot, pyshadow.ViewSet.zigzag(8, 16), resolution=32, progress=False)
    rng = np.random.default_rng(17)
    s = pyshadow.Scene(ground=0.0)
    for i in range(48):
        T = np.eye(4)
        T[:3, :3] *= 0.25 / a.radius
        T[:3, 3] = [3.0 * (i % 4) - 4.5, 0.3 + rng.uniform(0, 0.1), rng.uniform(-0.15, 0.15)] - a.centre * 0.25 / a.radius
        s.add(a, T, mesh=spot)
    rows, _, _ = csm_backend._instance_data(s, s.anchor(), "nearest")
    header, cells, items = grid.instance_grid(rows["centre"], rows["radius"])
    assert np.diff(cells).max() > 8 and csm_backend.instance_accel(s) == "grid"
    m = 3000
    pts = np.c_[rng.uniform(-6, 6, m // 16), np.zeros(m // 16), rng.uniform(-1, 1, m // 16)]
    P = np.concatenate([np.repeat(pts, 16, axis=0), np.c_[rng.uniform(-6, 6, m), rng.uniform(0, 0.8, m),
                                                           rng.uniform(-1, 1, m)]])
    D = rng.normal(size=(len(P), 3))
    D[:, 1] = np.abs(D[:, 1])
    N = np.tile([0.0, 1.0, 0.0], (len(pts), 1))
    by_grid = [s.visible(P, D, lookup=lk) for lk in ("nearest", "vote")]
    by_grid.append(s.ambient_occlusion(pts, N, sampling=pyshadow.Sampling(32)))
    monkeypatch.setattr(csm_backend, "BVH_MIN_INSTANCES", 10 ** 9)
    every = [s.visible(P, D, lookup=lk) for lk in ("nearest", "vote")]
    every.append(s.ambient_occlusion(pts, N, sampling=pyshadow.Sampling(32)))
    for x, y in zip(by_grid, every):
        np.testing.assert_array_equal(x, y)
    assert (~by_grid[0]).sum() >= 100 and by_grid[0].sum() >= 100
    assert 0.02 < 1 - by_grid[2].mean() < 0.9                # the clusters darken the points' AO


def test_grid_declines_where_it_would_be_unbalanced():
    c = np.zeros((200, 3))
    assert grid.instance_grid(c, np.full(200, 0.5)) is None                    # 200 in one cell
    assert grid.instance_grid(c, np.full(200, 0.5), balanced_only=False) is not None
    rng = np.random.default_rng(0)
    c = rng.uniform(-50, 50, (300, 3))
    r = np.full(300, 0.2)
    r[:grid.MAX_BIG + 1] = 40.0                                                # too many wide casters
    assert grid.instance_grid(c, r) is None
    r[grid.MAX_BIG:] = 0.2
    assert grid.instance_grid(c, r)[0]["big"][0] == grid.MAX_BIG


def test_grid_margin_is_a_power_of_two_above_the_rounding_bound():
    for pe, be in [(1.0, 2.0), (5e3, 30.0), (1e-3, 1e-3)]:
        m = grid.grid_margin(pe, be)
        assert 1e-5 * (pe + be) <= m < 2e-5 * (pe + be) and np.log2(m) == np.round(np.log2(m))


def _rays(s, k, rng, m=4000):
    P = np.c_[rng.uniform(-k / 2, k / 2, m), rng.uniform(0.0, 0.8, m), rng.uniform(-k / 2, k / 2, m)]
    D = rng.normal(size=(m, 3))
    D[::5, rng.integers(0, 3)] = 0.0                      # rays parallel to the cells' faces
    D[::7, :2] = 0.0
    D[::7, 2] = 1.0
    n = len(s.instances)
    P[::11] = scene_arrays(s)["world_centre"][rng.integers(0, n, len(P[::11]))] + [0.0, 0.0, 3.0]
    P[::13, 0] = 5e3                                       # far away: the margin grows with it
    D[::13] = [-1.0, 0.0, 0.0]
    # rays on the cells' faces, along them: the grid's origin and edge, in world units
    rows, _, _ = csm_backend._instance_data(s, s.anchor(), "nearest")
    header, _, _ = grid.instance_grid(rows["centre"], rows["radius"])
    o = header["origin"][0].astype(float) + s.anchor()
    h = float(header["cell"][0][0])
    sel = np.arange(3, m, 17)
    P[sel, 0] = o[0] + h * rng.integers(0, header["dims"][0][0], len(sel))
    D[sel] = [0.0, 0.1, 1.0]
    N = rng.normal(size=(m, 3))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    return P, D, N, rng.integers(-1, n, m)


def test_grid_answers_bit_identical_to_the_tree_and_to_every_caster(monkeypatch):
    rng = np.random.default_rng(3)
    s, k = _scene(60, rng)
    assert csm_backend.instance_accel(s) == "grid"
    P, D, N, ids = _rays(s, k, rng)
    by_grid = _answers(s, P, D, N, ids)
    monkeypatch.setattr(csm_backend, "USE_GRID", False)
    assert csm_backend.instance_accel(s) == "tree"
    by_tree = _answers(s, P, D, N, ids)
    monkeypatch.setattr(csm_backend, "BVH_MIN_INSTANCES", 10 ** 9)
    assert csm_backend.instance_accel(s) == "all"
    every = _answers(s, P, D, N, ids)
    for a, b, c in zip(by_grid, by_tree, every):
        np.testing.assert_array_equal(a, c)
        np.testing.assert_array_equal(b, c)
    assert 0.05 < by_grid[0].mean() < 0.95 and 0.05 < by_grid[2].mean() < 0.95   # both outcomes occur


def test_grid_with_a_wide_caster_answers_as_every_caster(monkeypatch):
    """One body far wider than the cells (asked of every ray, not listed in cells) among small ones."""
    rng = np.random.default_rng(11)
    s, k = _scene(40, rng)
    big = pyshadow.CoherentShadowMap.build(pyshadow.data.mesh("spot"), pyshadow.ViewSet.zigzag(8, 16),
                                           resolution=32, progress=False)
    T = np.eye(4)
    T[:3, :3] *= 4.0
    T[:3, 3] = [0.0, -3.0, 0.0]
    s.add(big, T, mesh=pyshadow.data.mesh("spot"))
    rows, _, _ = csm_backend._instance_data(s, s.anchor(), "nearest")
    assert grid.instance_grid(rows["centre"], rows["radius"])[0]["big"][0] == 1
    assert csm_backend.instance_accel(s) == "grid"
    P, D, N, ids = _rays(s, k, rng, 2500)
    by_grid = _answers(s, P, D, N, ids)
    monkeypatch.setattr(csm_backend, "BVH_MIN_INSTANCES", 10 ** 9)
    every = _answers(s, P, D, N, ids)
    for a, b in zip(by_grid, every):
        np.testing.assert_array_equal(a, b)
    assert (~by_grid[0]).sum() >= 30 and by_grid[0].sum() >= 30        # casters block some, not all


def test_scene_of_co_located_casters_takes_the_tree():
    spot = pyshadow.data.mesh("spot")
    a = pyshadow.CoherentShadowMap.build(spot, pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)
    s = pyshadow.Scene(ground=0.0)
    for i in range(grid.MAX_CELL + 1):
        s.add(a, np.eye(4), mesh=spot)
    assert csm_backend.instance_accel(s) == "tree"
    assert csm_backend.CSMVisibility().query_defines(s)["INSTANCE_BVH"] == 1
    s2 = pyshadow.Scene(ground=0.0)
    s2.add(a, np.eye(4), mesh=spot)
    assert csm_backend.instance_accel(s2) == "all"
    d = csm_backend.CSMVisibility().query_defines(s2)
    assert (d["INSTANCE_BVH"], d["INSTANCE_GRID"]) == (0, 0)


def test_grid_rays_almost_parallel_to_a_face_they_lie_on(monkeypatch):
    """A direction component so small that 1 / w overflows float32, from a point on a cell face:
    the face's t would be 0 x inf, a NaN; the walk treats the axis as parallel and answers as
    every caster does."""
    rng = np.random.default_rng(13)
    s, k = _scene(40, rng)
    rows, _, _ = csm_backend._instance_data(s, s.anchor(), "nearest")
    header, _, _ = grid.instance_grid(rows["centre"], rows["radius"])
    o = header["origin"][0].astype(float) + s.anchor()
    h = float(header["cell"][0][0])
    m = 1500
    P = np.c_[rng.uniform(-k / 2, k / 2, m), rng.uniform(0.0, 0.8, m), rng.uniform(-k / 2, k / 2, m)]
    P[:, 0] = o[0] + h * rng.integers(0, header["dims"][0][0], m)
    D = np.c_[np.where(rng.random(m) < 0.5, -1e-39, 1e-39), rng.uniform(0.0, 0.15, m), rng.normal(size=m)]
    D /= np.linalg.norm(D, axis=1, keepdims=True)
    assert csm_backend.instance_accel(s) == "grid"
    by_grid = [s.visible(P, D, lookup=lk) for lk in ("nearest", "vote")]
    monkeypatch.setattr(csm_backend, "BVH_MIN_INSTANCES", 10 ** 9)
    every = [s.visible(P, D, lookup=lk) for lk in ("nearest", "vote")]
    for a, b in zip(by_grid, every):
        np.testing.assert_array_equal(a, b)
    assert (~by_grid[0]).sum() >= 30 and by_grid[0].sum() >= 30        # casters block some, not all


def test_kept_device_tables_follow_set_transform():
    """A scene's instance table, grid and anchor are copied to the device once and kept while the
    scene is unchanged; a moved caster gives answers bit-identical to a scene built with it there."""
    rng = np.random.default_rng(11)
    s, k = _scene(60, rng)
    assert csm_backend.instance_accel(s) == "grid"
    P, D, N, ids = _rays(s, k, rng, m=1500)
    i = s.casters[3]
    c, r = s.instances[i].world_sphere()
    ring = np.linspace(0.0, 2.0 * np.pi, 64, endpoint=False)      # ground points around caster i
    G = c + 1.1 * r * np.c_[np.cos(ring), np.zeros(64), np.sin(ring)]
    G[:, 1] = 1e-3
    up = np.tile([0.0, 1.0, 0.0], (64, 1))

    def answers(scene):
        return [*_answers(scene, P, D, N, ids), scene.ambient_occlusion(G, up, sampling=pyshadow.Sampling(64))]

    before = answers(s)
    fan = c + [100.0, 0.0, 0.0] + 0.3 * r * np.c_[np.zeros(9), np.linspace(-1.0, 1.0, 9), np.zeros(9)]
    open_before = s.visible(fan + [0.0, 0.0, 1.2 * r], np.tile([0.0, 0.0, -1.0], (9, 1)))
    held = scene_arrays(s)
    rows = csm_backend._instance_data(s, s.anchor(), "nearest")[0]
    buf = csm_backend._on_device(held, rows)
    assert csm_backend._on_device(held, rows) is buf          # kept: no copy per query
    for a, b in zip(answers(s), before):
        np.testing.assert_array_equal(a, b)
    T = s.transform(i)
    T[:3, 3] += [100.0, 0.0, 0.0]                             # out of the grid's box: a new grid
    s.set_transform(i, T)
    assert scene_arrays(s) is not held                        # the kept copies went with the old arrays
    moved = answers(s)
    assert (moved[-1] > before[-1]).mean() > 0.5              # the ground around its old place opens up
    # rays through its new place, from beside it: nothing was there; now most meet it
    assert (~s.visible(fan + [0.0, 0.0, 1.2 * r], np.tile([0.0, 0.0, -1.0], (9, 1)))).mean() >= 0.5
    assert open_before.all()
    fresh = pyshadow.Scene(ground=s.ground)
    for inst in s.instances:
        if inst.casts:
            fresh.add(inst.csm, inst.transform, mesh=inst.mesh)
        else:
            fresh.add(inst.mesh, inst.transform, casts=False)
    np.testing.assert_array_equal(s.anchor(), fresh.anchor())
    for a, b in zip(moved, answers(fresh)):
        np.testing.assert_array_equal(a, b)

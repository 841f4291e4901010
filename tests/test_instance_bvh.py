"""The tree over the casters' bounding spheres (pyshadow.visibility.bvh, INSTANCE_BVH in
kernels/batch.h): its structure, answers bit-identical to visiting every caster, and the
stacked instance arrays it is built from (pyshadow.scene_arrays)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import pyshadow
from pyshadow.scene_arrays import scene_arrays
from pyshadow.visibility import bvh, csm as csm_backend


@pytest.mark.parametrize("n", [1, 4, 5, 17, 1000])
def test_tree_covers_every_sphere_once(n):
    rng = np.random.default_rng(n)
    c = rng.normal(size=(n, 3)) * rng.uniform(1e-3, 1e4)
    r = rng.uniform(0.01, 1.0, n) * np.abs(c).max()
    nodes, order, depth = bvh.instance_bvh(c, r)
    assert sorted(order.tolist()) == list(range(n))
    leaves = np.flatnonzero(nodes["b"] < 0)
    m = -(-n // bvh.LEAF)
    assert len(leaves) == m and depth == 1 + int(np.ceil(np.log2(m)))
    for k in leaves:                                     # a leaf's box holds its spheres
        inst = order[nodes["a"][k]:nodes["a"][k] - nodes["b"][k]]
        assert (nodes["lo"][k] <= c[inst] - r[inst, None]).all() and (nodes["hi"][k] >= c[inst] + r[inst, None]).all()
    seen = np.zeros(len(nodes), int)
    for k in np.flatnonzero(nodes["b"] >= 0):            # an inner box holds its children's
        for ch in {int(nodes["a"][k]), int(nodes["b"][k])}:
            seen[ch] += 1
            assert ch > k
            assert (nodes["lo"][k] <= nodes["lo"][ch]).all() and (nodes["hi"][k] >= nodes["hi"][ch]).all()
    assert seen[0] == 0 and (seen[1:] == 1).all()        # a tree: every node but the root has one parent


def _scene(n, rng, ground=0.0):
    spot = pyshadow.data.mesh("spot")
    fan = pyshadow.data.mesh("fandisk")
    a = pyshadow.CoherentShadowMap.build(spot, pyshadow.ViewSet.zigzag(8, 16), resolution=32, progress=False)
    b = pyshadow.CoherentShadowMap.build(fan, pyshadow.ViewSet.zigzag(8, 16), resolution=32, progress=False)
    s = pyshadow.Scene(ground=ground)
    k = int(np.ceil(np.sqrt(n)))
    for i in range(n):
        T = np.eye(4)
        T[:3, :3] = Rotation.random(random_state=i).as_matrix() * rng.uniform(0.1, 0.6)
        T[:3, 3] = [i % k - k / 2, rng.uniform(0.0, 0.8), i // k - k / 2]
        if i % 9 == 4:
            s.add(fan, T, casts=False)
        else:
            s.add(a if i % 2 else b, T, mesh=spot if i % 2 else fan)
    return s, k


def _answers(s, P, D, N, ids):
    out = []
    for lookup in ("nearest", "vote"):
        out.append(s.visible(P, D, lookup=lookup, surface_ids=ids))
        out.append(s.visible(P, D, lookup=lookup, surface_ids=ids, normals=N))
        ao, bent = s.ambient_occlusion(P[:400], N[:400], sampling=pyshadow.Sampling(24), lookup=lookup,
                                       return_bent_normals=True, surface_ids=ids[:400])
        out += [ao, bent]
    return out


def test_tree_answers_bit_identical_to_visiting_every_caster(monkeypatch):
    rng = np.random.default_rng(3)
    s, k = _scene(60, rng)
    m = 4000
    P = np.c_[rng.uniform(-k / 2, k / 2, m), rng.uniform(0.0, 0.8, m), rng.uniform(-k / 2, k / 2, m)]
    D = rng.normal(size=(m, 3))
    D[::5, rng.integers(0, 3)] = 0.0                      # rays parallel to the boxes' faces
    D[::7, :2] = 0.0
    D[::7, 2] = 1.0
    P[::11] = scene_arrays(s)["world_centre"][rng.integers(0, 60, len(P[::11]))] + [0.0, 0.0, 3.0]
    P[::13, 0] = 5e3                                       # far from every box: the margin grows with it
    D[::13] = [-1.0, 0.0, 0.0]
    N = rng.normal(size=(m, 3))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    ids = rng.integers(-1, 60, m)
    monkeypatch.setattr(csm_backend, "USE_GRID", False)                  # the tree, not the grid
    tree = _answers(s, P, D, N, ids)
    monkeypatch.setattr(csm_backend, "BVH_MIN_INSTANCES", 10 ** 9)       # every caster, one after another
    flat = _answers(s, P, D, N, ids)
    for a, b in zip(tree, flat):
        np.testing.assert_array_equal(a, b)
    assert 0.05 < tree[0].mean() < 0.95 and 0.05 < tree[2].mean() < 0.95   # both outcomes occur


@pytest.mark.parametrize("use_grid", [False, True])
def test_tree_scene_agrees_with_the_numpy_mirror(use_grid, monkeypatch):
    from pyshadow.visibility.mirror import visible_reference

    monkeypatch.setattr(csm_backend, "USE_GRID", use_grid)

    rng = np.random.default_rng(5)
    s, k = _scene(24, rng, ground=None)
    m = 600
    P = np.c_[rng.uniform(-k / 2, k / 2, m), rng.uniform(0.0, 0.8, m), rng.uniform(-k / 2, k / 2, m)]
    D = rng.normal(size=(m, 3))
    assert len(s.casters) >= bvh.BVH_MIN_INSTANCES
    assert csm_backend.instance_accel(s) == ("grid" if use_grid else "tree")
    got = s.visible(P, D)
    want = visible_reference(s, P, D)
    assert (got == want).mean() >= 0.995                  # float32 kernel vs float64 mirror: ties at texel edges
    assert 0.1 < got.mean() < 0.9


def test_scene_arrays_follow_set_transform():
    rng = np.random.default_rng(7)
    s, _ = _scene(20, rng)
    a = scene_arrays(s)
    assert scene_arrays(s) is a                           # kept while nothing changes
    for i in (0, 7, 19):
        c, r = s.instances[i].world_sphere()
        np.testing.assert_array_equal(a["world_centre"][i], c)
        assert a["world_radius"][i] == r
    with pytest.raises(ValueError):
        a["transform"][0, 0, 0] = 2.0                     # read-only
    i = s.casters[0]
    T = s.transform(i)
    T[:3, 3] += [100.0, 0.0, 0.0]
    centre = a["world_centre"][i].copy()
    s.set_transform(i, T)
    b = scene_arrays(s)
    np.testing.assert_array_equal(b["world_centre"][i], centre + [100.0, 0.0, 0.0])
    # a ray from beside the moved instance now meets it; it met nothing there before
    p = b["world_centre"][i] + [0.0, 0.0, 1.2 * b["world_radius"][i]]
    assert not s.visible(p[None], np.array([[0.0, 0.0, -1.0]]))[0]
    T[:3, 3] -= [100.0, 0.0, 0.0]
    T[:3, 3] += [0.0, 50.0, 0.0]
    s.set_transform(i, T)
    assert s.visible(p[None], np.array([[0.0, 0.0, -1.0]]))[0]
    T[0, 0] = 7.0                                         # the scene keeps its own copy
    assert s.transform(i)[0, 0] != 7.0

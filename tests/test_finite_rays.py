"""Finite shadow rays (pyshadow.visibility.finite): visible(..., max_distance=...) on every backend,
the straddling rays a CSM cannot answer (both sides of the boundary), and the ground plane."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree, visibility
from pyshadow.visibility import visible_reference
from pyshadow.visibility.csm import CSMVisibility
from pyshadow.visibility.finite import straddling, unit_directions

from conftest import surface_queries


def light_rays(scene, light, rng, n=1500):
    """Points on both bodies facing ``light``, their unit directions and distances to it, surface ids."""
    ps, ids, ns = [], [], []
    for i in (0, 1):
        inst = scene.instances[i]
        local, face = trimesh.sample.sample_surface(inst.mesh, n, seed=int(rng.integers(1 << 30)))
        T = inst.transform
        ps.append(local @ T[:3, :3].T + T[:3, 3])
        ns.append(inst.mesh.face_normals[face] @ inst.rotation.T)
        ids.append(np.full(n, i))
    p, n_, ids = np.concatenate(ps), np.concatenate(ns), np.concatenate(ids)
    d = light - p
    dist = np.linalg.norm(d, axis=1)
    keep = np.einsum("ij,ij->i", n_, d / dist[:, None]) > 0.1
    return p[keep], d[keep] / dist[keep, None], dist[keep], ids[keep], n_[keep]


def spheres(scene):
    return [scene.instances[i].world_sphere() for i in scene.casters]


def test_validation_launches_nothing(small_scene, no_launch):
    p, d = np.zeros((2, 3)) + [3.0, 0.5, 0.0], np.tile([0.0, 1.0, 0.0], (2, 1))
    for bad in (0.0, -1.0, np.nan, -np.inf, [1.0, 0.0], [1.0, np.nan], np.ones(3), np.ones((2, 1))):
        for backend in ("csm", "numpy", "embree"):
            with pytest.raises(ValueError, match="max_distance"):
                visibility.visible(small_scene, p, d, backend=backend, max_distance=bad)
    with pytest.raises(TypeError, match="max_distance"):
        small_scene.visible(p, d, max_distance="far")
    with pytest.raises(ValueError, match="straddle"):
        small_scene.visible(p, d, max_distance=1.0, straddle="guess")


def test_unbounded_lengths_are_todays_answers(two_bodies, rng):
    """inf (per ray or for all) answers as max_distance=None; the default compiles FINITE_RAYS=0."""
    p, d = surface_queries(two_bodies, 0, 500, 8, rng)
    ref = two_bodies.visible(p, d)
    assert 0.2 < ref.mean() < 0.95
    assert (two_bodies.visible(p, d, max_distance=np.inf) == ref).all()
    assert (two_bodies.visible(p, d, lookup="vote", max_distance=np.full(len(p), np.inf))
            == two_bodies.visible(p, d, lookup="vote")).all()
    assert CSMVisibility().query_defines(two_bodies)["FINITE_RAYS"] == 0
    assert (visible_reference(two_bodies, p[:300], d[:300], max_distance=1e300)
            == visible_reference(two_bodies, p[:300], d[:300])).all()


@pytest.mark.parametrize("lookup", ["nearest", "vote"])
def test_kernel_matches_mirror_and_embree_on_point_light_rays(two_bodies, rng, lookup):
    """A point light above and between the bodies, outside both spheres: kernel == float64 mirror
    (float32 ties aside), and close to Embree on the identical segments."""
    light = np.array([0.8, 2.6, 1.5])
    for c, r in spheres(two_bodies):
        assert np.linalg.norm(light - c) > r * 1.01
    p, w, dist, ids, n = light_rays(two_bodies, light, rng)
    ours = two_bodies.visible(p, w, lookup=lookup, surface_ids=ids, normals=n, max_distance=dist)
    ref = visible_reference(two_bodies, p, w, lookup=lookup, surface_ids=ids, normals=n, max_distance=dist)
    truth = embree.visible(two_bodies, p, w, max_distance=dist)
    assert 0.05 < 1 - truth.mean() < 0.9
    assert (ours == ref).mean() > 0.999
    assert (ours == truth).mean() > 0.95         # coarse maps: ~0.97-0.98 measured
    # the kernel's own per-ray lengths: half of them unbounded changes only those rows' answers
    mixed = np.where(np.arange(len(p)) % 2 == 0, dist, np.inf)
    m = two_bodies.visible(p, w, lookup=lookup, surface_ids=ids, normals=n, max_distance=mixed)
    inf = two_bodies.visible(p, w, lookup=lookup, surface_ids=ids, normals=n)
    assert (m[::2] == ours[::2]).all() and (m[1::2] == inf[1::2]).all()


def test_caster_beyond_the_light_is_culled(two_bodies):
    """Points above a light that hangs above the fandisk, rays through the light at the fandisk
    (no ground plane): the infinite rays hit it, the segments to the light do not."""
    scene = pyshadow.Scene()
    for i in two_bodies.casters:
        scene.add(two_bodies.instances[i].csm, two_bodies.instances[i].transform, mesh=two_bodies.instances[i].mesh)
    (cb, rb), (cf, rf) = spheres(scene)
    light = cf + [0.0, 1.6 * rf, 0.0]
    assert np.linalg.norm(light - cb) > rb
    rng = np.random.default_rng(3)
    w = unit_directions(cf + rng.normal(scale=0.15 * rf, size=(400, 3)) - light)
    p = light - 0.5 * rf * w
    dist = np.full(len(p), 0.5 * rf)
    occ_inf = ~embree.visible(scene, p, w)
    assert occ_inf.mean() > 0.5
    for backend in ("csm", "csm-vote", "numpy", "embree"):
        assert (~visibility.visible(scene, p, w, backend=backend))[occ_inf].mean() > 0.95, backend
        assert visibility.visible(scene, p, w, backend=backend, max_distance=dist).all(), backend


def _towards_centre(scene, k, t_end, start=4.0):
    """A ray from ``start`` radii beside sphere k (above the ground), aimed at its centre;
    returns (p, w, length) with the end at ``t_end`` (distance along the ray)."""
    c, r = spheres(scene)[k]
    w = unit_directions(np.array([[-1.0, -0.05, 0.2]]))[0]
    p = c - start * r * w
    return p[None], w[None], np.array([t_end])


@pytest.mark.parametrize("backend", ["csm", "csm-vote", "numpy", "numpy-vote"])
def test_both_sides_of_the_sphere_boundary(two_bodies, backend):
    """Ends just before the sphere (culled: visible), just inside its near side or its far side
    (refused, naming the instance), just past it (answered as the infinite ray: occluded)."""
    for k in (0, 1):
        c, r = spheres(two_bodies)[k]
        R = r * (1 + 1e-6)                  # the kernels' radius
        D = 4.0 * r                         # distance to the centre
        cases = {D - R * (1 + 1e-7): True, D + R * (1 + 1e-7): False}
        for t, expect in cases.items():
            p, w, t_ = _towards_centre(two_bodies, k, t)
            assert visibility.visible(two_bodies, p, w, backend=backend)[0] == False  # noqa: E712
            assert visibility.visible(two_bodies, p, w, backend=backend, max_distance=t_)[0] == expect, t
            assert embree.visible(two_bodies, p, w, max_distance=t_)[0] == expect
        for t in (D - R * (1 - 1e-7), D, D + R * (1 - 1e-7)):
            p, w, t_ = _towards_centre(two_bodies, k, t)
            with pytest.raises(ValueError, match=f"caster instance {k} .*straddle='embree'"):
                visibility.visible(two_bodies, p, w, backend=backend, max_distance=t_)


def test_straddle_embree_answers_only_the_straddling_rays(two_bodies, rng, monkeypatch):
    light = spheres(two_bodies)[0][0] + [0.0, 0.1, 0.0]       # inside the bunny's sphere
    p, w, dist, ids, n = light_rays(two_bodies, light, rng, 600)
    rows, inst = straddling(two_bodies, p, w, dist)
    assert len(rows) == len(p) and (inst == 0).all()
    p2, w2, t2 = _towards_centre(two_bodies, 1, 1.0)          # ends before the fandisk: not straddling
    P, W, T = np.concatenate([p, p2]), np.concatenate([w, w2]), np.concatenate([dist, t2])
    calls = []
    real = embree.visible
    monkeypatch.setattr(embree, "visible", lambda s, a, b, max_distance=None: calls.append(len(a)) or
                        real(s, a, b, max_distance=max_distance))
    v = two_bodies.visible(P, W, max_distance=T, straddle="embree")
    assert calls == [len(p)]
    assert (v[:-1] == real(two_bodies, p, w, max_distance=dist)).all() and v[-1]


def test_straddle_embree_needs_the_meshes(two_bodies):
    scene = pyshadow.Scene(ground=0.0)
    for i in two_bodies.casters:
        scene.add(two_bodies.instances[i].csm, two_bodies.instances[i].transform)
    p, w, t = _towards_centre(scene, 0, 4.0 * spheres(scene)[0][1])
    with pytest.raises(ValueError, match="needs every caster's mesh"):
        scene.visible(p, w, max_distance=t, straddle="embree")


@pytest.mark.parametrize("backend", ["csm", "numpy", "embree"])
def test_ground_blocks_only_segments_that_cross_it(backend):
    """A box on the ground, rays far from it: from above the plane down to an end below it
    (occluded), down to an end still above it (open), from below up to an end below (open)."""
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)))
    w = unit_directions(np.array([[0.3, -1.0, 0.1]] * 3 + [[0.3, 1.0, 0.1]] * 2))
    p = np.array([[20.0, 1.0, 0.0]] * 3 + [[20.0, -1.0, 0.0]] * 2)
    t = np.array([1.0 / -w[0, 1] * 1.01, 1.0 / -w[0, 1] * 0.99, np.inf, 0.99 / w[3, 1], 1.01 / w[3, 1]])
    v = visibility.visible(scene, p, w, backend=backend, max_distance=t)
    assert v.tolist() == [False, True, False, True, False]


def test_instance_tree_with_finite_rays(monkeypatch):
    """Many casters (the instance grid, and the tree, whose boxes are skipped where they begin
    beyond a ray's end): the same answers bit for bit as visiting every caster, and as the
    float64 mirror up to ties."""
    from test_instance_bvh import _scene

    from pyshadow.visibility import csm as csm_backend

    rng = np.random.default_rng(7)
    s, k = _scene(40, rng)
    m = 3000
    P = np.c_[rng.uniform(-k / 2, k / 2, m), rng.uniform(0.0, 0.8, m), rng.uniform(-k / 2, k / 2, m)]
    D = unit_directions(rng.normal(size=(m, 3)))
    D[:, 1] = np.abs(D[:, 1])
    T = rng.uniform(0.05, 3.0, m)
    T[::4] = np.inf
    rows, _ = straddling(s, P, D, T)
    keep = np.setdiff1d(np.arange(m), rows)
    assert len(keep) > m // 3
    P, D, T = P[keep], D[keep], T[keep]
    assert csm_backend.instance_accel(s) == "grid"
    by_grid = [s.visible(P, D, lookup=lk, max_distance=T) for lk in ("nearest", "vote")]
    monkeypatch.setattr(csm_backend, "USE_GRID", False)
    tree = [s.visible(P, D, lookup=lk, max_distance=T) for lk in ("nearest", "vote")]
    monkeypatch.setattr(csm_backend, "BVH_MIN_INSTANCES", 10 ** 9)
    flat = [s.visible(P, D, lookup=lk, max_distance=T) for lk in ("nearest", "vote")]
    for a, b, c in zip(by_grid, tree, flat):
        np.testing.assert_array_equal(a, c)
        np.testing.assert_array_equal(b, c)
    assert (tree[0] == visible_reference(s, P, D, max_distance=T)).mean() >= 0.995
    inf = s.visible(P, D)
    assert 0.05 < tree[0].mean() < 0.98 and (tree[0] >= inf).all() and (tree[0] > inf).any()


def test_finite_rays_read_every_input_form_alike(two_bodies, rng, monkeypatch):
    """float32 rows, directions of any scale, chunked launches and a float-only device: the same
    finite answers (the lengths travel with their rows)."""
    from pyshadow._cl import launch

    light = np.array([0.8, 2.6, 1.5])
    p, w, dist, ids, n = light_rays(two_bodies, light, rng, 800)
    base = two_bodies.visible(p, w, surface_ids=ids, max_distance=dist)
    assert 0.03 < 1 - base.mean() < 0.9
    for name, (pp, ww) in {"float32 points": (p.astype(np.float32), w), "huge directions": (p, w * 2.0 ** 700),
                           "float32 directions": (p, (w * 2.0 ** -70).astype(np.float32))}.items():
        assert (two_bodies.visible(pp, ww, surface_ids=ids, max_distance=dist) == base).mean() > 0.999, name
    with launch.override(query_chunk=300):
        assert (two_bodies.visible(p, w, surface_ids=ids, max_distance=dist) == base).all()
    monkeypatch.setattr(pyshadow.visibility.csm._cl, "has_fp64", lambda: False)
    assert (two_bodies.visible(p, w, surface_ids=ids, max_distance=dist) == base).all()


def test_straddle_refusal_launches_nothing(two_bodies, no_launch):
    p, w, t = _towards_centre(two_bodies, 1, 4.0 * spheres(two_bodies)[1][1])
    for lookup in ("nearest", "vote"):
        with pytest.raises(ValueError, match="caster instance 1"):
            two_bodies.visible(np.r_[p, p], np.r_[w, w], lookup=lookup, max_distance=np.r_[t, 1.0])

"""pyshadow.embree: the threaded tracer against the module's own ambient occlusion, and the
deprecated name pyshadow.reference."""
from __future__ import annotations

import sys

import numpy as np
import pytest

import pyshadow
from pyshadow import embree
from pyshadow.embree import EmbreeTracer

SAMPLES, STRATEGY, SEED, PATTERNS = 12, "halton", 3, 64


@pytest.fixture(scope="module")
def covered():
    """(scene, points, normals, pixel indices) of the pixels Embree's primary rays cover."""
    from pyshadow.data import default_scene

    scene, camera = default_scene(views=pyshadow.ViewSet.zigzag(4, 8), resolution=16, width=40,
                                  height=30)
    g = embree.gbuffer(scene.draw_items()[0], camera)
    sel = np.flatnonzero(g["object_id"].reshape(-1) != -1)
    dirs = camera.ray_directions().reshape(-1, 3)[sel]
    points = camera.eye + g["depth"].reshape(-1)[sel, None].astype(np.float64) * dirs
    normals = np.asarray(g["normal"], np.float64).reshape(-1, 3)[sel]
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    assert len(sel) > 1000
    return scene, points, normals, sel


def _trace(tracer, points, normals, sel):
    """Every ray's occlusion, and how many rays went to Embree."""
    d = pyshadow.sample_directions(normals, sampling=pyshadow.Sampling(SAMPLES, STRATEGY, PATTERNS, SEED),
                                   indices=sel)
    d32 = np.ascontiguousarray(d.reshape(-1, 3), dtype=np.float32)
    occ, todo, o32, dd = tracer.prepare(points, normals, d32, SAMPLES)
    assert occ.shape == (len(points) * SAMPLES,) and occ.dtype == bool
    assert o32.dtype == dd.dtype == np.float32 and o32.shape == dd.shape == (len(todo), 3)
    assert not occ[todo].any()                          # only rays the ground leaves open are traced
    hit = tracer.occluded(o32, dd)
    assert hit.shape == (len(todo),) and hit.dtype == bool
    occ[todo] = hit
    return occ, hit


@pytest.mark.parametrize("k", [-60, 60])
def test_embree_scene_answers_at_any_size_as_at_unit_size(k):
    """Embree's float32 triangle test fails beyond about 7e12 and below about 2e-13 (products of three
    coordinates); triangles, origins and lengths scaled by 2**k reach it scaled back by a power of
    two: the same hits, and distances scaled exactly."""
    import trimesh

    box = trimesh.creation.box((1.0, 1.0, 1.0))
    rng = np.random.default_rng(4)
    o = np.c_[rng.uniform(-2, 2, 3000), np.full(3000, 0.3), rng.uniform(-2, 2, 3000)]
    d = rng.normal(size=(3000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    f = 2.0 ** k
    base, scaled = embree.EmbreeScene(box.triangles), embree.EmbreeScene(box.triangles * f)
    assert base.unit == 1.0 and scaled.unit == 2.0 / f              # the largest coordinate, f / 2, to 1
    hit = base.occluded(o, d)
    assert 0.1 < hit.mean() < 0.5
    np.testing.assert_array_equal(scaled.occluded(o * f, d), hit)
    np.testing.assert_array_equal(scaled.occluded(o * f, d, tfar=0.5 * f), base.occluded(o, d, tfar=0.5))
    t0, p0, _ = base.intersect(o, d)
    t1, p1, _ = scaled.intersect(o * f, d)
    np.testing.assert_array_equal(p1, p0)
    np.testing.assert_array_equal(t1, t0 * f)


def test_embree_tracer_refuses_points_beyond_its_anchor_s_reach(covered):
    """The tracer keeps the scene's one anchor: points where that loses float32 precision are refused,
    named (embree.ambient_occlusion asks them relative to anchors of their own)."""
    scene, points, normals, _ = covered
    far = points[:4] + [1e9, 0.0, 0.0]
    dirs = pyshadow.sample_directions(normals[:4], sampling=pyshadow.Sampling(SAMPLES)).reshape(-1, 3)
    with EmbreeTracer(scene, threads=1) as tracer:
        tracer.prepare(points[:4], normals[:4], dirs.astype(np.float32), SAMPLES)
        with pytest.raises(ValueError, match=r"EmbreeTracer: points lie beyond 512 radii"):
            tracer.prepare(far, normals[:4], dirs.astype(np.float32), SAMPLES)


def test_embree_tracer_matches_ambient_occlusion(covered):
    """The threaded rays are ambient_occlusion's, bit for bit."""
    scene, points, normals, sel = covered
    with EmbreeTracer(scene, 2) as tracer:
        assert tracer.threads == 2
        assert tracer.eps == embree.surface_epsilon(scene)
        occ, hit = _trace(tracer, points, normals, sel)
    ao = (~occ.reshape(len(points), SAMPLES)).mean(axis=1).astype(np.float32)
    want = embree.ambient_occlusion(scene, points, normals, indices=sel,
                                    sampling=pyshadow.Sampling(SAMPLES, STRATEGY, PATTERNS, SEED))
    np.testing.assert_array_equal(ao, want)
    # non-trivial: Embree finds hits and misses, the ground decides some rays on its own
    assert 0.0 < hit.mean() < 1.0
    assert 0 < len(hit) < len(occ)
    assert np.any(want == 1.0) and np.any(want < 0.7)


def test_embree_tracer_answers_do_not_depend_on_threads(covered):
    scene, points, normals, sel = covered
    answers = []
    for threads in (1, 3):
        with EmbreeTracer(scene, threads) as tracer:
            occ, hit = _trace(tracer, points, normals, sel)
        assert len(hit) > 2 * 4096            # at least three chunks of 4096 rays: all 3 threads work
        answers.append(occ)
    np.testing.assert_array_equal(answers[0], answers[1])


def test_embree_tracer_no_rays(covered):
    scene = covered[0]
    tracer = EmbreeTracer(scene, 1)
    try:
        out = tracer.occluded(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32))
        assert out.shape == (0,) and out.dtype == bool
    finally:
        tracer.close()
    with pytest.raises(RuntimeError):                     # the pool is shut down
        tracer.pool.submit(int)


def test_embree_tracer_is_public():
    assert "EmbreeTracer" in embree.__all__
    assert EmbreeTracer.__module__ == "pyshadow.embree"


def test_reference_is_a_deprecated_alias_of_embree(monkeypatch):
    monkeypatch.delitem(sys.modules, "pyshadow.reference", raising=False)
    monkeypatch.delattr(pyshadow, "reference", raising=False)
    with pytest.warns(DeprecationWarning, match=r"pyshadow\.embree"):
        import pyshadow.reference as reference
    assert reference.visible is embree.visible
    assert reference.ambient_occlusion is embree.ambient_occlusion
    assert set(reference.__all__) == set(embree.__all__)


def test_the_embree_backend_refuses_what_the_kernels_refuse(small_scene):
    """The ground truth checks its input as the CSM backend does: a NaN point, a zero direction or normal,
    a direction short of a row, an (N, 2) array -- each the CSM backend's error, not an answer."""
    p, d, n = np.array([[0.0, 2, 0], [0.1, 2, 0]]), np.array([[0.0, -1, 0]] * 2), np.array([[0.0, 1, 0]] * 2)
    s = pyshadow.Sampling(8)
    cases = [((np.array([[np.nan, 2, 0], [0, 2, 0]]), d), "points: 1 rows are not finite"),
             ((p, np.array([[0.0, 0, 0], [0, -1, 0]])), "directions: 1 rows are zero vectors"),
             ((p, d[:1]), "directions has 1 rows but points has 2"),
             ((p[:, :2], d), r"points must have shape \(N, 3\)")]
    for args, match in cases:
        for backend in ("csm", "embree"):
            with pytest.raises(ValueError, match=match):
                small_scene.visible(*args, backend=backend)
    for args, match in (((np.array([[np.nan, 0, 0], [0, 2, 0]]), n), "points: 1 rows are not finite"),
                        ((p, np.array([[0.0, 0, 0], [0, 1, 0]])), "normals: 1 rows are zero vectors")):
        for backend in ("csm", "embree"):
            with pytest.raises(ValueError, match=match):
                small_scene.ambient_occlusion(*args, backend=backend, sampling=s)
    # valid rays: the box stands on the ground at the origin, so a ray down from above it is shadowed
    np.testing.assert_array_equal(small_scene.visible(p, d, backend="embree"), [False, False])
    np.testing.assert_array_equal(small_scene.visible(p, -d, backend="embree"), [True, True])

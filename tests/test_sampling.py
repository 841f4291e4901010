"""Sampling (pyshadow.sampling): the device's directions against the NumPy reference, the
patterns' properties, the strategies' order against Embree, and the Sampling value."""
import dataclasses

import numpy as np
import pytest

import pyshadow
from pyshadow import Sampling, embree, sampling


def test_sample_directions_match_numpy_reference():
    n = np.random.default_rng(1).normal(size=(3000, 3))
    n[:4] = [[0, 0, 1], [0, 0, -1], [1e-9, 0, -1], [0, 1, 0]]
    for strategy in pyshadow.STRATEGIES:
        d = pyshadow.sample_directions(n, sampling=Sampling(36, strategy, 64, seed=5))
        r = sampling.sample_directions_reference(n, sampling=Sampling(36, strategy, 64, seed=5))
        assert d.shape == (3000, 36, 3) and d.dtype == np.float32
        np.testing.assert_allclose(d, r, atol=1e-6)
        unit_n = n / np.linalg.norm(n, axis=1, keepdims=True)
        cos = np.einsum("nsk,nk->ns", r, unit_n)
        assert (cos > 0).all()
        assert abs(cos.mean() - 2 / 3) < 0.01          # cosine-weighted: E[cos] = 2/3


def test_sample_patterns_properties():
    N = 16
    for strategy in pyshadow.STRATEGIES:
        a = sampling.sample_patterns(N, strategy, 8, seed=1)
        b = sampling.sample_patterns(N, strategy, 8, seed=1)
        c = sampling.sample_patterns(N, strategy, 8, seed=2)
        np.testing.assert_array_equal(a, b)
        assert not np.array_equal(a, c)
        assert ((a >= 0) & (a < 1)).all()
    s = sampling.sample_patterns(N, "stratified", 8)
    cells = np.floor(s * 4).astype(int)
    for pat in cells:                                   # one point per 4x4 cell
        assert len({tuple(x) for x in pat}) == 16
    for strategy in ("latin_hypercube", "hammersley"):  # one point per row and per column
        s = sampling.sample_patterns(N, strategy, 8)
        for pat in s:
            assert len(set(np.floor(pat[:, 0] * N).astype(int))) == N
            assert len(set(np.floor(pat[:, 1] * N).astype(int))) == N
    h = sampling.sample_patterns(N, "hammersley", 8)    # a (0, 4, 2)-net: every 2x8 box holds one
    for pat in h:
        assert len({(int(x * 2), int(y * 8)) for x, y in pat}) == 16


def test_sampling_strategies_order_matches_thesis(bunny_scene):
    """RMSE at 36 samples against a 4096-sample Embree reference (thesis 5.3.1, Fig. 5.7)."""
    pts, nrm = bunny_scene.vertex_points(0)
    sel = np.random.default_rng(7).choice(len(pts), 2000, replace=False)
    p, n = pts[sel], nrm[sel]
    truth = embree.ambient_occlusion(bunny_scene, p, n, sampling=Sampling(4096, "hammersley", seed=99, patterns=16))
    rmse = {}
    for strategy in pyshadow.STRATEGIES:
        ao = bunny_scene.ambient_occlusion(p, n, sampling=Sampling(36, strategy, seed=3))
        rmse[strategy] = float(np.sqrt(np.mean((ao - truth) ** 2)))
    assert max(rmse, key=rmse.get) == "random"
    best = sorted(rmse, key=rmse.get)[:2]
    assert set(best) == {"halton", "hammersley"}, rmse


# ---------------------------------------------------------------------------
# the Sampling value
# ---------------------------------------------------------------------------
def test_sampling_defaults_and_fields():
    s = Sampling()
    assert (s.samples, s.strategy, s.patterns, s.seed) == (36, "hammersley", 256, 0)
    assert Sampling(64, "halton", 16, 3) == Sampling(samples=64, strategy="halton", patterns=16, seed=3)
    assert Sampling(64) != Sampling(64, seed=1)
    assert hash(Sampling(64)) == hash(Sampling(64))                 # usable as a cache key
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.samples = 64
    for strategy in pyshadow.STRATEGIES:
        Sampling(1, strategy, 1)
        Sampling(sampling.MAX_SAMPLES, strategy, sampling.MAX_PATTERNS, seed=2**40)
    Sampling(np.int64(8), patterns=np.int32(4), seed=np.uint8(1))   # NumPy integers pass


def test_sampling_directions_are_sample_directions():
    n = np.random.default_rng(4).normal(size=(500, 3))
    s = Sampling(12, "latin_hypercube", 32, 9)
    idx = np.arange(500) * 7 + 3
    np.testing.assert_array_equal(s.directions(n, indices=idx),
                                  pyshadow.sample_directions(n, sampling=s, indices=idx))
    np.testing.assert_array_equal(s.directions(n), pyshadow.sample_directions(n, sampling=s))


@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(samples=0), ValueError, "samples must be in 1..4096, got 0"),
    (dict(samples=5000), ValueError, "samples must be in 1..4096, got 5000"),
    (dict(samples=-1), ValueError, "samples must be in 1..4096, got -1"),
    (dict(samples=2.5), TypeError, "samples must be an int, got 2.5"),
    (dict(samples=True), TypeError, "samples must be an int, got True"),
    (dict(samples="36"), TypeError, "samples must be an int, got '36'"),
    (dict(strategy="sobol"), ValueError, "unknown strategy 'sobol'; expected one of random, stratified, "
                                         "latin_hypercube, halton, hammersley"),
    (dict(strategy="Halton"), ValueError, "unknown strategy 'Halton'"),
    (dict(patterns=0), ValueError, "patterns must be an int in 1..65536, got 0"),
    (dict(patterns=65537), ValueError, "patterns must be an int in 1..65536, got 65537"),
    (dict(patterns=1.5), ValueError, "patterns must be an int in 1..65536, got 1.5"),
    (dict(patterns=False), ValueError, "patterns must be an int in 1..65536, got False"),
    (dict(seed=1.5), TypeError, "seed must be an int, got 1.5"),
    (dict(seed=None), TypeError, "seed must be an int, got None"),
    (dict(seed=True), TypeError, "seed must be an int, got True"),
])
def test_sampling_rejects_bad_values_naming_them(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        Sampling(**kwargs)


@pytest.mark.parametrize("kwargs, exc, match", [
    (dict(samples=0), ValueError, "samples must be in 1..4096, got 0"),
    (dict(strategy="sobol"), ValueError, "unknown strategy 'sobol'"),
    (dict(patterns=0), ValueError, "patterns must be an int in 1..65536, got 0"),
])
def test_sample_functions_reject_bad_values(kwargs, exc, match):
    """The building blocks check as Sampling does (sample_directions takes a Sampling)."""
    args = dict(samples=8, strategy="hammersley", patterns=4)
    args.update(kwargs)
    with pytest.raises(exc, match=match):
        sampling.sample_patterns(**args)
    with pytest.raises(exc, match=match):
        sampling.direction_table(**args)


def test_direction_table_is_kept_read_only_and_equals_the_patterns_directions():
    """Every AO call reads its sampling's table: small ones are kept (the same array, read-only), and a
    kept table holds the directions of sample_patterns; a large one is built each time, read-only too."""
    for args in [(16, "hammersley", 256, 0), (36, "stratified", 64, 7), (4096, "random", 64, 3)]:
        t = sampling.direction_table(*args)
        want = sampling.local_directions(sampling.sample_patterns(*args)).astype(np.float32)
        np.testing.assert_array_equal(t, want)
        assert not t.flags.writeable
        with pytest.raises(ValueError, match="read-only"):
            t[0, 0, 0] = 0.0
        kept = args[0] * args[2] <= sampling._TABLE_CACHE_ENTRIES
        assert (sampling.direction_table(*args) is t) == kept
    assert sampling.direction_table(16, "hammersley", 256, 1) is not sampling.direction_table(16, "hammersley", 256, 0)

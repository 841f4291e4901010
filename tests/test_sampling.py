"""Sampling (pyshadow.sampling): the device's directions against the NumPy reference, the
patterns' properties, the strategies' order against Embree, and the Sampling value."""
import dataclasses
import re

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
        Sampling(sampling.MAX_SAMPLES, strategy, sampling.MAX_PATTERNS, seed=2**32 - 1)
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


# ---------------------------------------------------------------------------
# seeds, the sampling argument and the normals
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("seed", [-1, 2**32, 2**32 + 5, 2**64, -2**70, np.int64(-3), np.uint64(2**40)])
def test_seeds_beyond_32_bits_are_refused(seed):
    """The generator takes 32 bits of the seed: 5 and 5 + 2**32 gave the same patterns, 0, 2**64 and
    -2**70 the same everything. Refused wherever a seed is taken."""
    match = (r"^seed must be in 0\.\.4294967295 \(the pattern generator uses 32 bits of it\), "
             rf"got {int(seed)}$")
    with pytest.raises(ValueError, match=match):
        Sampling(16, seed=seed)
    with pytest.raises(ValueError, match=match):
        sampling.sample_patterns(4, "random", 2, seed)
    with pytest.raises(ValueError, match=match):
        sampling.direction_table(4, "random", 2, seed)
    with pytest.raises(ValueError, match=match):
        sampling.pattern_indices(np.arange(4), 16, seed)
    with pytest.raises(ValueError, match=match):
        with pytest.warns(DeprecationWarning):
            pyshadow._compat.reset()
            pyshadow.sample_directions(np.array([[0, 1.0, 0]]), seed=seed)       # the old keyword
    assert sampling.MAX_SEED == 2**32 - 1


def _splitmix_pattern(i: int, patterns: int, seed: int) -> int:
    """pattern_indices written out with Python integers (mod 2**64)."""
    m = (1 << 64) - 1
    z = (i + ((seed * 0x9E3779B97F4A7C15 + 0x632BE59BD9B4E019) & m)) & m
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & m
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & m
    return (z ^ (z >> 31)) % patterns


@pytest.mark.parametrize("seed", [0, 1, 12345, 2**31, 2**32 - 1, np.uint32(2**32 - 1), np.int64(7)])
def test_seeds_in_range_give_the_patterns_they_gave(seed):
    """Bit for bit: the 'random' patterns are the generator's draws for [seed, 0, N] (the 32-bit seed
    itself), the assignment the splitmix64 hash of the seed, both written out here."""
    N, M = 7, 5
    want = np.minimum(np.random.default_rng([int(seed), 0, N]).random((M, N, 2)), np.nextafter(1.0, 0.0))
    assert sampling.sample_patterns(N, "random", M, seed).tobytes() == want.tobytes()
    idx = np.array([0, 1, 2, 3, 1000, 2**31, 2**40 + 3])
    want_idx = [_splitmix_pattern(int(i), 97, int(seed)) for i in idx]
    assert sampling.pattern_indices(idx, 97, seed).tolist() == want_idx
    assert Sampling(N, "random", M, seed).seed == seed


@pytest.mark.parametrize("bad", ["halton", 16, 16.0, ("halton",), {"samples": 16}])
def test_sampling_must_be_a_sampling(bad):
    """sampling="halton" raised AttributeError ('str' object has no attribute 'samples')."""
    n = np.array([[0, 1.0, 0]])
    match = rf"^sampling must be a pyshadow\.Sampling, got {re.escape(repr(bad))} \(e\.g\. sampling="
    for f in (pyshadow.sample_directions, sampling.sample_directions_reference):
        with pytest.raises(TypeError, match=match):
            f(n, sampling=bad)


def test_normals_of_any_non_zero_length_are_normalised_as_ambient_occlusion_does():
    """A normal of length 1e-300 was "zero" here (an absolute 1e-12 threshold) while Scene.ambient_occlusion
    normalises it: both follow pyshadow._validate.unit_normals now."""
    s = Sampling(8, "halton", 16, 3)
    up = np.array([[0, 1.0, 0]])
    ref = sampling.sample_directions_reference(up, sampling=s)
    dev = pyshadow.sample_directions(up, sampling=s)
    for scale in (1e-300, 1e-13, 1e-12, 1e300, 5e-324):
        n = up * scale
        assert (sampling.sample_directions_reference(n, sampling=s) == ref).all()
        assert (pyshadow.sample_directions(n, sampling=s) == dev).all()
    for bad, match in [([[0, 0, 0.0]], "^normals: 1 rows are zero vectors$"),
                       ([[0, 1.0, 0], [0, 0, 0]], "^normals: 1 rows are zero vectors$"),
                       ([[np.nan, 1.0, 0]], "^normals: 1 rows are not finite$"),
                       ([[np.inf, 1.0, 0]], "^normals: 1 rows are not finite$"),
                       ([0, 1.0, 0], r"^normals must have shape \(N, 3\), got \(3,\)$"),
                       (np.ones((2, 2)), r"^normals must have shape \(N, 3\), got \(2, 2\)$")]:
        for f in (pyshadow.sample_directions, sampling.sample_directions_reference):
            with pytest.raises(ValueError, match=match):
                f(np.asarray(bad), sampling=s)
    with pytest.raises(TypeError, match="^normals must be numeric, got complex128$"):
        pyshadow.sample_directions(np.ones((1, 3), complex), sampling=s)


def test_normals_that_were_accepted_are_normalised_as_before():
    """Bit for bit n / np.linalg.norm(n) for the lengths the old threshold let through (float64 of any
    input dtype), so the directions are unchanged."""
    rng = np.random.default_rng(5)
    for scale, dtype in [(1e-11, np.float64), (1.0, np.float64), (1e100, np.float64), (1.0, np.float32),
                         (1e-3, np.float32), (3.0, np.int64)]:
        n = (rng.normal(size=(5000, 3)) * scale).astype(dtype)
        n[~n.any(axis=1)] = 1
        m = n.astype(np.float64)
        want = m / np.linalg.norm(m, axis=1)[:, None]
        assert sampling._check_normals(n).tobytes() == want.tobytes()


def test_indices_must_be_non_negative_integers():
    """A float index was truncated and a negative one wrapped into another point's pattern: both refused,
    by sample_directions, its NumPy reference and the AO path alike; integer indices keep their patterns."""
    import pyshadow
    from pyshadow._validate import check_indices

    n = np.tile([0.0, 1.0, 0.0], (3, 1))
    s = pyshadow.Sampling(8, "hammersley", patterns=16, seed=3)
    for f in (pyshadow.sample_directions, pyshadow.sampling.sample_directions_reference):
        with pytest.raises(TypeError, match="indices must be integers"):
            f(n, sampling=s, indices=[0.0, 1.5, 2.0])
        with pytest.raises(ValueError, match="indices must be >= 0"):
            f(n, sampling=s, indices=[0, -1, 2])
        np.testing.assert_array_equal(f(n, sampling=s, indices=np.array([5, 6, 7], np.uint32)),
                                      f(n, sampling=s, indices=[5, 6, 7]))
    with pytest.raises(ValueError, match="below 2\\*\\*63"):
        check_indices(np.array([2**63], np.uint64), 1)
    scene = pyshadow.Scene(ground=0.0)
    with pytest.raises(ValueError, match="indices must be >= 0"):
        scene.ambient_occlusion(np.ones((3, 3)), n, sampling=s, indices=[0, -1, 2])


def test_pattern_indices_validates_patterns_and_indices():
    """Was: patterns=0 divided by zero (RuntimeWarning, garbage patterns), -1 an OverflowError, 2**40
    gave patterns beyond any table; a float index was truncated, a negative one an OverflowError."""
    want = sampling.pattern_indices(np.arange(6), 16, 3)
    assert np.array_equal(sampling.pattern_indices(np.arange(6, dtype=np.uint32), 16, 3), want)
    for bad in (0, -1, 2**40, 2.0, True):
        with pytest.raises(ValueError, match=f"^patterns must be an int in 1..65536, got {re.escape(repr(bad))}$"):
            sampling.pattern_indices([1], bad)
    with pytest.raises(TypeError, match="^indices must be integers, got dtype float64$"):
        sampling.pattern_indices([1.5], 4)
    with pytest.raises(ValueError, match=r"^indices must be >= 0 and below 2\*\*63$"):
        sampling.pattern_indices([3, -1], 4)


def test_strategy_of_another_type_is_a_value_error():
    """Was: a list strategy raised 'unhashable type'."""
    with pytest.raises(ValueError, match=r"^unknown strategy \['halton'\]; expected one of random, "):
        Sampling(4, ["halton"])


def test_ao_from_samples_shapes_must_agree():
    """Was: 5 visibility flags for 4 directions averaged silently, no sample gave NaN (a RuntimeWarning)."""
    d = np.tile([0.0, 1.0, 0.0], (2, 4, 1))
    n = np.tile([0.0, 1.0, 0.0], (2, 1))
    assert sampling.ao_from_samples(d, np.ones((2, 4), bool), n).tolist() == [1.0, 1.0]
    with pytest.raises(ValueError, match=r"^directions \(N, S, 3\), visible \(N, S\) and normals \(N, 3\) must "
                                         r"agree, got \(2, 4, 3\), \(2, 5\) and \(2, 3\)$"):
        sampling.ao_from_samples(d, np.ones((2, 5), bool), n)
    with pytest.raises(ValueError, match=r"^directions hold no sample \(S = 0\)"):
        sampling.ao_from_samples(d[:, :0], np.ones((2, 0), bool), n)

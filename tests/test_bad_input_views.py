"""Bad and extreme input of the view sets (pyshadow.views) and the sampling helpers (pyshadow.sampling):
given layouts, huge bases, the octahedral map, the Hilbert curve, polar angles, empty index lists, AO from
samples; and the extremes that already gave the nearest map (poles, -0.0, denormals, tiny and huge
lengths, float32, the smallest layouts), kept so."""
import numpy as np
import pytest

import pyshadow
from pyshadow import sampling
from pyshadow.views import ViewSet, hilbert_d2xy, octahedral_decode, octahedral_encode, polar_direction


def _brute_nearest_dot(views, d):
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    return (d @ views.directions.T).max(axis=1), d


# -- a given ViewSet's layout and params ---------------------------------------------------------------------
def test_given_grid_layout_needs_its_params():
    """ViewSet(d, b, layout="zigzag") without params was accepted; its nearest() then raised a bare
    KeyError('theta') (a hilbert one KeyError('level'))."""
    z, h = ViewSet.zigzag(4, 8), ViewSet.hilbert(2)
    with pytest.raises(ValueError, match=r"^ViewSet: zigzag parameters miss 'theta', 'phi' \(expected"):
        ViewSet(z.directions, z.bases, "zigzag")
    with pytest.raises(ValueError, match=r"^ViewSet: hilbert parameters miss 'level' \(expected"):
        ViewSet(h.directions, h.bases, "hilbert", {})


@pytest.mark.parametrize("layout, params, rows, old", [
    ("zigzag", {"theta": 4, "phi": 8, "row_offset": 0.5}, slice(0, 5),
     "IndexError: index 31 is out of bounds for axis 0 with size 5"),
    ("zigzag", {"theta": 8, "phi": 4, "row_offset": 0.5}, slice(None), "map 31 where map 24 is nearest"),
    ("hilbert", {"level": 2}, slice(0, 16), "the hilbert lookup on zigzag directions"),
])
def test_given_grid_layout_must_be_the_grid_of_its_directions(layout, params, rows, old):
    """The O(1) lookups read the grid from the params, never from the directions: params of another grid
    gave an IndexError or, silently, a map that is not the nearest (zigzag(4, 8)'s directions called
    zigzag(8, 4): nearest((0, -1, 0)) was map 31, map 24 lies nearer)."""
    z = ViewSet.zigzag(4, 8)
    with pytest.raises(ValueError, match=rf"^ViewSet: the directions are not those of the {layout} layout of "
                                         r"params .*; give layout='custom' for other directions$"):
        ViewSet(z.directions[rows], z.bases[rows], layout, params)


def test_given_grid_layout_with_its_own_directions_keeps_working():
    """The grid's directions (also float32-rounded) with other bases (as benchmarks/compression.py gives
    the thesis's look-at cameras) are a valid zigzag or hilbert set, with the grid's lookups."""
    rng = np.random.default_rng(4)
    q = rng.normal(size=(2000, 3))
    for v in (ViewSet.zigzag(8, 16), ViewSet.zigzag(8, 16, 0.0), ViewSet.hilbert(3), ViewSet.hilbert(2, True)):
        w = ViewSet(v.directions.astype(np.float32), v.bases.astype(np.float32), v.layout, v.params)
        assert (w.nearest(q) == v.nearest(q)).all()
        assert (w.filter_window(q)[0] == v.filter_window(q)[0]).all()
        flipped = v.bases.copy()
        flipped[:, :2] *= -1                       # u, v turned half a turn: still right-handed
        ViewSet(v.directions, flipped, v.layout, dict(v.params))


@pytest.mark.parametrize("layout, params, exc, match", [
    ("spiral", None, ValueError, r"^ViewSet: layout must be one of 'zigzag', 'hilbert', 'custom', got 'spiral'$"),
    (None, None, ValueError, "^ViewSet: layout must be one of .*, got None$"),
    (5, None, ValueError, "^ViewSet: layout must be one of .*, got 5$"),
    ("custom", "ab", TypeError, r"^ViewSet: params must be a dict \(or None\), got 'ab'$"),
    ("custom", [1, 2], TypeError, r"^ViewSet: params must be a dict \(or None\), got \[1, 2\]$"),
])
def test_given_layout_must_be_known_and_params_a_dict(layout, params, exc, match):
    """An unknown layout was kept (repr 'ViewSet.5() with 32 maps', lookups of a custom set); params 'ab'
    raised "dictionary update sequence element #0 has length 1; 2 is required"."""
    z = ViewSet.zigzag(4, 8)
    with pytest.raises(exc, match=match):
        ViewSet(z.directions, z.bases, layout, params)


def test_huge_bases_are_refused_without_overflow():
    """Bases of entries 1e200 made the check's determinant overflow: RuntimeWarning "overflow encountered in
    det" (an error under pytest); with warnings off, u = (1e200, -1e200, 0), v = (1e200, 1e200, 0) passed
    (u . v = inf - inf = NaN, and NaN > tolerance is False)."""
    d = np.array([[0, 0, 1.0]])
    for b in ([[1e200, -1e200, 0], [1e200, 1e200, 0], [0, 0, 1.0]], [[1e200, 0, 0], [0, 1e200, 0], [0, 0, 1.0]],
              [[1e-200, 0, 0], [0, 1e-200, 0], [0, 0, 1.0]]):
        with pytest.raises(ValueError, match=r"^ViewSet: 1 bases are not orthonormal"):
            ViewSet(d, np.array([b]))


# -- the octahedral map, the Hilbert curve, polar angles --------------------------------------------------------
def test_octahedral_encode_takes_directions_of_any_length():
    """Lengths whose square under- or overflows: (1e-310, 1e-310, 0) gave NaN (RuntimeWarning "divide by zero
    encountered in divide"), (1e200, 1e200, 0) gave (0, 0), the north pole (RuntimeWarning "overflow
    encountered in multiply"); both are (1, 1, 0)'s point."""
    want = octahedral_encode([1.0, 1.0, 0.0])
    for scale in (5e-324, 1e-310, 1e-160, 1e-30, 1e30, 1e160, 1e200, 1e308):
        got = octahedral_encode(np.array([scale, scale, 0.0]))
        np.testing.assert_allclose(got, want, rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(octahedral_encode(np.array([[0, -1e-310, 0], [0, 1e300, 0]])), [[1, 1], [0, 0]])


@pytest.mark.parametrize("bad, exc, match", [
    ([0.0, 0.0, 0.0], ValueError, r"^octahedral_encode: dirs: 1 zero vectors"),                   # was NaN
    ([np.nan, 0, 0], ValueError, "^octahedral_encode: dirs must be finite$"),                     # was NaN
    ([np.inf, 0, 0], ValueError, "^octahedral_encode: dirs must be finite$"),
    (np.ones((4, 2)), ValueError, r"^octahedral_encode: dirs must have shape \(\.\.\., 3\), got \(4, 2\)$"),
    (np.ones((1, 3), complex), TypeError, "^octahedral_encode: dirs must hold real numbers, got dtype complex128$"),
])
def test_octahedral_encode_refuses_what_is_no_direction(bad, exc, match):
    """A zero or NaN row gave NaN (RuntimeWarning), an (N, 2) array "IndexError: index 2 is out of bounds",
    complex input a ComplexWarning."""
    with pytest.raises(exc, match=match):
        octahedral_encode(bad)


@pytest.mark.parametrize("bad, exc, match", [
    ([2.0, 0.0], ValueError, r"^octahedral_decode: uv must lie in the square \[-1, 1\]\^2"),      # was the south pole
    ([3.0, 0.5], ValueError, r"^octahedral_decode: uv must lie in the square"),                  # was the north pole
    ([np.nan, 0.0], ValueError, "^octahedral_decode: uv must be finite$"),
    ([np.inf, 0.0], ValueError, "^octahedral_decode: uv must be finite$"),
    (np.zeros((2, 3)), ValueError, r"^octahedral_decode: uv must have shape \(\.\.\., 2\), got \(2, 3\)$"),
    (np.array([[True, False]]), TypeError, "^octahedral_decode: uv must hold real numbers, got dtype bool$"),
])
def test_octahedral_decode_refuses_points_off_the_square(bad, exc, match):
    """Points outside [-1, 1]^2 gave directions silently ((2, 0) the south pole, (3, 0.5) the north pole); an
    (N, 3) array was read as (u, v) and its third column dropped."""
    with pytest.raises(exc, match=match):
        octahedral_decode(bad)
    # the square's own edges and corners, -0.0 included
    edge = octahedral_decode([[1, 1], [-1, -1], [-0.0, -0.0], [1, -0.0], [-1, 1]])
    np.testing.assert_allclose(edge, [[0, -1, 0], [0, -1, 0], [0, 1, 0], [1, 0, 0], [0, -1, 0]], atol=1e-15)


@pytest.mark.parametrize("args, exc, match", [
    ((2, [-1]), ValueError, r"^hilbert_d2xy: d must lie in 0\.\.15 \(the curve's cells\), got values -1\.\.-1$"),
    ((2, [16]), ValueError, r"^hilbert_d2xy: d must lie in 0\.\.15"),
    ((2, [1.7]), TypeError, "^hilbert_d2xy: d must hold integers, got dtype float64$"),
    ((-1, [0]), ValueError, r"^hilbert_d2xy: level must be in 0\.\.31, got -1$"),
    ((1.5, [0]), TypeError, "^hilbert_d2xy: level must be an int, got 1.5$"),
])
def test_hilbert_d2xy_checks_level_and_positions(args, exc, match):
    """d = -1 gave cell (3, 0) and d = 16 (beyond a level-2 curve) cell (0, 0), d's; d = 1.7 was cell 1;
    level -1 raised "negative shift count", level 1.5 "unsupported operand type(s) for <<"."""
    with pytest.raises(exc, match=match):
        hilbert_d2xy(*args)
    assert [a.tolist() for a in hilbert_d2xy(0, [0])] == [[0], [0]]
    assert [a.tolist() for a in hilbert_d2xy(3, [])] == [[], []]


@pytest.mark.parametrize("theta, phi, match", [
    (np.inf, 0.0, "^polar_direction: theta must be finite$"),
    (0.3, np.nan, "^polar_direction: phi must be finite$"),
    ([0.1, -np.inf], 0.0, "^polar_direction: theta must be finite$"),
])
def test_polar_direction_refuses_non_finite_angles(theta, phi, match):
    """theta = inf gave (nan, nan, nan) (RuntimeWarning "invalid value encountered in sin"); phi = NaN gave
    (nan, 0.955, nan), silently."""
    with pytest.raises(ValueError, match=match):
        polar_direction(theta, phi)
    with pytest.raises(TypeError, match="^polar_direction: theta must hold real numbers"):
        polar_direction("0.5", 0.0)


# -- sampling ----------------------------------------------------------------------------------------------------
def test_pattern_indices_of_no_index():
    """An empty list (float64 to NumPy) raised "TypeError: indices must be integers, got dtype float64"."""
    for empty in ([], np.zeros(0), np.zeros(0, np.int64)):
        out = sampling.pattern_indices(empty, 16, 3)
        assert out.dtype == np.int32 and out.shape == (0,)
    with pytest.raises(TypeError, match="^indices must be integers, got dtype float64$"):
        sampling.pattern_indices([1.0], 16)


def test_ao_from_samples_takes_array_likes_and_refuses_nan_weights():
    """Lists raised "AttributeError: 'list' object has no attribute 'mean'"; NaN weights gave AO NaN and
    weights of 2 an AO of 1.5, silently; object weights "loop of ufunc does not support argument 0"; NaN
    directions a bent normal of the normal itself."""
    assert sampling.ao_from_samples([[[0, 1, 0]]], [[True]], [[0, 1, 0]]).tolist() == [1.0]
    d, n = np.ones((1, 2, 3)) / np.sqrt(3), np.ones((1, 3)) / np.sqrt(3)
    for w in ([[np.nan, 1.0]], [[2.0, 1.0]], [[-0.5, 1.0]]):
        with pytest.raises(ValueError, match=r"^visible: weights must lie in \[0, 1\]"):
            sampling.ao_from_samples(d, np.array(w), n)
    with pytest.raises(TypeError, match="^visible must hold bools or real numbers, got object$"):
        sampling.ao_from_samples(d, np.array([[1, 0]], object), n, True)
    with pytest.raises(ValueError, match="^directions and normals must be finite"):
        sampling.ao_from_samples(np.full((1, 2, 3), np.nan), np.ones((1, 2), bool), n, True)
    ao, bent = sampling.ao_from_samples(d, np.array([[0.0, 1.0]]), n, True)
    assert ao.tolist() == [0.5] and np.allclose(bent, n)


# -- extremes that already worked, kept so -----------------------------------------------------------------------
def _extreme_directions():
    rows = [[0, 1, 0], [0, -1, 0], [-0.0, 1, -0.0], [-0.0, -1, -0.0], [1, -0.0, -0.0], [-1, 0, -0.0],
            [1e-7, 1, 0], [0, -1, -1e-7], [1e-17, 1, -1e-17], [5e-324, 0, 0], [0, 5e-324, 0], [1e-310, -1e-310, 0],
            [1e-30, 1e-30, 1e-30], [1e30, -1e30, 1], [1e300, 0, -1e300], [1.7e308, 1.7e308, 1.7e308]]
    ang = np.linspace(0, 2 * np.pi, 9)
    for e in (1e-15, 1e-7, 1e-3):
        for y in (1.0, -1.0):
            rows += np.stack([e * np.cos(ang), np.full(9, y), e * np.sin(ang)], axis=1).tolist()
    return np.array(rows, dtype=np.float64)


@pytest.mark.parametrize("make", [lambda: ViewSet.zigzag(1, 1), lambda: ViewSet.zigzag(1, 2),
                                  lambda: ViewSet.zigzag(2, 1), lambda: ViewSet.zigzag(1, 1, 0.0),
                                  lambda: ViewSet.zigzag(2, 4), lambda: ViewSet.zigzag(3, 5, 0.0),
                                  lambda: ViewSet.zigzag(16, 32), lambda: ViewSet.zigzag(16, 32, 0.0),
                                  lambda: ViewSet.hilbert(0), lambda: ViewSet.hilbert(1),
                                  lambda: ViewSet.hilbert(0, True), lambda: ViewSet.hilbert(1, True),
                                  lambda: ViewSet.hilbert(4)])
def test_extreme_directions_get_the_nearest_map_and_finite_weights(make):
    views = make()
    raw = _extreme_directions()
    for d in (raw, raw[np.abs(raw).max(axis=1) < 1e38].astype(np.float32)):
        keep = (np.abs(d.astype(np.float64)).max(axis=1) > 0)
        d = d[keep]
        b, u = _brute_nearest_dot(views, d.astype(np.float64) / np.abs(d.astype(np.float64)).max(axis=1)[:, None])
        idx = views.nearest(d)
        assert (np.einsum("ij,ij->i", views.directions[idx], u) >= b - 1e-12).all()
        maps, w = views.filter_window(d)
        assert np.isfinite(w).all() and (w > 0).all()
        np.testing.assert_allclose(w.sum(axis=1), 1.0, rtol=1e-12)
        assert (np.einsum("ijk,ik->ij", views.directions[maps], u).max(axis=1) >= b - 1e-12).all()


def test_thin_zigzag_grids_give_the_windows_nearest_as_documented():
    """The documented limit of the O(1) lookups (ViewSet.zigzag): with theta <= phi**2 / 2 the nearest of
    all maps; a thinner grid (64 x 8) the nearest of the 2 x 2 window only, as the kernels."""
    rng = np.random.default_rng(9)
    q = rng.normal(size=(20_000, 3))
    for T, P in [(2, 2), (4, 3), (8, 4), (18, 6), (32, 8)]:
        for off in (0.5, 0.0):
            v = ViewSet.zigzag(T, P, off)
            best, u = _brute_nearest_dot(v, q)
            assert (np.einsum("ij,ij->i", v.directions[v.nearest(q)], u) >= best - 1e-12).all(), (T, P, off)
    thin = ViewSet.zigzag(64, 8)
    best, u = _brute_nearest_dot(thin, q)
    got = np.einsum("ij,ij->i", thin.directions[thin.nearest(q)], u)
    assert (got < best - 1e-6).any()
    window = np.einsum("ijk,ik->ij", thin.directions[thin._zigzag_window(u)], u).max(axis=1)
    np.testing.assert_array_equal(got, window)


def test_views_sampling_entry_points_take_empty_and_one_row_inputs():
    z, h = ViewSet.zigzag(4, 8), ViewSet.hilbert(2)
    for v in (z, h, ViewSet(z.directions, z.bases)):
        assert v.nearest(np.zeros((0, 3))).shape == (0,)
        assert v.nearest(np.array([0, 1.0, 0])).shape == (1,)
    for v in (z, h):
        m, w = v.filter_window(np.zeros((0, 3)))
        assert m.shape == w.shape == (0, 4)
    assert octahedral_encode(np.zeros((0, 3))).shape == (0, 2)
    assert octahedral_decode(np.zeros((0, 2))).shape == (0, 3)
    s = pyshadow.Sampling(4, "halton", 2, 1)
    assert sampling.sample_directions_reference(np.zeros((0, 3)), sampling=s).shape == (0, 4, 3)

"""View sets: grid, order, bases and the O(1) nearest-view lookup."""
import numpy as np
import pytest

import pyshadow
from pyshadow.views import hilbert_d2xy, octahedral_decode, octahedral_encode

LAYOUTS = [
    pytest.param(lambda: pyshadow.ViewSet.zigzag(64, 128), id="zigzag64x128"),
    pytest.param(lambda: pyshadow.ViewSet.zigzag(8, 16), id="zigzag8x16"),
    pytest.param(lambda: pyshadow.ViewSet.zigzag(3, 5), id="zigzag3x5"),
    pytest.param(lambda: pyshadow.ViewSet.zigzag(4, 6), id="zigzag4x6"),
    pytest.param(lambda: pyshadow.ViewSet.zigzag(8, 16, row_offset=0.0), id="zigzag8x16-thesis"),
    pytest.param(lambda: pyshadow.ViewSet.hilbert(6), id="hilbert6"),
    pytest.param(lambda: pyshadow.ViewSet.hilbert(3), id="hilbert3"),
    pytest.param(lambda: pyshadow.ViewSet.hilbert(1), id="hilbert1"),
    pytest.param(lambda: pyshadow.ViewSet.hilbert(6, hemispheres=True), id="hilbert6x2"),
    pytest.param(lambda: pyshadow.ViewSet.hilbert(2, hemispheres=True), id="hilbert2x2"),
]


def special_directions():
    """Poles, next to the poles, the phi seam (z = -0 / +0 on the +x side), axes."""
    e = [0.0, 1e-12, 1e-7, 1e-3]
    dirs = []
    for y in (1.0, -1.0):
        for a in e:
            for ang in np.linspace(0, 2 * np.pi, 13):
                dirs.append([a * np.cos(ang), y, a * np.sin(ang)])
    for a in e:
        for s in (-1, 1):
            dirs.append([1.0, 0.3, s * a])
            dirs.append([1.0, -0.7, s * a])
    dirs += [[1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1], [1, 0, -0.0]]
    d = np.array(dirs, dtype=np.float64)
    return d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize("make", LAYOUTS)
def test_nearest_agrees_with_brute_force(make, rng):
    views = make()
    dirs = np.concatenate([rng.normal(size=(100_000, 3)), special_directions()])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    # directions exactly between two neighbouring maps and at the maps themselves
    k = rng.integers(0, len(views), 500)
    mid = views.directions[k] + views.directions[np.minimum(k + 1, len(views) - 1)]
    mid = mid[np.linalg.norm(mid, axis=1) > 1e-6]
    dirs = np.concatenate([dirs, mid / np.linalg.norm(mid, axis=1, keepdims=True), views.directions])
    idx = views.nearest(dirs)
    assert idx.dtype == np.int32 and idx.shape == (len(dirs),)
    best = np.empty(len(dirs))
    for s in range(0, len(dirs), 20000):
        best[s:s + 20000] = (dirs[s:s + 20000] @ views.directions.T).max(axis=1)
    got = np.einsum("ij,ij->i", views.directions[idx], dirs)
    # equal up to round-off: ties (the pole row, exact midpoints) may pick either map
    assert (got >= best - 1e-12).all(), np.flatnonzero(got < best - 1e-12)[:5]


@pytest.mark.parametrize("make", LAYOUTS)
def test_bases_orthonormal_right_handed(make):
    views = make()
    B = views.bases
    assert B.shape == (len(views), 3, 3)
    np.testing.assert_allclose(np.einsum("kij,klj->kil", B, B), np.broadcast_to(np.eye(3), B.shape), atol=1e-12)
    np.testing.assert_allclose(np.cross(B[:, 0], B[:, 1]), B[:, 2], atol=1e-12)
    np.testing.assert_array_equal(B[:, 2], views.directions)


@pytest.mark.parametrize("make", LAYOUTS)
def test_bases_vary_smoothly_along_the_order(make):
    views = make()
    B = views.bases
    rel = np.einsum("kij,klj->kil", B[1:], B[:-1])
    basis_angle = np.arccos(np.clip((np.trace(rel, axis1=1, axis2=2) - 1) / 2, -1, 1))
    if views.layout == "zigzag":
        step = np.pi / views.params["theta"]       # = 2 pi / phi when phi = 2 theta
        step = max(step, 2 * np.pi / views.params["phi"])
    else:
        step = np.arccos(np.clip(np.einsum("ij,ij->i", views.directions[1:], views.directions[:-1]), -1, 1)).max()
    # a basis never turns by more than one grid step between consecutive maps
    assert basis_angle.max() <= step * (1 + 1e-9)


def transport_one_map_at_a_time(dirs, u0):
    """Parallel transport written as the loop it is: rotate u by the smallest
    rotation taking d_{k-1} to d_k (Rodrigues), re-orthogonalise, normalise."""
    u = u0 - np.dot(u0, dirs[0]) * dirs[0]
    u /= np.linalg.norm(u)
    out = []
    for k, d in enumerate(dirs):
        if k:
            p = dirs[k - 1]
            axis = np.cross(p, d)
            s, c = np.linalg.norm(axis), float(np.dot(p, d))
            if s > 1e-15:
                axis /= s
                u = u * c + np.cross(axis, u) * s + axis * np.dot(axis, u) * (1.0 - c)
            u = u - np.dot(u, d) * d
            u /= np.linalg.norm(u)
        out.append([u, np.cross(d, u), d])
    return np.array(out)


@pytest.mark.parametrize("make", LAYOUTS)
def test_bases_are_parallel_transported(make):
    # the prefix-product transport gives the loop's bases (round-off only)
    views = make()
    u0 = views.bases[0, 0]
    np.testing.assert_allclose(views.bases, transport_one_map_at_a_time(views.directions, u0), rtol=0, atol=1e-12)
    # no twist: each u_k is u_{k-1} turned about d_{k-1} x d_k, so the turn
    # between consecutive bases is exactly the angle between their directions
    B = views.bases
    rel = np.einsum("kij,klj->kil", B[1:], B[:-1])
    basis_angle = np.arccos(np.clip((np.trace(rel, axis1=1, axis2=2) - 1) / 2, -1, 1))
    dir_angle = np.arccos(np.clip(np.einsum("ij,ij->i", views.directions[1:], views.directions[:-1]), -1, 1))
    np.testing.assert_allclose(basis_angle, dir_angle, rtol=0, atol=2e-7)


@pytest.mark.parametrize("row_offset", [0.0, 0.5])
def test_zigzag_matches_thesis_listing_5_1(row_offset):
    # Listing 5.1 is row_offset 0; 0.5 moves every row half a step down, nothing else
    theta_divs, phi_divs = 6, 12
    expected = []
    inc_phi = True
    for i_theta in range(theta_divs):          # Listing 5.1, literally
        for i_phi in range(0 + (not inc_phi), phi_divs + (not inc_phi)):
            theta = ((i_theta + row_offset) / theta_divs) * np.pi
            phi = (i_phi / phi_divs) * 2.0 * np.pi
            if not inc_phi:
                phi = 2.0 * np.pi - phi
            expected.append([np.sin(theta) * np.cos(phi), np.cos(theta), np.sin(theta) * np.sin(phi)])
        inc_phi = not inc_phi
    views = pyshadow.ViewSet.zigzag(theta_divs, phi_divs, row_offset=row_offset)
    np.testing.assert_allclose(views.directions, expected, atol=1e-12)
    assert len(views) == 72 and views.params == {"theta": 6, "phi": 12, "row_offset": row_offset}


def test_zigzag_default_centres_rows_so_both_poles_lie_half_a_step_from_a_map(rng):
    T, P = 16, 32
    step = np.pi / T

    def angle(views, d):
        d = np.asarray(d, float).reshape(-1, 3)
        d = d / np.linalg.norm(d, axis=1, keepdims=True)
        return np.arccos(np.clip(np.einsum("ij,ij->i", views.directions[views.nearest(d)], d), -1, 1))

    centred, thesis = pyshadow.ViewSet.zigzag(T, P), pyshadow.ViewSet.zigzag(T, P, row_offset=0.0)
    assert centred.params["row_offset"] == 0.5
    poles = [[0, 1.0, 0], [0, -1.0, 0]]
    np.testing.assert_allclose(angle(centred, poles), [step / 2, step / 2], rtol=1e-12)
    # the thesis's grid: a map on the north pole, the south pole a whole step away
    np.testing.assert_allclose(angle(thesis, poles), [0.0, step], atol=1e-7)
    # the centred grid's largest angle (the poles included) is the thesis grid's
    # largest off the south cap: the cell centre, half a step in theta and in phi
    d = rng.normal(size=(200_000, 3))
    worst = angle(centred, np.vstack([d, poles])).max()
    cell = np.arccos(np.cos(step / 2) * np.cos(step / 2))      # equator, dphi = dtheta
    assert worst <= cell + 1e-9 and worst >= 0.95 * cell
    assert angle(thesis, [[0, -1.0, 0]])[0] > 1.4 * worst


def test_zigzag_window_at_the_poles_surrounds_the_pole_on_centred_rows():
    # at a pole every map of the nearest (first or last) centred row lies half a
    # step away; the window takes four of them a quarter turn apart, equally
    # weighted, so the vote is neither the one-sided mix of a row and the next
    # row's maps nor two pairs of nearly one direction each
    T, P = 16, 32
    views = pyshadow.ViewSet.zigzag(T, P)
    poles = np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]])
    maps, w = views.filter_window(poles)
    np.testing.assert_allclose(w, 0.25, rtol=1e-9)
    ang = np.arccos(np.clip(np.einsum("ijk,ik->ij", views.directions[maps], poles), -1, 1))
    np.testing.assert_allclose(ang, np.pi / T / 2, rtol=1e-9)
    mean = views.directions[maps].mean(axis=1)
    np.testing.assert_allclose(mean[:, [0, 2]], 0.0, atol=1e-12)     # around the pole
    side = views.directions[maps][:, :, [0, 2]]
    turn = np.einsum("ijk,ijk->ij", side[:, :1], side) / np.einsum("ijk,ijk->ij", side[:, :1], side[:, :1])
    np.testing.assert_allclose(turn, [[1, 0, -1, 0]] * 2, atol=1e-9)  # quarter turns apart
    assert (maps[0] // P == 0).all() and (maps[1] // P == T - 1).all()
    # the thesis grid keeps its pole row and the repeated last row
    thesis = pyshadow.ViewSet.zigzag(T, P, row_offset=0.0)
    maps0, _ = thesis.filter_window(poles)
    assert (maps0[0] // P == [0, 0, 1, 1]).all() and (maps0[1] // P == T - 1).all()


def test_zigzag_row_offset_out_of_range_is_refused():
    with pytest.raises(ValueError, match="row_offset"):
        pyshadow.ViewSet.zigzag(4, 8, row_offset=1.0)
    with pytest.raises(ValueError, match="row_offset"):
        pyshadow.ViewSet.zigzag(4, 8, row_offset=-0.1)
    with pytest.raises(ValueError, match="row_offset"):
        pyshadow.ViewSet.zigzag(4, 8, row_offset=0.25)


def test_zigzag_pole_row_bases_are_defined():
    views = pyshadow.ViewSet.zigzag(64, 128, row_offset=0.0)
    pole = views.bases[:128]
    np.testing.assert_allclose(pole[:, 2], np.broadcast_to([0, 1, 0], (128, 3)), atol=1e-15)
    assert np.isfinite(pole).all()
    # the up-vector construction of eq. 5.4 (o x d) degenerates here; ours does not
    assert np.allclose(np.linalg.norm(np.cross([0, 1, 0], pole[:, 2]), axis=1), 0)
    assert np.allclose(np.linalg.norm(pole[:, 0], axis=1), 1)
    # one direction, one basis: the pole row's maps are identical, bit for bit
    assert (pole == pole[0]).all()


def test_octahedral_map_round_trip_and_equal_area(rng):
    uv = rng.uniform(-1, 1, size=(200_000, 2))
    np.testing.assert_allclose(octahedral_encode(octahedral_decode(uv)), uv, atol=1e-12)
    # uniform directions land uniformly on the square (equal-area map)
    d = rng.normal(size=(400_000, 3))
    h, _, _ = np.histogram2d(*octahedral_encode(d).T, bins=8, range=[[-1, 1], [-1, 1]])
    expected = len(d) / 64
    chi2 = ((h - expected) ** 2 / expected).sum()
    assert chi2 < 120           # 63 degrees of freedom: p < 1e-5 beyond this


def test_hilbert_curve_steps_to_edge_neighbours():
    for level in (1, 2, 5):
        x, y = hilbert_d2xy(level, np.arange(4**level))
        assert (np.abs(np.diff(x)) + np.abs(np.diff(y)) == 1).all()
        assert len(set(zip(x.tolist(), y.tolist()))) == 4**level


@pytest.mark.parametrize("hemispheres", [False, True])
def test_hilbert_directions_cover_sphere_evenly(hemispheres):
    views = pyshadow.ViewSet.hilbert(5, hemispheres)
    assert len(views) == 1024 * (2 if hemispheres else 1)
    # consecutive maps are neighbours on the sphere (the curve never jumps)
    step = np.arccos(np.clip(np.einsum("ij,ij->i", views.directions[1:], views.directions[:-1]), -1, 1))
    assert step.max() < 3.0 * np.sqrt(4 * np.pi / len(views))
    # nearest-neighbour spacing varies little over the sphere (near-uniform)
    dots = views.directions @ views.directions.T
    np.fill_diagonal(dots, -1)
    nn = np.arccos(dots.max(axis=1))
    assert nn.max() / nn.min() < 2.5


@pytest.mark.parametrize("args, match", [((0, 4), "theta must be in 1..65536, got 0"),
                                         ((4, 0), "phi must be in 1..65536, got 0"),
                                         ((-1, 2), "theta must be in 1..65536, got -1")])
def test_zigzag_rejects_empty_grid(args, match):
    with pytest.raises(ValueError, match=f"^ViewSet.zigzag: {match}$"):
        pyshadow.ViewSet.zigzag(*args)


def test_nearest_rejects_zero_and_nan():
    views = pyshadow.ViewSet.zigzag(4, 8)
    with pytest.raises(ValueError):
        views.nearest([[0, 0, 0]])
    with pytest.raises(ValueError):
        views.nearest([[np.nan, 1, 0]])


def test_slices_are_view_sets():
    views = pyshadow.ViewSet.hilbert(2)
    sub = views[3:7]
    assert len(sub) == 4 and sub.layout == "custom"
    np.testing.assert_array_equal(sub.bases, views.bases[3:7])
    np.testing.assert_array_equal(sub.nearest(views.directions[3:7]), np.arange(4))


@pytest.mark.parametrize("make", LAYOUTS)
def test_filter_window_maps_and_weights(make, rng):
    """filter_window: the maps the vote lookup (lookup="vote") asks. The nearest map is among
    them, the weights are the normalised inverse angles, and a direction on a
    map's own axis gives (nearly) all the weight to that axis."""
    views = make()
    dirs = np.concatenate([rng.normal(size=(20_000, 3)), special_directions()])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    maps, w = views.filter_window(dirs)
    assert maps.shape == w.shape == (len(dirs), 4)
    dots = np.einsum("ijk,ik->ij", views.directions[maps], dirs)
    best = np.concatenate([(dirs[s:s + 5000] @ views.directions.T).max(axis=1)
                           for s in range(0, len(dirs), 5000)])
    assert (dots.max(axis=1) >= best - 1e-12).all()
    np.testing.assert_allclose(w.sum(axis=1), 1.0, rtol=1e-12)
    angle = np.arccos(np.clip(dots, -1.0, 1.0))
    inv = 1.0 / (angle + pyshadow.views.FILTER_ANGLE_EPS)
    far = angle.min(axis=1) > 1e-3             # where arccos itself is accurate
    np.testing.assert_allclose(w[far], (inv / inv.sum(axis=1, keepdims=True))[far], rtol=1e-6)
    if views.layout == "zigzag":
        # the 2 x 2 grid cell around (theta, phi): rows r0, r0 + 1 (row 0 above
        # the first row, the last row repeated below the last), columns c0, c0 + 1
        # (cyclic); beyond the first or last of centred rows with P even, the
        # second pair is r0's opposite columns, across the pole
        T, P, off = views.params["theta"], views.params["phi"], views.params["row_offset"]
        rows = maps // P
        cols = np.where(rows % 2 == 0, maps % P, P - 1 - maps % P)
        th = np.arccos(np.clip(dirs[:, 1], -1, 1))
        ph = np.mod(np.arctan2(dirs[:, 2], dirs[:, 0]), 2 * np.pi)
        cap = (th < off * np.pi / T) | (th >= (T - 1 + off) * np.pi / T)
        across = cap & (off == 0.5) & (P % 2 == 0)
        assert (rows[:, 0] == rows[:, 1]).all() and (rows[:, 2] == rows[:, 3]).all()
        assert (rows[:, 2] == np.where(across, rows[:, 0], np.minimum(rows[:, 0] + 1, T - 1))).all()
        assert (((rows[:, 0] + off) * np.pi / T <= th + 1e-9) | (rows[:, 0] == 0)).all()
        assert ((th < (rows[:, 0] + 1 + off) * np.pi / T + 1e-9) | (rows[:, 0] == T - 1)).all()
        if P % 4 == 0:
            # across the pole: the four sides of the pole, a quarter turn apart, from the
            # column nearest phi (round: within half a column of it)
            q = np.where(across[:, None], np.arange(4) * (P // 4), 0)
            assert (cols[across] == (cols[across, :1] + q[across]) % P).all()
            near = np.abs(np.mod(ph - cols[:, 0] * 2 * np.pi / P + np.pi, 2 * np.pi) - np.pi)
            assert (near[across] <= np.pi / P + 1e-9).all()
        else:
            shift = np.where(across, P // 2, 0)
            assert (cols[across, 2] == (cols[across, 0] + shift[across]) % P).all()
            assert (cols[across, 3] == (cols[across, 1] + shift[across]) % P).all()
            assert (cols[across, 1] == (cols[across, 0] + 1) % P).all()
        rest = ~across
        assert (cols[rest, 2] == cols[rest, 0]).all() and (cols[rest, 3] == cols[rest, 1]).all()
        assert (cols[rest, 1] == (cols[rest, 0] + 1) % P).all()
        assert (np.mod(ph[rest] - cols[rest, 0] * 2 * np.pi / P + 1e-9, 2 * np.pi) < 2 * np.pi / P + 2e-9).all()
    else:
        # hilbert: the nearest first
        assert (np.diff(dots, axis=1) <= 1e-15).all()
    # on a map's own axis that map (and any sharing its direction, like the pole
    # row) weighs most, and more than 90 % (the least, 96 %, next to the zigzag
    # poles, where a row's maps lie 0.002 rad apart)
    maps, w = views.filter_window(views.directions)
    same = np.einsum("ijk,ik->ij", views.directions[maps], views.directions) > 1 - 1e-12
    assert ((w * same).max(axis=1) == w.max(axis=1)).all()
    assert ((w * same).sum(axis=1) > 0.9).all()


def test_filter_window_refuses_custom_layouts_and_bad_directions():
    d = np.eye(3)
    views = pyshadow.ViewSet(d, np.stack([np.roll(np.eye(3), -i - 1, axis=0) for i in range(3)]))
    with pytest.raises(ValueError, match="no map grid"):
        views.filter_window(d)
    zigzag = pyshadow.ViewSet.zigzag(8, 16)
    for bad in ([[0.0, 0.0, 0.0]], [[np.nan, 1.0, 0.0]], [[np.inf, 0.0, 0.0]]):
        with pytest.raises(ValueError, match="finite and non-zero"):
            zigzag.filter_window(bad)
    # any length: the window of 3 w is that of w
    w = np.random.default_rng(0).normal(size=(100, 3))
    a, b = zigzag.filter_window(w), zigzag.filter_window(3 * w)
    assert (a[0] == b[0]).all()
    np.testing.assert_allclose(a[1], b[1], rtol=1e-12)


# -- argument checks: sizes, hemispheres, given directions and bases ------------------------------
@pytest.mark.parametrize("args, exc, match", [
    ((2.7, 5.9), TypeError, "theta must be an int, got 2.7"),           # was a 2 x 5 grid
    ((4, 8.0), TypeError, "phi must be an int, got 8.0"),
    (("16", "32"), TypeError, "theta must be an int, got '16'"),         # was accepted
    ((True, 4), TypeError, "theta must be an int, got True"),
    ((np.nan, 4), TypeError, "theta must be an int, got nan"),          # was "cannot convert float NaN"
    ((4, np.inf), TypeError, "phi must be an int, got inf"),
    ((100000, 200000), ValueError, "theta must be in 1..65536, got 100000"),     # was a raw MemoryError
    ((8, 65537), ValueError, "phi must be in 1..65536, got 65537"),
    ((2048, 2048), ValueError, r"theta \* phi must be at most 2097152 \(2\*\*21\), got 2048x2048"),
    ((4, 8, "0.5"), TypeError, r"row_offset must be a number \(0 or 0.5\), got '0.5'"),
    ((4, 8, True), TypeError, r"row_offset must be a number \(0 or 0.5\), got True"),
])
def test_zigzag_requires_integer_sizes_in_range(args, exc, match):
    with pytest.raises(exc, match=f"^ViewSet.zigzag: {match}$"):
        pyshadow.ViewSet.zigzag(*args)


@pytest.mark.parametrize("args, exc, match", [
    ((2.9,), TypeError, "level must be an int, got 2.9"),               # was level 2
    (("3",), TypeError, "level must be an int, got '3'"),
    ((True,), TypeError, "level must be an int, got True"),
    ((None,), TypeError, "level must be an int, got None"),
    ((11,), ValueError, "level must be in 0..10, got 11"),
    ((-1,), ValueError, "level must be in 0..10, got -1"),
    ((3, "no"), TypeError, "hemispheres must be a bool, got 'no'"),     # was hemispheres on
    ((3, 1), TypeError, "hemispheres must be a bool, got 1"),
    ((3, None), TypeError, "hemispheres must be a bool, got None"),
])
def test_hilbert_requires_an_integer_level_and_a_bool(args, exc, match):
    with pytest.raises(exc, match=f"^ViewSet.hilbert: {match}$"):
        pyshadow.ViewSet.hilbert(*args)


def test_integer_sizes_of_any_integer_type_give_the_same_view_sets():
    """NumPy integers and bools are accepted and give the sets Python ints give, bit for bit; the
    largest zigzag (2**21 maps) is allowed."""
    a, b = pyshadow.ViewSet.zigzag(8, 16), pyshadow.ViewSet.zigzag(np.int64(8), np.uint16(16), np.float32(0.5))
    assert a.directions.tobytes() == b.directions.tobytes() and a.bases.tobytes() == b.bases.tobytes()
    assert b.params == {"theta": 8, "phi": 16, "row_offset": 0.5} and type(b.params["theta"]) is int
    for hemi in (True, np.bool_(True)):
        c, d = pyshadow.ViewSet.hilbert(3, True), pyshadow.ViewSet.hilbert(np.int8(3), hemi)
        assert c.bases.tobytes() == d.bases.tobytes() and d.params == {"level": 3, "hemispheres": True}
    assert pyshadow.ViewSet.maps_for("zigzag", {"theta": 1024, "phi": 2048}) == pyshadow.views.MAX_MAPS


def test_zigzag_grid_is_unchanged():
    """The directions of the grid, bit for bit: thesis eq. 5.1 at the Listing 5.1 angles, written out."""
    for T, P, off in [(3, 5, 0.5), (4, 6, 0.0), (1, 1, 0.5), (16, 32, 0.5)]:
        v = pyshadow.ViewSet.zigzag(T, P, off)
        rows = np.repeat(np.arange(T), P)
        k = np.tile(np.arange(P), T)
        th = (rows + off) * (np.pi / T)
        ph = np.where(rows % 2 == 0, k, P - 1 - k) * (2.0 * np.pi / P)
        want = np.stack([np.sin(th) * np.cos(ph), np.cos(th), np.sin(th) * np.sin(ph)], axis=-1)
        assert v.directions.tobytes() == want.tobytes()


@pytest.mark.parametrize("make", LAYOUTS)
def test_given_view_sets_of_the_layouts_pass_their_check(make):
    """The layouts' own directions and bases (and float32 copies of them) are within the tolerance of
    the check, and are kept as given."""
    v = make()
    w = pyshadow.ViewSet(v.directions, v.bases)
    assert w.directions is v.directions and w.bases is v.bases and w.layout == "custom"
    pyshadow.ViewSet(v.directions.astype(np.float32), v.bases.astype(np.float32))
    q = v.directions[::7]
    np.testing.assert_allclose(v.directions[w.nearest(q)], q, atol=1e-12)      # a pole row: any of its maps


def _one_view():
    return np.array([[0, 1.0, 0]]), np.array([[[0, 0, 1.0], [1.0, 0, 0], [0, 1.0, 0]]])     # u x v = d


@pytest.mark.parametrize("change, match", [
    (lambda d, b: (d * 2, b), r"1 directions are not unit vectors \(first: map 0, direction \[0.0, 2.0, 0.0\]"),
    (lambda d, b: (d * 0, b * 0), "1 directions are not unit vectors"),
    (lambda d, b: (d, b * 0), r"1 bases are not orthonormal \(rows u, v, d of unit length, at right angles\)"),
    (lambda d, b: (d, b * 2), "1 bases are not orthonormal"),
    (lambda d, b: (d, b + [[0, 0, 1e-5], [0, 0, 0], [0, 0, 0]]), "1 bases are not orthonormal"),
    (lambda d, b: (d, b[:, [1, 0, 2]]), r"1 bases are left-handed \(u x v = -d\)"),
    (lambda d, b: (d, np.eye(3)[None]), r"1 bases do not end with their map's direction \(row d_k\)"),
    (lambda d, b: (-d, b), "1 bases do not end with their map's direction"),
])
def test_given_directions_and_bases_must_be_unit_and_orthonormal(change, match):
    """Zero bases rendered nothing, silently; doubled directions and bases were taken as they came."""
    d, b = change(*_one_view())
    with pytest.raises(ValueError, match="^ViewSet: " + match):
        pyshadow.ViewSet(d, b)
    pyshadow.ViewSet(*_one_view())
    d, b = _one_view()
    pyshadow.ViewSet(d * (1 + 9e-7), b + [[0, 0, 4e-7], [0, 0, 0], [0, 0, 0]])      # within 1e-6


@pytest.mark.parametrize("args, exc, match", [
    ((np.zeros((2, 2)), np.zeros((2, 3, 3))), ValueError,
     r"ViewSet: directions must have shape \(N, 3\), got \(2, 2\)"),
    ((np.array([0, 1.0, 0]), np.eye(3)), ValueError, r"ViewSet: directions must have shape \(N, 3\), got \(3,\)"),
    ((*_one_view()[:1], np.eye(3)[None].repeat(2, 0)), ValueError,
     r"ViewSet: bases must have shape \(D, 3, 3\) for 1 directions, got \(2, 3, 3\)"),
    ((_one_view()[0], np.eye(3)), ValueError, r"ViewSet: bases must have shape \(D, 3, 3\) for 1 directions"),
    ((np.array([["a", "b", "c"]]), _one_view()[1]), TypeError, "ViewSet: directions must be numeric"),
    ((_one_view()[0], np.ones((1, 3, 3), complex)), TypeError, "ViewSet: bases must be numeric, got complex128"),
    ((np.array([[0, np.nan, 0]]), _one_view()[1]), ValueError, "ViewSet: directions and bases must be finite"),
])
def test_given_view_sets_must_have_the_documented_shapes(args, exc, match):
    with pytest.raises(exc, match=match):
        pyshadow.ViewSet(*args)
    assert len(pyshadow.ViewSet(np.zeros((0, 3)), np.zeros((0, 3, 3)))) == 0


def test_nearest_and_filter_window_refuse_other_shapes_clearly():
    """An (N, 2) array gave "cannot reshape array of size 4 into shape (3)"."""
    views = pyshadow.ViewSet.zigzag(4, 8)
    for bad, shape in [(np.zeros((2, 2)), r"\(2, 2\)"), (np.ones((2, 3, 1)), r"\(2, 3, 1\)"),
                       (np.ones(6), r"\(6,\)")]:
        with pytest.raises(ValueError, match=rf"^nearest: directions must have shape \(N, 3\), got {shape}$"):
            views.nearest(bad)
        with pytest.raises(ValueError, match=rf"^filter_window: directions must have shape \(N, 3\), got {shape}$"):
            views.filter_window(bad)
    with pytest.raises(TypeError, match="^nearest: directions must be numeric"):
        views.nearest(np.array([["a", "b", "c"]]))
    # one direction as (3,) is one row, as before
    assert views.nearest(np.array([0, 1.0, 0.2])).tolist() == views.nearest(np.array([[0, 1.0, 0.2]])).tolist()


@pytest.mark.parametrize("layout, params, message", [
    ("zigzag", {"theta": 8}, "ViewSet.from_params: zigzag parameters miss 'phi' (expected 'theta', 'phi'; optional "
                             "'row_offset'), got ['theta']"),
    ("zigzag", {"row_offset": 0.5}, "ViewSet.from_params: zigzag parameters miss 'theta', 'phi' (expected 'theta', "
                                    "'phi'; optional 'row_offset'), got ['row_offset']"),
    ("hilbert", {}, "ViewSet.from_params: hilbert parameters miss 'level' (expected 'level'; optional "
                    "'hemispheres'), got []"),
    ("spiral", {}, "unknown view-set layout 'spiral'"),
])
def test_from_params_names_missing_parameters(layout, params, message):
    """A missing key was a bare KeyError('phi'), in from_params and in maps_for (which checks a CSM file's
    header): both name the keys now, each naming itself."""
    with pytest.raises(ValueError) as e:
        pyshadow.ViewSet.from_params(layout, params)
    assert str(e.value) == message
    with pytest.raises(ValueError) as e:
        pyshadow.ViewSet.maps_for(layout, params)
    assert str(e.value) == message.replace("ViewSet.from_params:", "ViewSet.maps_for:")
    assert [pyshadow.ViewSet.maps_for(*a) for a in [("zigzag", {"theta": 4, "phi": 6}), ("hilbert", {"level": 2}),
            ("hilbert", {"level": 2, "hemispheres": True}), ("hilbert", {"level": 3, "hemispheres": False})]] \
        == [24, 16, 32, 64]
    for views, layout, params in [(pyshadow.ViewSet.zigzag(4, 6), "zigzag", {"theta": 4, "phi": 6, "row_offset": 0.5}),
                                  (pyshadow.ViewSet.zigzag(4, 6, 0.0), "zigzag", {"theta": 4, "phi": 6}),
                                  (pyshadow.ViewSet.hilbert(2, True), "hilbert", {"level": 2, "hemispheres": True})]:
        back = pyshadow.ViewSet.from_params(layout, params)
        assert back.params == views.params
        np.testing.assert_array_equal(back.bases, views.bases)

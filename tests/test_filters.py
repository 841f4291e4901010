"""Edge-aware AO filters (kernels/filters.cl) against their NumPy references and invariants."""
import numpy as np
import pytest

from pyshadow import _cl
from pyshadow.filters import (
    bilateral,
    bilateral_reference,
    edge_aware_box,
    edge_aware_box_reference,
    separable_reference,
    upsample,
    upsample_reference,
)

H, W = 40, 56


def unit(v):
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def synthetic_gbuffer(seed=7, h=H, w=W):
    """A small G-buffer with a tilted floor, a box in front of it (depth step),
    a crease of two planes, a spherical bump (continuously varying normals),
    a thin one-pixel post at an odd column, background (a block and scattered
    pixels, AO NaN there) and noisy AO."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    depth = 12.0 + 0.04 * x - 0.03 * y                     # tilted floor
    normal = np.broadcast_to(unit([0.2, 0.9, 0.3]), (h, w, 3)).copy()
    box = (y >= 6) & (y < 22) & (x >= 8) & (x < 26)         # box face, 40 % nearer
    depth[box] = 7.0 + 0.02 * x[box]
    normal[box] = unit([0.0, 0.0, 1.0])
    left = (y >= 26) & (x < 10)                              # crease at x = 10
    right = (y >= 26) & (x >= 10) & (x < 20)
    depth[left] = 9.0 + 0.05 * (10 - x[left])
    depth[right] = 9.0 + 0.05 * (x[right] - 10)
    normal[left] = unit([-0.7, 0.0, 0.7])
    normal[right] = unit([0.7, 0.0, 0.7])
    r2 = (y - 28.0) ** 2 + (x - 40.0) ** 2                   # spherical bump of radius 9
    bump = r2 < 81.0
    hgt = np.sqrt(np.clip(81.0 - r2, 0.0, None))
    depth[bump] = 10.0 - 0.1 * hgt[bump]
    normal[bump] = unit(np.stack([x - 40.0, y - 28.0, hgt], -1)[bump])
    post = (x == 31) & (y >= 4) & (y < 24)                   # thin post, nearer than the floor
    depth[post] = 5.0
    normal[post] = unit([0.0, 0.0, 1.0])
    bg = (y < 5) & (x >= w - 12)
    bg |= rng.random((h, w)) < 0.02
    depth[bg] = np.inf
    normal[bg] = 0.0
    smooth = 0.55 + 0.3 * np.sin(x / 7.0) * np.cos(y / 9.0)
    ao = np.clip(smooth + rng.uniform(-0.2, 0.2, (h, w)), 0.0, 1.0)
    ao[bg] = np.nan
    return ao.astype(np.float32), depth.astype(np.float32), normal.astype(np.float32)


def neighbour_pairs(depth, normal):
    """(relative depth difference, normal cosine) of every horizontal/vertical
    neighbour pair of surface pixels."""
    rel, cos = [], []
    for a, b in (((slice(None), slice(1, None)), (slice(None), slice(None, -1))),
                 ((slice(1, None), slice(None)), (slice(None, -1), slice(None)))):
        za, zb = depth[a].astype(np.float64), depth[b].astype(np.float64)
        ok = np.isfinite(za) & np.isfinite(zb)
        rel.append(np.abs(za[ok] - zb[ok]) / za[ok])
        cos.append(np.sum(normal[a] * normal[b], axis=-1)[ok])
    return np.concatenate(rel), np.concatenate(cos)


@pytest.fixture(scope="module")
def gbuf():
    ao, depth, normal = synthetic_gbuffer()
    # the data holds the cases the filters must handle
    rel, cos = neighbour_pairs(depth, normal)
    assert (rel > 0.2).sum() > 50                       # depth discontinuities
    assert ((rel < 0.01) & (cos > 0.999)).mean() > 0.5  # and smooth surfaces
    assert ((cos < 0.5) & (rel < 0.02)).any()           # a crease: same depth, other normal
    bg = ~np.isfinite(depth)
    assert bg.sum() > 60 and np.isnan(ao[bg]).all()     # background, AO NaN there
    orient = np.unique(np.round(normal[~bg], 2), axis=0)
    assert len(orient) > 20                             # many normal orientations
    box = bilateral_reference(ao, depth, normal, radius=3, sigma_spatial=1e9, sigma_depth=1e9,
                              sigma_normal=1e9)
    assert np.nanstd(ao - box) > 0.05  # noisy
    return ao, depth, normal


# --------------------------------------------------------------------------
# kernels against references
# --------------------------------------------------------------------------
@pytest.mark.parametrize("radius, ss, sz, sn", [(None, 2.0, 0.02, 0.2), (3, 1.5, 0.05, 0.3),
                                                (6, 4.0, 0.01, 0.1)])
def test_bilateral_matches_reference(gbuf, radius, ss, sz, sn):
    ao, depth, normal = gbuf
    ours = bilateral(ao, depth, normal, radius=radius, sigma_spatial=ss, sigma_depth=sz, sigma_normal=sn)
    ref = bilateral_reference(ao, depth, normal, radius=radius, sigma_spatial=ss, sigma_depth=sz,
                              sigma_normal=sn)
    assert ours.dtype == np.float32 and ours.shape == (H, W)
    surf = np.isfinite(depth)
    assert np.abs(ours[surf] - ref[surf]).max() <= 1e-5
    assert np.abs(ours[surf] - ao[surf]).max() > 0.05   # it did filter


@pytest.mark.parametrize("radius, ss", [(None, 2.0), (5, 3.0)])
def test_bilateral_separable_matches_reference(gbuf, radius, ss):
    ao, depth, normal = gbuf
    ours = bilateral(ao, depth, normal, radius=radius, sigma_spatial=ss, separable=True)
    ref = separable_reference(ao, depth, normal, radius=radius, sigma_spatial=ss)
    surf = np.isfinite(depth)
    assert np.abs(ours[surf] - ref[surf]).max() <= 1e-5
    full = bilateral_reference(ao, depth, normal, radius=radius, sigma_spatial=ss)
    assert np.abs(ref[surf] - full[surf]).max() > 1e-3  # an approximation, not the 2-D filter


@pytest.mark.parametrize("size, dt, nt", [(7, 0.02, 0.9), (3, 0.05, 0.5), (11, 0.01, 0.99)])
def test_edge_aware_box_matches_reference(gbuf, size, dt, nt):
    ao, depth, normal = gbuf
    ours = edge_aware_box(ao, depth, normal, size=size, depth_threshold=dt, normal_threshold=nt)
    ref = edge_aware_box_reference(ao, depth, normal, size=size, depth_threshold=dt, normal_threshold=nt)
    surf = np.isfinite(depth)
    assert np.abs(ours[surf] - ref[surf]).max() <= 1e-5
    assert np.abs(ours[surf] - ao[surf]).max() > 0.05


def footprint_min_rel(depth, s, r):
    """Per pixel, the smallest relative depth difference to one of its upsampling taps."""
    Hl, Wl = -(-depth.shape[0] // s), -(-depth.shape[1] // s)
    out = np.full(depth.shape, np.inf)
    for y, x in zip(*np.nonzero(np.isfinite(depth))):
        for i in range(max(y // s - r + 1, 0), min(y // s + r, Hl - 1) + 1):
            for j in range(max(x // s - r + 1, 0), min(x // s + r, Wl - 1) + 1):
                zq = float(depth[s * i, s * j])
                out[y, x] = min(out[y, x], abs(zq - float(depth[y, x])) / float(depth[y, x]))
    return out


@pytest.mark.parametrize("scale, radius", [(2, 2), (4, 2), (2, 1), (4, 3)])
def test_upsample_matches_reference(gbuf, scale, radius):
    ao, depth, normal = gbuf
    low = ao[::scale, ::scale].copy()
    assert np.isnan(low).any()                          # background samples are never read
    ours = upsample(low, depth, normal, radius=radius)
    ref = upsample_reference(low, depth, normal, radius=radius)
    assert ours.shape == (H, W) and ours.dtype == np.float32
    np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-5)
    # the thin post is seen by no low-res sample: those pixels take the fallback
    assert (footprint_min_rel(depth, scale, radius) > 0.3).sum() >= 5


def test_upsample_infers_scale(gbuf):
    ao, depth, normal = gbuf
    for s in (2, 4):
        low = ao[::s, ::s].copy()
        np.testing.assert_array_equal(upsample(low, depth, normal), upsample(low, depth, normal, scale=s))


@pytest.mark.parametrize("shape", [(1, 1), (1, 9), (9, 1), (3, 2)])
def test_filters_tiny_images_match_references(shape):
    ao, depth, normal = (a[: shape[0], : shape[1]].copy() for a in synthetic_gbuffer(3, 12, 12))
    depth[np.isinf(depth)] = 8.0                         # keep them all surface
    normal[np.all(normal == 0, axis=-1)] = [0.0, 0.0, 1.0]
    ao = np.nan_to_num(ao, nan=0.5)
    pairs = [(bilateral(ao, depth, normal), bilateral_reference(ao, depth, normal)),
             (bilateral(ao, depth, normal, separable=True), separable_reference(ao, depth, normal)),
             (edge_aware_box(ao, depth, normal), edge_aware_box_reference(ao, depth, normal))]
    for s in (2, 4):
        low = ao[::s, ::s].copy()
        pairs.append((upsample(low, depth, normal, scale=s), upsample_reference(low, depth, normal, scale=s)))
    for ours, ref in pairs:
        assert ours.shape == shape
        np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-5)


# --------------------------------------------------------------------------
# limits of the parameters
# --------------------------------------------------------------------------
def distinct_depth_gbuffer(seed=11):
    """Every pixel's depth differs from every other's; one normal; noisy AO."""
    rng = np.random.default_rng(seed)
    depth = (5.0 + 0.01 * np.arange(H * W).reshape(H, W)).astype(np.float32)
    depth = depth[:, rng.permutation(W)]
    normal = np.zeros((H, W, 3), np.float32)
    normal[..., 1] = 1.0
    ao = rng.random((H, W)).astype(np.float32)
    return ao, depth, normal


@pytest.mark.parametrize("separable", [False, True])
def test_bilateral_tiny_sigma_depth_is_identity(separable):
    ao, depth, normal = distinct_depth_gbuffer()
    assert len(np.unique(depth)) == H * W
    out = bilateral(ao, depth, normal, radius=3, sigma_spatial=2.0, sigma_depth=1e-12, sigma_normal=0.2,
                    separable=separable)
    np.testing.assert_array_equal(out, ao)


def box_mean(ao, depth, r):
    """Mean of ao over the window of radius r cut at the border, background left out."""
    out = ao.astype(np.float64).copy()
    for y in range(ao.shape[0]):
        for x in range(ao.shape[1]):
            if not np.isfinite(depth[y, x]):
                continue
            ys = slice(max(y - r, 0), y + r + 1)
            xs = slice(max(x - r, 0), x + r + 1)
            out[y, x] = ao[ys, xs][np.isfinite(depth[ys, xs])].astype(np.float64).mean()
    return out


def test_bilateral_huge_sigmas_give_box_mean(gbuf):
    ao, depth, normal = gbuf
    out = bilateral(ao, depth, normal, radius=3, sigma_spatial=1e9, sigma_depth=1e9, sigma_normal=1e9)
    expect = box_mean(ao, depth, 3)
    surf = np.isfinite(depth)
    np.testing.assert_allclose(out[surf], expect[surf], rtol=0, atol=1e-5)


def test_bilateral_separable_huge_sigmas_give_box_mean():
    ao, depth, normal = distinct_depth_gbuffer()        # no background: rectangles stay whole
    out = bilateral(ao, depth, normal, radius=4, sigma_spatial=1e9, sigma_depth=1e9, sigma_normal=1e9,
                    separable=True)
    np.testing.assert_allclose(out, box_mean(ao, depth, 4), rtol=0, atol=1e-5)


def test_bilateral_radius_zero_returns_input(gbuf):
    ao, depth, normal = gbuf
    np.testing.assert_array_equal(bilateral(ao, depth, normal, radius=0), ao)


def test_bilateral_default_radius_follows_sigma(gbuf):
    ao, depth, normal = gbuf
    np.testing.assert_array_equal(bilateral(ao, depth, normal, radius=None, sigma_spatial=1.2),
                                  bilateral(ao, depth, normal, radius=3, sigma_spatial=1.2))


def test_bilateral_is_scale_free(gbuf):
    ao, depth, normal = gbuf
    base = bilateral(ao, depth, normal)
    for unit_scale in (1e-3, 1e4):
        scaled = bilateral(ao, (depth * unit_scale).astype(np.float32), normal)
        np.testing.assert_allclose(scaled, base, rtol=0, atol=1e-5)


# --------------------------------------------------------------------------
# invariants
# --------------------------------------------------------------------------
FILTERS = {
    "bilateral": lambda a, d, n: bilateral(a, d, n),
    "separable": lambda a, d, n: bilateral(a, d, n, separable=True),
    "box": lambda a, d, n: edge_aware_box(a, d, n),
    "upsample2": lambda a, d, n: upsample(a[::2, ::2].copy(), d, n, fill=0.37),
    "upsample4": lambda a, d, n: upsample(a[::4, ::4].copy(), d, n, fill=0.37),
}


@pytest.mark.parametrize("name", list(FILTERS))
def test_filters_constant_image_unchanged(gbuf, name):
    _ao, depth, normal = gbuf
    ao = np.full((H, W), 0.37, np.float32)
    out = FILTERS[name](ao, depth, normal)
    np.testing.assert_allclose(out, 0.37, rtol=0, atol=1e-6)


@pytest.mark.parametrize("name", ["bilateral", "separable", "box"])
def test_filters_background_unchanged(gbuf, name):
    ao, depth, normal = gbuf
    ao = ao.copy()
    bg = ~np.isfinite(depth)
    ao[bg] = np.linspace(-3.0, 3.0, bg.sum())           # any value, NaN included, passes
    ao[np.argwhere(bg)[0][0], np.argwhere(bg)[0][1]] = np.nan
    out = FILTERS[name](ao, depth, normal)
    np.testing.assert_array_equal(out[bg], ao[bg])
    assert np.isfinite(out[~bg]).all()                  # never read by a neighbour
    assert out[~bg].min() >= 0.0 and out[~bg].max() <= 1.0


def test_upsample_background_gets_fill(gbuf):
    ao, depth, normal = gbuf
    out = upsample(ao[::2, ::2].copy(), depth, normal, fill=0.125)
    bg = ~np.isfinite(depth)
    assert (out[bg] == np.float32(0.125)).all()
    assert np.isfinite(out).all()


def step_gbuffer(edge_col=21, near=4.0, far=9.0):
    """Near plane left of ``edge_col`` (AO 0.2), far plane right of it (AO 0.9)."""
    x = np.arange(W)[None, :].repeat(H, 0)
    depth = np.where(x < edge_col, near, far).astype(np.float32)
    normal = np.zeros((H, W, 3), np.float32)
    normal[..., 2] = 1.0
    ao = np.where(x < edge_col, 0.2, 0.9).astype(np.float32)
    return ao, depth, normal, x < edge_col


def test_edge_aware_box_does_not_blur_across_depth_step():
    ao, depth, normal, left = step_gbuffer()
    out = edge_aware_box(ao, depth, normal, size=7)
    np.testing.assert_allclose(out, ao, rtol=0, atol=1e-6)
    # with the depth test disabled the same filter does blur the step
    blurred = edge_aware_box(ao, depth, normal, size=7, depth_threshold=10.0)
    assert np.abs(blurred - ao).max() > 0.2


def test_bilateral_does_not_blur_across_depth_step():
    ao, depth, normal, left = step_gbuffer()
    for separable in (False, True):
        out = bilateral(ao, depth, normal, separable=separable)
        np.testing.assert_allclose(out, ao, rtol=0, atol=1e-6)
    assert np.abs(bilateral(ao, depth, normal, sigma_depth=1e9) - ao).max() > 0.1


def test_edge_aware_box_does_not_blur_across_crease():
    ao, depth, normal, left = step_gbuffer(near=6.0, far=6.0)   # same depth, normals apart
    normal[left] = unit([0.6, 0.0, 0.8])
    out = edge_aware_box(ao, depth, normal, size=7)
    np.testing.assert_allclose(out, ao, rtol=0, atol=1e-6)


@pytest.mark.parametrize("scale", [2, 4])
def test_upsample_reproduces_smooth_field(scale):
    # flat, fronto-parallel G-buffer: only the spatial weights act
    depth = np.full((H, W), 6.0, np.float32)
    normal = np.zeros((H, W, 3), np.float32)
    normal[..., 2] = 1.0
    kx, ky = 2 * np.pi / 48, 2 * np.pi / 40
    y, x = np.mgrid[0:H, 0:W].astype(np.float64)
    f = 0.5 + 0.3 * np.sin(kx * x) * np.cos(ky * y)
    out = upsample(f[::scale, ::scale].astype(np.float32), depth, normal)   # default footprint
    sigma, radius = scale / 2, 2                                            # the defaults
    # Tolerance: out_p = sum_q w_q f(q) / sum_q w_q, so by Taylor's theorem
    # |out_p - f(p)| <= |grad f| |c_p| + 1/2 |Hess f| m_p, c_p the weighted mean
    # offset of the taps from p, m_p their weighted mean squared distance;
    # here |grad f| <= 0.3 |k| and |Hess f| <= 0.3 |k|^2.
    Hl, Wl = -(-H // scale), -(-W // scale)
    bound = np.zeros((H, W))
    for yy in range(H):
        for xx in range(W):
            ii = np.arange(max(yy // scale - radius + 1, 0), min(yy // scale + radius, Hl - 1) + 1)
            jj = np.arange(max(xx // scale - radius + 1, 0), min(xx // scale + radius, Wl - 1) + 1)
            dy, dx = np.meshgrid(scale * ii - yy, scale * jj - xx, indexing="ij")
            w = np.exp(-(dx**2 + dy**2) / (2 * sigma**2))
            c = np.hypot((w * dx).sum(), (w * dy).sum()) / w.sum()
            m = (w * (dx**2 + dy**2)).sum() / w.sum()
            bound[yy, xx] = 0.3 * np.hypot(kx, ky) * c + 0.5 * 0.3 * (kx**2 + ky**2) * m
    err = np.abs(out - f)
    assert (err <= bound + 1e-5).all(), float((err - bound).max())
    # and the bound means something wherever samples lie on both sides (all but
    # the last (H-1) % scale rows and columns, which are extrapolated): 5 % of
    # the field's 0.6 range at scale 2, 12 % at scale 4 (measured errors there
    # are about 2.5 times smaller still)
    inside = (y <= scale * (Hl - 1)) & (x <= scale * (Wl - 1))
    assert bound[inside].max() < (0.03 if scale == 2 else 0.075)


def test_upsample_does_not_bleed_across_depth_edge():
    ao, depth, normal, left = step_gbuffer(edge_col=21)  # not on the sample grid of 2 or 4
    for s in (2, 4):
        out = upsample(ao[::s, ::s].copy(), depth, normal, scale=s)
        np.testing.assert_allclose(out, ao, rtol=0, atol=1e-6)
    # without the depth term the pixels beside the edge do mix
    mixed = upsample(ao[::4, ::4].copy(), depth, normal, scale=4, sigma_depth=1e9)
    assert np.abs(mixed - ao).max() > 0.1


def test_upsample_thin_object_uses_closest_depth_tap():
    # a one-pixel post at odd column 5 in front of a wall whose depth grows with x:
    # no sample lands on the post, so every post pixel falls back to the tap
    # with the closest depth, the nearest column 2 (taps are columns 2, 4, 6, 8)
    y, x = np.mgrid[0:H, 0:W]
    depth = (10.0 + x).astype(np.float32)
    normal = np.zeros((H, W, 3), np.float32)
    normal[..., 2] = 1.0
    post = x == 5
    depth[post] = 3.0
    normal[post] = unit([1.0, 0.0, 1.0])
    low = np.broadcast_to(np.arange((W + 1) // 2) / 100.0, (H // 2, (W + 1) // 2))
    out = upsample(low.astype(np.float32), depth, normal, scale=2)
    np.testing.assert_array_equal(out[post], np.float32(0.01))
    ref = upsample_reference(low.astype(np.float32), depth, normal, scale=2)
    np.testing.assert_array_equal(ref[post], np.float32(0.01))


def test_upsample_pixel_without_surface_taps_gets_fill():
    depth = np.full((8, 8), np.inf, np.float32)
    normal = np.zeros((8, 8, 3), np.float32)
    depth[3, 5] = 2.0
    normal[3, 5] = [0.0, 1.0, 0.0]
    low = np.full((4, 4), np.nan, np.float32)
    out = upsample(low, depth, normal, scale=2, fill=0.75)
    assert (out == np.float32(0.75)).all()


# --------------------------------------------------------------------------
# errors: raised before anything is launched
# --------------------------------------------------------------------------
def _good():
    ao, depth, normal = synthetic_gbuffer(5, 8, 24)
    return {"ao": ao, "depth": depth, "normal": normal}


def _with(**changes):
    def make():
        args = _good()
        for key, fn in changes.items():
            args[key] = fn(args[key]) if callable(fn) else fn
        return args
    return make


def _set(index, value):
    def fn(a):
        a = a.copy()
        a[index] = value
        return a
    return fn


def _surface_pixel():
    """A pixel with finite depth that is also a sample of the 1/2-resolution image."""
    depth = _good()["depth"]
    return tuple(next(p for p in np.argwhere(np.isfinite(depth)) if (p % 2 == 0).all()))


P = _surface_pixel()
IMAGE_ERRORS = [
    (_with(ao=lambda a: np.zeros(a.shape, np.int32)), TypeError, "float array"),
    (_with(ao=lambda a: a[None]), ValueError, "expected 2 vs got 3"),
    (_with(ao=lambda a: a[:, :-1]), ValueError, "expected (8, 24) vs got (8, 23)"),
    (_with(normal=lambda n: n[..., :2]), ValueError, "expected (8, 24, 3) vs got (8, 24, 2)"),
    (_with(depth=lambda d: np.ones(d.shape, np.int64)), TypeError, "depth must be a float array"),
    (_with(ao=_set(P, np.nan)), ValueError, "NaN/inf"),
    (_with(ao=_set(P, np.inf)), ValueError, "NaN/inf"),
    (_with(depth=_set(P, np.nan)), ValueError, "NaN"),
    (_with(depth=_set(P, -1.0)), ValueError, "-1.0"),
    (_with(depth=_set(P, 0.0)), ValueError, "> 0"),
    (_with(depth=_set(P, -np.inf)), ValueError, "-inf"),
    (_with(depth=_set(P, 1e-42)), ValueError, "at least 1.18e-38"),
    (_with(normal=_set(P, [0.0, 0.0, 2.0])), ValueError, "unit length"),
    (_with(depth=lambda d: d[:0]), ValueError, "empty"),
]
PARAM_ERRORS = [
    ({"radius": -1}, ValueError, "0..32, got -1"),
    ({"radius": 33}, ValueError, "0..32, got 33"),
    ({"radius": 2.5}, TypeError, "int"),
    ({"sigma_spatial": 0.0}, ValueError, "sigma_spatial"),
    ({"sigma_depth": -0.1}, ValueError, "sigma_depth must be finite and > 0, got -0.1"),
    ({"sigma_normal": float("nan")}, ValueError, "sigma_normal"),
    ({"sigma_spatial": float("inf")}, ValueError, "sigma_spatial"),
    ({"sigma_depth": "0.1"}, TypeError, "sigma_depth"),
    ({"separable": 1}, TypeError, "separable"),
]
BOX_ERRORS = [
    ({"size": 6}, ValueError, "odd"),
    ({"size": 0}, ValueError, "1..65, got 0"),
    ({"size": 67}, ValueError, "1..65, got 67"),
    ({"depth_threshold": 0.0}, ValueError, "depth_threshold"),
    ({"normal_threshold": 1.0}, ValueError, "[-1, 1)"),
    ({"normal_threshold": -1.5}, ValueError, "[-1, 1)"),
]
UPSAMPLE_ERRORS = [
    ({"ao_low": lambda a: a[::3, ::3].copy()}, ValueError, "1/2 or 1/4"),
    ({"ao_low": lambda a: a[::2, ::2].copy(), "scale": 3}, ValueError, "scale must be one of (2, 4)"),
    ({"ao_low": lambda a: a[::2, ::2].copy(), "scale": 4}, ValueError,
     "expected (2, 6) vs got (4, 12)"),
    ({"ao_low": lambda a: np.zeros((4, 12), np.uint8)}, TypeError, "ao_low must be a float"),
    ({"ao_low": lambda a: a[::2, ::2].copy(), "radius": 0}, ValueError, "1..8, got 0"),
    ({"ao_low": lambda a: a[::2, ::2].copy(), "fill": float("nan")}, ValueError, "fill"),
    ({"ao_low": lambda a: _set(P, np.nan)(a)[::2, ::2].copy()}, ValueError, "ao_low holds"),
]


@pytest.fixture
def no_launch(monkeypatch):
    def refuse(*_a, **_k):
        raise AssertionError("a kernel was requested or a buffer made before validation failed")
    monkeypatch.setattr(_cl, "kernel", refuse)
    monkeypatch.setattr(_cl, "to_device", refuse)


def _raises(fn, args, kwargs, exc, match):
    with pytest.raises(exc) as info:
        fn(*args, **kwargs)
    assert match in str(info.value)


@pytest.mark.parametrize("fn", [bilateral, bilateral_reference, edge_aware_box,
                                edge_aware_box_reference])
@pytest.mark.parametrize("make, exc, match", IMAGE_ERRORS)
def test_filters_reject_bad_images(no_launch, fn, make, exc, match):
    a = make()
    _raises(fn, (a["ao"], a["depth"], a["normal"]), {}, exc, match)


@pytest.mark.parametrize("fn", [bilateral, bilateral_reference])
@pytest.mark.parametrize("kwargs, exc, match", PARAM_ERRORS)
def test_bilateral_rejects_bad_parameters(no_launch, fn, kwargs, exc, match):
    a = _good()
    _raises(fn, (a["ao"], a["depth"], a["normal"]), kwargs, exc, match)


@pytest.mark.parametrize("fn", [edge_aware_box, edge_aware_box_reference])
@pytest.mark.parametrize("kwargs, exc, match", BOX_ERRORS)
def test_edge_aware_box_rejects_bad_parameters(no_launch, fn, kwargs, exc, match):
    a = _good()
    _raises(fn, (a["ao"], a["depth"], a["normal"]), kwargs, exc, match)


@pytest.mark.parametrize("fn", [upsample, upsample_reference])
@pytest.mark.parametrize("kwargs, exc, match", UPSAMPLE_ERRORS)
def test_upsample_rejects_bad_arguments(no_launch, fn, kwargs, exc, match):
    a = _good()
    kwargs = dict(kwargs)
    low = kwargs.pop("ao_low")(a["ao"])
    _raises(fn, (low, a["depth"], a["normal"]), kwargs, exc, match)


def test_upsample_rejects_bad_guide(no_launch):
    a = _good()
    _raises(upsample, (a["ao"][::2, ::2].copy(), a["depth"], a["normal"][:, :-1]), {},
            ValueError, "expected (8, 24, 3) vs got (8, 23, 3)")

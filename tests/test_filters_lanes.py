"""The lane forms of the filters (kernels/filters.cl, filter_math.h) are the scalar ones, bit for bit.

Each filter works on LANES pixels of a row a work-item; its output must not
depend on the width. At every width the device passed the probe at (and the
one ``PYSHADOW_LANES`` pins) every filter is compared bit for bit with its
output at ``LANES = 1`` -- one pixel a work-item, the scalar code -- on
awkward sizes (1x1, widths that are not a multiple of any width, images
narrower than a lane vector), wild G-buffers (random normals, holes,
depths over many decades, -0.0 and NaN AO) and every radius class, and
with the NumPy references. The vector ``exp`` and ``dot`` of
filter_math.h are compared with the scalar builtins directly, and the
generic forms (``CPU_CLANG = 0``: one builtin call a lane) with the inline
ones. Last, the quick float32 screen of unit normals in filters_validate
(which spares the filters most of their checking time) keeps the exact rule.
"""
import numpy as np
import pyopencl as cl
import pytest

from pyshadow import _cl, filters
from pyshadow.filters import (
    bilateral,
    bilateral_reference,
    edge_aware_box,
    edge_aware_box_reference,
    upsample,
    upsample_reference,
)

SIZES = [(1, 1), (5, 7), (3, 37), (17, 13), (9, 33), (24, 41)]


def widths():
    """The widths to check: those the probe passed and the one in use (PYSHADOW_LANES pins it)."""
    choice = _cl.lane_choice()
    return sorted({w for w in choice["supported"] + [choice["lanes"]] if w != 1})


def gbuffer(kind, h, w, seed=0):
    """(ao, depth, normal) float32 of one of three kinds (see the module docstring)."""
    rng = np.random.default_rng(seed + 1000 * h + w)
    if kind == "wild":
        depth = (5.0 + 3.0 * rng.random((h, w))).astype(np.float32)
        v = rng.standard_normal((h, w, 3))
        ao = rng.random((h, w)).astype(np.float32)
        ao[rng.random((h, w)) < 0.1] = -0.0
    elif kind == "smooth":
        y, x = np.mgrid[0:h, 0:w].astype(np.float64)
        depth = (10 + 0.01 * x + 0.02 * y + 2.0 * ((x // 5 + y // 4) % 3 == 0)).astype(np.float32)
        v = np.stack([0.1 * np.sin(x / 5), np.ones_like(x), 0.1 * np.cos(y / 4)], -1)
        v += 0.05 * rng.standard_normal((h, w, 3))
        ao = np.clip(0.5 + 0.3 * np.sin(x / 3) + 0.1 * rng.standard_normal((h, w)), 0, 1).astype(np.float32)
    else:                                   # "decades": depths from 1e-30 to 1e30, AO of both signs
        depth = (10.0 ** rng.uniform(-30, 30, (h, w))).astype(np.float32)
        v = rng.standard_normal((h, w, 3)) + [0.0, 3.0, 0.0]
        ao = rng.uniform(-2, 2, (h, w)).astype(np.float32)
    normal = (v / np.linalg.norm(v, axis=-1, keepdims=True)).astype(np.float32)
    hole = rng.random((h, w)) < 0.15
    depth[hole] = np.inf
    ao[hole] = np.nan
    normal[hole] = 0.0
    return ao, depth, normal


def outputs(ao, depth, normal):
    """Every filter variant of an image, as {name: float32 array}."""
    out = {}
    for r in (1, 3, 9):
        out[f"bilateral r{r}"] = bilateral(ao, depth, normal, radius=r)
        out[f"separable r{r}"] = bilateral(ao, depth, normal, radius=r, separable=True)
    out["bilateral sharp"] = bilateral(ao, depth, normal, radius=2, sigma_spatial=0.3, sigma_depth=1e-3,
                                       sigma_normal=1e-2)
    out["bilateral flat"] = bilateral(ao, depth, normal, radius=2, sigma_spatial=1e30, sigma_depth=1e30,
                                      sigma_normal=1e30)
    for size in (1, 3, 9):
        out[f"box {size}"] = edge_aware_box(ao, depth, normal, size=size, depth_threshold=0.05,
                                            normal_threshold=0.5)
    for s in (2, 4):
        low = np.ascontiguousarray(ao[::s, ::s])
        for r, fill in ((1, 1.0), (2, 0.0), (5, -0.37)):
            out[f"upsample x{s} r{r}"] = upsample(low, depth, normal, scale=s, radius=r, fill=fill)
        out[f"upsample x{s} sharp"] = upsample(low, depth, normal, scale=s, sigma_spatial=0.2,
                                               sigma_depth=1e-3, sigma_normal=1e-2)
    return out


def assert_same_bits(got, want, what):
    for name in want:
        a, b = got[name].view(np.int32), want[name].view(np.int32)
        assert np.array_equal(a, b), f"{what}, {name}: {int((a != b).sum())} pixel(s) differ"


@pytest.mark.parametrize("kind", ["wild", "smooth", "decades"])
def test_filters_are_bit_identical_at_every_lane_width(kind):
    ws = widths()
    if not ws:
        pytest.skip("the device runs 1 lane only")
    for h, w in SIZES:
        args = gbuffer(kind, h, w)
        with _cl.use_lanes(1):
            want = outputs(*args)
        for lanes in ws:
            with _cl.use_lanes(lanes):
                assert_same_bits(outputs(*args), want, f"{kind} {h}x{w} at {lanes} lanes")


def test_generic_lane_forms_equal_inline_ones(monkeypatch):
    """CPU_CLANG = 0 (one scalar exp and dot call a lane, vloadN) gives the inline forms' bits."""
    ws = widths()
    if not ws:
        pytest.skip("the device runs 1 lane only")
    args = gbuffer("wild", 9, 33)
    with _cl.use_lanes(ws[-1]):
        want = outputs(*args)
        kernel = _cl.kernel

        def generic(src, name, defines=None):
            return kernel(src, name, {**(defines or {}), "CPU_CLANG": 0})
        monkeypatch.setattr(_cl, "kernel", generic)
        assert_same_bits(outputs(*args), want, f"CPU_CLANG=0 at {ws[-1]} lanes")


@pytest.mark.parametrize("h, w", [(1, 1), (5, 7), (17, 13)])
def test_lane_filters_match_references(h, w):
    ao, depth, normal = gbuffer("smooth", h, w)
    for lanes in widths() + [1]:
        with _cl.use_lanes(lanes):
            np.testing.assert_allclose(bilateral(ao, depth, normal, radius=3),
                                       bilateral_reference(ao, depth, normal, radius=3), rtol=0, atol=2e-6)
            np.testing.assert_allclose(edge_aware_box(ao, depth, normal, size=5),
                                       edge_aware_box_reference(ao, depth, normal, size=5), rtol=0,
                                       atol=2e-6)
            for s in (2, 4):
                low = np.ascontiguousarray(ao[::s, ::s])
                np.testing.assert_allclose(upsample(low, depth, normal, scale=s, radius=2),
                                           upsample_reference(low, depth, normal, scale=s, radius=2),
                                           rtol=0, atol=2e-6)


MATH_KERNELS = r"""
__kernel void exp_scalar(__global const float *x, __global float *o)
{ const int i = get_global_id(0); o[i] = exp(x[i]); }
__kernel void exp_lanes(__global const float *x, __global float *o)
{ const int i = get_global_id(0); VSTORE(EXP_V(VLOAD(i, x)), i, o); }
__kernel void dot_scalar(__global const float *a, __global float *o)
{
    const int i = get_global_id(0);
    o[i] = dot((float3)(a[i], a[LANES * 4096 + i], a[2 * LANES * 4096 + i]),
               (float3)(a[3 * LANES * 4096 + i], a[4 * LANES * 4096 + i], a[5 * LANES * 4096 + i]));
}
__kernel void dot_lanes(__global const float *a, __global float *o)
{
    const int i = get_global_id(0);
    const fv3 p = {VLOAD(i, a), VLOAD(i + 4096, a), VLOAD(i + 2 * 4096, a)};
    const fv3 q = {VLOAD(i + 3 * 4096, a), VLOAD(i + 4 * 4096, a), VLOAD(i + 5 * 4096, a)};
    VSTORE(DOT_V(p, q), i, o);
}
"""


def _math_results(lanes, x, pairs, cpu_clang=None):
    defines = {"LANES": lanes} if cpu_clang is None else {"LANES": lanes, "CPU_CLANG": cpu_clang}
    prg = _cl.build_source(_cl.kernel_source("filter_math.h") + MATH_KERNELS, "filter_math test", defines)
    q = _cl.queue()
    res = []
    for name, data, n, items in (("exp_scalar", x, len(x), len(x)), ("exp_lanes", x, len(x), len(x) // lanes),
                                 ("dot_scalar", pairs, 4096 * lanes, 4096 * lanes),
                                 ("dot_lanes", pairs, 4096 * lanes, 4096)):
        o = _cl.empty(4 * n)
        cl.Kernel(prg, name)(q, (items,), None, _cl.to_device(data), o)
        host = np.empty(n, np.float32)
        cl.enqueue_copy(q, host, o)
        res.append(host)
    return res


def test_lane_exp_and_dot_are_the_scalar_builtins():
    """EXP_V over a sample of every binade of [-104, 0] (all of it measured once: 1.1e9 arguments),
    the ends of its range, zeros and infinities; DOT_V on normals and on wild vectors. At every
    width, 1 too (on PoCL its kernels use the inline forms at 1 lane as well)."""
    bits = np.arange(0x80000000, 0x80000000 + int(np.float32(104.0).view(np.uint32)) + 1, 4099,
                     dtype=np.uint64).astype(np.uint32)
    special = np.array([0.0, -0.0, -np.inf, np.inf, -1e-45, -87.3, -87.5, -88.7, -103.9, -104.0,
                        -104.00001, -150.0, -1e30, 1.0, 88.0, 104.0, 105.0, 1e30], np.float32)
    rng = np.random.default_rng(5)
    for lanes in [1] + widths():
        x = np.concatenate([bits.view(np.float32), special])
        x = np.concatenate([x, np.zeros(-len(x) % lanes, np.float32)])
        v = rng.standard_normal((6, 4096 * lanes)).astype(np.float32)
        for c in (0, 3):                    # half of them unit normals
            v[c:c + 3, : 2048 * lanes] /= np.linalg.norm(v[c:c + 3, : 2048 * lanes], axis=0)
        for cpu_clang in (None, 0):
            e1, ev, d1, dv = _math_results(lanes, x, v.ravel(), cpu_clang)
            tag = f"{lanes} lanes, CPU_CLANG={cpu_clang}"
            assert np.array_equal(e1.view(np.int32), ev.view(np.int32)), \
                f"exp, {tag}: {int((e1.view(np.int32) != ev.view(np.int32)).sum())} differ"
            assert np.array_equal(d1.view(np.int32), dv.view(np.int32)), f"dot, {tag}"


def test_filters_launch_lanes_pixels_a_work_item(monkeypatch):
    """The host's range: ceil(W / LANES) work-items a row; SCALE ceil(Wl / LANES) for the upsampling."""
    seen = []
    run = filters._run_passes

    def spy(names, defines, image, guides, scalars, size):
        seen.append((names[0], size(8), size(1)))
        return run(names, defines, image, guides, scalars, size)
    monkeypatch.setattr(filters, "_run_passes", spy)
    ao, depth, normal = gbuffer("smooth", 6, 17)
    bilateral(ao, depth, normal, radius=1)
    upsample(np.ascontiguousarray(ao[::2, ::2]), depth, normal, scale=2)
    assert seen == [("bilateral_2d", (3, 6), (17, 6)), ("upsample_joint_bilateral", (4, 6), (18, 6))]


def test_quick_normal_screen_keeps_the_exact_rule():
    """filters_validate screens unit normals in float32 and falls back to the exact float64 test
    (and its message) near the tolerance: lengths 1 +- 0.0099 pass, 1 +- 0.0101 fail, NaN and
    inf fail where the depth is finite, anything passes on background."""
    ao, depth, normal = gbuffer("smooth", 6, 9)
    surf = tuple(np.argwhere(np.isfinite(depth))[0])
    back = tuple(np.argwhere(~np.isfinite(depth))[0])
    for length, ok in ((1.0099, True), (0.9901, True), (1.0101, False), (0.9899, False)):
        n = normal.copy()
        n[surf] = [0.0, length, 0.0]
        if ok:
            bilateral(ao, depth, n, radius=1)
        else:
            with pytest.raises(ValueError, match="unit length"):
                bilateral(ao, depth, n, radius=1)
    for bad in (np.nan, np.inf):
        n = normal.copy()
        n[surf] = [bad, 0.0, 0.0]
        with pytest.raises(ValueError, match="non-finite"):
            bilateral(ao, depth, n, radius=1)
        n = normal.copy()
        n[back] = [bad, 1e30, 0.0]
        bilateral(ao, depth, n, radius=1)

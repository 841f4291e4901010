"""render_depth against its NumPy reference and against Embree rays."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree, raster
from pyshadow.raster import render_depth_reference

from conftest import load


def agreement(ours, truth):
    """(coverage agreement, share of |dz| <= 1e-4 where both hit) per layer."""
    out = []
    for l in range(ours.shape[1]):
        a, b = ours[:, l], truth[:, l]
        cov = (np.isfinite(a) == np.isfinite(b)).mean()
        both = np.isfinite(a) & np.isfinite(b)
        close = (np.abs(a[both] - b[both]) <= 1e-4).mean() if both.any() else 1.0
        out.append((cov, close, both.sum()))
    return out


def test_render_depth_matches_numpy_reference():
    # suzanne (closed parts: 2+ layers) beside an open sheet (1 layer)
    sheet = trimesh.Trimesh([[1.5, -1, -1], [1.5, 1, -1], [1.5, 1, 1], [1.5, -1, 1]], [[0, 1, 2], [0, 2, 3]])
    m = pyshadow.load_mesh(trimesh.util.concatenate([load("suzanne.ply"), sheet]))
    views = pyshadow.ViewSet.zigzag(3, 6)
    ours, front = pyshadow.render_depth(m, views, resolution=24, layers=3, facing=True)
    ref, ref_front = render_depth_reference(m, views, resolution=24, layers=3, facing=True)
    assert ours.shape == ref.shape == (18, 3, 24, 24)
    assert ours.dtype == np.float32
    np.testing.assert_array_equal(np.isfinite(ours), np.isfinite(ref))
    hit = np.isfinite(ref)
    np.testing.assert_allclose(ours[hit], ref[hit], atol=1e-5)
    # the data is not trivial: misses, one-layer and multi-layer texels all occur
    assert (~hit[:, 0]).any() and hit[:, 2].any() and (hit[:, 0] & ~hit[:, 1]).any()
    # facing flags, where the two depth orders agree (equal depths may swap)
    order_same = hit & (np.abs(np.where(hit, ours, 0) - np.where(hit, ref, 0)) <= 1e-5)
    np.testing.assert_array_equal(front[hit & order_same], ref_front[hit & order_same])
    assert not front[~hit].any() and front[hit].any() and (~front[hit]).any()


@pytest.mark.parametrize("name", ["stanford-bunny.obj", "fandisk.obj", "teapot.obj", "pyvista:airplane"])
@pytest.mark.parametrize("layout", ["zigzag", "hilbert"])
def test_render_depth_agrees_with_embree(name, layout):
    m = load(name)
    views = pyshadow.ViewSet.zigzag(8, 8) if layout == "zigzag" else pyshadow.ViewSet.hilbert(3)
    assert len(views) >= 64
    ours, front = pyshadow.render_depth(m, views, resolution=128, layers=2, facing=True)
    truth, truth_front = embree.depth_layers(m, views, resolution=128, layers=2, facing=True)
    # facing changes nothing
    np.testing.assert_array_equal(pyshadow.render_depth(m, views, resolution=128, layers=2), ours)
    for layer, (cov, close, n) in enumerate(agreement(ours, truth), start=1):
        assert n > 1000, f"layer {layer}: too few texels hit to judge"
        assert cov >= 0.995, f"layer {layer}: coverage agrees on {cov:.4%}"
        assert close >= 0.995, f"layer {layer}: |dz| <= 1e-4 on {close:.4%}"
    # the facing flags: the same surface (depths within 1e-4) faces the same way
    both = np.isfinite(ours) & np.isfinite(truth)
    same = both & (np.abs(np.where(both, ours, 0) - np.where(both, truth, 0)) <= 1e-4)
    assert (front[same] == truth_front[same]).mean() >= 0.999
    assert not front[~np.isfinite(ours)].any()
    assert front[same].any() and (~front[same]).any()


def test_render_depth_depth_range_and_convention():
    # unit sphere around the origin: texel (r, c) at (x, y) has depth (1 - sqrt(1-x^2-y^2))/2
    sphere = pyshadow.load_mesh(trimesh.creation.icosphere(subdivisions=6))
    views = pyshadow.ViewSet.hilbert(1)
    R = 64
    d = pyshadow.render_depth(sphere, views, resolution=R, layers=2)
    s = 2 * (np.arange(R) + 0.5) / R - 1
    y, x = np.meshgrid(s, s, indexing="ij")
    rho2 = x * x + y * y
    inner = rho2 < 0.9
    h = np.sqrt(np.clip(1 - rho2, 0, None))
    expect1, expect2 = (1 - h) / 2, (1 + h) / 2
    for k in range(len(views)):
        assert np.abs(d[k, 0][inner] - expect1[inner]).max() < 2e-3   # tessellation error
        assert np.abs(d[k, 1][inner] - expect2[inner]).max() < 2e-3
        assert np.isinf(d[k, 0][rho2 > 1.0001]).all()
    assert np.nanmin(d[np.isfinite(d)]) >= 0 and d[np.isfinite(d)].max() <= 1


def test_render_depth_row_and_column_orientation():
    # a small triangle at +u, -v of map 0 must land at high column, low row
    views = pyshadow.ViewSet.zigzag(2, 4)
    u, v, dd = views.bases[0]
    centre = 0.5 * u - 0.5 * v
    tri = trimesh.Trimesh(np.array([centre + 0.25 * u, centre - 0.25 * v, centre + 0.25 * v]),
                          [[0, 1, 2]], process=False)
    R = 32
    d = pyshadow.render_depth(tri, views[0:1], resolution=R, layers=1, frame=(np.zeros(3), 1.0))
    rows, cols = np.nonzero(np.isfinite(d[0, 0]))
    assert len(rows) > 2
    # x = 2(c+0.5)/R - 1 = 0.5 -> c = 0.75R - 0.5;  y = -0.5 -> r = 0.25R - 0.5
    assert (np.abs(cols - (0.75 * R - 0.5)) <= 0.25 * R / 2 + 1).all()
    assert (np.abs(rows - (0.25 * R - 0.5)) <= 0.25 * R / 2 + 1).all()
    np.testing.assert_allclose(d[0, 0][rows, cols], 0.5, atol=1e-6)   # the plane p.d = 0


@pytest.mark.parametrize("name", ["fandisk.obj", "torus.STL"])
def test_render_depth_watertight_on_closed_mesh(name):
    """Every ray entering a closed mesh leaves it: no cracks, no double counts."""
    m = load(name)
    assert m.is_watertight
    d = pyshadow.render_depth(m, pyshadow.ViewSet.hilbert(3), resolution=128, layers=3)
    l1, l2 = np.isfinite(d[:, 0]), np.isfinite(d[:, 1])
    assert l1.sum() > 10000
    np.testing.assert_array_equal(l1, l2)
    assert (d[:, 1][l2] > d[:, 0][l2]).all()


@pytest.mark.parametrize("scale, offset", [(1e-3, 0.0), (1e4, 0.0), (1.0, 1e5), (1e4, 1e5)])
def test_render_depth_invariant_to_scale_and_position(scale, offset):
    m = load("fandisk.obj")
    moved = trimesh.Trimesh(m.vertices * scale + offset, m.faces, process=False)
    views = pyshadow.ViewSet.zigzag(4, 8)
    a = pyshadow.render_depth(m, views, resolution=64, layers=2)
    b = pyshadow.render_depth(moved, views, resolution=64, layers=2)
    cov = (np.isfinite(a) == np.isfinite(b)).mean()
    assert cov > 0.999
    both = np.isfinite(a) & np.isfinite(b)
    assert np.quantile(np.abs(a[both] - b[both]), 0.999) < 1e-5


def test_render_depth_blocks_give_the_same_maps():
    m = load("suzanne.ply")
    views = pyshadow.ViewSet.zigzag(4, 8)
    a = pyshadow.render_depth(m, views, resolution=32, layers=2)
    b = pyshadow.render_depth(m, views, resolution=32, layers=2, block=5)
    np.testing.assert_array_equal(a, b)


@pytest.fixture
def no_launch(monkeypatch):
    """Fail the test if anything reaches the device."""
    def boom(*a, **k):
        raise AssertionError("a kernel was launched or a buffer created")
    monkeypatch.setattr(raster.DepthRenderer, "__init__", boom)
    monkeypatch.setattr(raster._cl, "empty", boom)


@pytest.mark.parametrize("resolution", [0, -1, 4097, 10**6])
def test_render_depth_rejects_resolution(no_launch, resolution):
    with pytest.raises(ValueError, match="resolution must be in 1..4096"):
        pyshadow.render_depth(load("suzanne.ply"), pyshadow.ViewSet.zigzag(2, 2), resolution=resolution)


@pytest.mark.parametrize("resolution", [2.5, "64", None])
def test_render_depth_rejects_non_integer_resolution(no_launch, resolution):
    with pytest.raises(TypeError, match="resolution must be an int"):
        pyshadow.render_depth(load("suzanne.ply"), pyshadow.ViewSet.zigzag(2, 2), resolution=resolution)


@pytest.mark.parametrize("layers", [0, 4, -1, 2.5, "2", True])
def test_render_depth_rejects_layers(no_launch, layers):
    with pytest.raises(ValueError, match=r"layers must be 1, 2 or 3"):
        pyshadow.render_depth(load("suzanne.ply"), pyshadow.ViewSet.zigzag(2, 2), resolution=16, layers=layers)


def test_render_depth_rejects_empty_view_set(no_launch):
    empty = pyshadow.ViewSet.zigzag(2, 2)[0:0]
    assert len(empty) == 0
    with pytest.raises(ValueError, match="view set is empty"):
        pyshadow.render_depth(load("suzanne.ply"), empty, resolution=16)


def test_render_depth_rejects_non_view_set(no_launch):
    with pytest.raises(TypeError, match="ViewSet"):
        pyshadow.render_depth(load("suzanne.ply"), np.eye(3), resolution=16)


@pytest.mark.parametrize("frame, msg", [
    (((0.0, 0.0, 0.0), 0.0), "frame: the radius must be finite and > 0, got 0.0"),
    (((0.0, 0.0, 0.0), -1.0), "frame: the radius must be finite and > 0, got -1.0"),
    (((0.0, 0.0, 0.0), float("nan")), "frame: the radius must be finite and > 0, got nan"),
    (((float("nan"), 0.0, 0.0), 1.0), "frame: the centre must be 3 finite numbers, got array([nan,  0.,  0.])"),
    (((0.0, 0.0), 2.0), "frame: the centre must be 3 finite numbers, got array([0., 0.])"),
    (3, "frame must be (centre, radius), got 3"),
    (((0.0, 0.0, 0.0), 0.1), "frame: a vertex lies 1 from the centre, outside the radius 0.1"),
])
def test_render_depth_checks_the_frame(frame, msg):
    """Was: radius 0 divided by zero, -1 mirrored the mesh, NaN gave maps of +inf only, a frame smaller
    than the mesh depths outside [0, 1] (-4.3 .. 5.3), all without an error."""
    import re

    mesh = trimesh.creation.icosphere(1)
    for f in (raster.render_depth, raster.render_depth_reference):
        with pytest.raises(ValueError, match=f"^{re.escape(msg)}$"):
            f(mesh, pyshadow.ViewSet.zigzag(2, 4), resolution=4, frame=frame)
    d = raster.render_depth(mesh, pyshadow.ViewSet.zigzag(2, 4), resolution=4, frame=((0.0, 0.0, 0.0), 1.5))
    assert np.nanmin(d) >= 0 and np.max(d[np.isfinite(d)]) <= 1


def test_render_depth_block_and_layers_are_ints():
    """Was: block=1.5 was truncated and True taken as 1; layers=2.0 accepted, an array an ambiguous truth value."""
    mesh = trimesh.creation.icosphere(1)
    views = pyshadow.ViewSet.zigzag(2, 4)
    for bad in (1.5, True, "2"):
        with pytest.raises(TypeError, match=f"^block must be an int, got {bad!r}$"):
            raster.render_depth(mesh, views, resolution=4, block=bad)
    with pytest.raises(ValueError, match="^block must be >= 1, got 0$"):
        raster.render_depth(mesh, views, resolution=4, block=0)
    for bad in (2.0, np.array([1, 2])):
        with pytest.raises(ValueError, match="^layers must be 1, 2 or 3, got "):
            raster.render_depth(mesh, views, resolution=4, layers=bad)
    assert raster.render_depth(mesh, views, resolution=4, layers=np.int64(2), block=np.int64(3)).shape == (8, 2, 4, 4)

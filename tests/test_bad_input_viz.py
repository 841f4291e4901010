"""Bad and extreme input to :mod:`pyshadow.viz`: clear errors, never silently wrong pictures.

Image panels with NaN, integer or complex pixels and log scales over zeros,
colour ranges that are reversed or repeated, bent normals with NaN or a
mask of another shape, transforms that shear or are not affine, scalars for
instances that do not exist, cameras looking straight down, ground grids
given a 3-D centre, view sets on a negative sphere and the SSAO pass's
arguments. Plotters render off screen in small windows.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import viz

pytest.importorskip("pyvista")


@pytest.fixture
def plotter():
    p = viz.make_plotter(window_size=(160, 120), off_screen=True)
    yield p
    p.close()


def _background_share(img) -> float:
    h = viz.BACKGROUND.lstrip("#")
    bg = np.array([int(h[i:i + 2], 16) for i in (0, 2, 4)])
    return float((np.abs(img[..., :3].astype(int) - bg).max(axis=-1) <= 3).mean())


# ---------------------------------------------------------------------------
# image_panel
# ---------------------------------------------------------------------------
def test_image_panel_leaves_out_rgb_pixels_with_nan(plotter):
    rgb = np.full((2, 3, 3), 0.5)
    rgb[0, 1] = [np.nan, 0.2, 0.2]                 # was cast to uint8 (RuntimeWarning, black)
    actor = viz.image_panel(plotter, rgb)
    assert actor.mapper.dataset.n_cells == 5


@pytest.mark.parametrize("dtype", [np.int64, np.uint16])
def test_image_panel_rejects_integer_rgb_that_is_not_uint8(plotter, dtype):
    rgb = np.full((2, 2, 3), 128, dtype=dtype)     # was clipped to [0, 1]: all white
    with pytest.raises(TypeError, match="uint8"):
        viz.image_panel(plotter, rgb)


def test_image_panel_rejects_complex_images(plotter):
    with pytest.raises(TypeError, match="image"):
        viz.image_panel(plotter, np.array([[1.0 + 1.0j, 2.0]]))


def test_image_panel_log_scale_ignores_non_positive_pixels(plotter):
    img = np.array([[0.0, 10.0], [100.0, 1000.0]])  # the 0 made the range (0, 1000): 10 and 100 white
    actor = viz.image_panel(plotter, img, log_scale=True)
    assert actor.mapper.dataset.n_cells == 3
    np.testing.assert_allclose(actor.mapper.scalar_range, (10.0, 1000.0))
    shot = plotter.screenshot(return_img=True)
    h, w = shot.shape[:2]
    assert shot[int(0.3 * h), int(0.6 * w), 0] < 40          # 10: the low end, black


@pytest.mark.parametrize("kw", [{"clim": (1.0, 0.0)}, {"clim": (0.5, 0.5)}, {"clim": (0.0, np.nan)},
                                {"clim": (0.0, 1.0), "log_scale": True}])
def test_image_panel_rejects_bad_clim(plotter, kw):
    with pytest.raises(ValueError, match="clim"):
        viz.image_panel(plotter, np.array([[0.1, 0.9]]), **kw)


def test_image_panel_rejects_a_value_range_beyond_float64(plotter):
    with pytest.raises(ValueError, match="clim"):         # was drawn all black
        viz.image_panel(plotter, np.array([[-1e308, 1e308], [0.0, 1.0]]))


# ---------------------------------------------------------------------------
# colour_bar
# ---------------------------------------------------------------------------
def test_colour_bars_with_the_same_title_in_two_subplots():
    p = viz.make_plotter((1, 2), (320, 80), off_screen=True)
    try:
        p.subplot(0, 0)
        a = viz.colour_bar(p, "AO", clim=(0.0, 1.0))
        p.subplot(0, 1)
        b = viz.colour_bar(p, "AO", clim=(0.0, 5.0))        # pyvista returned None here
        assert a.GetTitle() == b.GetTitle() == "AO"
        assert a.GetLookupTable().GetRange() == (0.0, 1.0)
        assert b.GetLookupTable().GetRange() == (0.0, 5.0)
    finally:
        p.close()


@pytest.mark.parametrize("clim", [(1.0, 0.0), (0.5, 0.5), (0.0, np.nan), (0.0, np.inf)])
def test_colour_bar_rejects_bad_clim(plotter, clim):
    with pytest.raises(ValueError, match="clim"):
        viz.colour_bar(plotter, "AO", clim=clim)


# ---------------------------------------------------------------------------
# bent_normal_rgb
# ---------------------------------------------------------------------------
def test_bent_normal_rgb_nan_pixels_are_black():
    b = np.zeros((2, 2, 3))
    b[..., 1] = 1.0
    b[1, 0] = [np.nan, 1.0, 0.0]
    rgb = viz.bent_normal_rgb(b)                           # was a RuntimeWarning from the cast
    assert rgb[1, 0].tolist() == [0, 0, 0]
    assert rgb[0, 0].tolist() == [128, 255, 128]


@pytest.mark.parametrize("shape", [(2,), (3, 2), (2, 3, 3)])
def test_bent_normal_rgb_rejects_a_mask_of_another_shape(shape):
    with pytest.raises(ValueError, match="mask"):          # (2,) blacked out whole rows
        viz.bent_normal_rgb(np.zeros((2, 3, 3)), mask=np.ones(shape, bool))


# ---------------------------------------------------------------------------
# meshes
# ---------------------------------------------------------------------------
def test_mesh_to_polydata_normals_under_a_shear():
    grid = viz.ground_grid(divisions=2)                    # y = 0, normals +y
    T = np.eye(4)
    T[1, 0] = 1.0                                          # y' = y + x: the plane y = x
    poly = viz.mesh_to_polydata(grid, T)
    n = np.asarray(poly.point_data["Normals"], np.float64)
    np.testing.assert_allclose(n, np.tile([-1.0, 1.0, 0.0], (len(n), 1)) / np.sqrt(2.0), atol=1e-6)


def test_mesh_to_polydata_normals_under_a_huge_uniform_scale():
    mesh = trimesh.creation.icosphere(subdivisions=1)
    poly = viz.mesh_to_polydata(mesh, np.diag([1e160, 1e160, 1e160, 1.0]))   # were all 0
    np.testing.assert_allclose(poly.point_data["Normals"], mesh.vertex_normals, atol=1e-6)


@pytest.mark.parametrize("bad", ["nan", "projective"])
def test_mesh_to_polydata_rejects_bad_transforms(bad):
    T = np.eye(4)
    if bad == "nan":
        T[0, 0] = np.nan
    else:
        T[3] = [0.0, 0.0, 1.0, 0.0]
    with pytest.raises(ValueError, match="transform"):
        viz.mesh_to_polydata(trimesh.creation.icosphere(subdivisions=1), T)


def test_mesh_to_polydata_rejects_an_empty_mesh():
    with pytest.raises(ValueError, match="mesh has no vertices"):
        viz.mesh_to_polydata(trimesh.Trimesh())


@pytest.fixture
def two_receivers():
    scene = pyshadow.Scene(ground=0.0)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix([0, 0.5, 0]),
              casts=False)
    scene.add(viz.ground_grid(divisions=2), casts=False)
    return scene


@pytest.mark.parametrize("key", [5, -1, "0"])
def test_scene_to_plotter_rejects_scalars_for_unknown_instances(plotter, two_receivers, key):
    with pytest.raises(ValueError, match="scalars"):       # was drawn plain white
        viz.scene_to_plotter(two_receivers, plotter, {key: np.ones(8)})


def test_scene_to_plotter_rejects_a_reversed_clim(plotter, two_receivers):
    with pytest.raises(ValueError, match="clim"):
        viz.scene_to_plotter(two_receivers, plotter, {0: np.ones(8)}, clim=(1.0, 0.0))


@pytest.mark.parametrize("kw", [{"radius": 0.0}, {"radius": -1.0}, {"radius": np.nan},
                                {"direction": (0.0, 0.0, 0.0)}, {"fill": 0.0}, {"fill": -0.5},
                                {"centre": (0.0, np.nan, 0.0)}])
def test_look_at_bodies_rejects_bad_input(plotter, kw):
    args = {"centre": (0.0, 0.0, 0.0), "radius": 1.0, **kw}
    with pytest.raises(ValueError, match=next(iter(kw))):
        viz.look_at_bodies(plotter, **args)


@pytest.mark.parametrize("direction", [(0.0, 1.0, 0.0), (0.0, -1.0, 0.0)])
def test_look_at_bodies_straight_down_or_up_shows_the_bodies(plotter, direction):
    plotter.add_mesh(viz.mesh_to_polydata(trimesh.creation.icosphere(subdivisions=2)), color="white")
    viz.look_at_bodies(plotter, (0.0, 0.0, 0.0), 1.0, direction=direction)     # was an empty picture
    assert abs(np.dot(plotter.camera.up, direction)) < 1e-6
    assert _background_share(plotter.screenshot(return_img=True)) < 0.7


@pytest.mark.parametrize("kw, err", [({"centre": (1.0, 0.0, 2.0)}, ValueError),   # z was taken from y
                                     ({"size": np.inf}, ValueError), ({"height": np.nan}, ValueError),
                                     ({"centre": (np.nan, 0.0)}, ValueError),
                                     ({"divisions": 2.7}, TypeError)])
def test_ground_grid_rejects_bad_input(kw, err):
    with pytest.raises(err, match=next(iter(kw))):
        viz.ground_grid(**kw)


# ---------------------------------------------------------------------------
# view sets, SSAO pass
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("radius", [-1.0, 0.0, np.nan, np.inf])
def test_view_set_points_rejects_bad_radius(radius):
    with pytest.raises(ValueError, match="radius"):        # -1 put every map on its antipode
        viz.view_set_points(pyshadow.ViewSet.zigzag(4, 8), radius=radius)


@pytest.mark.parametrize("kw, err", [({"bias": np.nan}, ValueError), ({"kernel_size": 2.5}, TypeError)])
def test_vtk_ssao_rejects_bad_bias_and_kernel_size(two_receivers, kw, err):
    cam = pyshadow.Camera([0.0, 1.6, 3.0], [0.0, 0.3, 0.0], width=32, height=24)
    with pytest.raises(err, match=next(iter(kw))):
        viz.vtk_ssao(two_receivers, cam, 0.5, **kw)


@pytest.mark.parametrize("value, log", [(1.0, False), (0.0, False), (-3.0, False), (1e20, False),
                                        (0.25, True), (1e-300, True)])
def test_image_panel_of_one_value_draws_the_middle_colour(plotter, value, log):
    """An image of one value (an unoccluded AO image: all 1.0) was given the range (v, v + 1) and drawn
    in the colour map's lowest colour: black, as if fully occluded; now v is the range's middle."""
    actor = viz.image_panel(plotter, np.full((4, 5), value), log_scale=log)
    lo, hi = actor.mapper.scalar_range
    assert lo < value < hi
    if log:
        assert np.isclose(np.log(value) - np.log(lo), np.log(hi) - np.log(value))
    else:
        assert value - lo == hi - value


def test_image_panel_of_one_value_at_float64s_limit_asks_for_clim(plotter):
    for value, log in ((1.5e308, False), (5e-324, True)):
        with pytest.raises(ValueError, match="pass clim"):
            viz.image_panel(plotter, np.full((2, 2), value), log_scale=log)


def test_a_screenshot_that_fails_half_way_leaves_the_earlier_image_and_no_partial_file(plotter, tmp_path):
    """save_screenshot wrote straight into the target: a write that failed half way (a full disk, an
    interrupt) left a truncated PNG where the earlier image was. Now a temporary file is renamed over
    it only once written."""
    from pyshadow.io import read_image

    viz.image_panel(plotter, np.linspace(0.0, 1.0, 12).reshape(3, 4))
    out = tmp_path / "frame.png"
    assert viz.save_screenshot(plotter, out) == str(out)
    before = out.read_bytes()
    assert read_image(out).shape[:2] == (120, 160)

    def broken(path, *a, **k):
        with open(path, "wb") as f:
            f.write(before[:40])                    # part of a PNG, then the failure
        raise OSError(28, "No space left on device", str(path))
    plotter.screenshot = broken
    with pytest.raises(OSError, match="No space left") as info:
        viz.save_screenshot(plotter, out)
    assert info.value.filename == str(out)
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["frame.png"]


@pytest.mark.parametrize("size", [(np.nan, 300), (640.5, 480), ("wide", 480), (640, np.inf), None])
def test_make_plotter_names_a_window_size_that_is_no_two_whole_numbers(size):
    """Was: NaN gave "cannot convert float NaN to integer", infinity an OverflowError, text "invalid literal
    for int()", None a TypeError, and 640.5 opened a 640-wide window; each now gets make_plotter's message."""
    with pytest.raises(ValueError, match="window_size must be"):
        viz.make_plotter(window_size=size, off_screen=True)

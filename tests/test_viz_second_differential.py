"""Differential checks of :mod:`pyshadow.viz` pictures: what is drawn against the arrays it was given.

Measured without defects (pinned here): image panel pixels read back from an
off-screen render match the colour map at the pixel's value (viridis, within
1 of 255), with row 0 at the top for ``origin='upper'`` and at the bottom for
``'lower'``; a constant image (1x1 included) is the colour map's middle at any
magnitude; a colour bar maps values exactly as a panel with the same
``cmap`` and ``clim``. Defects fixed: polydata and image panels that shared
memory with the caller's vertices, scalars or image, float16 scalars that VTK
cannot hold, colour bar labels that printed 0.00 for a small range, screenshots
to an upper-case suffix (or none) that failed after all the work.
"""
from __future__ import annotations

import matplotlib
import numpy as np
import pytest
import trimesh

from pyshadow import viz

pytest.importorskip("pyvista")


def _panel_cells(img, **kw):
    """Render ``img`` alone in a 200 x 200 window; the colour at each pixel's centre, (H, W, 3) int."""
    p = viz.make_plotter(window_size=(200, 200), off_screen=True)
    try:
        viz.image_panel(p, img, **kw)
        p.render()
        shot = p.screenshot(return_img=True)[..., :3].astype(int)
    finally:
        p.close()
    bg = np.array([int(viz.BACKGROUND[i:i + 2], 16) for i in (1, 3, 5)])
    ys, xs = np.nonzero(np.abs(shot - bg).max(-1) > 3)
    y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
    H, W = np.shape(img)[:2]
    rows = (y0 + (np.arange(H) + 0.5) * (y1 - y0) / H).astype(int)
    cols = (x0 + (np.arange(W) + 0.5) * (x1 - x0) / W).astype(int)
    return shot[rows][:, cols]


@pytest.mark.parametrize("origin", ["upper", "lower"])
def test_image_panel_pixels_are_the_colour_map_at_their_values(origin):
    """Each drawn pixel is viridis at its value (256-entry table: within 1 of 255), rows in ``origin`` order."""
    img = np.array([[0.0, 0.25, 0.5], [0.6, 0.8, 1.0]])
    got = _panel_cells(img, origin=origin, cmap="viridis", clim=(0.0, 1.0))
    cm = matplotlib.colormaps["viridis"]
    shown = img if origin == "upper" else img[::-1]
    want = np.round(np.array([[cm(v)[:3] for v in row] for row in shown]) * 255)
    assert np.abs(got - want).max() <= 1


@pytest.mark.parametrize("value", [0.0, -3.0, 1e6, 5e307])
def test_image_panel_constant_1x1_is_the_middle_grey(value):
    """One pixel of any magnitude is drawn in the middle of the gray map (128), not at an end."""
    assert _panel_cells(np.full((1, 1), value)).reshape(-1).tolist() == [128, 128, 128]


def test_colour_bar_maps_like_a_panel_with_the_same_range():
    """The bar's lookup table gives the panel's colour at the range's ends and inside it."""
    p = viz.make_plotter(window_size=(200, 80), off_screen=True)
    try:
        bar = viz.colour_bar(p, "ao", cmap="viridis", clim=(0.2, 0.8))
        actor = viz.image_panel(p, np.array([[0.2, 0.8]]), cmap="viridis", clim=(0.2, 0.8))
        a, b = bar.GetLookupTable(), actor.mapper.lookup_table
        assert a.GetRange() == b.GetRange() == (0.2, 0.8)
        for v in (0.2, 0.35, 0.5, 0.8):
            ca, cb = [0.0] * 3, [0.0] * 3
            a.GetColor(v, ca)
            b.GetColor(v, cb)
            assert ca == cb
    finally:
        p.close()


def test_mesh_to_polydata_does_not_share_the_mesh_vertices():
    """Before: the polydata's points were the trimesh mesh's vertex buffer. ``poly.points[:, 0] += 10`` moved
    the mesh by 10 (its cached centroid stayed put), and editing the mesh moved the drawn polydata (by 5)
    behind VTK's back; a Scene's meshes drawn by scene_to_plotter were shared the same way."""
    mesh = trimesh.creation.box()
    v0 = np.array(mesh.vertices)
    poly = viz.mesh_to_polydata(mesh)
    poly.points[:, 0] += 10.0
    np.testing.assert_array_equal(mesh.vertices, v0)
    mesh.vertices[:, 1] += 5.0
    np.testing.assert_array_equal(poly.points, v0 + [10.0, 0.0, 0.0])


def test_update_scalars_keeps_the_values_given():
    """Before: the polydata kept the caller's array; ``ao *= 0`` after drawing (say to reuse the buffer for a
    difference) turned every drawn AO value into 0. The values passed stay, bit for bit."""
    mesh = trimesh.creation.icosphere(1)
    ao = np.linspace(0.0, 1.0, len(mesh.vertices))
    want = ao.copy()
    poly = viz.mesh_to_polydata(mesh, scalars=ao)
    ao *= 0.0
    np.testing.assert_array_equal(poly.point_data["ao"], want)
    viz.update_scalars(poly, ao, "d")
    ao += 1.0
    np.testing.assert_array_equal(poly.point_data["d"], 0.0)


def test_update_scalars_accepts_float16():
    """Before: float16 AO (a compact store) raised TypeError 'Could not find a suitable VTK type for float16'.
    It is widened to float32, exactly."""
    mesh = trimesh.creation.icosphere(1)
    ao = np.linspace(0.0, 1.0, len(mesh.vertices)).astype(np.float16)
    poly = viz.mesh_to_polydata(mesh, scalars=ao)
    got = poly.point_data["ao"]
    assert got.dtype == np.float32
    np.testing.assert_array_equal(got, ao.astype(np.float32))


def _bar(clim, **kw):
    p = viz.make_plotter(window_size=(400, 60), off_screen=True)
    try:
        bar = viz.colour_bar(p, "AO difference", cmap="RdBu_r", clim=clim, **kw)
        p.render()
        return p.screenshot(return_img=True), bar.GetLabelFormat()
    finally:
        p.close()


def test_colour_bar_labels_tell_small_ranges_apart():
    """Before: labels were always '%.2f', so a range (0, 0.004) read 0.00 at every label and its bar was
    pixel for pixel the bar of (0, 0.003). Each label now prints within 2 % of the step between labels."""
    a, fmt = _bar((0.0, 0.004))
    b, _ = _bar((0.0, 0.003))
    assert not np.array_equal(a, b)
    assert [fmt % v for v in np.linspace(0.0, 0.004, 5)] == ["0", "0.001", "0.002", "0.003", "0.004"]
    _, fmt = _bar((1000.0, 1000.001))
    assert fmt % 1000.00025 == "1000.00025"


def test_colour_bar_keeps_two_decimals_where_they_suffice():
    """AO (0, 1) and ranges whose labels print within 2 % of a step keep '%.2f'; an explicit fmt is kept."""
    assert _bar((0.0, 1.0))[1] == "%.2f"
    assert _bar((-2.0, 3.0))[1] == "%.2f"
    assert _bar((0.0, 0.004), fmt="%.1e")[1] == "%.1e"


def test_save_screenshot_upper_case_suffix_and_no_suffix(tmp_path):
    """Before: '--screenshot OUT.PNG' (accepted by screenshot_path) failed at the very end with 'Unsupported
    extension .PNG' (so did '.Tif'), and a path without a suffix with 'Unsupported extension .tmp'. Now
    they are the bytes written for 'a.png' (a PNG without a suffix), and no temporary file stays."""
    p = viz.make_plotter(window_size=(64, 48), off_screen=True)
    try:
        viz.image_panel(p, np.array([[0.0, 1.0]]))
        for name in ("a.png", "a.PNG", "noext", "b.tif", "b.Tif"):
            assert viz.save_screenshot(p, tmp_path / name) == str(tmp_path / name)
    finally:
        p.close()
    assert sorted(f.name for f in tmp_path.iterdir()) == ["a.PNG", "a.png", "b.Tif", "b.tif", "noext"]
    png = (tmp_path / "a.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert (tmp_path / "a.PNG").read_bytes() == png == (tmp_path / "noext").read_bytes()
    assert (tmp_path / "b.Tif").read_bytes() == (tmp_path / "b.tif").read_bytes()


@pytest.mark.parametrize("origin", ["lower", "upper"])
@pytest.mark.parametrize("rgb", [False, True])
def test_image_panel_keeps_the_values_given(origin, rgb):
    """Before: with origin='lower' (depth maps, texel grids) the panel's cell data was the caller's array, so
    refilling that buffer for the next map (here: adding 1/8, or 1 to uint8 RGB) changed every panel drawn
    from it; 'upper' copied (the flip). The cell values are the image's rows in drawing order, bit for bit."""
    img = (np.arange(12, dtype=np.uint8).reshape(2, 2, 3) if rgb
           else np.array([[0.0, 0.5], [0.75, 1.0]]))
    want = np.array((img[::-1] if origin == "upper" else img).reshape(4, -1).squeeze())
    p = viz.make_plotter(window_size=(64, 48), off_screen=True)
    try:
        actor = viz.image_panel(p, img, origin=origin)
        img += np.uint8(1) if rgb else 0.125
        np.testing.assert_array_equal(actor.mapper.dataset.cell_data["values"], want)
    finally:
        p.close()

"""viz.image_panel draws a float RGB image as write_image's PNG holds it (linear floats, sRGB-encoded)."""
import numpy as np
import pytest

import pyshadow
from pyshadow import viz

pytest.importorskip("pyvista")
oiio = pytest.importorskip("OpenImageIO")


def _png_bytes(path, img):
    pyshadow.write_image(path, img)
    f = oiio.ImageInput.open(str(path))
    try:
        return np.asarray(f.read_image(format=oiio.UINT8)).reshape(img.shape)
    finally:
        f.close()


def _panel_values(img):
    p = viz.make_plotter(window_size=(64, 48), off_screen=True)
    try:
        actor = viz.image_panel(p, img, origin="lower")
        return np.array(actor.mapper.dataset.cell_data["values"]).reshape(img.shape)
    finally:
        p.close()


def test_float_rgb_panel_holds_the_png_bytes(tmp_path):
    """Was: image_panel scaled float RGB by 255 without encoding (linear 0.5 drew 128) while write_image's PNG
    of the same array holds 188 (sRGB): the panel looked darker than the file. Now they hold the same bytes."""
    v = np.array([0.0, 0.001, 0.003, 0.05, 0.2, 0.5, 0.8, 0.999, 1.0, 1.5, -0.2, 0.0031308])
    img = np.stack([v, v[::-1], np.roll(v, 3)], axis=-1).reshape(3, 4, 3)
    want = _png_bytes(tmp_path / "a.png", img)
    np.testing.assert_array_equal(_panel_values(img), want)
    assert _panel_values(np.full((1, 1, 3), 0.5)).ravel().tolist() == [188, 188, 188]


def test_uint8_rgb_and_scalar_panels_unchanged(tmp_path):
    """uint8 RGB (tonemap's, bent_normal_rgb's) is drawn as is, as write_image writes it; scalar images keep
    their colour map (0.5 on 'gray' is the map's middle, its colour bar's)."""
    img = np.arange(36, dtype=np.uint8).reshape(3, 4, 3) * 7
    np.testing.assert_array_equal(_panel_values(img), _png_bytes(tmp_path / "b.png", img))
    grey = np.array([[0.0, 0.5], [0.75, 1.0]])
    np.testing.assert_array_equal(_panel_values(grey), grey)

"""Atomic writes through a symbolic link whose target has another extension (or none): the format is the
one the caller's path asks for, not the one the link's target name suggests."""
import os

import numpy as np
import OpenImageIO as oiio
import pytest

from pyshadow.io import linear_to_srgb, read_image, write_image

pytestmark = pytest.mark.skipif(not hasattr(os, "symlink"), reason="no symbolic links")


def _format(path):
    inp = oiio.ImageInput.open(str(path))
    try:
        return inp.format_name(), str(inp.spec().format)
    finally:
        inp.close()


def test_png_link_to_a_file_without_extension_writes_a_png(tmp_path):
    """Was: ``latest.png -> frame_0042`` (a link into a content store) failed with OSError 'OpenImageIO has
    no writer for it', the temporary file being named after the target (no extension). Now a PNG."""
    (tmp_path / "latest.png").symlink_to("frame_0042")
    img = np.array([[[0.5, 0.25, 1.0]]], np.float32)
    write_image(tmp_path / "latest.png", img)
    assert (tmp_path / "latest.png").is_symlink()
    assert _format(tmp_path / "frame_0042") == ("png", "uint8")
    codes = np.floor(linear_to_srgb(img) * 255 + 0.5)
    assert np.array_equal(np.round(linear_to_srgb(read_image(tmp_path / "latest.png")) * 255), codes)
    assert sorted(os.listdir(tmp_path)) == ["frame_0042", "latest.png"]


def test_png_link_to_an_exr_name_stores_srgb_codes_not_a_half_exr(tmp_path):
    """Was: ``view.png -> data.exr`` wrote the 8-bit sRGB codes into a half-float EXR: linear 0.5 read back
    as 0.737 (code 188 / 255). Now the file holds the PNG the caller asked for (0.5029, the code decoded)."""
    (tmp_path / "data.exr").write_bytes(b"old")
    (tmp_path / "view.png").symlink_to("data.exr")
    write_image(tmp_path / "view.png", np.full((2, 3), 0.5, np.float32))
    assert _format(tmp_path / "data.exr") == ("png", "uint8")
    back = read_image(tmp_path / "view.png")
    assert np.allclose(back, 0.5028865, rtol=0, atol=1e-6)


def test_exr_link_to_a_png_name_keeps_floats_nan_and_range(tmp_path):
    """Was: ``depth.exr -> depth.png`` wrote the float data through OpenImageIO's PNG writer: no sRGB
    encoding, NaN as 0 and 2.0 clipped to 255 (codes 128, 0, 255 for 0.5, NaN, 2.0). Now a float EXR, bit
    exact."""
    (tmp_path / "depth.exr").symlink_to("depth.png")
    img = np.array([[0.5, np.nan, 2.0, np.inf]], np.float32)
    write_image(tmp_path / "depth.exr", img)
    assert _format(tmp_path / "depth.png") == ("openexr", "float")
    back = read_image(tmp_path / "depth.exr")
    assert np.array_equal(back.view(np.uint32), img.view(np.uint32))

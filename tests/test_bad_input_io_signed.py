"""Signed-integer image files are refused by ``read_image``, not read with their negative half lost.

Before, a TIFF of int16 values -32768, -1, 0, 1000, 32767 read as 0, 0, 0, 0.00236, 1: OpenImageIO maps
signed integers to [-1, 1], and ``read_image`` then sRGB-decoded them as colour, which clamps every
negative value to 0 without a word.
"""
import numpy as np
import OpenImageIO as oiio
import pytest

from pyshadow.io import read_image, srgb_to_linear


def _tiff(path, array, type_name):
    spec = oiio.ImageSpec(array.shape[1], array.shape[0], 1, type_name)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec)
    assert out.write_image(array.reshape(array.shape[0], array.shape[1], 1))
    out.close()


@pytest.mark.parametrize("dtype, type_name", [(np.int8, "int8"), (np.int16, "int16")])   # int32: the TIFF writer converts
def test_signed_integer_tiffs_are_refused_by_name(tmp_path, dtype, type_name):
    info = np.iinfo(dtype)
    path = tmp_path / "signed.tif"
    _tiff(path, np.array([[info.min, -1, 0, 5, info.max]], dtype), type_name)
    inp = oiio.ImageInput.open(str(path))
    try:
        assert inp.spec().format == oiio.TypeDesc(type_name)        # the file does hold signed integers
    finally:
        inp.close()
    with pytest.raises(ValueError, match=rf"cannot read image .*signed\.tif: its channels are signed integers "
                                         rf"\({type_name}\)"):
        read_image(path)


def test_unsigned_16_bit_tiffs_still_decode_as_srgb(tmp_path):
    values = np.array([[0, 1, 1000, 32768, 65535]], np.uint16)
    path = tmp_path / "unsigned.tif"
    _tiff(path, values, "uint16")
    np.testing.assert_array_equal(read_image(path), srgb_to_linear(values / 65535.0).astype(np.float32))

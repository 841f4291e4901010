"""Radiance HDR files stored column-wise read back upright, for all eight resolution lines."""
import numpy as np
import pytest

from pyshadow.io import read_image

H, W = 3, 5
UPRIGHT = (np.arange(H * W).reshape(H, W) + 20).astype(np.uint8)      # RGBE mantissas, exponent fixed


def _radiance(path, first: str, second: str):
    """A flat Radiance HDR holding UPRIGHT with the resolution line ``first N second M`` (major
    axis first; Y points up, so ``+Y`` stores the bottom row first), written from Radiance's
    definition (resolu.c), independently of OpenImageIO."""
    n = {"X": W, "Y": H}
    px = bytearray()
    for s in range(n[first[1]]):
        for i in range(n[second[1]]):
            idx, sign = {first[1]: s, second[1]: i}, {first[1]: first[0], second[1]: second[0]}
            col = idx["X"] if sign["X"] == "+" else W - 1 - idx["X"]
            row = idx["Y"] if sign["Y"] == "-" else H - 1 - idx["Y"]
            px += bytes([UPRIGHT[row, col]] * 3 + [129])                 # value = m / 128 (OpenImageIO)
    header = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n{first} {n[first[1]]} {second} {n[second[1]]}\n"
    path.write_bytes(header.encode() + bytes(px))


@pytest.mark.parametrize("first, second", [("-Y", "+X"), ("-Y", "-X"), ("+Y", "-X"), ("+Y", "+X"),
                                           ("+X", "-Y"), ("-X", "-Y"), ("-X", "+Y"), ("+X", "+Y")])
def test_radiance_hdr_every_resolution_line_reads_upright(tmp_path, first, second):
    """Was: ``+X 5 +Y 3`` and ``-X 5 -Y 3`` (column-wise files) came back rotated by 180 degrees
    (pixel (0, 0) held 34/128 instead of 20/128): OpenImageIO reports EXIF orientation 6 for
    ``+X +Y`` and 8 for ``-X -Y``, the two swapped (scanline x of ``+X +Y`` is column x read from
    the bottom up: orientation 8). The other six lines were right."""
    p = tmp_path / "o.hdr"
    _radiance(p, first, second)
    img = read_image(p)
    assert img.shape == (H, W, 3)
    want = UPRIGHT.astype(np.float64) / 128.0
    np.testing.assert_array_equal(img[:, :, 0], want.astype(np.float32))
    np.testing.assert_array_equal(img[:, :, 2], want.astype(np.float32))

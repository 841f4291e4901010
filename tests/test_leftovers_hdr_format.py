"""A Radiance HDR whose header has no FORMAT= line (optional; its default is 32-bit_rle_rgbe) reads as that."""
import os
import tempfile

import numpy as np
import pytest

from pyshadow.io import read_image

# RGBE texels (mantissas, exponent 129: value m / 128 as OpenImageIO decodes them), written by hand
TEXELS = np.array([[[64, 32, 16], [128, 96, 200]]], np.uint8)
STORED = TEXELS.astype(np.float64) / 128.0
PIXELS = np.concatenate([TEXELS, np.full((1, 2, 1), 129, np.uint8)], axis=2).tobytes()


def _copies():
    return {n for n in os.listdir(tempfile.gettempdir()) if n.startswith("pyshadow-") and n.endswith(".hdr")}


@pytest.mark.parametrize("header, divisor, columns", [
    (b"#?RADIANCE\n\n-Y 1 +X 2\n", 1.0, [0, 1]),
    (b"#?RGBE\n\n-Y 1 +X 2\n", 1.0, [0, 1]),
    (b"#?RADIANCE\nSOFTWARE=hand\nEXPOSURE=2\n\n-Y 1 +X 2\n", 2.0, [0, 1]),
    (b"#?RADIANCE\n\n-Y 1 -X 2\n", 1.0, [1, 0]),     # stored right to left
], ids=["plain", "rgbe-magic", "exposure", "right-to-left"])
def test_a_radiance_file_without_a_format_line_reads_as_rgbe(tmp_path, header, divisor, columns):
    """Was: ValueError "cannot read image ...: no FORMAT specifier found" (OpenImageIO's HDR reader wants
    the line, Radiance's own readers take 32-bit_rle_rgbe where it is missing). The values, EXPOSURE and
    orientation come out as for the same file with the line, and no temporary copy is left behind."""
    p = tmp_path / "nofmt.hdr"
    p.write_bytes(header + PIXELS)
    before = _copies()
    img = read_image(p)
    assert _copies() == before
    assert img.dtype == np.float32 and img.shape == (1, 2, 3)
    np.testing.assert_allclose(img, STORED[:, columns] / divisor, rtol=1e-7)
    with_format = tmp_path / "fmt.hdr"
    with_format.write_bytes(header.replace(b"\n", b"\nFORMAT=32-bit_rle_rgbe\n", 1) + PIXELS)
    np.testing.assert_array_equal(img, read_image(with_format))


@pytest.mark.parametrize("data, reason", [
    (b"#?RADIANCE\n\nnot a resolution\n" + PIXELS, "image size"),     # broken beyond the missing line
    (b"#?RADIANCE\n\n-Y 3 +X 2\n" + PIXELS, "scanline"),              # rows missing
    # another format, named (was OpenImageIO's "no FORMAT specifier found", beside the line that gives one)
    (b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 2\n" + PIXELS,
     "Radiance HDR of FORMAT='32-bit_rle_xyze'; OpenImageIO reads only 32-bit_rle_rgbe .*ra_xyze -r"),
], ids=["resolution", "short", "xyze"])
def test_a_broken_radiance_file_is_still_a_clear_error(tmp_path, data, reason):
    p = tmp_path / "bad.hdr"
    p.write_bytes(data)
    before = _copies()
    with pytest.raises(ValueError, match=f"cannot read image {p}: .*{reason}"):
        read_image(p)
    assert _copies() == before

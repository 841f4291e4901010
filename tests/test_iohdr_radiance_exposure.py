"""Radiance HDR files with EXPOSURE= and COLORCORR= header lines read back as the radiances they were made from."""
import numpy as np
import pytest

from pyshadow.io import read_image

# RGBE texels (mantissas, exponent 129: value m / 128 as OpenImageIO decodes them), written by hand
TEXELS = np.array([[[64, 32, 16], [128, 96, 200]]], np.uint8)
STORED = TEXELS.astype(np.float64) / 128.0


def _radiance(path, lines):
    header = "#?RADIANCE\n" + "".join(f"{ln}\n" for ln in lines) + "FORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n"
    px = np.concatenate([TEXELS, np.full((1, 2, 1), 129, np.uint8)], axis=2)
    path.write_bytes(header.encode() + px.tobytes())


@pytest.mark.parametrize("lines, divisor", [
    (["EXPOSURE=2"], [2.0, 2.0, 2.0]),
    (["EXPOSURE= 4.0e+00", "\tpfilt -x /2", "EXPOSURE=0.5"], [2.0, 2.0, 2.0]),     # cumulative
    (["COLORCORR=2 1 0.5"], [2.0, 1.0, 0.5]),
    (["EXPOSURE=8", "COLORCORR=1 2 4"], [8.0, 16.0, 32.0]),
])
def test_radiance_multipliers_are_divided_out(tmp_path, lines, divisor):
    """Was: the stored values came back as they were (EXPOSURE=2: 0.5, 0.25, 0.125 read as 1.0, 0.5, 0.25,
    twice the radiance; OpenImageIO reports only the last EXPOSURE line, as hdr:exposure, and divides
    nothing). Radiance's convention: a file's values are the radiances times every EXPOSURE (and per
    channel COLORCORR) line, which its readers (pvalue) divide out."""
    p = tmp_path / "e.hdr"
    _radiance(p, lines)
    img = read_image(p)
    assert img.dtype == np.float32 and img.shape == (1, 2, 3)
    np.testing.assert_allclose(img, STORED / np.array(divisor), rtol=1e-7)


@pytest.mark.parametrize("lines", [[], ["EXPOSURE=1"], ["EXPOSURE=0"], ["EXPOSURE=-2"], ["EXPOSURE=nan"],
                                   ["EXPOSURE=abc"], ["# EXPOSURE=2 in a comment"]])
def test_radiance_without_a_meaningful_multiplier_reads_as_stored(tmp_path, lines):
    """A file without a multiplier, or with one of no meaning (zero, negative, not a number, not at the start
    of a line), reads back bit for bit as stored."""
    p = tmp_path / "n.hdr"
    _radiance(p, lines)
    np.testing.assert_array_equal(read_image(p), STORED.astype(np.float32))


def test_environment_map_from_file_holds_the_radiance(tmp_path):
    """Was: EnvironmentMap.from_file of a file with EXPOSURE=4 held 4 times the radiance it was made from."""
    from pyshadow.lighting import EnvironmentMap
    p = tmp_path / "sky.hdr"
    header = "#?RADIANCE\nEXPOSURE=4\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 4\n"
    p.write_bytes(header.encode() + bytes([64, 64, 64, 129] * 8))
    env = EnvironmentMap.from_file(p, "latlong")
    np.testing.assert_allclose(env.radiance, 0.5 / 4.0, rtol=1e-7)

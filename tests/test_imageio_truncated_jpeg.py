"""A truncated JPEG is refused instead of read back with its missing part filled with grey."""
import numpy as np
import pytest

from pyshadow.io import read_image, write_image


def _jpeg(tmp_path):
    rng = np.random.default_rng(3)
    img = rng.random((64, 64, 3))
    p = tmp_path / "full.jpg"
    write_image(p, img)
    return p, p.read_bytes()


@pytest.mark.parametrize("keep", [0.3, 0.9, 0.99])
def test_truncated_jpeg_is_refused(tmp_path, keep):
    """Was: a JPEG cut to 30 %, 90 % or 99 % of its bytes (an interrupted download or copy) read
    back without complaint, the missing rows grey: pixels off by up to 0.78 (linear, of 1) from
    the whole file's; OpenImageIO records libjpeg's "Premature end of JPEG file" but returns the
    pixels."""
    p, data = _jpeg(tmp_path)
    cut = tmp_path / "cut.jpg"
    cut.write_bytes(data[:int(len(data) * keep)])
    with pytest.raises(ValueError, match="truncated"):
        read_image(cut)


def test_benign_jpeg_complaint_still_reads(tmp_path):
    """Stray bytes between markers (libjpeg: "Corrupt JPEG data: 2 extraneous bytes") leave the
    pixels intact: such a file still reads, equal to the clean one."""
    p, data = _jpeg(tmp_path)
    i = data.find(b"\xff\xda")                    # start of scan
    odd = tmp_path / "odd.jpg"
    odd.write_bytes(data[:i] + b"\x12\x34" + data[i:])
    np.testing.assert_array_equal(read_image(odd), read_image(p))

"""Writing Radiance HDR (RGBE) files with pyshadow.write_image and pyshadow.lighting.write_radiance.

RGBE stores per pixel three 8-bit mantissas k and one shared exponent: a value is k * q with the pixel's
step q = 2^(e - 8), 2^(e-1) <= m < 2^e for its largest channel m (so k of m is 128..255). OpenImageIO (and
read_image through it) decode k * q. Rounding each channel to the nearest multiple of q leaves the largest
channel within q / 2 <= m * 2^-8 (relative 2^-8) and every channel within q / 2 = 2^-8 * (a largest channel,
before or after rounding: where m rounds up to 2^e the step doubles). OpenImageIO's own encoder truncates:
errors up to 2^-7, all downwards.
"""
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pytest

import pyshadow
from pyshadow.lighting import EnvironmentMap, write_radiance

ROOT = Path(__file__).resolve().parents[1]
BOUND = 2.0 ** -8


def _oiio_read(path):
    inp = oiio.ImageInput.open(str(path))
    assert inp is not None, oiio.geterror()
    try:
        return np.asarray(inp.read_image(oiio.TypeFloat), np.float64)
    finally:
        inp.close()


def _radiance(shape=(37, 53), lo=-14.0, hi=14.0, seed=0):
    """Linear RGB over ~12 decades, channels of one pixel up to e^28 apart."""
    return np.exp(np.random.default_rng(seed).uniform(lo, hi, shape + (3,)))


def _check_bound(written, back):
    a = np.asarray(written, np.float64)
    top = a.max(axis=2, keepdims=True)
    largest = a == top
    err = np.abs(np.asarray(back, np.float64) - a)
    assert (err[largest] / a[largest]).max() <= BOUND
    assert (err / np.maximum(top, back.max(axis=2, keepdims=True))).max() <= BOUND


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_hdr_round_trip_within_rgbe_rounding(tmp_path, dtype):
    """Was: ValueError "cannot tell the image format of '.../r.hdr' from its extension '.hdr'"; OpenImageIO's
    encoder alone truncates (max error 2^-7 = 0.0078 of the largest channel, mean -0.0027). Now read_image and
    OpenImageIO read the same values, within 2^-8 (largest channel) and unbiased (|mean| < 2^-11)."""
    a = _radiance().astype(dtype)
    p = tmp_path / "r.HDR"
    pyshadow.write_image(p, a)
    back, direct = pyshadow.read_image(p), _oiio_read(p)
    assert back.dtype == np.float32 and back.shape == a.shape
    assert np.array_equal(back, direct)
    _check_bound(a, back)
    a64 = a.astype(np.float64)
    largest = a64 == a64.max(axis=2, keepdims=True)
    assert abs(((back - a64)[largest] / a64[largest]).mean()) < 2.0 ** -11
    assert os.listdir(tmp_path) == ["r.HDR"]


def test_hdr_header_has_no_exposure_and_rows_top_down(tmp_path):
    """Was: no HDR could be written. Now the header holds no EXPOSURE= (read_image divides those out: no
    double application), the resolution line is '-Y H +X W', and row 0 (top) and column 0 stay in place."""
    H, W = 6, 9
    y, x = np.mgrid[0:H, 0:W].astype(np.float64)
    a = np.dstack([1.0 + y, 1.0 + x, np.full((H, W), 0.5)])       # 1..6, 1..9: exact in RGBE
    p = tmp_path / "o.hdr"
    pyshadow.write_image(p, a)
    head = p.read_bytes()[:200]
    header = head.split(b"\n\n")[0]
    assert b"EXPOSURE" not in header and b"COLORCORR" not in header
    assert head.split(b"\n\n")[1].startswith(f"-Y {H} +X {W}\n".encode())
    assert np.array_equal(pyshadow.read_image(p), a)
    assert np.array_equal(_oiio_read(p), a)


def test_hdr_refuses_values_rgbe_cannot_hold(tmp_path):
    """Was: ValueError on the extension. OpenImageIO's encoder, given them, wrote +inf, NaN and 2**127 as 0
    (black) and a negative channel as garbage (-1 read back 3.0). Now each is a ValueError naming the count,
    the file is left untouched and no temporary file stays."""
    p = tmp_path / "keep.hdr"
    good = np.full((3, 4, 3), 0.25)
    pyshadow.write_image(p, good)
    before = p.read_bytes()
    for bad, word in ((np.nan, "NaN"), (-1.0, "negative"), (np.inf, r"\+inf"), (2.0 ** 127, r"1\.7e38"),
                      (1e300, r"1\.7e38")):
        a = good.copy()
        a[1, 2, 0] = bad
        with pytest.raises(ValueError, match=f"1 .*{word}.*EXR"):
            pyshadow.write_image(p, a)
    with pytest.raises(ValueError, match="no alpha.*image\\[..., :3\\]"):
        pyshadow.write_image(p, np.ones((3, 4, 4)))
    with pytest.raises(TypeError, match="float"):
        pyshadow.write_image(p, np.ones((3, 4, 3), np.uint8))
    assert p.read_bytes() == before and os.listdir(tmp_path) == ["keep.hdr"]


def test_hdr_extremes_of_the_range_and_rounding_to_the_next_exponent(tmp_path):
    """Was: not writable. Now 1e38 and 1e-30 keep the bound; a pixel below 1e-32 is black; a largest
    channel that rounds up to a power of two (255.75 / 128 -> 2) keeps the small channels within 2^-8 of it;
    grey (H, W) is written as R = G = B and reads back (H, W, 3)."""
    a = np.array([[[1e38, 3e37, 1e30], [1e-30, 2e-31, 0.0], [9e-33, 1e-33, 0.0]],
                  [[255.75 / 128, 0.0117, 0.0039], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]])
    p = tmp_path / "x.hdr"
    pyshadow.write_image(p, a)
    back = pyshadow.read_image(p)
    assert np.all(back[0, 2] == 0) and np.all(back[1, 2] == 0)
    assert back[1, 0, 0] == 2.0 and back[1, 1].tolist() == [1.0, 0.0, 0.0]
    _check_bound(a[:, :2], back[:, :2])
    g = np.linspace(0.01, 100.0, 12).reshape(3, 4)
    pyshadow.write_image(p, g)
    back = pyshadow.read_image(p)
    assert back.shape == (3, 4, 3) and np.array_equal(back[..., 0], back[..., 2])
    assert (np.abs(back[..., 1] - g) / g).max() <= BOUND


def test_write_radiance_writes_hdr_that_environment_maps_read(tmp_path):
    """Was: ValueError "radiance is written as EXR; '.../sky.hdr' does not end in .exr". Now write_radiance
    writes .hdr; EnvironmentMap.from_file reads it back within 2^-8; +inf, which the EXR keeps, is refused."""
    sky = _radiance((16, 32), -3.0, 8.0, seed=3)
    p = tmp_path / "sky.hdr"
    write_radiance(p, sky)
    env = EnvironmentMap.from_file(p)
    _check_bound(sky, env.radiance)
    sky[0, 0, 0] = np.inf
    write_radiance(tmp_path / "sky.exr", sky)
    with pytest.raises(ValueError, match="\\+inf"):
        write_radiance(p, sky)
    with pytest.raises(ValueError, match=r"\.exr nor \.hdr"):
        write_radiance(tmp_path / "sky.png", sky)


def test_an_hdr_cut_short_is_an_oserror_not_a_truncated_image(tmp_path):
    """Was (OpenImageIO's HDR writer, the file size limit 300 bytes short of the file): success reported and
    the truncated file ('Read error on scanline 99') left in place. Now OSError; the earlier image stays."""
    script = textwrap.dedent("""
        import os, resource, signal, sys
        sys.path.insert(0, sys.argv[1])
        import numpy as np
        import pyshadow.io as pio
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        img = np.random.default_rng(0).random((100, 100, 3))
        pio.write_image("full.hdr", img)
        full = os.path.getsize("full.hdr")
        pio.write_image("a.hdr", np.zeros((4, 4, 3)))
        before = open("a.hdr", "rb").read()
        pio._size_limit = lambda: None                      # a limit the check before writing cannot see
        resource.setrlimit(resource.RLIMIT_FSIZE, (full - 300, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))
        try:
            pio.write_image("a.hdr", img)
            print("written", os.path.getsize("a.hdr"))
        except OSError as e:
            print("refused", e.filename, "incomplete" in str(e))
        print(open("a.hdr", "rb").read() == before, sorted(os.listdir(".")))
    """)
    out = subprocess.run([sys.executable, "-c", script, str(ROOT)], cwd=tmp_path, capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 0, out.stderr[-500:]
    assert out.stdout.split("\n")[:2] == ["refused a.hdr True", "True ['a.hdr', 'full.hdr']"]


def test_wide_integers_and_long_doubles_get_clear_errors(tmp_path):
    """Was: a uint16 array to PNG was told only "8-bit images are written from linear float arrays in [0, 1] or
    from uint8 arrays (got dtype uint16)" (nothing about 16-bit PNG) and one to EXR "for 8-bit data divide by
    255" (wrong for uint16). Now the messages say no 16-bit PNG is written and divide by 65535; a long double
    beyond float64 to HDR is the ValueError, not a RuntimeWarning (an error under -W error)."""
    a = np.arange(12, dtype=np.uint16).reshape(3, 4) * 5000
    with pytest.raises(TypeError, match=r"no 16-bit PNG is written.*srgb_to_linear\(array / 65535\)"):
        pyshadow.write_image(tmp_path / "a.png", a)
    with pytest.raises(TypeError, match="pass array / 65535"):
        pyshadow.write_image(tmp_path / "a.exr", a)
    with pytest.raises(TypeError, match="pass array / 65535"):
        pyshadow.write_image(tmp_path / "a.hdr", a)
    with pytest.raises(TypeError, match=r"got dtype uint8\); for 8-bit data divide by 255 or write a PNG$"):
        pyshadow.write_image(tmp_path / "a.exr", a.astype(np.uint8))       # unchanged for 8 bits
    if np.finfo(np.longdouble).max > np.finfo(np.float64).max:
        huge = np.full((2, 2, 3), np.longdouble(10) ** 400)
        with pytest.raises(ValueError, match=r"12 value\(s\) \+inf"):
            pyshadow.write_image(tmp_path / "a.hdr", huge)
    assert os.listdir(tmp_path) == []

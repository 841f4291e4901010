"""Image files through OpenImageIO: bit-exact float EXR, 8-bit sRGB PNG/JPEG, atomic writes."""
import os

import numpy as np
import OpenImageIO as oiio
import pytest

import pyshadow.io as pio
from pyshadow.io import read_image, write_image


def srgb_encode(x):
    """IEC 61966-2-1, written out independently of pyshadow.io."""
    x = np.clip(np.asarray(x, np.float64), 0.0, 1.0)
    out = np.empty_like(x)
    low = x <= 0.0031308
    out[low] = 12.92 * x[low]
    out[~low] = 1.055 * x[~low] ** (1 / 2.4) - 0.055
    return out


def srgb_decode(c):
    c = np.asarray(c, np.float64)
    out = np.empty_like(c)
    low = c <= 0.04045
    out[low] = c[low] / 12.92
    out[~low] = ((c[~low] + 0.055) / 1.055) ** 2.4
    return out


def raw(path):
    """Stored pixels and channel names of a file, straight from OpenImageIO."""
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)
    inp = oiio.ImageInput.open(str(path), config)
    spec = inp.spec()
    data = inp.read_image(spec.format)
    inp.close()
    return np.asarray(data), tuple(spec.channelnames), spec.format


def awkward_floats(shape, seed=0):
    rng = np.random.default_rng(seed)
    a = (rng.standard_normal(shape) * 10.0 ** rng.integers(-30, 30, shape)).astype(np.float32)
    flat = a.reshape(-1)
    flat[:6] = [np.inf, -np.inf, np.nan, 0.0, -0.0, np.float32(1e-45)]   # incl. a denormal
    return a


# --------------------------------------------------------------------------
# EXR
# --------------------------------------------------------------------------
@pytest.mark.parametrize("shape, names", [((9, 13), ("Y",)), ((9, 13, 1), ("Y",)),
                                          ((9, 13, 3), ("R", "G", "B")),
                                          ((9, 13, 4), ("R", "G", "B", "A"))])
def test_write_image_exr_round_trip_is_bit_exact(tmp_path, shape, names):
    a = awkward_floats(shape)
    path = tmp_path / "data.exr"
    write_image(path, a)
    b = read_image(path)
    assert b.dtype == np.float32
    assert b.shape == shape[:2] + ((shape[2],) if len(shape) == 3 and shape[2] > 1 else ())
    np.testing.assert_array_equal(b.reshape(a.shape).view(np.uint32), a.view(np.uint32))
    stored, stored_names, fmt = raw(path)
    assert stored_names == names and fmt == oiio.TypeFloat


def test_write_image_exr_bytes_carry_no_time_of_writing(tmp_path):
    """Was: OpenImageIO stamped each EXR with the time it was written (a ``DateTime`` / capDate header): equal
    images written a second apart gave other bytes, so a bake's recorded SHA-256 of a frame changed from run to
    run. Now the header holds no time: equal images, equal bytes."""
    a = np.linspace(0.0, 1.0, 48, dtype=np.float32).reshape(6, 8)
    write_image(tmp_path / "a.exr", a)
    inp = oiio.ImageInput.open(str(tmp_path / "a.exr"))
    names = [x.name for x in inp.spec().extra_attribs]
    inp.close()
    assert "DateTime" not in names and "capDate" not in names, names
    np.testing.assert_array_equal(read_image(tmp_path / "a.exr"), a)


def test_write_image_exr_keeps_inf_background_depth(tmp_path):
    depth = np.full((6, 8), np.inf, np.float32)
    depth[2:5, 1:6] = np.linspace(0.5, 3.5, 15, dtype=np.float32).reshape(3, 5)
    write_image(tmp_path / "depth.exr", depth)
    back = read_image(tmp_path / "depth.exr")
    assert np.isposinf(back[np.isinf(depth)]).all()
    np.testing.assert_array_equal(back, depth)


def test_write_image_exr_rounds_float64_to_float32(tmp_path):
    a = np.array([[1 / 3, 1e-40, 1e300]])
    write_image(tmp_path / "a.exr", a)
    back = read_image(tmp_path / "a.exr")
    np.testing.assert_array_equal(back, [[np.float32(1 / 3), np.float32(1e-40), np.inf]])


def test_write_image_uppercase_extension(tmp_path):
    a = np.arange(6, dtype=np.float32).reshape(2, 3)
    write_image(tmp_path / "A.EXR", a)
    np.testing.assert_array_equal(read_image(tmp_path / "A.EXR"), a)


# --------------------------------------------------------------------------
# 8-bit sRGB
# --------------------------------------------------------------------------
def gradient(h=4, w=256):
    return np.broadcast_to(np.linspace(0.0, 1.0, w, dtype=np.float32), (h, w)).copy()


def test_write_image_png_gradient_is_srgb_encoded(tmp_path):
    g = gradient()
    write_image(tmp_path / "g.png", g)
    stored, names, fmt = raw(tmp_path / "g.png")
    assert fmt == oiio.TypeUInt8 and names == ("Y",)
    codes = np.floor(srgb_encode(g) * 255 + 0.5)
    np.testing.assert_array_equal(stored[..., 0], codes)
    back = read_image(tmp_path / "g.png")
    assert back.dtype == np.float32 and back.shape == g.shape
    np.testing.assert_allclose(back, srgb_decode(codes / 255), rtol=0, atol=1e-7)
    # in the encoded domain the round trip is within half a code (1/255 with margin)
    assert np.abs(srgb_encode(back) - srgb_encode(g)).max() <= 0.5 / 255 + 1e-6
    # and the encoding matters: a linear 8-bit store would not give these codes
    assert (codes != np.floor(g * 255 + 0.5)).mean() > 0.5


def test_write_image_png_rgba_alpha_is_linear_and_straight(tmp_path):
    g = gradient(3, 64)
    rgba = np.stack([g, g[:, ::-1], np.full_like(g, 0.25), 1.0 - g], axis=-1)
    write_image(tmp_path / "c.png", rgba)
    stored, names, _fmt = raw(tmp_path / "c.png")
    assert names == ("R", "G", "B", "A")
    np.testing.assert_array_equal(stored[..., :3], np.floor(srgb_encode(rgba[..., :3]) * 255 + 0.5))
    np.testing.assert_array_equal(stored[..., 3], np.floor(rgba[..., 3] * 255.0 + 0.5))
    back = read_image(tmp_path / "c.png")
    np.testing.assert_allclose(back[..., 3], stored[..., 3] / 255, rtol=0, atol=1e-7)


def test_write_image_png_uint8_is_written_as_is(tmp_path):
    a = np.arange(2 * 128 * 3, dtype=np.int64).reshape(2, 128, 3) % 256
    write_image(tmp_path / "u.png", a.astype(np.uint8))
    stored, names, _fmt = raw(tmp_path / "u.png")
    assert names == ("R", "G", "B")
    np.testing.assert_array_equal(stored, a)
    np.testing.assert_allclose(read_image(tmp_path / "u.png"), srgb_decode(a / 255), atol=1e-7)


def test_write_image_png_clips_to_unit_range(tmp_path):
    a = np.array([[-0.5, -np.inf, 0.0, 1.0, 1.5, np.inf]], np.float32)
    write_image(tmp_path / "c.png", a)
    stored, _n, _f = raw(tmp_path / "c.png")
    np.testing.assert_array_equal(stored[..., 0], [[0, 0, 0, 255, 255, 255]])


@pytest.mark.parametrize("ext", [".jpg", ".jpeg"])
def test_write_image_jpeg_round_trip_is_close(tmp_path, ext):
    g = gradient(16, 256)
    rgb = np.stack([g, g[:, ::-1], np.full_like(g, 0.5)], axis=-1)
    write_image(tmp_path / ("j" + ext), rgb)
    back = read_image(tmp_path / ("j" + ext))
    assert back.shape == rgb.shape and back.dtype == np.float32
    # lossy (quality 95, chroma subsampled): within 5 codes of the 8-bit encoding
    assert np.abs(srgb_encode(back) - srgb_encode(rgb)).max() <= 5 / 255


# --------------------------------------------------------------------------
# atomic writes
# --------------------------------------------------------------------------
def test_write_image_replaces_existing_and_leaves_no_temp_file(tmp_path):
    path = tmp_path / "ao.exr"
    write_image(path, np.zeros((3, 4), np.float32))
    write_image(path, np.ones((5, 2), np.float32))
    np.testing.assert_array_equal(read_image(path), np.ones((5, 2), np.float32))
    assert sorted(os.listdir(tmp_path)) == ["ao.exr"]


def test_write_image_failure_keeps_target_and_removes_temp(tmp_path, monkeypatch):
    path = tmp_path / "ao.png"
    write_image(path, gradient())
    before = path.read_bytes()
    seen = []

    def half_write(tmp, data, kind):
        seen.append(tmp)
        tmp.write_bytes(b"\x89PNG partial")              # a partial file exists, then failure
        raise OSError("disk full")

    monkeypatch.setattr(pio, "_write_oiio", half_write)
    with pytest.raises(OSError, match="disk full"):
        write_image(path, np.zeros((4, 4), np.float32))
    assert seen and seen[0].parent == tmp_path and seen[0].suffix == ".png"
    assert path.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["ao.png"]


def test_write_image_failed_replace_removes_temp(tmp_path, monkeypatch):
    def refuse(src, dst):
        raise PermissionError("replace refused")

    monkeypatch.setattr(os, "replace", refuse)
    with pytest.raises(PermissionError):
        write_image(tmp_path / "x.exr", np.zeros((2, 2), np.float32))
    assert os.listdir(tmp_path) == []


def test_write_image_oiio_failure_leaves_nothing(tmp_path, monkeypatch):
    class Broken:
        def __init__(self, out):
            self.out = out

        def open(self, *a):
            return self.out.open(*a)

        def write_image(self, data):
            return False

        def geterror(self):
            return "simulated write error"

        def close(self):
            return self.out.close()

    real_create = oiio.ImageOutput.create
    monkeypatch.setattr(oiio.ImageOutput, "create", lambda name: Broken(real_create(name)))
    with pytest.raises(OSError, match="simulated write error"):
        write_image(tmp_path / "x.exr", np.zeros((2, 2), np.float32))
    assert os.listdir(tmp_path) == []


# --------------------------------------------------------------------------
# errors
# --------------------------------------------------------------------------
@pytest.mark.parametrize("name, array, exc, match", [
    ("a.tif", np.zeros((2, 2), np.float32), ValueError, "'.tif'"),
    ("a", np.zeros((2, 2), np.float32), ValueError, "extension"),
    ("a.exr", np.zeros((2, 2, 2), np.float32), ValueError, "got shape (2, 2, 2)"),
    ("a.exr", np.zeros((2, 2, 3, 1), np.float32), ValueError, "got shape (2, 2, 3, 1)"),
    ("a.exr", np.zeros(5, np.float32), ValueError, "got shape (5,)"),
    ("a.exr", np.zeros((0, 3), np.float32), ValueError, "empty"),
    ("a.exr", np.zeros((2, 2), np.uint8), TypeError, "got dtype uint8"),
    ("a.png", np.zeros((2, 2), np.int32), TypeError, "got dtype int32"),
    ("a.png", np.full((2, 2), np.nan, np.float32), ValueError, "NaN"),
    ("a.jpg", np.zeros((2, 2, 4), np.float32), ValueError, "alpha"),
])
def test_write_image_rejects_bad_input(tmp_path, name, array, exc, match):
    with pytest.raises(exc) as info:
        write_image(tmp_path / name, array)
    assert match in str(info.value)
    assert os.listdir(tmp_path) == []


def test_write_image_missing_directory(tmp_path):
    with pytest.raises(FileNotFoundError):
        write_image(tmp_path / "nope" / "a.exr", np.zeros((2, 2), np.float32))


def test_read_image_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError):
        read_image(tmp_path / "missing.exr")


@pytest.mark.parametrize("name, content", [("bad.exr", b"not an image at all"),
                                           ("bad.png", b"\x89PNG\r\n\x1a\n truncated"),
                                           ("bad.xyz", b"whatever")])
def test_read_image_unreadable_file(tmp_path, name, content):
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(ValueError) as info:
        read_image(path)
    assert str(path) in str(info.value)


def test_read_image_truncated_exr(tmp_path):
    write_image(tmp_path / "a.exr", awkward_floats((64, 64, 3)))
    data = (tmp_path / "a.exr").read_bytes()
    (tmp_path / "t.exr").write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match="t.exr"):
        read_image(tmp_path / "t.exr")


def test_read_image_directory(tmp_path):
    with pytest.raises(ValueError, match="not a file"):
        read_image(tmp_path)


def test_srgb_helpers_are_inverse():
    x = np.linspace(0.0, 1.0, 1001)
    np.testing.assert_allclose(pio.srgb_to_linear(pio.linear_to_srgb(x)), x, atol=1e-12)
    np.testing.assert_allclose(pio.linear_to_srgb(x), srgb_encode(x), atol=1e-15)


def _rgbe_file(path, resolution: str, values):
    """A flat (uncompressed) Radiance HDR file with the given resolution line; grey pixels in file order."""
    px = b""
    for v in values:                     # v = m 2^e, m in [0.5, 1): RGBE (256 m, 256 m, 256 m, e + 128)
        m, e = np.frexp(v)
        px += bytes([int(m * 256)] * 3 + [int(e) + 128])
    path.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + resolution.encode() + b"\n" + px)


@pytest.mark.parametrize("resolution, want", [
    ("-Y 2 +X 4", [[1.0, 1.25, 1.5, 1.75], [2.0, 2.25, 2.5, 2.75]]),       # the standard: top-down
    ("+Y 2 +X 4", [[2.0, 2.25, 2.5, 2.75], [1.0, 1.25, 1.5, 1.75]]),       # stored bottom-up
    ("-Y 2 -X 4", [[1.75, 1.5, 1.25, 1.0], [2.75, 2.5, 2.25, 2.0]]),       # stored right to left
    ("+X 4 -Y 2", [[1.0, 1.5, 2.0, 2.5], [1.25, 1.75, 2.25, 2.75]]),       # stored by columns
])
def test_hdr_orientation_is_applied(tmp_path, resolution, want):
    """A Radiance HDR stored bottom-up (or mirrored, or by columns) came back in file order: an
    environment map upside down, the sun below the horizon. It comes back upright."""
    p = tmp_path / "o.hdr"
    _rgbe_file(p, resolution, [1.0 + 0.25 * i for i in range(8)])
    img = read_image(p)
    assert img.shape == (2, 4, 3)
    assert img[:, :, 0].tolist() == want


def test_exr_data_window_is_placed_in_the_display_window(tmp_path):
    """An EXR whose data window (4 x 2 at (2, 1)) is smaller than its display window (8 x 4) came back
    as the bare 4 x 2 data window (a lat-long map's aspect: silently taken for the whole sphere)."""
    p = str(tmp_path / "dw.exr")
    spec = oiio.ImageSpec(4, 2, 3, oiio.TypeFloat)
    spec.x, spec.y = 2, 1
    spec.full_x, spec.full_y, spec.full_width, spec.full_height = 0, 0, 8, 4
    out = oiio.ImageOutput.create(p)
    assert out.open(p, spec)
    assert out.write_image(np.arange(24, dtype=np.float32).reshape(2, 4, 3))
    assert out.close()
    img = read_image(p)
    assert img.shape == (4, 8, 3)
    assert img[:, :, 0].tolist() == [[0] * 8, [0, 0, 0, 3, 6, 9, 0, 0], [0, 0, 12, 15, 18, 21, 0, 0], [0] * 8]

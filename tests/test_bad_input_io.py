"""Image and file I/O at the edges: EXR id channels, failed writes named after the target, file names
near the length limit, symbolic link loops, long doubles, non-numbers for the sRGB functions, and a
bundled mesh written over an earlier file."""
import builtins
import errno
import io
import os

import numpy as np
import OpenImageIO as oiio
import pytest

import pyshadow.io as pio
from pyshadow._files import write_bytes_atomic
from pyshadow.io import read_image, write_image


def _exr(path, data, names, formats):
    """Write ``data`` (uint32, (H, W, C)) with per-channel formats; float channels get data / (2**32 - 1)."""
    H, W, C = data.shape
    spec = oiio.ImageSpec(W, H, C, oiio.TypeUInt32)
    spec.channelnames = names
    spec.channelformats = formats
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec)
    assert out.write_image(np.ascontiguousarray(data, np.uint32))
    assert out.close()


def test_exr_uint_channels_come_back_as_their_integers(tmp_path):
    """An EXR id channel (UINT) came back scaled by 2**32 - 1 and sRGB-decoded: ids 7 and 123456 read as
    1.3e-10 and 3.4e-6; beside half R, G, B it came back scaled only. The integers come back as stored."""
    ids = np.array([[[0], [7], [123456], [2 ** 24]]], np.uint32)
    _exr(tmp_path / "id.exr", ids, ("id",), [oiio.TypeUInt32])
    assert read_image(tmp_path / "id.exr").tolist() == [[0.0, 7.0, 123456.0, 16777216.0]]

    data = np.zeros((1, 4, 4), np.uint32)
    data[..., :3] = 2 ** 30                              # stored as half 0.25
    data[..., 3] = ids[..., 0]
    _exr(tmp_path / "mix.exr", data, ("R", "G", "B", "id"), [oiio.TypeHalf] * 3 + [oiio.TypeUInt32])
    img = read_image(tmp_path / "mix.exr")
    assert img.dtype == np.float32 and img.shape == (1, 4, 4)
    assert np.array_equal(img[..., :3], np.full((1, 4, 3), 0.25, np.float32))
    assert img[0, :, 3].tolist() == [0.0, 7.0, 123456.0, 16777216.0]


def test_exr_uint_beyond_float32_is_refused(tmp_path):
    """An id of 2**24 + 1 (not a float32) came back as a tiny sRGB-decoded fraction; now refused, named."""
    _exr(tmp_path / "big.exr", np.array([[[2 ** 24 + 1]]], np.uint32), ("id",), [oiio.TypeUInt32])
    with pytest.raises(ValueError, match=r"big\.exr: its uint channel 'id' holds 16777217, beyond 2\*\*24"):
        read_image(tmp_path / "big.exr")


class _Failing:
    """An OpenImageIO writer that fails as ``mode`` says, with OpenImageIO's kind of message."""

    def __init__(self, name, mode):
        self.name, self.mode = name, mode

    def open(self, name, spec):
        return self.mode != "open"

    def write_image(self, data):
        return self.mode != "write"

    def geterror(self):
        return f'Could not open file "{self.name}"' if self.mode == "open" else ""

    def close(self):
        return True


@pytest.mark.parametrize("mode", ["none", "open", "write"])
def test_failed_write_names_the_target_not_the_temporary_file(tmp_path, monkeypatch, mode):
    """A failed write said 'could not open /x/.a.3f9c2b1d7e4a.tmp.png for writing: Could not open file
    "/x/.a.3f9c2b1d7e4a.tmp.png"' (or 'could not write ...: ' with no reason): a hidden name nobody asked
    for. The OSError names the target, as pyshadow._files.atomic_path promises."""
    path = tmp_path / "ao.png"
    write_image(path, np.full((3, 4), 0.5, np.float32))
    before = path.read_bytes()
    monkeypatch.setattr(oiio.ImageOutput, "create",
                        lambda name: None if mode == "none" else _Failing(name, mode))
    with pytest.raises(OSError) as info:
        write_image(path, np.zeros((3, 4), np.float32))
    assert info.value.filename == str(path) and ".tmp" not in str(info.value)
    assert str(info.value).endswith(")" + f": {str(path)!r}") and "()" not in str(info.value)
    assert path.read_bytes() == before and os.listdir(tmp_path) == ["ao.png"]


def _name_max(folder):
    try:
        return os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError):
        return -1


@pytest.mark.parametrize("stem", ["x" * 250, "\u00e9" * 125])      # 254 bytes with ".png"
def test_file_names_near_the_length_limit_are_writable(tmp_path, stem):
    """A target name of 254 bytes is valid, but its temporary name (.<stem>.<12 hex>.tmp.png) was not:
    write_image failed ('could not open ...'), write_bytes_atomic said 'File name too long' of the target."""
    if _name_max(tmp_path) != 255:
        pytest.skip("file system without a 255-byte name limit")
    a = np.linspace(0.0, 1.0, 12, dtype=np.float32).reshape(3, 4)
    png, exr, raw = tmp_path / (stem + ".png"), tmp_path / (stem[:-1] + ".exr"), tmp_path / (stem + ".bin")
    write_image(png, a)
    write_image(png, a)                                            # and replaced
    write_image(exr, a)
    write_bytes_atomic(raw, b"payload")
    assert np.array_equal(read_image(exr), a) and raw.read_bytes() == b"payload"
    assert np.abs(read_image(png) - a).max() < 0.01
    assert sorted(os.listdir(tmp_path)) == sorted([png.name, exr.name, raw.name])


def test_symlink_loop_is_an_oserror_naming_the_path(tmp_path):
    """A link to itself gave RuntimeError('Symlink loop from ...') from pathlib; now OSError ELOOP."""
    link = tmp_path / "loop.png"
    os.symlink(link, link)
    with pytest.raises(OSError) as info:
        write_image(link, np.zeros((2, 2), np.float32))
    assert info.value.errno == errno.ELOOP and info.value.filename == str(link)
    assert os.listdir(tmp_path) == ["loop.png"]


@pytest.mark.skipif(np.finfo(np.longdouble).max <= np.finfo(np.float64).max, reason="long double is float64")
def test_long_double_beyond_float64_is_clipped_not_a_warning(tmp_path):
    """A long double of 1e4000 (a valid linear value: white) raised 'RuntimeWarning: overflow encountered
    in cast' for an 8-bit file and in linear_to_srgb / srgb_to_linear."""
    a = np.array([[np.longdouble("1e4000"), -np.longdouble("1e4000"), 0.5]])
    write_image(tmp_path / "a.png", a)
    write_image(tmp_path / "b.png", np.array([[np.inf, -np.inf, 0.5]]))     # the same codes as float64's
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()
    assert pio.linear_to_srgb(a).tolist() == pio.linear_to_srgb([[np.inf, -np.inf, 0.5]]).tolist()
    assert pio.srgb_to_linear(a).tolist() == [[1.0, 0.0, pio.srgb_to_linear(0.5)]]


@pytest.mark.parametrize("bad", [None, "0.5", [0.5, None], 1 + 2j, np.array([0.5], np.complex64)])
@pytest.mark.parametrize("fn", [pio.linear_to_srgb, pio.srgb_to_linear])
def test_srgb_functions_refuse_non_numbers(fn, bad):
    """None came back NaN and '0.5' as if it were 0.5; complex gave 'float() argument must be a string or a
    real number' (or a ComplexWarning). Now a TypeError naming the argument."""
    with pytest.raises(TypeError, match=r"^(x|c): expected real numbers \(got dtype "):
        fn(bad)
    assert fn(np.array([0.0, 1.0])).tolist() == [0.0, fn(1.0)] and fn(True) == fn(1.0)


def test_mesh_file_failing_half_way_keeps_the_earlier_file(tmp_path, monkeypatch):
    """mesh_file wrote straight into the target: a write failing half way (disk full) left a truncated
    file in place of the earlier one. Now atomic: the earlier file stays, no temporary file is left."""
    from pyshadow.data import mesh_bytes, mesh_file

    (tmp_path / "spot.obj").write_bytes(b"earlier")
    real_open = io.open

    class HalfFile:
        def __init__(self, f):
            self.f = f

        def write(self, b):
            self.f.write(bytes(b)[: len(b) // 2])
            self.f.flush()
            raise OSError(errno.ENOSPC, "No space left on device")

        def __getattr__(self, name):
            return getattr(self.f, name)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.f.close()

    def opener(file, mode="r", *args, **kwargs):
        f = real_open(file, mode, *args, **kwargs)
        return HalfFile(f) if "w" in mode and os.path.dirname(os.fspath(file)) == str(tmp_path) else f

    monkeypatch.setattr(io, "open", opener)
    monkeypatch.setattr(builtins, "open", opener)
    with pytest.raises(OSError, match="No space left"):
        mesh_file("spot", tmp_path)
    monkeypatch.undo()
    assert (tmp_path / "spot.obj").read_bytes() == b"earlier" and os.listdir(tmp_path) == ["spot.obj"]
    assert mesh_file("SPOT.OBJ", tmp_path) == tmp_path / "spot.obj"
    assert (tmp_path / "spot.obj").read_bytes() == mesh_bytes("spot")


# --------------------------------------------------------------------------
# unusual input that was already handled: kept so
# --------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["\u00fcn\u00ef c\u00f8d\u00e9 \u56fe.EXR", "with space.Exr", "a.PNG"])
@pytest.mark.parametrize("array", [np.full((1, 1), 0.5, np.float32), np.arange(7, dtype=">f8")[None] / 7,
                                   (np.arange(60, dtype=np.float32).reshape(4, 5, 3) / 60)[::2, ::-2],
                                   np.full((2, 3, 1), 0.25, np.float16)])
def test_unusual_names_and_arrays_round_trip(tmp_path, name, array):
    write_image(tmp_path / name, array)
    back = read_image(tmp_path / name)
    want = np.asarray(array, np.float32).reshape(back.shape)
    if name.lower().endswith(".exr"):
        assert np.array_equal(back, want)
    else:
        codes = np.floor(pio.linear_to_srgb(want) * 255 + 0.5) / 255
        assert np.allclose(back, pio.srgb_to_linear(codes), rtol=0, atol=1e-7)
    assert os.listdir(tmp_path) == [name]


@pytest.mark.parametrize("array, exc", [(np.zeros((2, 2), bool), TypeError), (np.zeros((2, 2), complex), TypeError),
                                        (np.zeros((2, 2), object), TypeError), (np.zeros((2, 2, 2)), ValueError),
                                        (np.zeros((1, 0, 3)), ValueError)])
@pytest.mark.parametrize("ext", [".png", ".exr"])
def test_unwritable_arrays_are_refused_and_leave_nothing(tmp_path, array, exc, ext):
    with pytest.raises(exc):
        write_image(tmp_path / ("a" + ext), array)
    assert os.listdir(tmp_path) == []


def test_a_replaced_file_keeps_its_permissions(tmp_path):
    """An atomic write replaced the file by a new one of the default mode: a private 0600 image (or
    cache file) became 0644, readable by everyone. The temporary file now takes the old file's mode."""
    import stat

    from pyshadow._files import write_bytes_atomic
    from pyshadow.io import write_image

    for name, write in (("a.bin", lambda p: write_bytes_atomic(p, b"new")),
                        ("a.png", lambda p: write_image(p, np.zeros((2, 2, 3), np.float32)))):
        p = tmp_path / name
        p.write_bytes(b"old")
        p.chmod(0o600)
        write(p)
        assert stat.S_IMODE(p.stat().st_mode) == 0o600 and p.read_bytes() != b"old"
    fresh = tmp_path / "b.bin"
    write_bytes_atomic(fresh, b"x")
    assert stat.S_IMODE(fresh.stat().st_mode) == 0o666 & ~_umask()


def _umask() -> int:
    import os

    m = os.umask(0)
    os.umask(m)
    return m

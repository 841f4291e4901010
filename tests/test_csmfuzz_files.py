""".csm files and CSM objects from untrusted input: what the kernels are given is checked first
(pyshadow.csm.file_checks), save never writes what load refuses, and the header's JSON is read strictly."""
import hashlib
import json
import struct

import numpy as np
import pytest

import pyshadow
from pyshadow import CoherentShadowMap, CSMFormatError
from pyshadow.csm import fileformat

from conftest import csm_fields


@pytest.fixture(scope="module")
def spot():
    return {bits: CoherentShadowMap.build(pyshadow.data.mesh("spot"), pyshadow.ViewSet.zigzag(4, 8), resolution=16,
                                          depth_bits=bits, progress=False) for bits in (16, 32)}


def _rays(csm, n=512):
    d = np.random.default_rng(0).normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return csm.centre + 1.5 * csm.radius * d, -d          # from outside, at the body


def _visible(csm):
    scene = pyshadow.Scene()
    scene.add(csm)
    return scene.visible(*_rays(csm))


def test_constructed_csm_whose_offsets_do_not_fit_its_resolution_is_refused_before_an_upload(spot):
    """Was: a CoherentShadowMap given resolution 32 with the 257 offsets of 16^2 texels (or 100 offsets at
    16) went to the device unchecked, and Scene.visible on it died of a segmentation fault (rc -11): the
    kernels read offsets[t] for t up to 1023."""
    csm = spot[16]
    for change, match in (({"resolution": 32}, "257 offsets for resolution 32"),
                          ({"offsets": np.array(csm.offsets)[:100]}, "100 offsets for resolution 16")):
        bad = CoherentShadowMap(**csm_fields(csm, **change))
        with pytest.raises(CSMFormatError, match=match):
            bad.search_arrays()          # the gate of every upload (device_buffers, the scene's atlas)


def _last_list_short(csm):
    iend = np.array(csm.iend)
    iend[-1] = 3                          # the last texel's list ends at map 3, not D - 1 = 31
    return {"iend": iend}


def _nan_depth(csm):
    depth = np.array(csm.depth)
    depth[7] = np.nan
    return {"depth": depth}


def _negative_iend(csm):
    iend = np.array(csm.iend).astype(np.int64)
    iend[3] = -1
    return {"iend": iend}


@pytest.mark.parametrize("bits, change, match", [
    (16, _last_list_short, "segment list of texel 255 does not end at map 31"),
    (32, _nan_depth, "stored depth .*nan.* is neither finite"),
    (16, _negative_iend, "an i_end is beyond the last map 31"),
])
def test_constructed_csm_with_broken_segment_lists_is_refused_by_queries_and_save(tmp_path, spot, bits, change,
                                                                                    match):
    """Was: a CSM built with the constructor from segment lists that break the kernels' rules (a list that
    does not end at map D-1, so the search runs past it -- past the table for the last texel --, a NaN
    depth, an i_end of -1) was queried without a word (Scene.visible answered, 512 rays), and save wrote
    a file over the old one that load then refused."""
    csm = spot[bits]
    bad = CoherentShadowMap(**csm_fields(csm, **change(csm)))
    with pytest.raises(CSMFormatError, match=match):
        _visible(bad)
    path = csm.save(tmp_path / "spot.csm")
    before = path.read_bytes()
    with pytest.raises(CSMFormatError, match=match):
        bad.save(path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["spot.csm"]


def test_constructed_csm_of_byte_swapped_float_depth_is_refused_on_the_device_and_saved_right(tmp_path, spot):
    """Was: a 32-bit CSM whose depth was big-endian float32 (the same values) had its bytes taken as they
    are by the device tables: 172 of 512 rays into the body came back lit where the native array gives 0
    (silent garbage). Now refused before the upload; save writes it as the file's little-endian floats."""
    csm = spot[32]
    want = _visible(csm)
    assert not want.any()
    swapped = CoherentShadowMap(**csm_fields(csm, depth=np.array(csm.depth).astype(">f4")))
    with pytest.raises(CSMFormatError, match="native byte order"):
        _visible(swapped)
    back = CoherentShadowMap.load(swapped.save(tmp_path / "swapped.csm"))
    assert back.depth.tobytes() == np.asarray(csm.depth).tobytes()
    np.testing.assert_array_equal(_visible(back), want)


def test_constructed_csm_of_a_custom_view_set_is_a_clear_error(spot):
    """Was: KeyError 'custom' from the scene's atlas at the first query (the kernels look maps up only
    in the zigzag and hilbert grids)."""
    csm = spot[16]
    views = pyshadow.ViewSet(csm.views.directions, csm.views.bases)
    bad = CoherentShadowMap(**csm_fields(csm, views=views))
    with pytest.raises(CSMFormatError, match="view layout 'custom'"):
        _visible(bad)


def test_save_of_int64_offsets_writes_the_file_dtype(tmp_path, spot):
    """Was: a CSM whose offsets were int64 (as compress_reference gives them) was saved with offsets_dtype
    '<i8' in the header and 8-byte offsets, a file load refused ("offsets dtype '<i8' for 1554 segments");
    now the offsets are written as the '<u4' load reads, and the file round-trips."""
    csm = spot[16]
    wide = CoherentShadowMap(**csm_fields(csm, offsets=np.array(csm.offsets).astype(np.int64)))
    back = CoherentShadowMap.load(wide.save(tmp_path / "wide.csm", reproducible=True))
    assert back.offsets.dtype == np.dtype("<u4")
    assert back.offsets.tobytes() == np.asarray(csm.offsets).tobytes()
    assert (tmp_path / "wide.csm").read_bytes() == csm.save(tmp_path / "base.csm", reproducible=True).read_bytes()


def test_save_of_arrays_of_other_lengths_is_a_format_error_and_leaves_the_old_file(tmp_path, spot):
    """Was: AssertionError (no message) from inside the write for a depth array one shorter than iend; an
    assert, which python -O drops."""
    csm = spot[16]
    path = csm.save(tmp_path / "spot.csm")
    before = path.read_bytes()
    bad = CoherentShadowMap(**csm_fields(csm, depth=np.array(csm.depth)[:-1]))
    with pytest.raises(CSMFormatError, match=r"shape \(1553,\) for 1554 segments"):
        bad.save(path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["spot.csm"]


def _resealed(path, head_bytes):
    """The file at ``path`` with its JSON header replaced by ``head_bytes`` (same length or the arrays
    moved) and a valid checksum."""
    raw = path.read_bytes()
    hlen = struct.unpack("<I", raw[12:16])[0]
    head = json.loads(raw[16:16 + hlen])
    layout, _ = fileformat.array_layout(16 + hlen, head["resolution"], head["maps"], head["segments"],
                                        head["depth_bits"], head["offsets_dtype"])
    arrays = [raw[off:off + dt.itemsize * n] for _, dt, n, off in layout]
    out = bytearray(fileformat.MAGIC + struct.pack("<II", 1, len(head_bytes)) + head_bytes)
    for a in arrays:
        out += b"\0" * (-len(out) % 64) + a
    out += hashlib.sha256(bytes(out)).digest()
    path.write_bytes(bytes(out))
    return path


def resealed_with(path, **change):
    """:func:`_resealed` with the header's fields ``change``d (sorted keys, the arrays moved to fit)."""
    hlen = struct.unpack("<I", path.read_bytes()[12:16])[0]
    head = json.loads(path.read_bytes()[16:16 + hlen])
    return _resealed(path, json.dumps({**head, **change}, sort_keys=True).encode())


def test_header_with_a_key_twice_is_refused(tmp_path, spot):
    """Was: a header holding "centre" twice (checksum valid) loaded, with the last centre, [0.5, 0, 0]
    instead of [0, 0.1007, 0.2652]: another JSON reader takes the first; which one the file means is not
    known."""
    path = spot[16].save(tmp_path / "dup.csm")
    head = json.dumps(fileformat.header(spot[16]), sort_keys=True).encode()
    _resealed(path, head[:-1] + b', "centre": [0.5, 0, 0]}')
    with pytest.raises(CSMFormatError, match="key 'centre' more than once"):
        CoherentShadowMap.load(path)
    _resealed(path, head.replace(b'"phi": 8', b'"phi": 8, "phi": 8'))      # in layout_params, the same value
    with pytest.raises(CSMFormatError, match="key 'phi' more than once"):
        CoherentShadowMap.load(path)


def test_header_integer_of_5000_digits_is_a_format_error(tmp_path, spot):
    """Was: a raw ValueError from the json module ("Exceeds the limit (4300 digits) for integer string
    conversion"), not a CSMFormatError, without the file's name."""
    path = spot[16].save(tmp_path / "long.csm")
    head = json.dumps(fileformat.header(spot[16]), sort_keys=True).encode()
    _resealed(path, head.replace(b'"resolution": 16', b'"resolution": 1' + b"0" * 5000))
    with pytest.raises(CSMFormatError, match=r"long\.csm: unreadable header \(ValueError: Exceeds the limit"):
        CoherentShadowMap.load(path)

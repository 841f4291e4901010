""".csm files and the host checks before the kernels: save refuses the header values load refuses (so a
good file is never replaced by one that cannot be read back), and the device summary of a CSM given i_end
in another integer dtype is laid out in the kernels' IEND_T."""
import numpy as np
import pytest

import pyshadow
from pyshadow import CoherentShadowMap, CSMFormatError

from conftest import csm_fields


@pytest.fixture(scope="module")
def spot():
    return CoherentShadowMap.build(pyshadow.data.mesh("spot"), pyshadow.ViewSet.zigzag(4, 8), resolution=16,
                                   progress=False)


@pytest.mark.parametrize("change, match", [
    ({"radius": float("nan")}, "radius must be positive and finite"),
    ({"radius": 1e39}, "radius must be positive and finite"),
    ({"centre": [float("nan"), 0.0, 0.0]}, "centre must be 3 finite numbers"),
    ({"layer_rule": 1}, "layer_rule 1 is not 2 or 3"),
    ({"front_margin_texels": -1.0}, "front_margin_texels must be a finite number >= 0"),
    ({"box": [[-2.0] * 3, [2.0] * 3]}, "box must be"),
    ({"two_sided": True, "both_sided_faces": None}, "two_sided must be"),
    ({"build_seconds": -1.0}, "build_seconds must be a number >= 0"),
])
def test_save_refuses_a_header_load_refuses_and_keeps_the_old_file(tmp_path, spot, change, match):
    """Was: save wrote the file (a NaN radius as the JSON literal NaN, a layer rule of 1, a box beyond the
    normalised frame, ...) over the good one, and load then refused it (CSMFormatError: "radius must be
    positive and finite ..."): the CSM that had been saved could not be read back. 8 of 8 such values were
    written."""
    path = spot.save(tmp_path / "spot.csm")
    before = path.read_bytes()
    bad = CoherentShadowMap(**csm_fields(spot, **change))
    with pytest.raises(CSMFormatError, match=f"CoherentShadowMap.save: {match}"):
        bad.save(path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["spot.csm"]
    CoherentShadowMap.load(path)


def test_save_of_numpy_scalars_in_the_two_sided_record_round_trips(tmp_path, spot):
    """Was: TypeError "Object of type int64 is not JSON serializable" from inside json for a CSM given
    both_sided_faces=np.int64(3) (two_sided np.True_): nothing saved."""
    csm = CoherentShadowMap(**csm_fields(spot, two_sided=np.True_, both_sided_faces=np.int64(3)))
    back = CoherentShadowMap.load(csm.save(tmp_path / "np.csm"))
    assert back.two_sided is True and back.both_sided_faces == 3
    assert type(back.both_sided_faces) is int


@pytest.mark.parametrize("dtype", [np.int64, np.uint8, np.int16, ">u2", np.uint64])
def test_depth_for_of_a_csm_given_iend_in_another_dtype_matches_uint16(spot, dtype):
    """Was: a CSM constructed with i_end as int64, uint64, int16, uint8 or big-endian uint16 uploaded its
    block summary in that dtype while the kernel read it as IEND_T (uint): 20 of 8192 texels of depth_for
    differed from the same CSM with uint16 i_end, and for uint8 the kernel read past the end of the
    summary buffer (4 bytes per entry of a 1-byte array)."""
    m, r, c = np.meshgrid(np.arange(spot.maps), np.arange(16), np.arange(16), indexing="ij")
    want = spot.depth_for(m, r, c)
    other = CoherentShadowMap(**csm_fields(spot, iend=np.array(spot.iend).astype(dtype)))
    a = other.search_arrays()
    assert a["summary"].dtype == (np.uint16 if other.defines["IEND_T"] == "ushort" else np.uint32)
    np.testing.assert_array_equal(a["summary"], spot.search_arrays()["summary"])
    np.testing.assert_array_equal(other.depth_for(m, r, c), want)
    np.testing.assert_array_equal(other.segment_index(m, r, c).reshape(-1), spot.segment_index_reference(m, r, c))


def _rays(csm, n=2000):
    rng = np.random.default_rng(0)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    dirs = -d + 0.3 * rng.normal(size=(n, 3))
    return csm.centre + 1.5 * csm.radius * d, dirs / np.linalg.norm(dirs, axis=1, keepdims=True)


def test_a_mapped_csm_given_byte_swapped_depth_is_refused_as_one_in_memory(tmp_path):
    """Was: a CSM loaded with mmap=True whose depth was then set to a big-endian float32 copy skipped the
    dtype checks (only a mapped file's values were checked): Scene.visible took the swapped bits as depths
    and 984 of 2000 rays differed from the CSM's own answers; the same CSM read into memory is refused
    ("depth must be in native byte order"). Offsets set to int64 gave "CSMs with 2^32 or more segments are
    not supported" for 1554 segments."""
    csm = CoherentShadowMap.build(pyshadow.data.mesh("spot"), pyshadow.ViewSet.zigzag(4, 8), resolution=16,
                                  depth_bits=32, progress=False)
    path = csm.save(tmp_path / "spot32.csm")
    origins, dirs = _rays(csm)
    scene = pyshadow.Scene()
    scene.add(CoherentShadowMap.load(path, mmap=True))
    want = scene.visible(origins, dirs)
    scene = pyshadow.Scene()
    scene.add(csm)
    np.testing.assert_array_equal(scene.visible(origins, dirs), want)
    for name, array, match in (("depth", lambda a: a.astype(">f4"), "depth must be in native byte order"),
                               ("offsets", lambda a: a.astype(np.int64), "offsets must be uint32")):
        for mmap in (False, True):
            mapped = CoherentShadowMap.load(path, mmap=mmap)
            setattr(mapped, name, array(np.array(getattr(mapped, name))))
            scene = pyshadow.Scene()
            scene.add(mapped)
            with pytest.raises(CSMFormatError, match=match):
                scene.visible(origins, dirs)


def test_arrays_set_after_an_upload_are_checked_and_uploaded_again(spot):
    """Was: device_buffers kept the first upload for the CSM's life: after one depth_for, a CSM given the
    arrays and depth precision of a 32-bit CSM answered from the old 16-bit buffers with kernels compiled
    for wide pairs (read past the end of the pair buffer): 2799 of 8192 texels differed from the 32-bit
    CSM's; offsets cut to 100 entries were never checked (no error)."""
    csm = CoherentShadowMap(**csm_fields(spot))
    wide = CoherentShadowMap.build(pyshadow.data.mesh("spot"), spot.views, resolution=16, depth_bits=32,
                                   progress=False)
    m, r, c = np.meshgrid(np.arange(spot.maps), np.arange(16), np.arange(16), indexing="ij")
    np.testing.assert_array_equal(csm.depth_for(m, r, c), spot.depth_for(m, r, c))
    csm.depth_bits, csm.offsets, csm.iend, csm.depth = 32, wide.offsets, wide.iend, wide.depth
    np.testing.assert_array_equal(csm.depth_for(m, r, c), wide.depth_for(m, r, c))
    csm.offsets = np.array(wide.offsets)[:100]
    with pytest.raises(CSMFormatError, match="100 offsets for resolution 16"):
        csm.depth_for(m, r, c)


def test_a_file_of_the_wrong_size_names_the_fields_that_give_it(tmp_path, spot):
    """Was: "size 8132 bytes does not match the header (8134 expected)" for a header claiming 1555
    segments (checksum valid): no field named."""
    import hashlib
    import json
    import struct
    path = spot.save(tmp_path / "spot.csm")
    raw = path.read_bytes()
    hlen = struct.unpack("<I", raw[12:16])[0]
    text = raw[16:16 + hlen].replace(b'"segments": 1554', b'"segments": 1555')
    assert json.loads(text)["segments"] == 1555
    body = raw[:16] + text + raw[16 + hlen:-32]
    path.write_bytes(body + hashlib.sha256(body).digest())
    with pytest.raises(CSMFormatError, match=r"8134 expected from resolution 16, maps 32, segments 1555, "
                                             r"depth_bits 16"):
        CoherentShadowMap.load(path)

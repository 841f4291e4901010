"""Second fuzzing round of .csm files and the CSM cache (6,000 mutated files): a header radius whose
reciprocal float32 cannot hold loaded and failed every query; a damaged sidecar crashed the cache."""
import json
from pathlib import Path

import numpy as np
import pytest

import pyshadow
from pyshadow import CoherentShadowMap, CSMFormatError
from pyshadow.cache import CSMCache
from test_csmfuzz_files import resealed_with


@pytest.fixture(scope="module")
def small():
    return CoherentShadowMap.build(pyshadow.data.mesh("spot"), pyshadow.ViewSet.zigzag(2, 4), resolution=8,
                                   progress=False)


def _with_header(path, csm, **change):
    """``csm`` saved at ``path`` with header fields ``change``d, the arrays moved to fit and the checksum made good."""
    csm.save(path)
    return resealed_with(path, **change)


@pytest.mark.parametrize("radius", [1e-45, 1e-320])
def test_radius_whose_reciprocal_is_beyond_float32_is_refused_at_load(tmp_path, small, radius):
    """Was: a header radius of 1e-45 (or 1e-320, 0 as float32) loaded, and every query on the CSM then
    failed ("instance 0: its placement lies beyond float32's range ... the kernels need 1 / radius"):
    the file is refused at load now, and the same CSM is not saved."""
    path = _with_header(tmp_path / "tiny.csm", small, radius=radius)
    with pytest.raises(CSMFormatError, match=r"tiny\.csm: radius must be positive and finite, it and its "
                                             r"reciprocal within float32's range"):
        CoherentShadowMap.load(path)
    small.save(tmp_path / "keep.csm")
    before = (tmp_path / "keep.csm").read_bytes()
    small.radius, radius0 = radius, small.radius
    try:
        with pytest.raises(CSMFormatError, match="radius must be positive"):
            small.save(tmp_path / "keep.csm")
    finally:
        small.radius = radius0
    assert (tmp_path / "keep.csm").read_bytes() == before


def test_radius_1e_38_still_loads(tmp_path, small):
    """The bound is the reciprocal's: 1e-38 (1 / radius = 1e38) is a radius float32 holds both ways."""
    assert CoherentShadowMap.load(_with_header(tmp_path / "r.csm", small, radius=1e-38)).radius == 1e-38


@pytest.mark.parametrize("text", ['{"key": "KEY", "build_seconds": 1' + "0" * 400 + "}",
                                  "[" * 100000 + "]" * 100000])
def test_cache_hit_with_a_damaged_sidecar_reports_no_build_time(tmp_path, text):
    """Was: CSMCache.csm of a cached CSM whose sidecar .json held build_seconds 10**400 raised
    OverflowError (math.isfinite of the integer), one of arrays nested 100,000 deep RecursionError: the
    cached CSM was lost to a crash. Now the build time is unknown (None), as for any unusable sidecar."""
    cache = CSMCache(tmp_path)
    args = ("spot", pyshadow.data.mesh("spot"), pyshadow.ViewSet.zigzag(2, 4), 8, 16)
    _, info = cache.csm(*args)
    side = Path(info["file"]).with_suffix(".json")
    side.write_text(text.replace("KEY", json.loads(side.read_text())["key"]))
    csm, info = cache.csm(*args)
    assert info["source"] == "cached" and info["build_seconds"] is None
    assert isinstance(csm.depth, np.ndarray)


@pytest.mark.parametrize("field", ["radius", "centre", "front_margin_texels"])
def test_cache_file_whose_frame_is_not_its_mesh_is_rebuilt(tmp_path, field):
    """Was: a cached file whose header (checksum made good) gave another radius (x 2), centre (moved by
    half the radius) or front margin (1e6 texels) than the build of its mesh was returned as 'cached',
    and every query shadowed from the wrong sphere: the mesh hash does not cover them. Now such a file
    is unusable and rebuilt, as one of other views or resolution is."""
    cache = CSMCache(tmp_path)
    args = ("spot", pyshadow.data.mesh("spot"), pyshadow.ViewSet.zigzag(2, 4), 8, 16)
    want, info = cache.csm(*args)
    change = {"radius": {"radius": 2 * want.radius},
              "centre": {"centre": (want.centre + [0.5 * want.radius, 0, 0]).tolist()},
              "front_margin_texels": {"front_margin_texels": 1e6}}[field]
    _with_header(Path(info["file"]), want, **change)
    assert getattr(CoherentShadowMap.load(info["file"]), field) is not None     # the forged file loads
    csm, info = cache.csm(*args)
    assert info["source"] == "rebuilt"
    np.testing.assert_array_equal(csm.centre, want.centre)
    assert (csm.radius, csm.front_margin_texels) == (want.radius, want.front_margin_texels)

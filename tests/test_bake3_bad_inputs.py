"""Bad arguments of the frame bake that gave errors naming nothing the caller passed (pyshadow.bake.frames),
found by the third audit of the bake. Tiny bakes (2x2 maps of 8 texels, 8x6 images, one sample, serial)."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.bake.frames import bake_frames

BOX = trimesh.creation.box((1.0, 1.0, 1.0))
CAM = pyshadow.Camera([3.0, 3.0, 3.0], [0.0, 0.0, 0.0], width=8, height=6)


def _csm(name, mesh):
    return pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(2, 2), resolution=8, progress=False)


def _bake(out, parts=None, camera=CAM):
    return bake_frames(out, parts or [("box", BOX, True)], camera, np.eye(4)[None, None], samples=1, csm_for=_csm,
                       executor="serial", progress=False)


def test_camera_that_is_no_camera_is_refused_before_the_manifest_goes(tmp_path):
    """Was: camera=None raised "AttributeError: 'NoneType' object has no attribute 'eye'" from writing the
    manifest, after the earlier run's manifest had been removed: the folder was left with none. Now a
    TypeError naming the camera, before anything in the folder changes."""
    _bake(tmp_path)
    before = (tmp_path / "manifest.json").read_bytes()
    with pytest.raises(TypeError, match="camera must be a pyshadow.Camera, got NoneType"):
        _bake(tmp_path, camera=None)
    assert (tmp_path / "manifest.json").read_bytes() == before


@pytest.mark.parametrize("parts, message", [
    ([("box", BOX)], r"parts\[0\] must be a \(name, mesh, casts\) triple"),
    ([("box", "box.obj", True)], r"parts\[0\]: the mesh must be a trimesh.Trimesh, got str"),
])
def test_malformed_parts_are_named(tmp_path, parts, message):
    """Was: a (name, mesh) pair raised 'ValueError: not enough values to unpack (expected 3, got 2)', and a
    file name for the mesh "AttributeError: 'str' object has no attribute 'vertices'": neither named the
    part. Now TypeError naming parts[i] and what it must be, before the folder is made."""
    with pytest.raises(TypeError, match=message):
        _bake(tmp_path / "out", parts=parts)
    assert not (tmp_path / "out").exists()

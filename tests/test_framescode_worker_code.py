"""pyshadow.bake.bake_frames with a worker that runs other pyshadow code than the driver, and the user's
troubles of a frame bake (truncated outputs, failing frames). The bakes are tiny (2x2 maps of 8 texels,
8x6 images, one sample, serial)."""
from __future__ import annotations

import numpy as np
import trimesh

import pyshadow
import pyshadow.bake.frames as frames

BOX = trimesh.creation.box((1.0, 1.0, 1.0))
TWO = np.repeat(np.eye(4)[None, None], 2, axis=0)      # two frames of one body


def _csm(name, mesh):
    return pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(2, 2), resolution=8, progress=False)


def _bake(out, T=TWO, **kw):
    cam = pyshadow.Camera([3.0, 3.0, 3.0], [0.0, 0.0, 0.0], width=8, height=6)
    return frames.bake_frames(out, [("box", BOX, True)], cam, T, csm_for=_csm, executor="serial", samples=1,
                              progress=False, **kw)


def test_frames_of_other_code_are_not_kept_under_this_codes_key(tmp_path, monkeypatch):
    """Was: the driver (here: new code, its digest replaced) stored the frames a worker of other code
    rendered under the driver's key: 2 of 2 frames 'rendered', and every rerun 'skipped' them, keeping the
    other code's images as this code's for good."""
    real = frames.code_digest()
    monkeypatch.setattr(frames, "code_digest", lambda: "f" * 64)      # the driver's code; the worker's is real
    m = _bake(tmp_path)
    assert m["summary"] == {"rendered": 0, "skipped": 0, "failed": 2, "interrupted": 0}
    for e in m["frames"]:
        assert "other pyshadow code" in e["error"] and real[:12] in e["error"]
    assert not (tmp_path / "records").exists() and not (tmp_path / "exr").exists()
    monkeypatch.setattr(frames, "code_digest", lambda: real)          # the same code on both sides
    assert _bake(tmp_path)["summary"]["rendered"] == 2
    assert _bake(tmp_path)["summary"]["skipped"] == 2

"""The cube-map march's device buffers belong to the OpenCL context in use (``pyshadow._cl.use_device``)."""
from __future__ import annotations

import numpy as np
import trimesh

import pyshadow
from pyshadow import _cl
from pyshadow.cubemap import CubeProbe, raymarch_visible
from pyshadow.cubemap.device import probe_buffers


def test_probe_buffers_follow_the_context_in_use():
    """Was: a probe's device copies were cached per probe only, so after a switch of context (``use_device``,
    whose contract is that objects holding buffers rebuild them for the context in use) the march read the
    buffers of the first context: their ``context`` was the old one (PoCL lets that pass on one device; two
    devices' contexts do not mix)."""
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(trimesh.creation.box((0.3, 0.3, 0.3)), trimesh.transformations.translation_matrix([0.8, 0.15, 0.7]))
    probe = CubeProbe(scene, [0.0, 1.0, 1.0], 16)
    rng = np.random.default_rng(0)
    P = np.tile([[0.3, 0.0, 0.6]], (64, 1))
    W = rng.normal(size=(64, 3))
    W[:, 1] = np.abs(W[:, 1])
    first = raymarch_visible(probe, P, W, 1.0, device=True)
    assert probe_buffers(probe)[0].context == _cl.context()
    other = _cl._open(_cl._choose_device(None))            # a second context (of the same device here)
    saved = dict(_cl._state)
    try:
        _cl._state.clear()
        _cl._state.update(other)
        again = raymarch_visible(probe, P, W, 1.0, device=True)
        assert all(b.context == other["context"] for b in probe_buffers(probe))
    finally:
        _cl._state.clear()
        _cl._state.update(saved)
    np.testing.assert_array_equal(again, first)
    assert all(b.context == saved["context"] for b in probe_buffers(probe))

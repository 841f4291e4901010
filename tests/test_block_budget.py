"""Default blocks of maps fit the device's largest buffer (pyshadow._cl.launch.block_budget)."""
from __future__ import annotations

import numpy as np
import trimesh

import pyshadow
from test_bad_input_cl import limited


def test_default_blocks_fit_a_small_device(monkeypatch):
    """Was: the default block asked 64 MiB of depth maps (render_depth) and 96 MiB of a CSM build's buffers
    whatever the device allows: with 32 MiB a buffer, render_depth(res=256, layers=3) raised
    DeviceNotSupportedError ("a buffer of 56,623,104 bytes is more than ... allocates at once"), a build at
    512^2 likewise. Now the blocks shrink to fit: the same depths and the same CSM as on the whole device."""
    mesh = trimesh.creation.icosphere(2)
    views = pyshadow.ViewSet.zigzag(4, 8)
    want = pyshadow.render_depth(mesh, views, resolution=256, layers=3)
    csm = pyshadow.CoherentShadowMap.build(mesh, views, resolution=512, progress=False)
    limited(monkeypatch, max_mem_alloc_size=32 << 20)          # an embedded-profile device's 32 MiB a buffer
    got = pyshadow.render_depth(mesh, views, resolution=256, layers=3)
    small = pyshadow.CoherentShadowMap.build(mesh, views, resolution=512, progress=False)
    assert np.array_equal(got, want)
    monkeypatch.undo()
    p = np.random.default_rng(0).normal(size=(500, 3))
    d = -p / np.linalg.norm(p, axis=1, keepdims=True)
    scene = pyshadow.Scene(ground=None)
    scene.add(csm, mesh=mesh)
    other = pyshadow.Scene(ground=None)
    other.add(small, mesh=mesh)
    assert np.array_equal(scene.visible(3 * p, d), other.visible(3 * p, d))
    assert small.stats["bytes"] == csm.stats["bytes"]

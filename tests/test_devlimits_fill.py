"""Buffers a GPU allocates at their first use, a fill: a device error naming its limits, not a raw pyopencl one.

A GPU driver allocates a new buffer's memory where it is first used; for the depth maps of a CSM build,
the G-buffer's depth and id buffers and a shadow map's depths that first use is ``enqueue_fill_buffer``,
which then fails with MEM_OBJECT_ALLOCATION_FAILURE. Simulated here on the CPU device.
"""
import numpy as np
import pyopencl as cl
import pytest
import trimesh

import pyshadow
from pyshadow import _cl
from pyshadow.lighting.shadow_map import ShadowMapVisibility


def _fill_fails(queue, buf, pattern, offset, size, *args, **kwargs):
    raise cl.MemoryError(cl._cl._ErrorRecord("clEnqueueFillBuffer", -4, "MEM_OBJECT_ALLOCATION_FAILURE"))


def _calls():
    mesh = trimesh.creation.icosphere(1)
    views = pyshadow.ViewSet.zigzag(2, 4)
    cam = pyshadow.Camera(eye=[0.0, 0.5, 4.0], target=[0.0, 0.0, 0.0], width=16, height=12)
    scene = pyshadow.Scene(ground=-1.0)
    scene.add(pyshadow.CoherentShadowMap.build(mesh, views, resolution=8, progress=False), np.eye(4), mesh=mesh)
    return {"render_depth": lambda: pyshadow.render_depth(mesh, views, resolution=8),
            "csm_build": lambda: pyshadow.CoherentShadowMap.build(mesh, views, resolution=8, progress=False),
            "render_gbuffer": lambda: pyshadow.render_gbuffer([(mesh, np.eye(4))], cam),
            "shadow_map": lambda: ShadowMapVisibility(16).shadow_map(scene, position=[0.3, 3.0, 0.2])}


@pytest.mark.parametrize("name", ["render_depth", "csm_build", "render_gbuffer", "shadow_map"])
def test_a_fill_out_of_device_memory_is_a_device_error_naming_the_limits(monkeypatch, name):
    """Was: the raw pyopencl 'MemoryError: clEnqueueFillBuffer failed: MEM_OBJECT_ALLOCATION_FAILURE' from
    render_depth (also a CSM build), render_gbuffer and a shadow map, naming neither the device's memory nor
    what to ask less of."""
    call = _calls()[name]
    monkeypatch.setattr(cl, "enqueue_fill_buffer", _fill_fails)
    dev = _cl.device()
    with pytest.raises(pyshadow.DeviceNotSupportedError) as info:
        call()
    msg = str(info.value)
    assert "MEM_OBJECT_ALLOCATION_FAILURE" in msg and "filling a buffer of" in msg
    assert repr(dev.name.strip()) in msg and f"{int(dev.global_mem_size):,} bytes of global memory" in msg
    assert "PYSHADOW_DEVICE" in msg
    assert isinstance(info.value.__cause__, cl.MemoryError)

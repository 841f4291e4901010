"""Launches a device refuses for want of resources: a pyshadow error naming its limits, not a raw pyopencl one.

A GPU allocates buffers at their first use, so a scene whose buffers together outgrow its memory (each
within max_mem_alloc_size, which pyshadow checks when it creates them) fails at the kernel launch with
MEM_OBJECT_ALLOCATION_FAILURE or OUT_OF_RESOURCES; a work-group larger than a kernel allows fails with
INVALID_WORK_GROUP_SIZE. Simulated here on the CPU device.
"""
import numpy as np
import pyopencl as cl
import pytest
import trimesh

import pyshadow
from pyshadow import _cl
from pyshadow._cl import launch
from test_bad_input_cl import box_scene, queries


def out_of_memory(code, name):
    def launch_fails(self, *args, **kwargs):
        raise cl.MemoryError(cl._cl._ErrorRecord("clEnqueueNDRangeKernel", code, name))
    return launch_fails


@pytest.mark.parametrize("code, name", [(-4, "MEM_OBJECT_ALLOCATION_FAILURE"), (-5, "OUT_OF_RESOURCES")])
def test_a_launch_out_of_device_memory_is_a_device_error_naming_the_limits(monkeypatch, code, name):
    """Was: the raw pyopencl MemoryError 'clEnqueueNDRangeKernel failed: MEM_OBJECT_ALLOCATION_FAILURE' (or
    OUT_OF_RESOURCES) from scene.visible and render_depth, naming neither the device's memory nor what to reduce."""
    scene = box_scene()
    p, d = queries(200)
    scene.visible(p, d)                     # built and cached before launches fail
    dev = _cl.device()
    monkeypatch.setattr(cl.Kernel, "__call__", out_of_memory(code, name))
    for call in (lambda: scene.visible(p, d),
                 lambda: pyshadow.render_depth(trimesh.creation.icosphere(1), pyshadow.ViewSet.zigzag(2, 4),
                                               resolution=8)):
        with pytest.raises(pyshadow.DeviceNotSupportedError) as info:
            call()
        msg = str(info.value)
        assert name in msg and repr(dev.name.strip()) in msg
        assert f"{int(dev.global_mem_size):,} bytes of global memory" in msg
        assert f"{int(dev.max_mem_alloc_size):,} bytes a buffer" in msg
        assert "fewer or lower-resolution CSMs" in msg and "PYSHADOW_DEVICE" in msg
        assert isinstance(info.value.__cause__, cl.MemoryError)


def test_a_work_group_the_device_refuses_is_a_device_error_naming_the_group(monkeypatch):
    """Was: a raw pyopencl LogicError 'clEnqueueNDRangeKernel failed: INVALID_WORK_GROUP_SIZE' (PoCL's own,
    groups of 8192 on a device of 4096) when a kernel's group limit was read too high."""
    scene = box_scene()
    p, d = queries(3000)
    scene.visible(p, d)
    monkeypatch.setattr(launch, "kernel_group_limit", lambda k: 10 ** 6)
    big = 2 * int(_cl.device().max_work_group_size)
    with launch.override(query_group=big), pytest.raises(pyshadow.DeviceNotSupportedError) as info:
        scene.visible(p, d)
    msg = str(info.value)
    assert "INVALID_WORK_GROUP_SIZE" in msg and f"groups of ({big},)" in msg and "'scene_visible'" in msg
    assert f"{int(_cl.device().max_work_group_size):,} work-items a group" in msg


def test_other_launch_errors_pass_unchanged():
    """Was: (new) launches through pyshadow.kernel; an error that is no lack of resources stays pyopencl's own."""
    k = _cl.kernel("raster.cl", "render_depth_layers", {"RES": 8, "LAYERS": 1, "FACING": 0})
    assert isinstance(k, launch.Kernel) and isinstance(k, cl.Kernel)
    with pytest.raises(TypeError, match="missing 6 required"):
        k(_cl.queue(), (1,), None, _cl.empty(16))          # too few arguments
    err = cl.LogicError(cl._cl._ErrorRecord("clEnqueueNDRangeKernel", -38, "INVALID_MEM_OBJECT"))
    assert launch.launch_error(k, err, (1,), None) is None


def test_a_buffer_the_device_cannot_allocate_is_a_device_error_naming_the_limits(monkeypatch):
    """Was: the raw pyopencl MemoryError 'clCreateBuffer failed: MEM_OBJECT_ALLOCATION_FAILURE' from
    to_device, host_buffer, empty and a scene query (a device whose memory other buffers or programs hold),
    each buffer within max_mem_alloc_size."""
    scene = box_scene()
    p, d = queries(200)
    want = scene.visible(p, d)
    real = cl.Buffer

    def no_memory(ctx, flags, size=0, hostbuf=None):
        if (size or hostbuf.nbytes) > 1000:
            raise cl.MemoryError(cl._cl._ErrorRecord("clCreateBuffer", -4, "MEM_OBJECT_ALLOCATION_FAILURE"))
        return real(ctx, flags, size, hostbuf)
    monkeypatch.setattr(cl, "Buffer", no_memory)
    a = np.zeros(1000, np.float32)
    dev = _cl.device()
    for make in (lambda: _cl.to_device(a), lambda: _cl.host_buffer(a), lambda: _cl.empty(a.nbytes),
                 lambda: scene.visible(p, d)):
        with pytest.raises(pyshadow.DeviceNotSupportedError) as info:
            make()
        msg = str(info.value)
        assert "MEM_OBJECT_ALLOCATION_FAILURE" in msg and "bytes of global memory" in msg
        assert f"{int(dev.max_mem_alloc_size):,} bytes a buffer" in msg and "PYSHADOW_DEVICE" in msg
        assert isinstance(info.value.__cause__, cl.MemoryError)
    assert "a buffer of 4,000 bytes" in str(pytest.raises(pyshadow.DeviceNotSupportedError, _cl.empty, 4000).value)
    assert _cl.empty(16).size == 16 and np.array_equal(scene.visible(p[:10], d[:10]), want[:10])

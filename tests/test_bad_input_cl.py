"""The OpenCL runtime on other machines: devices with small limits, no doubles, a
compiler that fails, a probe child that hangs with a process of its own, no platform.

Other devices are simulated: the real device with some reported limits changed
(:class:`Limited`), or a fake device object.
"""
import sys
import time

import numpy as np
import pyopencl as cl
import pytest
import trimesh

import pyshadow
from pyshadow import _cl
from pyshadow._cl import launch
from pyshadow._cl import probe as probe_mod
from pyshadow.lighting.transfer import sh_transfer


class Limited:
    """The chosen device, but reporting ``limits`` (e.g. ``max_mem_alloc_size``) as its own."""

    def __init__(self, dev, **limits):
        self._dev, self._limits = dev, limits

    def __getattr__(self, name):
        if name in self._limits:
            return self._limits[name]
        return getattr(self._dev, name)


def limited(monkeypatch, **limits):
    dev = Limited(_cl.device(), **limits)
    monkeypatch.setattr(_cl, "device", lambda: dev)
    return dev


def box_scene():
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix([0, 0.5, 0]))
    return scene


def queries(n, seed=3):
    rng = np.random.default_rng(seed)
    p = np.column_stack([rng.uniform(-2, 2, n), np.zeros(n), rng.uniform(-2, 2, n)])
    d = rng.normal(size=(n, 3))
    d[:, 1] = np.abs(d[:, 1]) + 0.1
    return p, d


# ---------------------------------------------------------------------------
# buffers: sizes refused before allocating, chunks within the device's limit
# ---------------------------------------------------------------------------
def test_a_negative_buffer_size_is_refused_not_rounded_up():
    """A byte count that wrapped (int32 arithmetic) was a 4-byte buffer, for kernels to write past."""
    wrapped = int(np.int32(-(2 ** 31) + 8))
    for bad in (-1, -8, wrapped):
        with pytest.raises(ValueError, match=rf"device buffer of {bad} bytes"):
            _cl.empty(bad)
    assert _cl.empty(0).size == 4 and _cl.empty(10).size == 10


def test_a_buffer_beyond_the_device_limit_names_both_sizes():
    limit = int(_cl.device().max_mem_alloc_size)
    with pytest.raises(pyshadow.DeviceNotSupportedError) as info:
        _cl.empty(limit + 1)
    msg = str(info.value)
    assert f"{limit + 1:,} bytes" in msg and f"max_mem_alloc_size {limit:,} bytes" in msg
    assert repr(_cl.device().name.strip()) in msg and "PYSHADOW_DEVICE" in msg


def test_copies_and_host_buffers_are_checked_against_the_limit_before_allocating(monkeypatch):
    limited(monkeypatch, max_mem_alloc_size=1024)
    small, big = np.zeros(256, np.float32), np.zeros(257, np.float32)
    assert _cl.to_device(small).size == 1024 and _cl.host_buffer(small).size == 1024
    for make in (_cl.to_device, _cl.host_buffer, lambda a: _cl.empty(a.nbytes)):
        with pytest.raises(pyshadow.DeviceNotSupportedError, match="1,028 bytes .*max_mem_alloc_size 1,024"):
            make(big)


def test_query_and_ao_chunks_fit_a_device_that_allocates_little(monkeypatch):
    """A device of max_mem_alloc_size 64 KiB: visibility (float64 rows) and AO with SH transfer at one
    sample (36 bytes a point) launch in chunks whose buffers it can hold, with the same answers."""
    scene = box_scene()
    p, d = queries(6000)
    n = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    s1 = pyshadow.Sampling(1, seed=2)
    want_v = scene.visible(p, d)
    want_t = sh_transfer(scene, p, n, sampling=s1)
    limit = 64 << 10
    limited(monkeypatch, max_mem_alloc_size=limit)
    sizes = []
    for name in ("empty", "to_device", "host_buffer"):
        real = getattr(_cl, name)

        def rec(*a, _real=real, **k):
            buf = _real(*a, **k)
            sizes.append(buf.size)
            return buf
        monkeypatch.setattr(_cl, name, rec)
    got_v = scene.visible(p, d)
    got_t = sh_transfer(scene, p, n, sampling=s1)
    assert sizes and max(sizes) <= limit, max(sizes)
    assert np.array_equal(got_v, want_v)
    for a, b in zip(got_t, want_t):
        assert np.array_equal(a, b)


# ---------------------------------------------------------------------------
# work-groups within the device's limits
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("kind, wg, items", [("CPU", 8, (4096, 4096, 4096)), ("CPU", 1, (1, 1, 1)),
                                             ("CPU", 4096, (4, 4, 4)), ("GPU", 64, (64, 64, 64)),
                                             ("GPU", 1, (1, 1, 1)), ("GPU", 1024, (32, 1024, 64))])
def test_query_groups_are_within_the_device_work_group_limits(monkeypatch, kind, wg, items):
    t = cl.device_type.CPU if kind == "CPU" else cl.device_type.GPU
    limited(monkeypatch, type=t, max_work_group_size=wg, max_work_item_sizes=list(items))
    s = launch.shape()
    assert s.kind == kind
    assert 1 <= s.query_group <= min(wg, items[0])
    assert s.raster_group is None or s.raster_group <= min(wg, items[0])


def test_a_cpu_device_of_eight_work_items_a_group_answers_the_same(monkeypatch):
    scene = box_scene()
    p, d = queries(3000)
    want = scene.visible(p, d)
    limited(monkeypatch, max_work_group_size=8)
    groups = []
    real = launch.grid

    def rec(items, group, *kernel):
        groups.append(group)
        return real(items, group, *kernel)
    monkeypatch.setattr(launch, "grid", rec)
    assert np.array_equal(scene.visible(p, d), want)
    assert groups and max(groups) <= 8


def test_a_kernel_allowed_fewer_work_items_than_the_device_is_launched_within_its_own_limit(monkeypatch):
    """A GPU lowers CL_KERNEL_WORK_GROUP_SIZE below the device's limit for a kernel that needs many
    registers; the query kernels were launched in groups of the device's shape (128 on a GPU) whatever
    the kernel allowed, which such a device refuses (INVALID_WORK_GROUP_SIZE). Simulated: the device's
    shape asks for groups of 16 and the kernels say they allow 3."""
    scene = box_scene()
    p, d = queries(3000)
    n = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    s8 = pyshadow.Sampling(8, seed=2)
    want_v, want_ao = scene.visible(p, d), scene.ambient_occlusion(p, n, sampling=s8)
    asked, launched = [], []
    real_grid = launch.grid

    def limit(kernel):
        asked.append(kernel.function_name)
        return 3

    def rec(*a):
        g, loc = real_grid(*a)
        launched.append(loc[0])
        assert g[0] % loc[0] == 0
        return g, loc
    with launch.override(query_group=16):
        monkeypatch.setattr(launch, "kernel_group_limit", limit, raising=False)
        monkeypatch.setattr(launch, "grid", rec)
        got_v, got_ao = scene.visible(p, d), scene.ambient_occlusion(p, n, sampling=s8)
    assert np.array_equal(got_v, want_v) and np.array_equal(got_ao, want_ao)
    assert set(asked) == {"scene_visible", "scene_ao"} and set(launched) == {3}


def test_the_kernel_group_limit_is_the_kernels_own_and_asked_once():
    scene = box_scene()
    p, d = queries(100)
    scene.visible(p, d)
    k = next(k for k in _cl._kernels.values() if k.function_name == "scene_visible")
    want = k.get_work_group_info(cl.kernel_work_group_info.WORK_GROUP_SIZE, _cl.device())
    assert launch.kernel_group_limit(k) == want >= 1
    assert launch.grid(10, 10 ** 9, k) == ((-(-10 // want) * want,), (want,))
    assert launch.grid(10, 4, k) == ((12,), (4,))
    assert k in launch._group_limits


# ---------------------------------------------------------------------------
# doubles, compiler failures
# ---------------------------------------------------------------------------
class NoDoubles:
    """An OpenCL 1.1 device without cl_khr_fp64 that refuses the DOUBLE_FP_CONFIG query."""
    extensions = "cl_khr_byte_addressable_store cl_khr_global_int32_base_atomics"
    name = "Fake OpenCL 1.1 GPU"

    @property
    def double_fp_config(self):
        raise cl.LogicError("clGetDeviceInfo failed: INVALID_VALUE")


def test_a_device_without_cl_khr_fp64_is_not_asked_for_its_double_config(monkeypatch):
    fake = NoDoubles()
    monkeypatch.setattr(_cl, "device", lambda: fake)
    assert _cl.has_fp64() is False
    job = _cl._probe_job(fake)
    assert all("-DHAVE_FP64=0" in b["options"] for b in job["builds"] if b["label"] == "visibility.cl")


def test_a_build_error_keeps_the_compiler_log_when_the_source_cannot_be_saved(monkeypatch, tmp_path):
    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("")
    monkeypatch.setattr(_cl.tempfile, "gettempdir", lambda: str(not_a_folder))
    bad = "__kernel void broken(__global float *x) { x[0] = undefined_name; }"
    with pytest.raises(pyshadow.KernelBuildError) as info:
        _cl.build_source(bad, "broken.cl", {"FOO": 3})
    msg = str(info.value)
    assert "undefined_name" in msg and "-DFOO=3" in msg
    assert "could not be saved" in msg and "saved to" not in msg


# ---------------------------------------------------------------------------
# the probe's children
# ---------------------------------------------------------------------------
def test_the_probe_timeout_ends_a_child_whose_own_process_holds_its_pipes(tmp_path):
    """PoCL runs the linker as a process of its own; one that hangs kept the timed-out child's pipes open
    and the probe waited for it, past its timeout."""
    code = ("import subprocess, sys, time; g = subprocess.Popen(['sleep', '15']); "
            f"open({str(tmp_path / 'pid')!r}, 'w').write(str(g.pid)); time.sleep(60)")
    t0 = time.monotonic()
    found = probe_mod.run_probe(0, 0, {"probe": "", "builds": []}, widths=(8,), timeout=1.5,
                                command=lambda w: [sys.executable, "-c", code])
    assert time.monotonic() - t0 < 8
    assert found[8]["ok"] is False and "no answer within 1.5 s" in found[8]["why"]
    pid = int((tmp_path / "pid").read_text())
    try:
        with open(f"/proc/{pid}/stat") as f:
            state = f.read().rsplit(")", 1)[1].split()[0]
    except FileNotFoundError:
        state = "gone"
    assert state in ("gone", "Z", "X")          # killed with the child (a zombie of no parent at most)


# ---------------------------------------------------------------------------
# no platform, no devices (sound before: checked here so it stays so)
# ---------------------------------------------------------------------------
class Platform:
    name = "Fake platform"

    def __init__(self, devices):
        self.devices = devices

    def get_devices(self):
        if self.devices is None:
            raise cl.RuntimeError("clGetDeviceIDs failed: DEVICE_NOT_FOUND")
        return self.devices


@pytest.mark.parametrize("platforms", [cl.LogicError("clGetPlatformIDs failed: PLATFORM_NOT_FOUND_KHR"),
                                       [], [Platform(None), Platform([])]])
@pytest.mark.parametrize("want", ["", " ", "gpu", "0:0"])
def test_no_platform_or_no_device_is_a_device_not_found_error(monkeypatch, platforms, want):
    def listed():
        if isinstance(platforms, Exception):
            raise platforms
        return platforms
    monkeypatch.setattr(cl, "get_platforms", listed)
    with pytest.raises(pyshadow.DeviceNotFoundError, match="no OpenCL"):
        _cl._choose_device(want)

"""Launch shapes: lane width, batches, work-groups and chunks, per device kind.

Every kernel launch of pyshadow takes its shape from :func:`shape`, so what
depends on the device lives here and nowhere else: its work-group limits,
the largest buffer it allocates (:func:`check_alloc`) and what a launch the
device refuses for want of resources raises (:class:`Kernel`). Each value says why it
has its value; figures are from benchmarks/README.md. A launch of more work-items
than the kernels number (:data:`MAX_WORK_ITEMS`) is refused before it runs; a
device that refuses a context, or a forked child of a process that had one,
gets an error saying what to do (:func:`open_device`).
"""
from __future__ import annotations

import math
import os
import sys
import threading
from contextlib import contextmanager
from dataclasses import asdict, dataclass, replace

import pyopencl as cl

from .probe import DeviceNotSupportedError

__all__ = ["LaunchShape", "Kernel", "shape", "grid", "kernel_group_limit", "override", "check_alloc",
           "new_buffer", "fill", "block_budget", "open_device"]

_overrides: list[dict] = []


@dataclass(frozen=True)
class LaunchShape:
    """How kernels are launched on one device.

    Attributes
    ----------
    kind : str
        'CPU', 'GPU' or 'other'.
    lanes : int
        Lane width the lane kernels are built with (``-DLANES``).
    query_batch : int
        Queries per work-item of ``scene_visible`` and samples per
        ``batch_occluded`` call of ``scene_ao`` (``-DBATCH``), a multiple of
        ``lanes``.
    query_group : int
        Work-items per work-group of the query kernels.
    query_chunk : int
        Queries per launch of ``scene_visible`` (fewer where the device
        allocates less than a chunk's buffers at once).
    ao_chunk_samples : int
        Points x samples per launch of ``scene_ao`` (fewer likewise).
    raster_group : int or None
        Work-items (views) per work-group of ``render_depth_layers``; None
        lets the driver choose.
    triangle_pad : int
        The rasteriser's triangle rows are padded to a multiple of this.
    """

    kind: str
    lanes: int
    query_batch: int
    query_group: int
    query_chunk: int
    ao_chunk_samples: int
    raster_group: int | None
    triangle_pad: int

    def as_dict(self) -> dict:
        return asdict(self)


# one launch of scene_visible answers at most this many queries: keeps the
# kernel's int32 row indices (3 * row for (N, 3) arrays) far from overflow and
# the host buffers of one launch below 100 MB
QUERY_CHUNK = 1 << 22
# points x samples per scene_ao launch: the same bound on its inputs
AO_CHUNK_SAMPLES = 1 << 24
# a multiple of every lane width (16), so the triangle table is the same
# array whatever the width
TRIANGLE_PAD = 16
# the widest row of a launch's buffers: a float64 point or direction of
# scene_visible, the 9 float32 SH transfer terms of a scene_ao point; a chunk
# of rows must fit in one buffer of the device (max_mem_alloc_size, 128 MiB
# for the smallest full-profile device: 24 B x QUERY_CHUNK is 100 MB)
QUERY_ROW_BYTES, AO_ROW_BYTES = 24, 36
# work-items of one launch at most: the kernels number them with 32-bit ints
# (``int i = get_global_id(0)``, ``i >= W * H``), which a larger launch wraps
MAX_WORK_ITEMS = 2 ** 31 - 1


def shape() -> LaunchShape:
    """The launch shape of the current device (see :mod:`pyshadow._cl`)."""
    s = _device_shape()
    for changes in _overrides:
        s = replace(s, **changes)
    if s.query_batch % s.lanes:
        raise ValueError(f"query_batch {s.query_batch} is not a multiple of lanes {s.lanes}")
    return s


@contextmanager
def override(**changes):
    """Launch with some fields of the shape changed inside the block (tests,
    benchmarks): ``with override(query_chunk=1000): ...``; process-wide (every thread's launches)."""
    _overrides.append(changes)
    try:
        yield
    finally:
        _overrides.remove(changes)


def _device_shape() -> LaunchShape:
    from . import device, lanes

    dev = device()
    width = lanes()
    # work-items a group may hold (a kernel's own limit can be lower still:
    # grid() applies it)
    wg_max = max(1, min(int(dev.max_work_group_size), int(dev.max_work_item_sizes[0])))
    alloc = int(dev.max_mem_alloc_size)
    query_chunk = max(1, min(QUERY_CHUNK, alloc // QUERY_ROW_BYTES))
    ao_chunk = max(1, min(AO_CHUNK_SAMPLES, alloc // AO_ROW_BYTES))
    if dev.type & cl.device_type.CPU:
        return LaunchShape(
            kind="CPU",
            lanes=width,
            # 512 queries a work-item: the per-caster packing of
            # batch_occluded fills its lane groups from 512 candidates (the
            # fuller the groups, the fewer half-empty searches), and one ask
            # of the queue searches all its groups' lists together, their
            # cache misses in flight at once (benchmarks/README.md, "Frame
            # time: the lookups' cache misses"); a multiple of every width
            query_batch=512,
            # 16 work-items a group: each holds query_batch queries in private
            # arrays, which PoCL keeps together per group on its stack
            # (thousands of them overflow it); fewer where the device allows fewer
            query_group=min(16, wg_max),
            query_chunk=query_chunk,
            ao_chunk_samples=ao_chunk,
            # one view per group: views differ in cost, and groups of one let
            # PoCL's threads share them out evenly (its own choice split 234
            # views into one half per core and left a core idle: 0.94 against
            # 0.49 ms a map for the bunny at 128^2 on 2 cores)
            raster_group=1,
            triangle_pad=TRIANGLE_PAD,
        )
    gpu = bool(dev.type & cl.device_type.GPU)
    return LaunchShape(
        kind="GPU" if gpu else "other",
        lanes=width,
        # one query per work-item at 1 lane (the GPU's own SIMT lanes do what
        # the vectors do on a CPU); a whole vector otherwise
        query_batch=width,
        # a multiple of NVIDIA's 32-wide warps and AMD's 64-wide wavefronts,
        # within what the device allows
        query_group=min(128, wg_max),
        query_chunk=query_chunk,
        ao_chunk_samples=ao_chunk,
        raster_group=None,
        triangle_pad=TRIANGLE_PAD,
    )


def padded_samples(samples: int, s: LaunchShape | None = None) -> int:
    """``samples`` rounded up to the lane width: a point's lanes in ``scene_ao`` (its ``SPAD``)."""
    s = shape() if s is None else s
    return -(-int(samples) // s.lanes) * s.lanes


def lane_table(table):
    """(M, S, 3) local directions -> (M, 3, S padded to the lane width) for the lane kernels.

    Padding directions are (0, 1, 0) (along the normal); the kernel masks them out.
    """
    import numpy as np

    M, S, _ = table.shape
    spad = padded_samples(S)
    out = np.zeros((M, 3, spad), np.float32)
    out[:, 1, :] = 1.0
    out[:, :, :S] = table.transpose(0, 2, 1)
    return out


def ao_points(samples: int, s: LaunchShape | None = None) -> int:
    """Points per work-item of ``scene_ao`` (``-DAO_POINTS``): as many as fill one batch
    (``query_batch`` queries) with their ``samples`` each (rounded up to the lane width), at least 1.

    The points of a work-item share its queue of CSM lookups, which then asks
    whole lane groups where one point's samples would leave most lanes empty.
    """
    s = shape() if s is None else s
    return max(1, s.query_batch // padded_samples(samples, s))


def grid(items: int, group: int, kernel: cl.Kernel | None = None):
    """Global and local sizes covering ``items`` work-items in groups of ``group``.

    With ``kernel``, a group holds at most the work-items that kernel allows
    on the device (``CL_KERNEL_WORK_GROUP_SIZE``, :func:`kernel_group_limit`),
    which a GPU lowers below the device's own limit for a kernel that needs
    many registers: a launch beyond it fails with INVALID_WORK_GROUP_SIZE.
    """
    if kernel is not None:
        group = min(group, kernel_group_limit(kernel))
    return (-(-int(items) // group) * group,), (group,)


_group_limits: dict = {}


def kernel_group_limit(kernel: cl.Kernel) -> int:
    """Work-items a group of ``kernel`` may hold on the current device (at least 1; asked once per kernel)."""
    limit = _group_limits.get(kernel)
    if limit is None:
        from . import device

        limit = max(1, int(kernel.get_work_group_info(cl.kernel_work_group_info.WORK_GROUP_SIZE, device())))
        _group_limits[kernel] = limit
    return limit


def check_alloc(nbytes) -> int:
    """``nbytes`` as an int, once it is known that the device allocates a buffer that large.

    Raises
    ------
    ValueError
        ``nbytes`` is negative (a byte count that overflowed on its way here).
    DeviceNotSupportedError
        ``nbytes`` is more than the device's ``max_mem_alloc_size``: said
        before anything is allocated, with both sizes (drivers say only
        INVALID_BUFFER_SIZE, or fail at a later launch).
    """
    from . import device

    n = int(nbytes)
    if n < 0:
        raise ValueError(f"a device buffer of {n} bytes was asked for (a byte count that overflowed?)")
    dev = device()
    limit = int(dev.max_mem_alloc_size)
    if n > limit:
        raise DeviceNotSupportedError(
            f"a buffer of {n:,} bytes is more than OpenCL device {dev.name.strip()!r} allocates at once "
            f"(max_mem_alloc_size {limit:,} bytes); ask for less at a time (fewer or lower-resolution CSMs in "
            "one scene, fewer points or a smaller image a call, a lower resolution or fewer maps a block), or "
            "choose another device with PYSHADOW_DEVICE")
    return n


def block_budget(nbytes: int) -> int:
    """The bytes a block of maps' buffers may take: ``nbytes``, or the device's ``max_mem_alloc_size`` where
    that is less (an embedded-profile device's 32 MiB refused the depth maps' 64 MiB default block; each of a
    block's buffers is a part of the budget)."""
    from . import device

    return max(1, min(int(nbytes), int(device().max_mem_alloc_size)))


# OpenCL error codes of a buffer or launch the device cannot hold: memory (a
# GPU allocates buffers at their first use, so a scene whose buffers together
# outgrow its memory fails at a launch, each buffer within max_mem_alloc_size),
# registers or work-group sizes
_RESOURCE_ERRORS = {-4: "MEM_OBJECT_ALLOCATION_FAILURE", -5: "OUT_OF_RESOURCES", -6: "OUT_OF_HOST_MEMORY",
                    -54: "INVALID_WORK_GROUP_SIZE", -55: "INVALID_WORK_ITEM_SIZE", -61: "INVALID_BUFFER_SIZE",
                    -63: "INVALID_GLOBAL_WORK_SIZE"}


#: held while a launch sets a kernel's arguments and enqueues it: :func:`pyshadow._cl.kernel` gives every thread
#: the same kernel object, whose arguments are state of that object (``clSetKernelArg`` is not thread-safe), so
#: two threads launching it at once enqueued one with the other's buffers (wrong answers, or a crash where those
#: buffers were freed first). Enqueueing does not wait for the kernel: the lock is held for microseconds.
_LAUNCH_LOCK = threading.Lock()


class Kernel(cl.Kernel):
    """A ``pyopencl.Kernel`` (what :func:`pyshadow._cl.kernel` returns) whose
    launch, when the device refuses it for want of resources, raises
    :class:`DeviceNotSupportedError` naming the device's limits and what to
    ask for less of (see :func:`launch_error`), as does a launch of more than
    :data:`MAX_WORK_ITEMS` work-items (before it runs); other errors pass unchanged.
    Threads may launch one kernel object at once: its arguments are set and the
    launch enqueued under a lock (:data:`_LAUNCH_LOCK`)."""

    __slots__ = ()

    def __call__(self, queue, global_size, local_size, *args, **kwargs):
        if math.prod(global_size) > MAX_WORK_ITEMS:
            raise DeviceNotSupportedError(
                f"kernel {self.function_name!r} over {tuple(global_size)} work-items: more than the "
                f"{MAX_WORK_ITEMS:,} (2**31 - 1) that pyshadow's kernels count with 32-bit integers in one "
                "launch; ask for less at once (fewer points or a smaller image a call)")
        try:
            with _LAUNCH_LOCK:
                return super().__call__(queue, global_size, local_size, *args, **kwargs)
        except cl.Error as exc:
            err = launch_error(self, exc, global_size, local_size)
            if err is None:
                raise
            raise err from exc


def open_device(dev, name: str, available) -> tuple:
    """A context and an in-order command queue on OpenCL device ``dev`` (``name``: 'P:D platform / device').

    Raises
    ------
    pyshadow.DeviceNotFoundError
        The device refuses them (a GPU another process holds in exclusive mode, a driver whose GPU is
        gone): naming it, the driver's error and ``available()`` (the devices found, a str).
    RuntimeError
        This process is a fork of one that had opened an OpenCL context (:func:`_after_fork`).
    """
    if _forked_from:
        raise RuntimeError(
            f"pyshadow cannot run OpenCL in this process: it is a fork of process {_forked_from[0]}, which had "
            "opened an OpenCL context, and an OpenCL runtime does not survive a fork (its threads stay behind: "
            "the first kernel here would wait forever). Start worker processes with multiprocessing's 'spawn' "
            "or 'forkserver' method (multiprocessing.get_context('spawn'); ProcessPoolExecutor(mp_context=...)),"
            " or before the parent first uses pyshadow")
    try:
        ctx = cl.Context([dev])
        return ctx, cl.CommandQueue(ctx)
    except cl.Error as exc:
        from . import DeviceNotFoundError

        raise DeviceNotFoundError(
            f"OpenCL device {name} could not be opened ({str(exc).strip()}); choose another device with "
            f"PYSHADOW_DEVICE ('cpu', 'gpu' or 'P:D'; available: {available()})") from exc


_forked_from: list[int] = []     # in a forked child of a process that had opened a context: that process


def _after_fork() -> None:
    """In a child process made by ``os.fork`` (multiprocessing's default 'fork' start method on Linux): where
    the parent had opened a context, forget it and make :func:`open_device` refuse to open another (PoCL's
    threads, and GPU drivers' state, do not survive a fork: kernels waited forever). The package's lock is
    new, as another thread of the parent may have held it."""
    pkg = sys.modules.get(__package__)
    if pkg is None:
        return
    if "queue" in pkg._state or pkg._opened:
        _forked_from[:] = _forked_from or [os.getppid()]
        pkg._state.clear()
        pkg._opened.clear()
    pkg._lock = threading.RLock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork)


def new_buffer(context: cl.Context, flags, nbytes: int, hostbuf=None) -> cl.Buffer:
    """A ``pyopencl.Buffer`` of ``nbytes`` (checked by :func:`check_alloc`);
    a device that refuses it for want of memory raises
    :class:`DeviceNotSupportedError` (see :func:`resource_error`)."""
    n = check_alloc(nbytes)
    try:
        if hostbuf is None:
            return cl.Buffer(context, flags, size=n)
        return cl.Buffer(context, flags, hostbuf=hostbuf)
    except cl.Error as exc:
        err = resource_error(exc, f"a buffer of {n:,} bytes")
        if err is None:
            raise
        raise err from exc


def fill(queue, buf: cl.Buffer, pattern, nbytes: int, offset: int = 0):
    """``pyopencl.enqueue_fill_buffer`` of ``nbytes`` bytes of ``buf`` from ``offset`` with ``pattern`` (a NumPy
    scalar); a device that refuses it for want of memory raises :class:`DeviceNotSupportedError` (see
    :func:`resource_error`): a GPU allocates a new buffer at its first use, often this fill, and said only
    ``MemoryError: clEnqueueFillBuffer failed: MEM_OBJECT_ALLOCATION_FAILURE``."""
    try:
        return cl.enqueue_fill_buffer(queue, buf, pattern, offset, nbytes)
    except cl.Error as exc:
        err = resource_error(exc, f"filling a buffer of {int(nbytes):,} bytes (its memory, at its first use)")
        if err is None:
            raise
        raise err from exc


def launch_error(kernel, exc: cl.Error, global_size, local_size) -> DeviceNotSupportedError | None:
    """The error a failed launch of ``kernel`` raises (:func:`resource_error`), or None."""
    try:
        name = repr(kernel.function_name)
        allows = f", the kernel allowing {kernel_group_limit(kernel):,} a group"
    except cl.Error:            # a device too broken to answer: the message without it
        name, allows = "?", ""
    group = "(driver choice)" if local_size is None else tuple(local_size)
    return resource_error(exc, f"kernel {name} over {tuple(global_size)} work-items in groups of {group}{allows}")


def resource_error(exc: cl.Error, doing: str) -> DeviceNotSupportedError | None:
    """A :class:`DeviceNotSupportedError` saying the device refused
    ``doing`` (a buffer, a launch) and naming its limits and what to ask for
    less of, where the OpenCL error ``exc`` says it lacks the memory or
    work-items asked for; else None (``exc`` itself is raised)."""
    from . import device

    what = _RESOURCE_ERRORS.get(getattr(exc, "code", None))
    if what is None:
        return None
    dev = device()
    return DeviceNotSupportedError(
        f"OpenCL device {dev.name.strip()!r} refused {doing}: {what} "
        f"(the device has {int(dev.global_mem_size):,} bytes of global memory and allocates at most "
        f"{int(dev.max_mem_alloc_size):,} bytes a buffer and {int(dev.max_work_group_size):,} work-items a group). "
        "Ask for less at once (fewer or lower-resolution CSMs in one scene, fewer points or a smaller "
        "image a call, a lower resolution or fewer maps a block), free other programs' use of the device, or "
        "choose another device with PYSHADOW_DEVICE")

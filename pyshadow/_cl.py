"""OpenCL runtime: device choice, one context and queue, the program cache.

This is the only module that builds OpenCL programs. Everything else asks for a
kernel with :func:`kernel` and gets the same ``pyopencl.Kernel`` object back for
the same (source file, compile-time defines) on every call.

Device choice
-------------
``PYSHADOW_DEVICE`` selects the device:

* unset: the first GPU of any platform, else the CPU device of PoCL (the
  ``pocl-binary-distribution`` wheel), else any CPU device;
* ``gpu`` / ``cpu``: the first device of that type;
* ``P:D``: device ``D`` of platform ``P`` (indices as listed by
  :func:`pyshadow.device_info` under ``"available"``).

When nothing matches, :class:`DeviceNotFoundError` names every device found.
"""
from __future__ import annotations

import hashlib
import os
import re
import tempfile
import threading
from pathlib import Path

import numpy as np
import pyopencl as cl

__all__ = [
    "DeviceNotFoundError",
    "KernelBuildError",
    "context",
    "queue",
    "device",
    "device_info",
    "kernel",
    "kernel_dir",
    "kernel_source",
    "build_source",
    "program",
]

_lock = threading.RLock()
_state: dict = {}
_programs: dict = {}
_kernels: dict = {}


class DeviceNotFoundError(RuntimeError):
    """No OpenCL device matches the request (``PYSHADOW_DEVICE``)."""


class KernelBuildError(RuntimeError):
    """An OpenCL program failed to compile; the message holds the build log."""


# --------------------------------------------------------------------------
# Kernel sources
# --------------------------------------------------------------------------
def kernel_dir() -> Path:
    """Folder holding the ``.cl`` / ``.h`` sources.

    An installed pyshadow has them as the subpackage ``pyshadow.kernels``
    (setup.cfg maps the top-level ``kernels/`` there). A source checkout
    imported from the repository root has no such subpackage, so the folder
    ``kernels/`` beside the package is used instead.
    """
    try:
        from importlib.resources import files

        base = files("pyshadow.kernels")
        path = Path(str(base))
        if (path / "raster.cl").is_file():
            return path
    except ModuleNotFoundError:
        pass
    path = Path(__file__).resolve().parent.parent / "kernels"
    if (path / "raster.cl").is_file():
        return path
    raise FileNotFoundError(
        "pyshadow's OpenCL sources were not found: neither the installed "
        f"package pyshadow.kernels nor {path} holds raster.cl"
    )


_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$', re.M)


def kernel_source(name: str) -> str:
    """Text of kernel file ``name`` with its ``#include "x.h"`` lines inlined."""
    root = kernel_dir()
    seen: set[str] = set()

    def expand(fname: str) -> str:
        path = root / fname
        if not path.is_file():
            raise FileNotFoundError(f"kernel source {fname!r} not found in {root}")
        text = path.read_text()

        def repl(m):
            inc = m.group(1)
            if inc in seen:
                return f"/* {inc} already included */"
            seen.add(inc)
            return f"/* ---- begin {inc} ---- */\n{expand(inc)}\n/* ---- end {inc} ---- */"

        return _INCLUDE.sub(repl, text)

    seen.add(name)
    return expand(name)


# --------------------------------------------------------------------------
# Device, context, queue
# --------------------------------------------------------------------------
def _all_devices():
    found = []
    try:
        platforms = cl.get_platforms()
    except cl.Error as exc:  # pragma: no cover - no ICD at all
        raise DeviceNotFoundError(f"no OpenCL platform could be listed: {exc}") from exc
    for pi, plat in enumerate(platforms):
        try:
            devs = plat.get_devices()
        except cl.Error:
            continue
        for di, dev in enumerate(devs):
            found.append((pi, di, plat, dev))
    return found


def _describe(found) -> str:
    if not found:
        return "no OpenCL devices at all (is pocl-binary-distribution installed?)"
    return "; ".join(
        f"{pi}:{di} {plat.name.strip()} / {dev.name.strip()} ({_type_name(dev.type)})"
        for pi, di, plat, dev in found
    )


def _choose_device():
    found = _all_devices()
    want = os.environ.get("PYSHADOW_DEVICE", "").strip().lower()

    def of_type(t):
        return [f for f in found if f[3].type & t]

    if want in ("", "auto"):
        gpus = of_type(cl.device_type.GPU)
        if gpus:
            return gpus[0]
        cpus = of_type(cl.device_type.CPU)
        pocl = [f for f in cpus if "portable computing language" in f[2].name.lower()]
        if pocl:
            return pocl[0]
        if cpus:
            return cpus[0]
        if found:
            return found[0]
        raise DeviceNotFoundError("no OpenCL device found: " + _describe(found))
    if want in ("gpu", "cpu"):
        t = cl.device_type.GPU if want == "gpu" else cl.device_type.CPU
        hits = of_type(t)
        if not hits:
            raise DeviceNotFoundError(
                f"PYSHADOW_DEVICE={want!r} but no {want.upper()} device was found; "
                f"available: {_describe(found)}"
            )
        return hits[0]
    m = re.fullmatch(r"(\d+):(\d+)", want)
    if m:
        pi, di = int(m.group(1)), int(m.group(2))
        for f in found:
            if f[0] == pi and f[1] == di:
                return f
        raise DeviceNotFoundError(
            f"PYSHADOW_DEVICE={want!r} names no device; available: {_describe(found)}"
        )
    raise DeviceNotFoundError(
        f"PYSHADOW_DEVICE={want!r} is not 'cpu', 'gpu' or 'P:D'; available: {_describe(found)}"
    )


def _init():
    with _lock:
        if "queue" not in _state:
            pi, di, plat, dev = _choose_device()
            ctx = cl.Context([dev])
            _state.update(
                platform=plat,
                device=dev,
                context=ctx,
                queue=cl.CommandQueue(ctx),
                index=(pi, di),
            )
        return _state


def context() -> cl.Context:
    """The process-wide OpenCL context (created on first use)."""
    return _init()["context"]


def queue() -> cl.CommandQueue:
    """The process-wide in-order command queue."""
    return _init()["queue"]


def device() -> cl.Device:
    """The chosen OpenCL device."""
    return _init()["device"]


def _type_name(t) -> str:
    for flag, name in ((cl.device_type.GPU, "GPU"), (cl.device_type.CPU, "CPU"),
                       (cl.device_type.ACCELERATOR, "ACCELERATOR")):
        if t & flag:
            return name
    return cl.device_type.to_string(t)


def device_info() -> dict:
    """Describe the OpenCL device pyshadow runs on.

    Returns
    -------
    info : dict
        ``platform`` (str), ``name`` (str), ``type`` ('CPU', 'GPU', ...),
        ``compute_units`` (int), ``opencl_version`` (str, the device's),
        ``opencl_c_version`` (str), ``global_mem_bytes`` (int),
        ``max_alloc_bytes`` (int), ``index`` ('P:D', usable in
        ``PYSHADOW_DEVICE``) and ``available`` (list of 'P:D name (type)'
        strings of every device found).

    Examples
    --------
    >>> info = device_info()
    >>> sorted(info)[:3]
    ['available', 'compute_units', 'global_mem_bytes']
    """
    st = _init()
    dev = st["device"]
    return {
        "platform": st["platform"].name.strip(),
        "name": dev.name.strip(),
        "type": _type_name(dev.type),
        "compute_units": int(dev.max_compute_units),
        "opencl_version": dev.version.strip(),
        "opencl_c_version": dev.opencl_c_version.strip(),
        "global_mem_bytes": int(dev.global_mem_size),
        "max_alloc_bytes": int(dev.max_mem_alloc_size),
        "index": "%d:%d" % st["index"],
        "available": [
            f"{pi}:{di} {d.name.strip()} ({_type_name(d.type)})"
            for pi, di, _p, d in _all_devices()
        ],
    }


# --------------------------------------------------------------------------
# Programs and kernels
# --------------------------------------------------------------------------
def _options(defines: dict | None) -> tuple[str, ...]:
    opts = ["-cl-std=CL1.2"]
    for key in sorted(defines or {}):
        val = defines[key]
        if isinstance(val, bool):
            val = int(val)
        if isinstance(val, float):
            val = repr(float(val)) + "f"
        opts.append(f"-D{key}={val}")
    return tuple(opts)


def program(source_file: str, defines: dict | None = None) -> cl.Program:
    """Built program for ``source_file`` with ``-D`` ``defines`` (memoised)."""
    st = _init()
    opts = _options(defines)
    key = (id(st["context"]), source_file, opts)
    with _lock:
        prg = _programs.get(key)
        if prg is None:
            prg = build_source(kernel_source(source_file), source_file, defines)
            _programs[key] = prg
        return prg


def build_source(src: str, label: str, defines: dict | None = None) -> cl.Program:
    """Build OpenCL C text ``src`` (not cached); ``label`` names it in errors.

    Raises
    ------
    KernelBuildError
        With the options used, the compiler log, and the path of a file that
        holds the full source as compiled.
    """
    st = _init()
    opts = _options(defines)
    try:
        return cl.Program(st["context"], src).build(options=list(opts))
    except (cl.RuntimeError, cl.LogicError) as exc:
        digest = hashlib.sha1(src.encode()).hexdigest()[:12]
        dump = Path(tempfile.gettempdir()) / f"pyshadow-{Path(label).stem}-{digest}.cl"
        dump.write_text(src)
        raise KernelBuildError(
            f"building {label} failed on {st['device'].name.strip()} "
            f"with options {' '.join(opts)}; full source saved to {dump}\n{exc}"
        ) from exc


def kernel(source_file: str, name: str, defines: dict | None = None) -> cl.Kernel:
    """The kernel ``name`` of ``source_file`` built with ``defines`` (memoised).

    The same ``Kernel`` object is returned for the same arguments, so argument
    setting and pyopencl's per-kernel caches are reused.
    """
    key = (source_file, name, _options(defines))
    with _lock:
        k = _kernels.get(key)
        if k is None:
            k = cl.Kernel(program(source_file, defines), name)
            _kernels[key] = k
        return k


def to_device(array: np.ndarray, dtype=None) -> cl.Buffer:
    """Copy a host array into a new read-only device buffer (C order)."""
    a = np.ascontiguousarray(array, dtype=dtype)
    mf = cl.mem_flags
    if a.nbytes == 0:
        a = np.zeros(1, dtype=a.dtype)
    return cl.Buffer(context(), mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a)


def host_buffer(array: np.ndarray, writable: bool = False) -> cl.Buffer:
    """A device buffer over a C-contiguous host array (no copy on CPU devices).

    The array must stay alive, and unchanged, until the kernels using the
    buffer have finished; for a writable buffer, map it (or finish the queue)
    before reading the array.
    """
    a = np.asarray(array)
    if not a.flags.c_contiguous:
        raise ValueError("host_buffer needs a C-contiguous array")
    if a.nbytes == 0:
        return to_device(np.zeros(1, a.dtype))
    mf = cl.mem_flags
    flags = (mf.READ_WRITE if writable else mf.READ_ONLY) | mf.USE_HOST_PTR
    return cl.Buffer(context(), flags, hostbuf=a)


def sync_host_buffer(buf: cl.Buffer, array: np.ndarray) -> None:
    """Make a :func:`host_buffer`'s device writes visible in its host array.

    Maps the buffer for reading and unmaps it again (free on CPU devices,
    where the buffer is the array; a copy back elsewhere).
    """
    mapped, _ev = cl.enqueue_map_buffer(queue(), buf, cl.map_flags.READ, 0, array.shape, array.dtype)
    mapped.base.release(queue())
    queue().finish()


def has_fp64() -> bool:
    """Whether the device computes in double precision (cl_khr_fp64)."""
    dev = device()
    return bool(dev.double_fp_config) and "cl_khr_fp64" in dev.extensions


def empty(nbytes: int) -> cl.Buffer:
    """A new device buffer of ``nbytes`` (at least 1)."""
    return cl.Buffer(context(), cl.mem_flags.READ_WRITE, size=max(int(nbytes), 4))

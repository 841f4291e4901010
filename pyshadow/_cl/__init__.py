"""OpenCL runtime: device choice, one context and queue, the program cache.

This is the only module that builds OpenCL programs. Everything else asks for a
kernel with :func:`kernel` and gets the same ``pyopencl.Kernel`` object back for
the same (source file, compile-time defines) on every call.

Device choice
-------------
``PYSHADOW_DEVICE`` selects the device:

* unset: the first GPU of any platform (not one typed CPU as well: a simulator, Oclgrind),
  else the CPU device of PoCL (``pocl-binary-distribution``), else any CPU device;
* ``gpu`` / ``cpu``: the first device of that type;
* ``P:D``: device ``D`` of platform ``P`` (indices as listed by
  :func:`pyshadow.device_info` under ``"available"``).

When nothing matches, :class:`DeviceNotFoundError` names every device found.

Lane width
----------
Kernels that work on lane vectors are built with ``-DLANES`` = 1, 4, 8 or 16
(``kernels/lanes.h``). :func:`lanes` gives the width in use: ``PYSHADOW_LANES``
if set, else the widest width the device passed in a probe run in child
processes (:mod:`pyshadow._cl.probe`; 1 on GPUs, one query per work-item),
cached on disk per device and driver. A width that failed the probe is never
used (``PYSHADOW_LANES`` naming a width that fails the probe, cached or run
then, raises :class:`DeviceNotSupportedError`); a device that fails them all
raises :class:`DeviceNotSupportedError` naming it. Launch shapes (batches,
work-groups, chunks) come from :func:`pyshadow._cl.launch.shape`.
"""
from __future__ import annotations

import hashlib
import os
import re
import tempfile
import threading
import warnings
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pyopencl as cl

from . import memo as _memo
from . import pocl_cpu as _pocl_cpu
from . import probe as _probe
from .launch import Kernel, check_alloc, new_buffer, open_device
from .probe import LANE_WIDTHS, DeviceNotSupportedError

__all__ = [
    "DeviceNotFoundError", "DeviceNotSupportedError", "KernelBuildError", "LaneWidthWarning", "LANE_WIDTHS",
    "lanes", "lane_choice", "use_lanes", "use_device", "devices", "context", "queue", "device", "device_info",
    "kernel", "kernel_dir", "kernel_source", "build_source", "program",
]

_lock = threading.RLock()
_state: dict = {}
_programs: dict = {}
_kernels: dict = {}


class DeviceNotFoundError(RuntimeError):
    """No OpenCL device matches the request (``PYSHADOW_DEVICE``)."""


class KernelBuildError(RuntimeError):
    """An OpenCL program failed to compile; the message holds the build log."""


class LaneWidthWarning(UserWarning):
    """The device failed the probe at its preferred lane width; a narrower one is used."""


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
    path = Path(__file__).resolve().parents[2] / "kernels"
    if (path / "raster.cl").is_file():
        return path
    raise FileNotFoundError(
        "pyshadow's OpenCL sources were not found: neither the installed "
        f"package pyshadow.kernels nor {path} holds raster.cl"
    )


_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$', re.M)


def kernel_source(name: str) -> str:
    """Text of kernel file ``name`` with its ``#include "x.h"`` lines inlined.

    Headers generated from the host's table dtypes (``scene_types.h``, see
    :mod:`pyshadow._cl.tables`) are served from memory.
    """
    from .tables import GENERATED_HEADERS

    root = kernel_dir()
    seen: set[str] = set()

    def expand(fname: str) -> str:
        if fname in GENERATED_HEADERS:
            return GENERATED_HEADERS[fname]
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
    _pocl_cpu.apply()       # before PoCL reads the host's CPU name (a CPU its LLVM does not know)
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
        return "no OpenCL devices at all (is pocl-binary-distribution installed?)" + _pocl_cpu.devices_hint()
    return "; ".join(
        f"{pi}:{di} {plat.name.strip()} / {dev.name.strip()} ({_type_name(dev.type)})"
        for pi, di, plat, dev in found
    )


def _choose_device(want: str | None = None):
    found = _all_devices()
    if want is None:
        want = os.environ.get("PYSHADOW_DEVICE", "")
    want = want.strip().lower()

    def of_type(t):
        return [f for f in found if f[3].type & t]

    if want in ("", "auto"):       # a GPU that also claims the CPU type is a simulator (Oclgrind's 15): not chosen
        gpus = [f for f in of_type(cl.device_type.GPU) if not f[3].type & cl.device_type.CPU]
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


def _open(choice) -> dict:
    pi, di, plat, dev = choice
    ctx, q = open_device(dev, f"{pi}:{di} {plat.name.strip()} / {dev.name.strip()}", lambda: _describe(_all_devices()))
    return dict(platform=plat, device=dev, context=ctx, queue=q, index=(pi, di))


def _init():
    with _lock:
        if "queue" not in _state:
            _state.update(_open(_choose_device()))
        return _state


_opened: dict = {}     # (platform, device) -> state kept by use_device(), so each
                      # device gets one context and its programs are built once


def devices() -> list[str]:
    """Every OpenCL device found, as 'P:D' strings usable in ``PYSHADOW_DEVICE``."""
    return ["%d:%d" % (pi, di) for pi, di, _p, _d in _all_devices()]


@contextmanager
def use_device(spec: str):
    """Run the enclosed code on device ``spec`` ('P:D', 'cpu' or 'gpu'), then go back.

    Buffers made inside belong to that device's context; objects that keep device buffers (CSMs, scenes)
    rebuild them for the context in use. Process-wide: every thread's queries run there meanwhile.
    """
    choice = _choose_device(spec)
    with _lock:
        saved = dict(_state)
        if saved.get("index") != choice[:2]:
            opened = _opened.get(choice[:2])
            if opened is None:
                opened = _opened[choice[:2]] = _open(choice)
            _state.clear()
            _state.update(opened)
    try:
        yield
    finally:
        with _lock:
            _state.clear()
            _state.update(saved)


# --------------------------------------------------------------------------
# Lane width
# --------------------------------------------------------------------------
_lane_override: list[int] = []


def lane_choice() -> dict:
    """The lane width of the current device and why it was chosen.

    Returns
    -------
    dict
        ``lanes`` (int), ``reason`` (str), ``supported`` (list of widths
        that passed the probe, widest first), ``verdicts`` ({width: why}),
        ``source`` ('PYSHADOW_LANES', 'cache' or 'probe').

    Raises
    ------
    ValueError
        ``PYSHADOW_LANES`` is set to something other than 1, 4, 8 or 16.
    DeviceNotSupportedError
        The device failed the probe at every width.
    """
    st = _init()
    override = _probe.parse_override(os.environ.get("PYSHADOW_LANES"))
    if override is not None:
        with _lock:         # one probe, not one a thread: threads' first queries at once each started one
            if st.get("override_checked", (None,))[0] != override:
                st["override_checked"] = (override, _probe.check_override(
                    override, *st["index"], st["platform"], st["device"], _probe_job(st["device"])))
            found = st["override_checked"][1]
        choice = {"lanes": override, "supported": [w for w in LANE_WIDTHS if found[w]["ok"]],
                  "verdicts": {w: v["why"] for w, v in found.items()}, "source": "PYSHADOW_LANES",
                  "reason": f"PYSHADOW_LANES={override} (checked by the probe)"}
    else:
        with _lock:
            cached = st.get("lane_choice")
            if cached is None:
                cached = st["lane_choice"] = _probe_choice(st)
        choice = dict(cached)
    if _lane_override:
        choice.update(lanes=_lane_override[-1], source="use_lanes",
                      reason=f"use_lanes({_lane_override[-1]})")
    return choice


def _probe_choice(st) -> dict:
    """Probe verdicts (cached or fresh) and the width they choose."""
    dev, plat = st["device"], st["platform"]
    found, source = _probe.verdicts(*st["index"], plat, dev, _probe_job(dev))
    ok = [w for w in LANE_WIDTHS if found[w]["ok"]]
    name = dev.name.strip()
    why = _probe.grouped_whys(found)
    if not ok:
        hint = _probe.extra_flags_hint(why)
        if "unknown target CPU" in why:        # PoCL's LLVM does not know this CPU (pocl_cpu.py)
            hint += (f" PoCL's compiler does not know this CPU ({_pocl_cpu.ENV}="
                     f"{os.environ.get(_pocl_cpu.ENV, '') or 'unset'}); set {_pocl_cpu.ENV} to a CPU name "
                     "it knows, e.g. x86-64, or unset it to let pyshadow choose.")
        raise DeviceNotSupportedError(
            f"OpenCL device {name!r} ({plat.name.strip()}, driver {dev.driver_version.strip()}) "
            f"cannot run pyshadow's kernels at any lane width ({why}).{hint} Choose another device "
            f"with PYSHADOW_DEVICE (available: {_describe(_all_devices())})" + (f". These verdicts were read "
            f"from {_probe.cache_file()}: delete it to probe this device again" if source == "cache" else ""))
    gpu = bool(dev.type & cl.device_type.GPU)
    preferred = 1 if gpu else LANE_WIDTHS[0]
    width = 1 if (gpu and 1 in ok) else ok[0]
    if width != preferred:
        reason = (f"{preferred} lanes failed the probe ({found[preferred]['why']}); "
                  f"{width} is the widest that passed")
        if source == "probe":
            warnings.warn(f"pyshadow: {preferred}-lane kernels fail on OpenCL device {name!r}: "
                          f"{found[preferred]['why']}. Using {width} lanes instead "
                          f"(verdict cached in {_probe.cache_file()}).", LaneWidthWarning,
                          stacklevel=4)
    else:
        reason = ("GPU: one query per work-item" if gpu
                  else f"the widest width, {width}, passed the probe")
    return {"lanes": width, "supported": ok, "source": source, "reason": f"{reason} ({source})",
            "verdicts": {w: v["why"] for w, v in found.items()}}


def _probe_job(dev) -> dict:
    """What the probe builds at each width: its own small kernel (run and
    checked) and the lane kernels in their widest variants (built only)."""
    # the extension first: an OpenCL 1.0/1.1 device without it may refuse the DOUBLE_FP_CONFIG query
    fp64 = int("cl_khr_fp64" in dev.extensions.split() and bool(dev.double_fp_config))
    scene = {"DEPTH_BITS": 16, "IEND_T": "ushort", "PAIR_WIDE": 0, "SEARCH_BLOCK": 16,
             "NTYPES": 1, "GROUND": 1, "LAYOUT_ZIGZAG": 1, "LAYOUT_HILBERT": 1,
             "FILTER_ANGLE_EPS": "1e-4f", "HAVE_FP64": fp64, "BATCH": 128, "SURFACE_NORMALS": 1,
             "SURFACE_LIFT_TEXELS": "0.5f", "PLANE_BIAS": 1, "PLANE_BIAS_TEXELS": "0.25f"}
    builds = [("raster.cl", {"RES": 64, "LAYERS": 3, "FACING": 1}),
              ("visibility.cl", {**scene, "FILTERED": 0, "POINTS_F64": fp64, "DIRS_F64": fp64,
                                 "SAMPLES": 36, "AO_POINTS": 3, "BENT_NORMALS": 1, "TRANSFER": 1}),
              ("visibility.cl", {**scene, "FILTERED": 1, "POINTS_F64": 0, "DIRS_F64": 0})]
    return {"probe": kernel_source("probe.cl"),
            "builds": [{"label": f, "source": kernel_source(f), "options": list(_options(d))}
                       for f, d in builds]}


def lanes() -> int:
    """Lanes per vector (1, 4, 8 or 16) the kernels are built with on this device."""
    return lane_choice()["lanes"]


@contextmanager
def use_lanes(width: int):
    """Build and run kernels at ``width`` lanes inside the block (tests, benchmarks; process-wide: every thread's)."""
    if width not in LANE_WIDTHS:
        raise ValueError(f"lane width must be one of {LANE_WIDTHS}, got {width!r}")
    _lane_override.append(int(width))
    try:
        yield
    finally:
        _lane_override.pop()


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
        ``PYSHADOW_DEVICE``), ``available`` (list of 'P:D name (type)'
        strings of every device found), ``lanes`` (int, lane width of the
        kernels), ``lanes_reason`` (str, why that width), ``lanes_supported``
        (list of int, widths that passed the probe) and ``launch`` (dict, the
        launch shape of :func:`pyshadow._cl.launch.shape`).

    Examples
    --------
    >>> info = device_info()
    >>> sorted(info)[:3]
    ['available', 'compute_units', 'global_mem_bytes']
    """
    st = _init()
    dev = st["device"]
    choice = lane_choice()
    from .launch import shape

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
        "lanes": choice["lanes"],
        "lanes_reason": choice["reason"],
        "lanes_supported": choice["supported"],
        "launch": shape().as_dict(),
        "pocl_cpu": _pocl_cpu.applied(),
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


_lane_files: dict = {}


def _uses_lanes(source_file: str) -> bool:
    """Whether ``source_file`` includes ``lanes.h`` (directly or through a header)."""
    hit = _lane_files.get(source_file)
    if hit is None:
        hit = _lane_files[source_file] = "---- begin lanes.h ----" in kernel_source(source_file)
    return hit


def _with_lanes(source_file: str, defines: dict | None) -> dict:
    """``defines`` plus ``LANES`` (the device's lane width) for the files that
    work on lanes, unless ``defines`` names a width."""
    d = dict(defines or {})
    if _uses_lanes(source_file):
        d.setdefault("LANES", lanes())
    return d


def program(source_file: str, defines: dict | None = None) -> cl.Program:
    """Built program for ``source_file`` with ``-D`` ``defines`` (memoised; while one builds, other threads'
    programs and kernels are found and built: :mod:`.memo`).

    Files that include ``lanes.h`` get ``LANES`` from :func:`lanes` unless
    ``defines`` holds it.
    """
    st = _init()
    defines = _with_lanes(source_file, defines)
    opts = _options(defines)
    key = (id(st["context"]), source_file, opts)
    return _memo.once(_programs, key, lambda: build_source(kernel_source(source_file), source_file, defines))


ABI_WARNING = "changes the ABI"     # clang's, as probe_child.py's (4 doubles at an SSE2 target: 1 ray in 3 wrong)


def build_source(src: str, label: str, defines: dict | None = None) -> cl.Program:
    """Build OpenCL C text ``src`` (not cached); ``label`` names it in errors.

    Raises
    ------
    KernelBuildError
        With the options used, the compiler log, and the path of a file that
        holds the full source as compiled; also where the log warns that a
        vector argument changes the ABI (the build would run miscompiled).
    """
    st = _init()
    opts = _options(defines)
    try:
        prg = cl.Program(st["context"], src).build(options=list(opts))
        log = prg.get_build_info(st["device"], cl.program_build_info.LOG) or ""
        if ABI_WARNING in log:      # "built", but its calls into the builtin library are miscompiled
            raise cl.RuntimeError(f"the compiler warns that a vector argument {ABI_WARNING}: this build's calls "
                                  "into the device's builtin library would run miscompiled (its target lacks "
                                  f"the vector registers they assume):\n{log.strip()[-2000:]}")
        return prg
    except (cl.RuntimeError, cl.LogicError) as exc:
        digest = hashlib.sha1(src.encode()).hexdigest()[:12]
        dump = Path(tempfile.gettempdir()) / f"pyshadow-{Path(label).stem}-{digest}.cl"
        try:
            dump.write_text(src)
            saved = f"full source saved to {dump}"
        except OSError as err:      # a read-only or full temporary folder: the compiler's log all the same
            saved = f"the full source could not be saved ({err})"
        raise KernelBuildError(
            f"building {label} failed on {st['device'].name.strip()} "
            f"with options {' '.join(opts)}; {saved}\n{exc}"
        ) from exc


def kernel(source_file: str, name: str, defines: dict | None = None) -> cl.Kernel:
    """The kernel ``name`` of ``source_file`` built with ``defines`` (memoised).

    The same ``Kernel`` object is returned for the same arguments, so argument
    setting and pyopencl's per-kernel caches are reused. It is a
    :class:`pyshadow._cl.launch.Kernel`: a launch the device refuses for want
    of memory or work-items raises :class:`DeviceNotSupportedError`.
    """
    defines = _with_lanes(source_file, defines)
    key = (id(context()), source_file, name, _options(defines))
    return _memo.once(_kernels, key, lambda: Kernel(program(source_file, defines), name))


def to_device(array: np.ndarray, dtype=None) -> cl.Buffer:
    """Copy a host array into a new read-only device buffer (C order)."""
    a = np.ascontiguousarray(array, dtype=dtype)
    mf = cl.mem_flags
    if a.nbytes == 0:
        a = np.zeros(1, dtype=a.dtype)
    return new_buffer(context(), mf.READ_ONLY | mf.COPY_HOST_PTR, a.nbytes, a)


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
    return new_buffer(context(), flags, a.nbytes, a)


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
    return "cl_khr_fp64" in dev.extensions.split() and bool(dev.double_fp_config)


def empty(nbytes: int) -> cl.Buffer:
    """A new device buffer of ``nbytes`` (at least 1; see :func:`~pyshadow._cl.launch.check_alloc`)."""
    return new_buffer(context(), cl.mem_flags.READ_WRITE, max(check_alloc(nbytes), 4))

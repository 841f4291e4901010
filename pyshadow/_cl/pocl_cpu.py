"""PoCL 3.0's target CPU on processors its LLVM 14 does not know.

The PoCL of pip (pocl-binary-distribution 3.0, bundled in pyopencl's wheel
as a 3.0-rc2 build on LLVM 14) names the CPU it compiles for by LLVM's
detection of the host. A processor newer than LLVM 14 (seen: AMD family 1Ah,
Zen 5) comes out as ``"generic"``, which that clang refuses (``error:
unknown target CPU 'generic'``): no kernel builds at all, not even a one-line
one. That PoCL has no setting for the name (later ones read
``POCL_LLVM_CPU_NAME``), so :func:`apply`, run before the first OpenCL
call, asks the loaded PoCL for it and, only when it is ``"generic"``,
rewrites the entry of the exported function that returns it
(``pocl_get_llvm_cpu_name``, x86-64 machine code: a tail call of the C
library's ``strdup``, no Python, so any PoCL thread may call it) to return
the most capable CPU LLVM 14 knows whose instruction sets the host has
(``/proc/cpuinfo``). The lane-width probe (:mod:`.probe`) then tests the
kernels on that target as on any other.

``PYSHADOW_POCL_CPU``: a CPU name to use instead (it is used whatever PoCL
detects), or ``off`` to leave PoCL alone. Imports only the standard
library: the probe's child process loads this file too.
"""
from __future__ import annotations

import ctypes
import glob
import os
import platform
import struct
import sys

__all__ = ["ENV", "TARGETS", "choose_target", "apply", "applied", "devices_hint", "compile_key"]

ENV = "PYSHADOW_POCL_CPU"

# LLVM 14 CPU names, most capable first, each with the /proc/cpuinfo flags of
# the instruction sets its code generation may use
_AVX2 = {"avx", "avx2", "fma", "bmi1", "bmi2", "f16c", "movbe", "abm", "popcnt", "sse4_1", "sse4_2", "ssse3"}
TARGETS = (
    ("skylake-avx512", _AVX2 | {"adx", "avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"}),
    ("haswell", _AVX2),
    ("sandybridge", {"avx", "popcnt", "sse4_1", "sse4_2", "ssse3"}),
    ("nehalem", {"popcnt", "sse4_1", "sse4_2", "ssse3"}),
    ("x86-64", set()),
)

_state: dict = {}


def choose_target(flags) -> str:
    """The first name of :data:`TARGETS` whose instruction sets are all among ``flags``."""
    have = set(flags)
    return next(name for name, need in TARGETS if need <= have)


def _cpu_flags() -> set:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("flags"):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def _bundled_pocl():
    """Path of the PoCL library in pyopencl's wheel, or None (a PoCL of the system: left alone)."""
    try:
        import pyopencl
    except ImportError:
        return None
    here = os.path.dirname(pyopencl.__file__)
    for libs in (os.path.join(here, ".libs"), here + ".libs"):     # pyopencl/.libs, or auditwheel's pyopencl.libs
        found = sorted(glob.glob(os.path.join(libs, "libpocl*.so*")))
        if found:
            return found[0]
    return None


def _returning_copy(func_addr: int, text_addr: int, strdup_addr: int) -> bool:
    """Overwrite the entry of the function at ``func_addr`` (x86-64) so that it returns
    ``strdup(text)``: a tail call of the C library's ``strdup`` with ``text_addr`` as its argument.
    Machine code only, no Python: PoCL may call it from any thread."""
    libc = ctypes.CDLL(None)
    libc.mprotect.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int]
    code = (b"\x48\xbf" + struct.pack("<Q", text_addr)       # movabs rdi, text
            + b"\x48\xb8" + struct.pack("<Q", strdup_addr)   # movabs rax, strdup
            + b"\xff\xe0")                                   # jmp rax
    page = os.sysconf("SC_PAGE_SIZE")
    start = func_addr & ~(page - 1)
    span = func_addr + len(code) - start
    if libc.mprotect(start, span, 7) != 0:          # read, write, execute
        return False
    ctypes.memmove(func_addr, code, len(code))
    libc.mprotect(start, span, 5)                    # read, execute
    return True


def _apply() -> str | None:
    want = os.environ.get(ENV, "").strip()
    if want.lower() == "off" or not sys.platform.startswith("linux") \
            or platform.machine().lower() not in ("x86_64", "amd64"):
        return None
    path = _bundled_pocl()
    if path is None:
        return None
    lib = ctypes.CDLL(path, mode=ctypes.RTLD_GLOBAL)
    try:
        get = lib.pocl_get_llvm_cpu_name
    except AttributeError:
        return None
    get.restype, get.argtypes = ctypes.c_void_p, []
    libc = ctypes.CDLL(None)
    libc.free.argtypes = [ctypes.c_void_p]
    libc.strdup.restype, libc.strdup.argtypes = ctypes.c_void_p, [ctypes.c_char_p]
    ptr = get()
    detected = ctypes.string_at(ptr).decode() if ptr else ""
    if ptr:
        libc.free(ptr)
    _state["detected"] = detected
    if not want and detected not in ("", "generic"):
        return None
    name = want or choose_target(_cpu_flags())
    text = ctypes.create_string_buffer(name.encode())
    # PoCL frees the name it is given: a copy from the C library's allocator on every call
    if not _returning_copy(ctypes.cast(get, ctypes.c_void_p).value, ctypes.addressof(text),
                           ctypes.cast(libc.strdup, ctypes.c_void_p).value):
        return None
    _state["keep"] = (lib, text)                    # the name must live as long as the process
    return name


def apply() -> str | None:
    """Give the bundled PoCL a CPU name its compiler knows, if it detects none (once per process).

    Returns
    -------
    str or None
        The CPU name PoCL now compiles for, or None where nothing was
        changed (PoCL knows the CPU, not the bundled PoCL, not Linux on
        x86-64, ``PYSHADOW_POCL_CPU=off``, or the change was refused).
        Call it before the first OpenCL call of the process; afterwards
        PoCL has read the name already.
    """
    if "name" not in _state:
        try:
            _state["name"] = _apply()
        except Exception:           # a failed attempt leaves PoCL as it was: its own error follows
            _state["name"] = None
    return _state["name"]


def devices_hint() -> str:
    """Where ``POCL_DEVICES`` is set, a clause saying it may be why PoCL lists no device (PoCL 3, that of
    pyopencl's wheel, lists none for ``POCL_DEVICES=cpu``, the name later PoCLs give its ``pthread``
    device); else ''."""
    kinds = os.environ.get("POCL_DEVICES", "").strip()
    if not kinds:
        return ""
    return (f"; POCL_DEVICES={kinds!r} is set, and PoCL lists only devices of the kinds it names: unset it, or "
            "name a kind this PoCL has (its CPU device is 'pthread' in PoCL 3, 'cpu' in PoCL 4 and later)")


# the /proc/cpuinfo flags of the instruction sets by which PoCL picks its builtin library and LLVM its code
_ISA_PREFIXES = ("sse", "ssse", "avx", "fma", "f16c", "xop", "bmi", "popcnt", "movbe", "abm", "adx")


def compile_key() -> str:
    """What, beside the device's name and driver, decides the code PoCL compiles on this host: the CPU name
    it compiles for (:func:`applied`, else its own detection), the host's instruction sets and
    ``POCL_EXTRA_BUILD_FLAGS``. The lane-width probe's verdicts are cached under it (:mod:`.probe`): a CPU's
    name (``pthread-Intel(R) Xeon(R) Processor`` in many virtual machines) does not tell its instruction
    sets, so a cache shared by two machines of the same name would give one the other's verdicts."""
    flags = sorted(f for f in _cpu_flags() if f.startswith(_ISA_PREFIXES))
    return "|".join([applied() or _state.get("detected", ""), " ".join(flags),
                     os.environ.get("POCL_EXTRA_BUILD_FLAGS", "").strip()])


def applied() -> str | None:
    """What :func:`apply` returned in this process (None if not called or nothing changed)."""
    return _state.get("name")

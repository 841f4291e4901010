"""Lane width per device: probed in child processes, cached on disk.

The kernels that work on lane vectors (``kernels/lanes.h``) are compiled for
``LANES`` = 1, 4, 8 or 16. Which widths a device can run is not something its
reported properties tell: the PoCL of the pip wheel (LLVM 14) on AMD Zen 4
reports 16 float lanes, targets znver3 (no AVX-512) and picks an AVX-512
builtin library, so 16-wide kernels crash, hang or come out wrong there. So
each width is tried in a child process (``probe_child.py``: build, run,
compare with NumPy) that can crash or hang without taking the caller along;
the verdicts are cached per (platform version, device name, driver version,
probe sources, and :func:`.pocl_cpu.compile_key`: the CPU PoCL compiles for,
the host's instruction sets), so later runs pay nothing. A width whose child timed out or
was killed (SIGKILL: the kernel's out-of-memory killer, say) is the
exception: the machine, not the device, may have been to blame, so later runs
probe that width again until it has failed so in :data:`TIMEOUT_RUNS` runs in
a row.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from . import pocl_cpu

__all__ = ["LANE_WIDTHS", "PROBE_TIMEOUT_S", "TIMEOUT_RUNS", "DeviceNotSupportedError", "parse_override",
           "verdicts", "cache_file"]

LANE_WIDTHS = (16, 8, 4, 1)
# a child builds and runs the probe kernel and builds the lane kernels: all
# four children together took 4 s on the 2-core development machine with
# PoCL's compiler cache empty; 60 s leaves room for a slower or loaded machine
# and still ends a compiler that hangs (seen: more than 5 minutes), once per
# device and driver
PROBE_TIMEOUT_S = 60.0
# runs in a row in which a width must time out (or be killed) before that
# verdict is cached as final: one timeout may be a loaded machine (four
# children compiling at once on two cores, and whatever else runs), one
# SIGKILL the out-of-memory killer, and cached as final either would narrow
# the width, or refuse the device, until the driver changes
TIMEOUT_RUNS = 2
_TIMEOUT_WHY = "no answer within "
_KILLED_WHY = f"the child process died of signal {getattr(signal, 'SIGKILL', 9):d}"
# a child that could not be started (an embedded interpreter's empty sys.executable, a process limit): the
# machine's doing, never cached, and a width forced by PYSHADOW_LANES is used unprobed
_UNSTARTED_WHY = "the child process could not be started"
_CHILD = Path(__file__).with_name("probe_child.py")
# the job file a child reads where no temporary folder can hold one: its standard input
_STDIN = "/dev/stdin"


class DeviceNotSupportedError(RuntimeError):
    """The device cannot run what pyshadow asks of it: its lane kernels at any width, or a buffer
    larger than it allocates at once (:func:`pyshadow._cl.launch.check_alloc`)."""


def parse_override(value: str | None) -> int | None:
    """``PYSHADOW_LANES`` as an int, None when unset; ValueError when not 1, 4, 8 or 16."""
    if value is None or not value.strip():
        return None
    text = value.strip()
    try:
        # ASCII digits only: int() also reads "1_6" as 16, and other scripts' digits
        n = int(text) if re.fullmatch(r"\+?[0-9]+", text) else None
    except ValueError:          # more digits than int() converts
        n = None
    if n not in LANE_WIDTHS:
        raise ValueError(f"PYSHADOW_LANES={value!r} is not one of 1, 4, 8, 16 "
                         "(lanes per vector in the kernels; unset it to probe the device)")
    return n


def cache_file() -> Path:
    """``$PYSHADOW_CACHE/lanes.json`` (``~`` expanded, as for the CSM cache:
    :func:`pyshadow.cache.default_cache_dir`), else in ``platformdirs.user_cache_dir("pyshadow")``."""
    # not default_cache_dir() itself: that would make cache.py a module a CSM build runs
    # (tests/test_cache.py, test_code_digest_covers_every_module_a_build_runs)
    env = os.environ.get("PYSHADOW_CACHE", "").strip()
    if env:
        return Path(env).expanduser() / "lanes.json"
    import platformdirs

    return Path(platformdirs.user_cache_dir("pyshadow")) / "lanes.json"


def _key(platform, device, job: dict) -> str:
    h = hashlib.sha256()
    for part in (platform.version, device.name, device.driver_version, json.dumps(job),
                 _CHILD.read_text(), str(LANE_WIDTHS), pocl_cpu.compile_key()):
        h.update(part.strip().encode() + b"\0")
    return h.hexdigest()[:24]


#: lanes.json: {"format": "pyshadow-lanes", "version": 1, "entries": {key: entry}, "sha256": of the
#: entries' canonical JSON}; a file of another version, or whose checksum does not match, is read as empty
_CACHE_FORMAT, _CACHE_VERSION = "pyshadow-lanes", 1


def _entries_digest(entries: dict) -> str:
    return hashlib.sha256(json.dumps(entries, sort_keys=True).encode()).hexdigest()


def _read_cache() -> dict:
    """The cached entries, {} where the file is missing, unreadable, of another version or altered."""
    try:
        data = json.loads(cache_file().read_text())
    except (OSError, ValueError, RecursionError):
        return {}
    if not (isinstance(data, dict) and data.get("format") == _CACHE_FORMAT
            and data.get("version") == _CACHE_VERSION and isinstance(data.get("entries"), dict)
            and data.get("sha256") == _entries_digest(data["entries"])):
        return {}
    return data["entries"]


def _cached_verdicts(entry) -> dict | None:
    """An entry's verdicts {width: {"ok": bool, "why": str}} when it holds one for every width, else None."""
    v = entry.get("verdicts") if isinstance(entry, dict) else None
    if not (isinstance(v, dict) and set(v) == {str(w) for w in LANE_WIDTHS} and all(
            isinstance(x, dict) and isinstance(x.get("ok"), bool) and isinstance(x.get("why"), str)
            for x in v.values())):
        return None
    return {int(w): {"ok": x["ok"], "why": x["why"]} for w, x in v.items()}


#: Seconds a process waits for another's write of lanes.json before leaving its own entry out
CACHE_LOCK_S = 10.0


def _write_cache(key: str, entry: dict) -> None:
    """Add ``key: entry`` to lanes.json: read, merged and replaced under a lock file beside it
    (``lanes.json.lock``), so that processes probing at once keep each other's entries."""
    import filelock

    from .._files import write_bytes_atomic

    path = cache_file()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with filelock.FileLock(f"{path}.lock", timeout=CACHE_LOCK_S):
            entries = {**_read_cache(), key: entry}
            data = {"format": _CACHE_FORMAT, "version": _CACHE_VERSION, "entries": entries,
                    "sha256": _entries_digest(entries)}
            write_bytes_atomic(path, json.dumps(data, indent=1, sort_keys=True).encode())
    except (OSError, filelock.Timeout):
        pass            # a read-only cache, or one held too long, only costs the probe again next time


def _child_env() -> dict:
    """The child's environment: this process's, with the CPU name given to PoCL here (:mod:`.pocl_cpu`)."""
    env = {**os.environ, "PYOPENCL_COMPILER_OUTPUT": "0"}
    if pocl_cpu.applied():
        env[pocl_cpu.ENV] = pocl_cpu.applied()
    return env


def run_probe(platform_index: int, device_index: int, job: dict,
              widths=LANE_WIDTHS, timeout: float = PROBE_TIMEOUT_S,
              command=None) -> dict[int, dict]:
    """Try each width in a child process of its own, all at once.

    ``job`` is what the child builds (see ``probe_child.py``), given to it as
    a file in a temporary folder, or on its standard input where no temporary
    folder is writable; ``command(width)`` (tests only) replaces the child's
    command line.
    Returns ``{width: {"ok": bool, "why": str}}``. Each child leads a process
    group of its own, killed whole at the timeout (PoCL runs the linker as a
    process of its own, which would hold the child's pipes open) or when the
    caller is interrupted.
    """
    text = json.dumps(job)
    with contextlib.ExitStack() as stack:
        try:
            src = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="pyshadow-probe-"))) / "job.json"
            src.write_text(text)
        except OSError as exc:
            # no writable temporary folder (a read-only /tmp and working folder, a full disk): each
            # child reads the job from its standard input instead, where the system names it a file
            if not os.path.exists(_STDIN):
                raise OSError(f"the lane-width probe of pyshadow found no writable temporary folder ({exc}); "
                              "set TMPDIR to a writable folder") from exc
            src = None
        procs, unstarted = {}, {}
        try:
            for w in widths:
                cmd = command(w) if command else [sys.executable, str(_CHILD), str(platform_index),
                                                  str(device_index), str(w), str(src or _STDIN)]
                try:
                    procs[w] = subprocess.Popen(cmd, stdin=subprocess.DEVNULL if src else subprocess.PIPE,
                                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                                env=_child_env(), start_new_session=True)
                except OSError as exc:
                    unstarted[w] = {"ok": False, "why": f"{_UNSTARTED_WHY} ({cmd[0]!r}: {exc}); set "
                                                        "PYSHADOW_LANES to a width to run it unprobed"}
                    continue
                if src is None:
                    _feed(procs[w], text)
            found = {**_collect(procs, timeout), **unstarted}
            return {w: found[w] for w in widths}
        finally:
            for p in procs.values():
                if p.poll() is None:
                    _kill(p)
                    p.wait()


def _feed(p, text: str) -> None:
    """Write ``text`` to child ``p``'s standard input from a thread of its own (a child that never reads it
    cannot block the caller past the probe's timeout), then close it; ``p.stdin`` is left None so that
    ``communicate`` reads the child's output alone."""
    pipe, p.stdin = p.stdin, None

    def write():
        try:
            with pipe:
                pipe.write(text)
        except OSError:         # the child died, or was killed, before it read everything
            pass

    threading.Thread(target=write, name="pyshadow-probe-job", daemon=True).start()


def _kill(p) -> None:
    """Kill child ``p`` and what it started (its process group)."""
    try:
        os.killpg(p.pid, signal.SIGKILL)
    except (AttributeError, OSError):       # no process groups here, or the group is gone
        p.kill()


def _collect(procs, timeout):
    deadline = time.monotonic() + timeout
    out = {}
    for w, p in procs.items():
        try:
            stdout, stderr = p.communicate(timeout=max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            _kill(p)
            try:
                p.communicate(timeout=5.0)
            except subprocess.TimeoutExpired:   # a process that left the group still holds the pipes
                p.wait()
            out[w] = {"ok": False, "why": f"{_TIMEOUT_WHY}{timeout:g} s (the compiler or "
                                          "the kernel hung; the child was killed)"}
            continue
        try:
            v = json.loads(stdout.strip().splitlines()[-1])
            verdict = {"ok": bool(v["ok"]), "why": str(v["why"])}
        except (ValueError, IndexError, KeyError, TypeError):
            verdict = None
        died = (f"the child process died of signal {-p.returncode}" if p.returncode < 0
                else f"the child process exited with status {p.returncode}")
        if verdict is None:
            out[w] = {"ok": False, "why": died + _tail(stderr)}
        elif p.returncode != 0:
            # a child that answered and then crashed (PoCL tearing down a
            # broken LLVM state, say) fails the width all the same
            out[w] = {"ok": False, "why": f"{verdict['why']}; then {died}{_tail(stderr)}"}
        else:
            out[w] = verdict
    return out


def _tail(text: str) -> str:
    lines = [ln for ln in (text or "").strip().splitlines() if ln.strip()]
    return f": {lines[-1][:200]}" if lines else ""


def grouped_whys(found: dict) -> str:
    """The verdicts in a line, widest first, widths sharing a reason named together ('16, 8: ...; 4: ...'):
    a build option PoCL refuses failed all four widths with the same compiler log, which was printed four times."""
    groups: dict = {}
    for w, v in sorted(found.items(), reverse=True):
        groups.setdefault(v["why"], []).append(str(w))
    return "; ".join(f"{', '.join(ws)}: {why}" for why, ws in groups.items())


def extra_flags_hint(why: str) -> str:
    """A sentence naming ``POCL_EXTRA_BUILD_FLAGS`` where it is set and a build failed: PoCL adds it to every
    build, so a bad option there fails every kernel, whatever pyshadow passes."""
    flags = os.environ.get("POCL_EXTRA_BUILD_FLAGS", "").strip()
    if not flags or "building" not in why:
        return ""
    return (f" POCL_EXTRA_BUILD_FLAGS={flags!r} is set: PoCL adds it to every kernel build; unset it or "
            "correct it.")


def _timed_out(verdict: dict) -> bool:
    """The width failed by a timeout or a SIGKILL from outside: not final on its own (:data:`TIMEOUT_RUNS`)."""
    why = verdict["why"]
    return not verdict["ok"] and (why.startswith(_TIMEOUT_WHY) or why == _KILLED_WHY
                                  or why.startswith(_KILLED_WHY + ":") or why.startswith(_UNSTARTED_WHY))


def _cached_timeouts(entry) -> dict:
    """An entry's {width: runs in a row that width timed out or was killed}; {} where it holds none
    (older entries)."""
    t = entry.get("timeouts") if isinstance(entry, dict) else None
    if not isinstance(t, dict):
        return {}
    return {int(w): n for w, n in t.items()
            if w in {str(x) for x in LANE_WIDTHS} and type(n) is int and n > 0}


def check_override(width: int, platform_index: int, device_index: int, platform, device, job: dict) -> dict:
    """Raise :class:`DeviceNotSupportedError` where ``PYSHADOW_LANES=width`` names a width that fails on this
    device: its verdict from the cache, or from a probe run now (and cached) where the cache has none.

    A forced width is not chosen by the probe, but it is checked by it: a width the device cannot run
    fails at its first kernel, or aborts the process as it exits (README, lane width), where the probe
    fails only its child. A width whose probe timed out (not final: a busy machine) is not refused.
    Returns the verdicts, ``{width: {"ok": bool, "why": str}}``."""
    found, _ = verdicts(platform_index, device_index, platform, device, job)
    if found[width]["ok"] or _timed_out(found[width]):
        return found
    ok = [w for w in LANE_WIDTHS if found[w]["ok"]]
    raise DeviceNotSupportedError(
        f"PYSHADOW_LANES={width}: {width}-lane kernels failed the probe on OpenCL device {device.name.strip()!r} "
        f"({found[width]['why']}); widths that passed: {', '.join(map(str, ok)) or 'none'}. Unset "
        f"PYSHADOW_LANES or set it to one of those (verdicts cached in {cache_file()})")


def verdicts(platform_index, device_index, platform, device, job, *, refresh=False):
    """Every width's verdict for a device, from the cache or a fresh probe.

    A cached verdict that a width timed out or was killed is not final:
    that width (with any other such, the rest taken from the cache) is
    probed again until it has failed so in :data:`TIMEOUT_RUNS` runs in a row.
    A run in which a child could not be started is not cached.

    Returns ``(verdicts, source)`` with ``source`` 'cache' or 'probe'.
    """
    key = _key(platform, device, job)
    entry = None if refresh else _read_cache().get(key)
    cached = _cached_verdicts(entry)
    runs = _cached_timeouts(entry) if cached is not None else {}
    if cached is None:
        again = LANE_WIDTHS
        found = run_probe(platform_index, device_index, job)
    else:
        again = [w for w in LANE_WIDTHS if _timed_out(cached[w]) and runs.get(w, 0) < TIMEOUT_RUNS]
        if not again:
            return cached, "cache"
        fresh = run_probe(platform_index, device_index, job, widths=again)
        found = {w: fresh.get(w, cached[w]) for w in LANE_WIDTHS}
    if any(found[w]["why"].startswith(_UNSTARTED_WHY) for w in again):
        return found, "probe"           # the machine could not start a child this time: nothing learnt
    for w in again:
        runs[w] = runs.get(w, 0) + 1 if _timed_out(found[w]) else 0
    entry = {"device": device.name.strip(), "platform": platform.version.strip(),
             "driver": device.driver_version.strip(), "verdicts": {str(w): v for w, v in found.items()}}
    if any(runs.values()):
        entry["timeouts"] = {str(w): n for w, n in runs.items() if n}
    _write_cache(key, entry)
    return found, "probe"

"""pyshadow in a process forked from one that had used OpenCL (multiprocessing's default 'fork' start method
on Linux): a clear error, where the first kernel waited forever."""
import os
import select
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import pyshadow
from pyshadow import _cl

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork here")


def in_fork(fn, timeout):
    """``fn()``'s repr (or its exception's type and message) from a forked child; None if it did not answer
    within ``timeout`` seconds (the child is killed)."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:                        # the child: answer and leave at once, whatever happens
        try:
            try:
                out = repr(fn())
            except BaseException as exc:            # noqa: B902 - reported to the parent
                out = f"{type(exc).__name__}: {exc}"
            os.write(w, out.encode()[:60000])
        finally:
            os._exit(0)
    os.close(w)
    try:
        ready, _, _ = select.select([r], [], [], timeout)
        return os.read(r, 65536).decode() if ready else None
    finally:
        os.close(r)
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        os.waitpid(pid, 0)


def test_a_forked_child_of_a_process_that_used_opencl_gets_a_clear_error():
    """Was: the child's first kernel (pyshadow.sample_directions here) never returned: PoCL's threads stay in
    the parent, and the child waited for them forever (killed here after 15 s)."""
    normals = np.array([[0.0, 1.0, 0.0]])
    pyshadow.sample_directions(normals, sampling=pyshadow.Sampling(2))      # the parent has a context
    t0 = time.monotonic()
    got = in_fork(lambda: pyshadow.sample_directions(normals, sampling=pyshadow.Sampling(2)), 15.0)
    assert got is not None, "the forked child hung"
    assert time.monotonic() - t0 < 10
    assert got.startswith("RuntimeError: pyshadow cannot run OpenCL in this process: it is a fork of process "
                          f"{os.getpid()}") and "'spawn'" in got
    assert "queue" in _cl._state            # the parent is untouched
    pyshadow.sample_directions(normals, sampling=pyshadow.Sampling(2))


def test_a_fork_before_any_opencl_use_is_left_alone():
    """Was: (unchanged) a process that forks before it first uses pyshadow's OpenCL runs kernels in the
    child as in any process."""
    code = ("import os, numpy as np, pyshadow; pid = os.fork()\n"
            "if pid == 0:\n"
            "    d = pyshadow.sample_directions(np.array([[0.0, 1.0, 0.0]]), sampling=pyshadow.Sampling(2))\n"
            "    os._exit(0 if d.shape == (1, 2, 3) else 3)\n"
            "_, status = os.waitpid(pid, 0); raise SystemExit(os.waitstatus_to_exitcode(status))\n")
    run = subprocess.run([sys.executable, "-W", "ignore", "-c", code], timeout=120, capture_output=True)
    assert run.returncode == 0, run.stderr.decode()[-2000:]

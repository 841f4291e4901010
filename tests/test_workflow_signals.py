"""pyshadow-bake stopped by a signal: SIGTERM handled as Ctrl-C, and pool workers that end with their driver."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.skipif(not hasattr(signal, "SIGKILL") or sys.platform == "win32",
                                reason="POSIX signals")


def _python(code: str, logs: Path, timeout: float = 120):
    """Run ``code`` in a fresh interpreter at the repository root (so it imports this checkout's pyshadow);
    returns its exit status, stdout and stderr. The output goes through files, not pipes, which an orphaned
    child process would hold open."""
    with open(logs / "stdout", "w+") as out, open(logs / "stderr", "w+") as err:
        rc = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=REPO, stdout=out, stderr=err,
                            timeout=timeout).returncode
        out.seek(0)
        err.seek(0)
        return rc, out.read(), err.read()


def _alive(pid: int) -> bool:
    """Whether process ``pid`` runs (a zombie, dead but not yet reaped, does not)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        return state not in ("Z", "X")
    except OSError:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        except PermissionError:
            return True
        return True


def test_sigterm_is_handled_as_ctrl_c(tmp_path):
    """Was: SIGTERM (``kill``, ``timeout``, a job scheduler) ended pyshadow-bake at once with status -15: no
    manifest written (an earlier run's would have stayed), the assets in flight not marked 'interrupted', and
    a process pool's workers left running. Now it stops as Ctrl-C does: manifest written, status 143."""
    src, out = tmp_path / "box.obj", tmp_path / "out"
    src.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    rc, _, stderr = _python(f"""
        import os, signal, sys, time
        from pyshadow.bake import cli, library

        def stopped(*args, **kwargs):          # the bake of the asset, cut short by a SIGTERM to the driver
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(60)

        library.bake_asset = stopped
        sys.exit(cli.main(["assets", {str(src)!r}, "-o", {str(out)!r}, "--executor", "serial", "--quiet",
                           "--maps", "2x2", "--resolution", "8", "--samples", "1"]))
    """, tmp_path)
    assert rc == 128 + signal.SIGTERM, (rc, stderr[-2000:])
    assert "interrupted" in stderr
    m = json.loads((out / "manifest.json").read_text())
    assert m["summary"] == {"baked": 0, "skipped": 0, "failed": 0, "interrupted": 1}, m["summary"]
    assert not (out / "records" / "box.json").exists()


def test_sighup_ignored_by_nohup_stays_ignored():
    """``nohup`` runs a bake with SIGHUP ignored; the handler must not replace that (a closed terminal would
    then stop the bake the user asked to survive it)."""
    from pyshadow.bake.cli import _stop_on_signals

    old = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        replaced = _stop_on_signals([])
        try:
            assert signal.SIGHUP not in replaced
            assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
        finally:
            for s, h in replaced.items():
                signal.signal(s, h)
    finally:
        signal.signal(signal.SIGHUP, old)


def test_pool_worker_ends_when_its_driver_is_killed(tmp_path):
    """Was: a process pool's worker outlived a driver killed by SIGKILL (the out-of-memory killer; the hard
    stop after a grace period) for good: idle, holding its memory and the driver's stdout and stderr (a
    ``pyshadow-bake ... | tee log`` never returned). Now it ends within seconds of the driver."""
    rc, stdout, stderr = _python("""
        import os, signal
        from pyshadow.bake.runner import open_executor

        ex = open_executor("process", workers=1, threads=1)
        [(tag, pid, err)] = list(ex.run(os.getpid, [(0, ())]))
        print(pid, flush=True)
        os.kill(os.getpid(), signal.SIGKILL)
    """, tmp_path)
    assert rc == -signal.SIGKILL, stderr[-2000:]
    worker = int(stdout.split()[0])
    deadline = time.monotonic() + 15.0
    while _alive(worker) and time.monotonic() < deadline:
        time.sleep(0.1)
    orphan = _alive(worker)
    if orphan:
        os.kill(worker, signal.SIGKILL)
    assert not orphan, f"the pool's worker {worker} still runs 15 s after its driver was killed"

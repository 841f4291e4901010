"""First use of pyshadow from several threads at once (pyshadow/_cl/__init__.py, ``lane_choice``).

With ``PYSHADOW_LANES`` set, the width is checked by the lane probe (child processes building the kernels at
each width, seconds) the first time it is asked. That check was made outside the package's lock: threads whose
first queries came at once each started a probe of their own (4 threads: 16 child compilers at once, on 2 cores
within the probe's timeout). Now one thread probes and the others wait for its verdicts, as without
``PYSHADOW_LANES``. Before the fix the test below failed in 10 of 10 runs (4 probes).
"""
from __future__ import annotations

import threading
import time

from pyshadow import _cl
from pyshadow._cl import probe


def test_forced_width_probed_once_from_threads(monkeypatch):
    started = []

    def check_override(width, *args):       # the probe's check of a forced width, made slow as a real one is
        started.append(width)
        time.sleep(0.2)
        return {w: {"ok": True, "why": "passed"} for w in probe.LANE_WIDTHS}

    _cl._init()
    monkeypatch.setenv("PYSHADOW_LANES", "4")
    monkeypatch.setattr(probe, "check_override", check_override)
    monkeypatch.setitem(_cl._state, "override_checked", (None, None))     # not checked yet (restored after)
    start, got = threading.Barrier(4), []

    def first_query():
        start.wait()
        got.append(_cl.lane_choice())

    threads = [threading.Thread(target=first_query) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(started) == 1, f"{len(started)} probes of PYSHADOW_LANES=4 started by 4 threads, not 1"
    assert [c["lanes"] for c in got] == [4] * 4
    assert all(c["source"] == "PYSHADOW_LANES" and c["supported"] == [16, 8, 4, 1] for c in got)

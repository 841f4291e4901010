"""The lane-width probe on a machine without a writable temporary folder (a read-only /tmp and working
folder, a full disk): the children read their job from standard input instead of a file."""
import hashlib
import json
import sys
import tempfile
import time

import pytest

from pyshadow import _cl
from pyshadow._cl import probe as probe_mod

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/dev/stdin")


@pytest.fixture
def no_tmp(monkeypatch, tmp_path):
    """tempfile's folder made one that cannot be created (what gettempdir() gives where no candidate
    is writable: it raises FileNotFoundError itself)."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "missing" / "tmp"))
    monkeypatch.setenv("PYSHADOW_CACHE", str(tmp_path / "cache"))


def test_the_probe_runs_without_a_temporary_folder(no_tmp):
    """Was: FileNotFoundError "No such file or directory: '.../pyshadow-probe-3o10d9cc'" from the probe (the
    first kernel of any call, and PYSHADOW_LANES too, since a forced width is probed): pyshadow could not run
    at all. Now the child reads the job on its standard input and gives the verdict it gives from a file."""
    job = {"probe": _cl.kernel_source("probe.cl"), "builds": []}
    pi, di = _cl._init()["index"]
    found = probe_mod.run_probe(pi, di, job, widths=(1,))
    assert found == {1: {"ok": True, "why": "built and computed correctly"}}


def test_a_child_that_never_reads_its_job_still_times_out(no_tmp):
    """Was: (as above, no probe at all.) The job is written from a thread of its own: a child that hangs
    before reading a job larger than a pipe holds (1 MB here) is killed at the timeout, not waited for."""
    job = {"probe": "x" * (1 << 20), "builds": []}
    t0 = time.monotonic()
    found = probe_mod.run_probe(0, 0, job, widths=(8, 4), timeout=1.0,
                                command=lambda w: [sys.executable, "-c", "import time; time.sleep(30)"])
    assert time.monotonic() - t0 < 6
    assert all(not v["ok"] and v["why"].startswith("no answer within 1 s") for v in found.values())


def test_the_job_reaches_a_child_whole(no_tmp):
    """Was: (as above.) A job of 3 MB (the real one is about 1 MB) reaches each of four children unaltered."""
    job = {"probe": "abc" * (1 << 20), "builds": [{"label": "x", "source": "y", "options": ["-DZ=1"]}]}
    want = hashlib.sha256(json.dumps(job, sort_keys=True).encode()).hexdigest()
    code = ("import hashlib, json, sys; j = json.load(open(sys.argv[1])); "
            "h = hashlib.sha256(json.dumps(j, sort_keys=True).encode()).hexdigest(); "
            "print(json.dumps({'ok': True, 'why': h}))")
    found = probe_mod.run_probe(0, 0, job, command=lambda w: [sys.executable, "-c", code, "/dev/stdin"])
    assert found == {w: {"ok": True, "why": want} for w in probe_mod.LANE_WIDTHS}

"""pyshadow-bench's robustness: AO arrays read back from the cache are checked before use
(pyshadow/bench/common.py), and Ctrl-C ends a run with one line, status 130 and no partly
written output (pyshadow/bench/cli.py)."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import numpy as np
import pytest

from test_bench import TINY

INTERRUPTED = "pyshadow-bench: interrupted\n"


# ---------------------------------------------------------------------------
# cached AO arrays
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("a, reason", [
    (np.array([0.0, 0.5, 1.0], np.float32), None),
    (np.array([0.0, 0.5], np.float32), "shape (2,), expected (3,)"),
    (np.zeros((3, 1), np.float32), "shape (3, 1), expected (3,)"),
    (np.array([0.0, np.nan, np.inf], np.float32), "2 of 3 values are not finite"),
    (np.array([-0.25, 0.5, 1.0], np.float32), "1 of 3 values are outside [0, 1] (min -0.25, max 1)"),
    (np.array([0.0, 1.5, 2.0], np.float32), "2 of 3 values are outside [0, 1] (min 0, max 2)"),
])
def test_ao_defect(a, reason):
    from pyshadow.bench.common import ao_defect

    assert ao_defect(a, 3) == reason


def test_cached_ao_refuses_impossible_arrays(tmp_path):
    """A checksummed file holding no possible AO is a miss (one note); put_array then replaces it."""
    from pyshadow.bench.common import cached_ao
    from pyshadow.cache import CSMCache

    cache, key, notes = CSMCache(tmp_path), "ab" * 32, []
    good = np.linspace(0.0, 1.0, 5, dtype=np.float32)
    assert cached_ao(cache, key, 5, notes.append) is None and notes == []      # absent: no note
    cache.put_array(key, good)
    assert np.array_equal(cached_ao(cache, key, 5, notes.append), good) and notes == []
    for bad, why in ((np.full(5, np.nan, np.float32), "5 of 5 values are not finite"),
                     (good * 2, "2 of 5 values are outside [0, 1] (min 0, max 2)"),
                     (good[:4], "shape (4,), expected (5,)")):
        cache.put_array(key, bad)
        assert np.array_equal(cache.array(key), bad, equal_nan=True)   # the file itself passes its check
        notes.clear()
        assert cached_ao(cache, key, 5, notes.append) is None
        assert notes == [f"cache: reference/{key[:40]}.npz is not a possible AO of 5 pixels ({why}); "
                         "recomputing it"]
        assert cached_ao(cache, key, 5) is None                      # log None: refused silently
    cache.put_array(key, good)                                       # what the caller does next
    assert np.array_equal(cached_ao(cache, key, 5, notes.append), good)
    assert cached_ao(CSMCache(None), key, 5, notes.append) is None   # cache off


# ---------------------------------------------------------------------------
# Ctrl-C
# ---------------------------------------------------------------------------
@pytest.fixture
def interrupted_main(monkeypatch, tmp_path):
    """``run(fake_run_main)``: pyshadow-bench's main in-process (tiny, --quiet, an output folder
    holding an earlier results.json) with ``run_main`` replaced; returns (status, out folder)."""
    from pyshadow.bench import cli
    from pyshadow.bench.common import _PROGRESS

    monkeypatch.setitem(_PROGRESS, "on", _PROGRESS["on"])          # main sets it
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.json").write_text('{"earlier": true}\n')

    def run(fake):
        monkeypatch.setattr(cli, "run_main", fake)
        try:
            return cli.main([*TINY, "--out", str(out), "--no-cache", "--quiet"]), out
        except KeyboardInterrupt:                     # would end the pytest session: fail this test
            pytest.fail("KeyboardInterrupt escaped pyshadow.bench.cli.main")
    return run


def test_ctrl_c_during_the_run(interrupted_main, capsys):
    def fake(*a, **k):
        raise KeyboardInterrupt

    status, out = interrupted_main(fake)
    assert status == 130
    assert capsys.readouterr() == ("", INTERRUPTED)
    assert sorted(os.listdir(out)) == ["results.json"]                # no probe, no temporary file
    assert (out / "results.json").read_text() == '{"earlier": true}\n'


def test_ctrl_c_while_results_json_is_written(interrupted_main, capsys, monkeypatch):
    """Interrupted with results.json's temporary file complete but not yet renamed: the earlier
    results.json stays as it was, and no temporary file is left."""
    written = []

    def fsync(fd):
        written.append(os.fstat(fd).st_size)
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "fsync", fsync)
    status, out = interrupted_main(lambda *a, **k: {"files": {}, "figures": {"x": 1.0}})
    assert status == 130 and written and written[0] > 0
    assert capsys.readouterr() == ("", INTERRUPTED)
    assert sorted(os.listdir(out)) == ["results.json"]
    assert json.loads((out / "results.json").read_text()) == {"earlier": True}


def test_ctrl_c_between_outputs_leaves_no_stale_results_json(interrupted_main, capsys, monkeypatch):
    """Interrupted after the run's first image is written, before its second: the earlier results.json
    (describing an earlier run's images) is gone, not left beside the new ao.png; results.json comes last."""
    import pyshadow
    from pyshadow.bench.single import run_main

    real, written = pyshadow.write_image, []

    def write_image(path, array):
        if written:
            raise KeyboardInterrupt
        real(path, array)
        written.append(os.path.basename(path))

    monkeypatch.setattr(pyshadow, "write_image", write_image)
    status, out = interrupted_main(run_main)                         # the real single benchmark
    assert status == 130 and written == ["ao.png"]
    assert capsys.readouterr() == ("", INTERRUPTED)
    assert sorted(os.listdir(out)) == ["ao.png"]


def test_ctrl_c_between_sweep_outputs_leaves_no_stale_sweep_json(tmp_path, capsys, monkeypatch):
    """The sweep alike: interrupted after pareto.png, before sweep.md, the earlier sweep.json is gone."""
    from pyshadow.bench import cli
    from pyshadow.bench.common import _PROGRESS
    from test_bench_report import _sweep

    monkeypatch.setitem(_PROGRESS, "on", _PROGRESS["on"])
    out = tmp_path / "out"
    out.mkdir()
    (out / "sweep.json").write_text('{"earlier": true}\n')
    sw = _sweep()
    sw["rows"] = sw["rows"][:1]                                      # one measured row
    monkeypatch.setattr(cli, "run_sweep", lambda *a, **k: sw)
    written = []

    def write_bytes_atomic(path, data):
        written.append(os.path.basename(path))
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "write_bytes_atomic", write_bytes_atomic)
    status = cli.main([*TINY, "--sweep", "--sweep-grid", "tiny", "--out", str(out), "--no-cache", "--quiet"])
    assert status == 130 and written == ["sweep.md"]
    assert capsys.readouterr() == ("", INTERRUPTED)
    assert sorted(os.listdir(out)) == ["pareto.png"]


class _HalfBuilt:
    """Caught by Ctrl-C in its __init__, so its __del__ fails (as pytools' PersistentDict does)."""

    def __init__(self):
        raise KeyboardInterrupt

    def __del__(self):
        self.mutex                                   # never set


def test_ctrl_c_frees_half_built_objects_quietly(interrupted_main, capsys):
    # without main's quiet unraisablehook, pytest turns the __del__ error into a failing warning
    status, _ = interrupted_main(lambda *a, **k: _HalfBuilt())
    assert status == 130
    assert capsys.readouterr() == ("", INTERRUPTED)


def test_sigint_ends_the_command_with_one_line(tmp_path):
    """A real SIGINT while the first CSM builds: status 130, the one line, no traceback, no output."""
    env = {k: v for k, v in os.environ.items() if k != "PYSHADOW_CACHE"}
    p = subprocess.Popen([sys.executable, "-m", "pyshadow.bench", *TINY, "--out", str(tmp_path / "out"),
                          "--no-cache"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        lines = []
        for line in p.stderr:                         # wait until the run is under way
            lines.append(line)
            if line.startswith("building the CSM"):
                break
        p.send_signal(signal.SIGINT)
        stdout, rest = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    err = "".join(lines) + rest
    assert p.returncode == 130, err
    assert stdout == ""
    assert err.endswith(INTERRUPTED) and "Traceback" not in err, err
    assert os.listdir(tmp_path / "out") == []


def test_a_reader_that_leaves_ends_the_command_without_a_traceback(tmp_path):
    """``pyshadow-bench --json | head -1``: the JSON written into a pipe whose reader had gone ended in a
    BrokenPipeError traceback (and another at the interpreter's exit). Now status 141, as for SIGPIPE,
    no traceback, and results.json is written."""
    env = {k: v for k, v in os.environ.items() if k != "PYSHADOW_CACHE"}
    r, w = os.pipe()
    os.close(r)                                       # the reader has gone before anything is written
    try:
        p = subprocess.run([sys.executable, "-m", "pyshadow.bench", *TINY, "--out", str(tmp_path / "out"),
                            "--no-cache", "--json", "--quiet"], stdout=w, stderr=subprocess.PIPE, text=True,
                           env=env, timeout=300)
    finally:
        os.close(w)
    assert p.returncode == 141, p.stderr
    assert "Traceback" not in p.stderr and "BrokenPipeError" not in p.stderr, p.stderr
    assert json.loads((tmp_path / "out" / "results.json").read_text())["files"]

"""The lane-width probe on a loaded machine, and ``PYSHADOW_LANES`` spellings that are no width.

The probe's children are stand-ins (``python -c``) that hang or answer at
once, run by the real :func:`pyshadow._cl.probe.run_probe` with a short
timeout; the device is a fake (only its name, driver and platform version
make the cache key). The cache lives in ``tmp_path`` (``PYSHADOW_CACHE``).
"""
import json
import os
import sys

import pytest

from pyshadow._cl import probe as probe_mod
from pyshadow.cache import default_cache_dir

JOB = {"probe": "", "builds": []}
HANG = "import time; time.sleep(30)"
OK = "import json; print(json.dumps({'ok': True, 'why': 'fine'}))"
RUN_PROBE = probe_mod.run_probe


class Platform:
    version = "OpenCL 3.0 fake platform"


class Device:
    name = "fake device"
    driver_version = "1.0"


def scripted(monkeypatch, tmp_path, plan):
    """Make each call of run_probe run the children of ``plan[call]`` ({width: HANG or OK}) with a
    0.5 s timeout; returns the list of widths each call probed."""
    monkeypatch.setenv("PYSHADOW_CACHE", str(tmp_path))
    calls = []

    def run(pi, di, job, widths=probe_mod.LANE_WIDTHS, timeout=None, command=None):
        code = plan[len(calls)]
        calls.append(tuple(widths))
        return RUN_PROBE(pi, di, job, widths=widths, timeout=0.5,
                    command=lambda w: [sys.executable, "-c", code[w]])
    monkeypatch.setattr(probe_mod, "run_probe", run)
    return calls


def ask():
    found, source = probe_mod.verdicts(0, 0, Platform, Device, JOB)
    return {w: v["ok"] for w, v in found.items()}, source


ALL_OK = {w: True for w in probe_mod.LANE_WIDTHS}


def test_widths_that_timed_out_once_are_probed_again_by_the_next_run(monkeypatch, tmp_path):
    """Every child timed out once (a loaded machine): the timeouts were cached as the device's
    verdicts, so every later run said 'cache' with every width failed (the device refused with
    DeviceNotSupportedError until the cache was deleted) and never probed again."""
    calls = scripted(monkeypatch, tmp_path, [dict.fromkeys(probe_mod.LANE_WIDTHS, HANG),
                                             dict.fromkeys(probe_mod.LANE_WIDTHS, OK)])
    assert ask() == ({w: False for w in probe_mod.LANE_WIDTHS}, "probe")
    assert ask() == (ALL_OK, "probe")
    assert ask() == (ALL_OK, "cache")
    assert calls == [(16, 8, 4, 1), (16, 8, 4, 1)]
    (entry,) = json.loads((tmp_path / "lanes.json").read_text())["entries"].values()
    assert "timeouts" not in entry           # passed at last: nothing left to retry


def test_a_width_that_times_out_in_two_runs_in_a_row_is_settled(monkeypatch, tmp_path):
    """16 lanes timed out, the others passed: the timeout was final after one run (8 lanes for good,
    on a machine that was only busy). Now only 16 is probed again, and its second timeout in a row
    stands, so a compiler that really hangs costs the timeout twice, not every run."""
    hang16 = {16: HANG, 8: OK, 4: OK, 1: OK}
    calls = scripted(monkeypatch, tmp_path, [hang16, hang16])
    want = {16: False, 8: True, 4: True, 1: True}
    assert ask() == (want, "probe")
    assert ask() == (want, "probe")
    assert ask() == (want, "cache") and ask() == (want, "cache")
    assert calls == [(16, 8, 4, 1), (16,)]
    (entry,) = json.loads((tmp_path / "lanes.json").read_text())["entries"].values()
    assert entry["timeouts"] == {"16": probe_mod.TIMEOUT_RUNS} == {"16": 2}
    # asked to probe afresh (refresh=True), all four are probed and the count is gone once 16 passes
    again = scripted(monkeypatch, tmp_path, [{**hang16, 16: OK}])
    found, source = probe_mod.verdicts(0, 0, Platform, Device, JOB, refresh=True)
    assert source == "probe" and {w: v["ok"] for w, v in found.items()} == ALL_OK
    assert again == [(16, 8, 4, 1)] and ask() == (ALL_OK, "cache")


def test_a_timeout_cached_before_the_count_was_kept_is_probed_again(monkeypatch, tmp_path):
    """A cache entry written without the count (as every entry was before): its timed-out width was
    taken from the cache for good."""
    calls = scripted(monkeypatch, tmp_path, [{16: OK}])
    why = "no answer within 60 s (the compiler or the kernel hung; the child was killed)"
    verdicts = {"16": {"ok": False, "why": why}, **{str(w): {"ok": True, "why": "fine"} for w in (8, 4, 1)}}
    entries = {probe_mod._key(Platform, Device, JOB): {"device": Device.name, "verdicts": verdicts}}
    data = {"format": "pyshadow-lanes", "version": 1, "entries": entries, "sha256": probe_mod._entries_digest(entries)}
    (tmp_path / "lanes.json").write_text(json.dumps(data))
    assert ask() == (ALL_OK, "probe")
    assert calls == [(16,)]
    assert ask() == (ALL_OK, "cache")


@pytest.mark.parametrize("value", ["1_6", "0_8", "\u0668", "\uff11\uff16", "+1_6"])
def test_pyshadow_lanes_written_other_than_in_ascii_digits_is_refused(value):
    """``int()`` read '1_6' as 16, '0_8' as 8 and Arabic-Indic or full-width digits as their values,
    so these were used as lane widths."""
    with pytest.raises(ValueError, match=r"PYSHADOW_LANES=.* is not one of 1, 4, 8, 16"):
        probe_mod.parse_override(value)


def test_pyshadow_lanes_in_plain_digits_is_read_as_before():
    for value, want in (("1", 1), (" 4 ", 4), ("08", 8), ("+16", 16), ("16\n", 16), ("", None), ("  ", None),
                        (None, None)):
        assert probe_mod.parse_override(value) == want, value
    for value in ("0", "-1", "abc", "9" * 5000, "8.0", "0x10"):
        with pytest.raises(ValueError, match="is not one of 1, 4, 8, 16"):
            probe_mod.parse_override(value)


def test_a_cache_folder_given_as_tilde_is_the_home_folder_as_for_the_csm_cache(monkeypatch, tmp_path):
    """``PYSHADOW_CACHE=~/x`` (quoted in a shell, so not expanded there): the CSM cache used ~/x in the
    home folder, but the probe wrote lanes.json to a folder named '~' in the current directory."""
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.setenv("PYSHADOW_CACHE", "~/pscache")
    assert probe_mod.cache_file() == tmp_path / "home" / "pscache" / "lanes.json"
    assert probe_mod.cache_file().parent == default_cache_dir()
    monkeypatch.setenv("PYSHADOW_CACHE", f"  {tmp_path / 'plain'}  ")
    assert probe_mod.cache_file() == tmp_path / "plain" / "lanes.json"
    monkeypatch.delenv("PYSHADOW_CACHE")
    assert probe_mod.cache_file().parent == default_cache_dir()
    assert os.path.isabs(probe_mod.cache_file())


KILLED = "import os, signal; os.kill(os.getpid(), signal.SIGKILL)"
ABORT = "import os; os.abort()"


def test_a_child_killed_from_outside_once_is_probed_again(monkeypatch, tmp_path):
    """16 lanes' child got SIGKILL (what the out-of-memory killer sends when four compilers run at
    once): 'died of signal 9' was cached as final and 16 lanes never used on that machine again."""
    calls = scripted(monkeypatch, tmp_path, [{16: KILLED, 8: OK, 4: OK, 1: OK}, {16: OK}])
    found, source = probe_mod.verdicts(0, 0, Platform, Device, JOB)
    assert source == "probe" and found[16] == {"ok": False, "why": "the child process died of signal 9"}
    assert ask() == (ALL_OK, "probe")
    assert ask() == (ALL_OK, "cache")
    assert calls == [(16, 8, 4, 1), (16,)]


def test_a_child_that_crashes_by_itself_is_final_at_once(monkeypatch, tmp_path):
    """A crash of the child's own (SIGABRT, as PoCL's LLVM aborts at 16 lanes on this machine) is the
    device's verdict: cached after one run, as before."""
    calls = scripted(monkeypatch, tmp_path, [{16: ABORT, 8: OK, 4: OK, 1: OK}])
    want = {16: False, 8: True, 4: True, 1: True}
    assert ask() == (want, "probe")
    assert ask() == (want, "cache")
    assert calls == [(16, 8, 4, 1)]

"""The lane-width probe where no child process can be started (an embedded interpreter whose
``sys.executable`` is empty, a process limit): a clear error naming PYSHADOW_LANES, which then works."""
import sys

import pytest

import pyshadow
from pyshadow import _cl
from pyshadow._cl import probe as probe_mod


@pytest.fixture
def no_child(monkeypatch, tmp_path):
    monkeypatch.setattr(sys, "executable", "")      # as Python leaves it where it cannot tell its own path
    monkeypatch.setenv("PYSHADOW_CACHE", str(tmp_path))
    st = _cl._init()
    return st["index"], st["platform"], st["device"], _cl._probe_job(st["device"])


def test_a_child_that_cannot_start_is_a_verdict_not_a_crash(no_child):
    """Was: PermissionError "[Errno 13] Permission denied: ''" out of the probe, from the first kernel of
    any call."""
    (pi, di), _plat, _dev, job = no_child
    found = probe_mod.run_probe(pi, di, job, widths=(8, 1))
    assert list(found) == [8, 1]
    for v in found.values():
        assert not v["ok"] and v["why"].startswith("the child process could not be started")
        assert "Permission denied" in v["why"] and "PYSHADOW_LANES" in v["why"]


def test_the_device_error_names_pyshadow_lanes_and_nothing_is_cached(no_child):
    """Was: the PermissionError above, with no way round it (a width forced by PYSHADOW_LANES is probed too)."""
    with pytest.raises(pyshadow.DeviceNotSupportedError, match="could not be started.*PYSHADOW_LANES"):
        _cl._probe_choice(dict(_cl._init()))
    assert not probe_mod.cache_file().exists()      # a machine's passing trouble is not the device's verdict


def test_a_forced_width_runs_unprobed(no_child):
    """Was: the PermissionError above with PYSHADOW_LANES=8 set as well. Now the width is used as forced
    (the probe could not say otherwise), and a later run with children probes the device as usual."""
    (pi, di), plat, dev, job = no_child
    found = probe_mod.check_override(8, pi, di, plat, dev, job)
    assert not found[8]["ok"] and "could not be started" in found[8]["why"]
    assert not probe_mod.cache_file().exists()

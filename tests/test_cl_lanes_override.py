"""``PYSHADOW_LANES`` naming a width whose probe failure is cached for this device."""
import pytest

from pyshadow import _cl
from pyshadow._cl import probe as lanes_mod


def _cache_verdicts(monkeypatch, tmp_path, failing: int, why: str):
    """A lanes.json in tmp_path whose entry for the current device says ``failing`` fails (``why``)."""
    monkeypatch.setenv("PYSHADOW_CACHE", str(tmp_path))
    st = _cl._init()
    key = lanes_mod._key(st["platform"], st["device"], _cl._probe_job(st["device"]))
    verdicts = {str(w): {"ok": w != failing, "why": why if w == failing else "built and computed correctly"}
                for w in _cl.LANE_WIDTHS}
    lanes_mod._write_cache(key, {"device": st["device"].name.strip(), "verdicts": verdicts})
    st.pop("override_checked", None)
    return st


def test_a_cached_failure_of_the_forced_width_is_a_clear_error(monkeypatch, tmp_path):
    """Was: PYSHADOW_LANES=16 on a CPU whose probe had failed 16 lanes (the Zen 4 PoCL) was used as
    asked; the rasteriser's build failed (clCreateKernel INVALID_KERNEL_NAME) and PoCL aborted the
    process as it exited (rc 134). Now the cached verdict is an error naming it and the widths that passed."""
    st = _cache_verdicts(monkeypatch, tmp_path, 4, "the compiler warns that a vector argument changes the ABI")
    monkeypatch.setenv("PYSHADOW_LANES", "4")
    try:
        with pytest.raises(_cl.DeviceNotSupportedError, match=r"PYSHADOW_LANES=4: 4-lane kernels failed the probe"
                           r".*changes the ABI.*widths that passed: 16, 8, 1"):
            _cl.lane_choice()
        monkeypatch.setenv("PYSHADOW_LANES", "8")            # a width that passed: used, as asked
        assert _cl.lane_choice()["lanes"] == 8
    finally:
        st.pop("override_checked", None)


def test_a_timed_out_or_missing_verdict_does_not_refuse_the_forced_width(monkeypatch, tmp_path):
    """A width whose probe only timed out (not final: a busy machine) is not refused, and without a
    cached verdict nothing is probed (no lanes.json written)."""
    st = _cache_verdicts(monkeypatch, tmp_path, 4, lanes_mod._TIMEOUT_WHY + " after 60 s")
    monkeypatch.setenv("PYSHADOW_LANES", "4")
    try:
        assert _cl.lane_choice()["lanes"] == 4
        empty = tmp_path / "empty"
        monkeypatch.setenv("PYSHADOW_CACHE", str(empty))
        st.pop("override_checked", None)
        assert _cl.lane_choice()["lanes"] == 4
        assert not (empty / "lanes.json").exists()
    finally:
        st.pop("override_checked", None)

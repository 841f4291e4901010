"""``PYSHADOW_LANES`` naming a width that fails the probe: cached, or probed when the cache has no verdict."""
import os
import subprocess
import sys
import textwrap

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


def test_a_timed_out_verdict_does_not_refuse_the_forced_width(monkeypatch, tmp_path):
    """A width whose probe only timed out (not final: a busy machine) is not refused."""
    st = _cache_verdicts(monkeypatch, tmp_path, 4, lanes_mod._TIMEOUT_WHY + " after 60 s")
    monkeypatch.setenv("PYSHADOW_LANES", "4")
    try:
        assert _cl.lane_choice()["lanes"] == 4
    finally:
        st.pop("override_checked", None)


def test_without_a_cached_verdict_the_forced_width_is_probed(monkeypatch, tmp_path):
    """Was: with no verdict cached, nothing was probed and the forced width was used as asked: a width the
    device cannot run failed at its first kernel. Now the probe runs (here a stand-in whose 4 lanes fail),
    its verdicts are cached, and the failing width is an error; a width that passed is used."""
    monkeypatch.setenv("PYSHADOW_CACHE", str(tmp_path))
    calls = []

    def fake(platform_index, device_index, job, widths=_cl.LANE_WIDTHS, **kw):
        calls.append(tuple(widths))
        return {w: {"ok": w != 4, "why": "wrong answers" if w == 4 else "built and computed correctly"}
                for w in widths}

    monkeypatch.setattr(lanes_mod, "run_probe", fake)
    st = _cl._init()
    st.pop("override_checked", None)
    try:
        monkeypatch.setenv("PYSHADOW_LANES", "4")
        with pytest.raises(_cl.DeviceNotSupportedError, match=r"PYSHADOW_LANES=4: 4-lane kernels failed the probe"
                           r" .*\(wrong answers\); widths that passed: 16, 8, 1"):
            _cl.lane_choice()
        assert calls == [_cl.LANE_WIDTHS] and (tmp_path / "lanes.json").exists()
        monkeypatch.setenv("PYSHADOW_LANES", "8")
        choice = _cl.lane_choice()
        assert (choice["lanes"], choice["supported"]) == (8, [16, 8, 1])
        assert calls == [_cl.LANE_WIDTHS]                   # the cached verdicts answered
    finally:
        st.pop("override_checked", None)


def test_a_forced_width_the_cpu_cannot_run_is_an_error_not_a_crash(tmp_path):
    """Was: ``PYSHADOW_LANES=16`` with an empty cache on a CPU whose PoCL cannot run 16 lanes (this AMD EPYC,
    znver3) failed at its first kernel (clCreateKernel INVALID_KERNEL_NAME) and PoCL aborted the process
    as it exited (rc 134). Now, wherever 16 lanes fail the probe, the process ends with the error naming
    the widths that passed; where they pass, a kernel runs at 16 lanes and gives the NumPy answer."""
    code = textwrap.dedent("""
        import numpy as np, pyshadow, trimesh
        try:
            lanes = pyshadow.device_info()["lanes"]
        except pyshadow.DeviceNotSupportedError as exc:
            print("REFUSED", exc)
            raise SystemExit(0)
        scene = pyshadow.Scene()
        scene.add(pyshadow.CoherentShadowMap.build(trimesh.creation.icosphere(2), pyshadow.ViewSet.zigzag(8, 16),
                                                   resolution=32, progress=False))
        points = np.float32([[0, 0, 3], [0, 0, 3], [3, 0, 0], [3, 0, 0]])
        dirs = np.float32([[0, 0, -1], [0, 0, 1], [-1, 0, 0], [1, 0, 0]])
        print("RAN", lanes, np.asarray(scene.visible(points, dirs)).astype(int).tolist())
    """)
    env = {**os.environ, "PYSHADOW_CACHE": str(tmp_path), "PYSHADOW_LANES": "16"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    if out.stdout.startswith("REFUSED"):
        assert "PYSHADOW_LANES=16: 16-lane kernels failed the probe" in out.stdout
        assert "widths that passed:" in out.stdout
    else:
        assert out.stdout.strip() == "RAN 16 [0, 1, 0, 1]", out.stdout

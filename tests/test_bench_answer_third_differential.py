"""Third differential audit of ``pyshadow-bench``'s answer path (pyshadow/bench/answer.py): what
``frame_budget.json`` records against what the printed answer says and the choice rule it uses.

The CLI runs as a subprocess at the tiny settings of test_bench.py (a few seconds); the
verification's time correction runs in process on a fake clock."""
from __future__ import annotations

import argparse
import json
import types

import pytest

from pyshadow.bench import answer
from pyshadow.bench.config import Config
from pyshadow.bench.scenes import SceneFactory
from pyshadow.cache import CSMCache
from test_bench import TINY, bench

BUDGET = 1e-5     # 10 us a frame: no configuration renders 64x48 pixels that fast


@pytest.fixture(scope="module")
def budget(tmp_path_factory):
    """--frame-budget BUDGET --json at the tiny settings: (parsed stdout, process)."""
    out = tmp_path_factory.mktemp("budget")
    p = bench(*TINY, "--frame-budget", BUDGET, "--out", out, "--json",
              cache=tmp_path_factory.mktemp("budget-cache"))
    return json.loads(p.stdout), p


def test_frame_budget_candidates_meet_is_the_budget_rule(budget):
    """A candidate ``meets`` --frame-budget T when its predicted frame time is at most T / TIME_MARGIN
    (the rule the choice uses). Before, ``meets`` compared the predicted RMSE with an infinite
    --max-error, so every candidate "met" a 10 us budget while the printed answer said that no
    configuration is predicted to render within it."""
    rec, p = budget
    T, margin = rec["frame_budget"]["budget"]["value"], rec["time_margin"]
    assert T == BUDGET and margin == 1.2
    assert rec["frame_budget"]["label"] is None and rec["attempts"] == []
    assert "no configuration is predicted to render within" in p.stderr
    assert len(rec["candidates"]) >= 2 * 11
    for c in rec["candidates"]:
        assert c["predicted_frame_time"]["value"] > T / margin, c["label"]
        assert c["meets"] is False, c["label"]


def test_frame_budget_text_states_the_budget(budget):
    """The printed answer names the budget of frame_budget.json: 10 us is "0.01 ms". Before, the
    budget printed rounded to whole milliseconds: "no configuration is predicted to render within
    0 ms a frame" for a valid budget of 10 us (any budget under 0.5 ms printed as 0 ms)."""
    rec, p = budget
    assert f"render within {rec['frame_budget']['budget']['value'] * 1e3:g} ms a frame" in p.stderr
    assert "render within 0.01 ms a frame" in p.stderr


class _Timed:
    """A scene whose render advances ``clock["t"]`` by ``(a + c S) k`` seconds: frame times exact."""

    def __init__(self, scene, clock):
        self._scene, self._clock = scene, clock

    def render(self, camera, sampling, **kw):
        self._clock["t"] += (0.01 + 0.001 * sampling.samples) * self._clock["k"]
        return self._scene.render(camera, sampling=sampling, **kw)

    def __getattr__(self, name):
        return getattr(self._scene, name)


def test_frame_budget_attempt_predicts_the_corrected_frame_time(tmp_path, monkeypatch):
    """Renders take 10 ms + 1 ms a sample while the model is fitted and 1.5 times as long once
    verification starts. Budget 60 ms (50 ms with the margin): the first pick, s36 (46 ms), runs
    69 ms, over budget, so every predicted time is scaled by 1.5 and the next pick is s16, 26 ms
    x 1.5 = 39 ms, which is what it measures. Before, its attempt and the answer recorded (and
    printed) the uncorrected 26 ms as its prediction, a figure the choice did not use."""
    clock = {"t": 0.0, "k": 1.0}
    cache = CSMCache(tmp_path, lambda m: None)
    fac = SceneFactory(None, (24, 18), cache, False)

    def factory(cfg):
        scene, camera, infos = fac(cfg)
        return _Timed(scene, clock), camera, infos

    factory.description, factory.size = fac.description, fac.size

    def log(msg):
        if msg.startswith("verifying"):
            clock["k"] = 1.5

    args = argparse.Namespace(max_error=None, frame_budget=0.06, strategy="hammersley", seed=0, patterns=256,
                              threads=2, repeats=2, reference_samples=64)
    monkeypatch.setattr(answer, "time", types.SimpleNamespace(perf_counter=lambda: clock["t"]))
    rec = answer.run_max_error(args, Config((8, 16), 32, 16, 8), factory, cache, log)
    first, second = rec["attempts"]
    assert first["config"]["samples"] == 36 and not first["met"]
    assert first["predicted_frame_time"]["value"] == pytest.approx(0.046, abs=1e-12)
    assert first["measured_frame_time"]["value"] == pytest.approx(0.069, abs=1e-12)
    ans = rec["frame_budget"]
    assert ans["time_scale"] == pytest.approx(1.5, abs=1e-9) and ans["met"] is True
    assert second["config"]["samples"] == 16 and ans["label"] == second["label"]
    cand = next(c for c in rec["candidates"] if c["label"] == second["label"])
    assert cand["predicted_frame_time"]["value"] == pytest.approx(0.026, abs=1e-12)
    for t in (second["predicted_frame_time"], ans["predicted"]["frame_time"], ans["measured"]["frame_time"]):
        assert t["value"] == pytest.approx(0.039, abs=1e-12)
    assert "39 ms/frame (predicted 39)" in answer.answer_text(rec)

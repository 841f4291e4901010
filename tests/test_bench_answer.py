"""``pyshadow-bench --max-error E`` without ``--sweep`` (pyshadow/bench/answer.py): the model of
AO noise, bias and frame time, its choice, its verification, and its outputs.

The CLI runs as a subprocess at the tiny settings of test_bench.py (64x48 pixels, 8x16 maps of
32^2 texels, 64-sample reference: a few seconds); the model's arithmetic is tested in process.
The sweep test in test_bench.py checks the model's predictions against the sweep's measurements
of the same configurations."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from test_bench import TINY, bench

E = 0.05          # met at the tiny settings by 4 samples + bilateral (RMSE 0.038)


@pytest.fixture(scope="module")
def answer(tmp_path_factory):
    """--max-error E --json at the tiny settings, beside a stale sweep.json it must not read:
    (parsed stdout, output dir, process)."""
    out = tmp_path_factory.mktemp("answer")
    (out / "sweep.json").write_text("not a sweep\n")
    p = bench(*TINY, "--max-error", E, "--out", out, "--json",
              cache=tmp_path_factory.mktemp("answer-cache"))
    return json.loads(p.stdout), out, p


def test_answer_json_is_max_error_json_and_no_sweep(answer):
    rec, out, p = answer
    assert json.loads((out / "max_error.json").read_text()) == rec
    assert rec["schema"] == "pyshadow-bench-max-error/1"
    assert (out / "sweep.json").read_text() == "not a sweep\n"          # neither read nor written
    assert not (out / "sweep.md").exists() and not (out / "pareto.png").exists()
    assert not (out / "results.json").exists()
    assert "sweep" not in p.stderr
    assert rec["base"]["maps"] == "8x16" and rec["base"]["resolution"] == 32
    assert rec["image"] == {"width": 64, "height": 48}
    assert rec["converged_source"] == "computed" and rec["csm_source"] == "built"
    assert rec["max_error"]["threshold"]["value"] == E
    assert 0.0 < rec["runtime"]["value"] < 120.0
    assert "fastest configuration with AO RMSE <= 0.05" in p.stderr      # the text, on stderr


def test_answer_meets_target_and_is_the_fastest_predicted(answer):
    rec, _, _ = answer
    ans = rec["max_error"]
    cands = rec["candidates"]
    ok = [c for c in cands if c["meets"]]
    assert ok and len(ok) < len(cands)
    for c in cands:      # "meets" is the margin rule
        assert c["meets"] == (c["predicted_rmse"]["value"] <= E / rec["margin"]), c["label"]
    fastest = min(ok, key=lambda c: (c["predicted_frame_time"]["value"], c["samples"], c["filter"] is not None))
    first = rec["attempts"][0]
    assert first["label"] == fastest["label"]
    assert first["predicted_rmse"] == fastest["predicted_rmse"]
    # the answer is the verified configuration, and verification measured it meeting E
    assert ans["met"] is True and ans["label"] == rec["attempts"][-1]["label"]
    assert ans["measured"]["rmse"]["value"] <= E
    assert all(not a["met"] for a in rec["attempts"][:-1]) and rec["attempts"][-1]["met"]
    assert ans["config"]["maps"] == "8x16" and ans["config"]["resolution"] == 32
    assert ans["measured"]["frame_time"]["value"] > 0


def test_answer_prediction_matches_verification(answer):
    """The verified configuration's measured RMSE (the run's seed, not one of the model's) is
    its prediction within the statistics of 3072 pixels: measured 0.0382 against 0.0397."""
    rec, _, _ = answer
    for a in rec["attempts"]:
        pred, meas = a["predicted_rmse"]["value"], a["measured_rmse"]["value"]
        assert 0.8 * pred <= meas <= rec["margin"] * pred, (a["label"], pred, meas)


def test_answer_model_is_physical(answer):
    """Noise falls with samples, faster than 1/S (stratified patterns: local p 1.39 and 1.44
    unfiltered, 1.60 and 1.28 filtered at these settings); the bilateral filter removes most
    noise and adds blur bias; frame time does not fall with samples; neither do predictions."""
    rec, _, _ = answer
    none, bil = rec["model"]["none"], rec["model"]["bilateral"]
    assert none["counts"] == bil["counts"] == [4, 8, 16]
    for fm in (none, bil):
        v = [x["value"] for x in fm["noise_variance"]]
        assert v[0] > v[1] > v[2] > 0
        assert all(p["value"] > 1.0 for p in fm["exponents"])
        assert fm["bias2"]["value"] >= 0 and fm["time_per_sample"]["value"] >= 0
        assert fm["noise_scale"] >= 1.0
    for vn, vb in zip(none["noise_variance"], bil["noise_variance"]):
        assert vb["value"] < 0.25 * vn["value"]
    assert bil["bias2"]["value"] > none["bias2"]["value"]
    assert none["time_per_sample"] == bil["time_per_sample"]            # shared slope
    for f in ("none", "bilateral"):
        cs = sorted((c for c in rec["candidates"] if (c["filter"] or "none") == f), key=lambda c: c["samples"])
        assert [c["samples"] for c in cs] == [4, 8, 9, 16, 25, 36, 49, 64, 100, 144, 196, 256]
        e = [c["predicted_rmse"]["value"] for c in cs]
        t = [c["predicted_frame_time"]["value"] for c in cs]
        assert all(a >= b for a, b in zip(e, e[1:])) and all(a <= b for a, b in zip(t, t[1:]))
        # at the measured counts the prediction is the measured noise plus the bias
        fm = rec["model"][f]
        for S, v in zip(fm["counts"], fm["noise_variance"]):
            c = next(c for c in cs if c["samples"] == S)
            assert c["predicted_rmse"]["value"] == pytest.approx(math.sqrt(v["value"] + fm["bias2"]["value"]))


def test_answer_unreachable_target_text(tmp_path, answer):
    """A target below the bias no sample count removes: no candidate, nothing verified, exit 0."""
    _, out, _ = answer
    rec0 = json.loads((out / "max_error.json").read_text())
    floor = min(math.sqrt(fm["bias2"]["value"]) for fm in rec0["model"].values())
    e = 0.5 * floor
    p = bench(*TINY, "--max-error", repr(e), "--out", tmp_path, "--quiet", cache=tmp_path / "cache")
    assert p.stdout.startswith(f"no configuration (samples x filter on the CSMs of 8x16 r32 16b s8) "
                               f"is predicted to reach AO RMSE <= {e:g}")
    assert "| 256 |" in p.stdout and p.stderr.strip() == ""
    rec = json.loads((tmp_path / "max_error.json").read_text())
    assert rec["max_error"]["label"] is None and rec["max_error"]["met"] is False
    assert rec["attempts"] == [] and not any(c["meets"] for c in rec["candidates"])


# ---------------------------------------------------------------------------
# the model, in process
# ---------------------------------------------------------------------------
def test_noise_and_bias_recovers_known_noise_and_bias():
    from pyshadow.bench.answer import noise_and_bias

    rng = np.random.default_rng(1)
    N, sigma, bias = 200_000, 0.05, 0.02
    conv = rng.random(N)
    for R in (2, 3, 5):
        renders = conv + bias + sigma * rng.standard_normal((R, N))
        v, b2 = noise_and_bias(renders, conv)
        # standard errors: v about sigma^2 sqrt(2 / N) / sqrt(R - 1), b2 about twice that / R
        assert v == pytest.approx(sigma ** 2, abs=4 * sigma ** 2 * math.sqrt(2 / N))
        assert b2 == pytest.approx(bias ** 2, abs=8 * sigma ** 2 * math.sqrt(2 / N))
    # two renders: the brief formula mean((A1 - A2)^2) / 2
    a = rng.random((2, 1000))
    assert noise_and_bias(a, conv[:1000])[0] == pytest.approx(np.mean((a[0] - a[1]) ** 2) / 2)
    assert noise_and_bias(np.stack([conv, conv]), conv) == (0.0, 0.0)
    with pytest.raises(ValueError, match="R >= 2"):
        noise_and_bias(conv[None], conv)


def _model(**kw):
    from pyshadow.bench import FilterModel

    args = dict(filter=None, counts=(4, 16, 36), variances=(9.6e-3, 1.4e-3, 0.5e-3),
                bias2s=(1e-5, 3e-5, 2e-5), times=(0.24, 0.30, 0.40))
    args.update(kw)
    return FilterModel(**args)


def test_filter_model_noise_rule():
    m = _model()
    p = [math.log(9.6e-3 / 1.4e-3) / math.log(4), math.log(1.4e-3 / 0.5e-3) / math.log(36 / 16)]
    assert m.exponents == pytest.approx(p) and min(p) > 1
    assert m.bias2 == pytest.approx(2e-5)
    for S, v in zip(m.counts, m.variances):
        assert m.noise_variance(S) == pytest.approx(v)                   # exact at the counts
    assert m.noise_variance(9) == pytest.approx(9.6e-3 * 4 / 9)           # 1/S from the count below
    assert m.noise_variance(25) == pytest.approx(1.4e-3 * 16 / 25)
    assert m.noise_variance(144) == pytest.approx(0.5e-3 * 36 / 144)
    assert m.noise_variance(35) > m.noise_variance(36)                   # p > 1: no step up
    assert m.rmse(144) == pytest.approx(math.sqrt(0.5e-3 / 4 + 2e-5))
    # below the lowest count: the first exponent, at least 1
    assert m.noise_variance(2) == pytest.approx(9.6e-3 * 2 ** p[0])
    flat = _model(variances=(2e-3, 1.4e-3, 0.5e-3))
    assert flat.exponents[0] < 1 and flat.noise_variance(2) == pytest.approx(2e-3 * 2)


def test_filter_model_time_and_shared_slope():
    from pyshadow.bench.answer import shared_slope

    m = _model(times=(0.24, 0.30, 0.40))
    S, t = np.array([4, 16, 36.0]), np.array([0.24, 0.30, 0.40])
    c, a = np.polyfit(S, t, 1)
    assert m.per_sample == pytest.approx(c) and m.intercept == pytest.approx(a)
    assert m.frame_time(100) == pytest.approx(a + 100 * c)
    b = _model(filter="bilateral", times=(0.50, 0.58, 0.64))
    cb = np.polyfit(S, b.times, 1)[0]
    assert shared_slope({None: m, "bilateral": b}) == pytest.approx((c + cb) / 2)
    b.slope = (c + cb) / 2
    assert b.intercept == pytest.approx(np.mean(b.times) - b.slope * S.mean())   # least squares at c
    falling = _model(times=(0.40, 0.40, 0.38))                           # timing noise: no negative cost
    assert falling.per_sample == 0.0 and falling.frame_time(256) == pytest.approx(np.mean(falling.times))


def test_correct_raises_prediction_to_the_miss():
    m = _model()
    before = m.rmse(25)
    m.correct(25, 1.5 * before)
    assert m.rmse(25) == pytest.approx(1.5 * before)
    assert m.noise_scale > 1 and m.rmse(64) > _model().rmse(64)
    m2 = _model()
    m2.correct(25, 0.5 * before)                                          # a hit never lowers it
    assert m2.noise_scale == 1.0 and m2.rmse(25) == pytest.approx(before)
    z = _model(variances=(0.0, 0.0, 0.0))
    z.correct(36, 0.02)
    assert z.rmse(36) == pytest.approx(0.02) and z.bias2_floor == pytest.approx(4e-4)


def test_choose_fastest_predicted_to_meet():
    from pyshadow.bench.answer import choose, predictions

    models = {None: _model(), "bilateral": _model(filter="bilateral", variances=(2.6e-4, 3.7e-5, 1.3e-5),
                                                  bias2s=(1e-4,) * 3, times=(0.50, 0.58, 0.69))}
    preds = predictions(models, [4, 9, 16, 36, 64, 144], 0.02)
    assert len(preds) == 12
    pick = choose(preds)
    ok = [p for p in preds if p["rmse"] <= 0.02 / 1.1]
    assert pick["frame_time"] == min(p["frame_time"] for p in ok) and pick in ok
    # 4 + bilateral: 0.0190, over 0.02 / 1.1; 9 + bilateral 0.0147 at 533 ms, then 64 unfiltered
    # (0.0174, 540 ms), then 16 + bilateral (0.0117, 574 ms)
    assert not next(p for p in preds if (p["samples"], p["filter"]) == (4, "bilateral"))["meets"]
    assert (pick["samples"], pick["filter"]) == (9, "bilateral")
    nxt = choose(preds, {(9, "bilateral")})
    assert (nxt["samples"], nxt["filter"]) == (64, None) and nxt["frame_time"] > pick["frame_time"]
    assert choose(preds, {(9, "bilateral"), (64, None)})["samples"] == 16
    assert choose(predictions(models, [4, 9], 1e-4)) is None
    # ties: fewer samples, then unfiltered
    tie = [{"samples": 9, "filter": None, "rmse": 0.01, "frame_time": 0.3, "meets": True},
           {"samples": 4, "filter": "bilateral", "rmse": 0.01, "frame_time": 0.3, "meets": True},
           {"samples": 4, "filter": None, "rmse": 0.01, "frame_time": 0.3, "meets": True}]
    assert choose(tie) is tie[2]


def test_model_counts():
    from pyshadow.bench.answer import model_counts

    assert model_counts(36) == (4, 16, 36)
    assert model_counts(16) == (4, 16, 36)
    assert model_counts(4) == (4, 16, 36)
    assert model_counts(8) == (4, 8, 16)
    assert model_counts(1024) == (4, 16, 64)
    assert model_counts(1) == (1, 4, 16)


def test_frame_budget_gives_the_least_predicted_error_within_it(tmp_path):
    """--frame-budget T: the least predicted RMSE among the candidates predicted within T / TIME_MARGIN,
    verified by timing; the budget is set between the model's own cheapest and dearest frames."""
    from pyshadow.bench.answer import TIME_MARGIN

    probe = bench(*TINY, "--max-error", E, "--out", tmp_path / "probe", "--json", cache=tmp_path / "cache")
    cands = json.loads(probe.stdout)["candidates"]
    times = sorted(c["predicted_frame_time"]["value"] for c in cands)
    T = TIME_MARGIN * times[len(times) // 2]                   # about half the candidates fit
    p = bench(*TINY, "--frame-budget", T, "--out", tmp_path / "b", "--json", cache=tmp_path / "cache")
    rec = json.loads(p.stdout)
    assert json.loads((tmp_path / "b" / "frame_budget.json").read_text()) == rec
    assert "max_error" not in rec and rec["frame_budget"]["budget"]["value"] == pytest.approx(T)
    bad = bench(*TINY, "--frame-budget", T, "--max-error", E, "--out", tmp_path / "c", check=False)
    assert bad.returncode == 2 and "--frame-budget answers alone" in bad.stderr
    # the rule, on the budget run's own predictions (its timings, not the probe's: the machine's load moves them)
    fit = [c for c in rec["candidates"] if c["predicted_frame_time"]["value"] <= T / TIME_MARGIN]
    if not fit:                                                # slower this time: no pick, said so
        assert rec["attempts"] == [] and rec["frame_budget"]["label"] is None
        assert "no configuration is predicted to render within" in p.stderr
        return
    best = min(fit, key=lambda c: (c["predicted_rmse"]["value"], c["predicted_frame_time"]["value"]))
    assert rec["attempts"][0]["label"] == best["label"]
    ans = rec["frame_budget"]
    assert ans["met"] == (ans["measured"]["frame_time"]["value"] <= T)
    assert "least AO RMSE within" in p.stderr

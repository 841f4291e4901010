"""``--max-error E`` without ``--sweep``: a model of AO error and frame time, its answer, verified.

The other direction, ``--frame-budget T``, uses the same model: the least
predicted RMSE among the configurations predicted to render within ``T /
TIME_MARGIN`` seconds a frame, verified by timing it (a verification slower
than predicted scales every predicted time by as much).

Instead of rendering and timing a grid of configurations, the answer keeps
the base configuration's CSMs (maps, resolution, depth bits, lookup) and
chooses only the AO sample count ``S`` and the filter. It renders the base
scene at three sample counts (:func:`model_counts`), a few times each with
different seeds, through :meth:`pyshadow.Scene.render` (the path the sweep
measures), for each filter of :data:`MODEL_FILTERS`, and fits per filter

- the noise variance ``v(S)`` of the AO about its mean over seeds,
- the squared bias ``b2`` of that mean against the converged reference
  (the CSM's discretisation error, the filter's blur and the reference's
  own noise: what no sample count removes),
- the frame time ``a + c S`` (``c`` shared by the filters, :func:`shared_slope`).

It predicts ``RMSE(S, filter) = sqrt(v(S) + b2)`` for every sample count of
:data:`SAMPLE_LADDER`, picks the fastest predicted configuration whose
predicted RMSE is at most ``E / MARGIN`` and then *verifies* it: renders it
at the run's seed and measures its RMSE against the converged reference. A
miss scales that filter's noise term by the measured excess and tries the
next pick, at most :data:`MAX_ATTEMPTS` renders in all.

How the noise scales with ``S``: a pixel's AO is the mean of ``S`` binary
visibilities; for independent samples its variance is ``sigma^2 / S``, and
the scrambled Hammersley (every stratified) pattern makes it fall at least
that fast. So ``v(S) = v(S_k) S_k / S``, continued from the nearest measured
count ``S_k <= S``, overestimates the noise: the prediction is conservative
above each measured count. The filters of :mod:`pyshadow.filters` weigh
neighbours by depth and normal only, never by AO, so a filtered image is a
fixed linear map of the unfiltered one and its noise variance scales the
same way (it is still measured per filter, not assumed).

The variance is not one power law, so the model does not extrapolate down:
Hammersley sets of a power-of-two size are (0, m, 2)-nets and converge
faster than their neighbours. On the default scene (64x128 maps, 640x480)
the unfiltered variance falls as ``S^-1.41`` from 4 to 16 samples, ``S^-1.20``
from 16 to 36 and ``S^-1.95`` from 36 to 64; a power law fitted at 16 and 36
and extrapolated down underestimated the RMSE at 4 samples by 13 % (0.086
against 0.099). Hence three counts, the lowest the ladder's lowest. Below the
lowest count (only with a base of fewer samples than the ladder's lowest) the
first segment's exponent, at least 1, extrapolates, without that guarantee.
"""
from __future__ import annotations

import dataclasses
import math
import statistics
import time

import numpy as np

from .._validate import check_int
from ..cache import CSMCache
from ..embree import EmbreeTracer
from ..sampling import Sampling
from .common import _fig, cached_ao, environment
from .config import Config, _config_of
from .measure import GBuffer, _errors, _reference_key, converged_reference
from .scenes import SceneFactory, _csm_summary

MAX_ERROR_SCHEMA = "pyshadow-bench-max-error/1"
#: Filters the model chooses among: unfiltered AO and the joint bilateral filter
#: (the filters of the sweep's grids).
MODEL_FILTERS = (None, "bilateral")
#: Sample counts the answer chooses among (the model's counts are added).
SAMPLE_LADDER = (4, 9, 16, 25, 36, 49, 64, 100, 144, 196, 256)
#: Sample counts the model always renders; the base's (at most 64) is added.
MODEL_SAMPLES = (4, 16)
#: The predicted RMSE must be at most E / MARGIN. 10 % in RMSE (21 % in mean squared
#: error) covers the statistical error of the fitted variance and bias (a few renders
#: of N pixels), the spread of one seed's RMSE about its expectation, and counts
#: between the measured ones that converge slower than 1/S from below (no power of two).
MARGIN = 1.1
#: ``--frame-budget T``: the predicted frame time must be at most T / TIME_MARGIN (frame times
#: of single renders on a shared 2-core machine scatter by 10-20 %).
TIME_MARGIN = 1.2
#: Verification renders at most (each a miss corrects the model, then the next pick).
MAX_ATTEMPTS = 3
#: Timed renders of the verified configuration (median), after its measuring render.
VERIFY_TIMED = 2


def model_counts(base_samples: int) -> tuple[int, ...]:
    """The sample counts the model renders: :data:`MODEL_SAMPLES` and the base's (at most 64).

    Ascending; 36 is added when the base's count is already one of
    :data:`MODEL_SAMPLES`, so that there are always three.
    """
    counts = set(MODEL_SAMPLES) | {max(1, min(int(base_samples), 64))}
    if len(counts) < 3:
        counts.add(36)
    return tuple(sorted(counts))


def noise_and_bias(renders, conv) -> tuple[float, float]:
    """Noise variance and squared bias of ``R >= 2`` renders of the same pixels.

    Parameters
    ----------
    renders : array_like, shape (R, N)
        The AO of the same N pixels at R seeds.
    conv : array_like, shape (N,)
        The converged reference at those pixels.

    Returns
    -------
    v : float
        Mean over pixels of the unbiased variance across renders (ddof 1): the
        expected squared difference of one render from its expectation. For
        R = 2 it is ``mean((A1 - A2)^2) / 2``.
    b2 : float
        ``max(0, mean((M - conv)^2) - v / R)`` with ``M`` the mean render: the
        squared distance of the expectation from the reference, the mean's own
        noise ``v / R`` taken out.

    Raises
    ------
    ValueError
        Fewer than 2 renders, no pixel, ``conv`` of another length, or a value
        that is not finite (a NaN would make the squared bias 0).
    """
    a = np.asarray(renders, np.float64)
    if a.ndim != 2 or a.shape[0] < 2:
        raise ValueError(f"need (R >= 2, N) renders, got shape {a.shape}")
    ref = np.asarray(conv, np.float64)
    if ref.shape != a.shape[1:]:
        raise ValueError(f"conv must have shape {a.shape[1:]} (one value per pixel of the renders), got {ref.shape}")
    if a.shape[1] == 0:
        raise ValueError("need renders of at least one pixel, got none")
    for x, name in ((a, "renders"), (ref, "conv")):
        bad = int(np.count_nonzero(~np.isfinite(x)))
        if bad:
            raise ValueError(f"{name}: {bad} values are not finite (NaN or inf); the AO must be measured")
    R = a.shape[0]
    v = float(np.mean(np.var(a, axis=0, ddof=1)))
    d = a.mean(axis=0) - ref
    return v, max(0.0, float(np.mean(d * d)) - v / R)


@dataclasses.dataclass
class FilterModel:
    """AO error and frame time of one filter as functions of the sample count.

    Attributes
    ----------
    filter : str or None
        ``denoise=`` of :meth:`pyshadow.Scene.render`.
    counts : tuple of int
        The measured sample counts, ascending (at least two).
    variances : tuple of float
        Noise variance at each count (:func:`noise_and_bias`).
    bias2s : tuple of float
        Squared bias at each count (the same in expectation: the model uses
        their mean, :attr:`bias2`).
    times : tuple of float
        Median frame time at each count, seconds.
    noise_scale : float
        Factor on the noise term: 1, raised by a verification that missed.
    bias2_floor : float
        Least squared bias: 0, raised by a miss that no noise term explains.
    slope : float or None
        Frame time per sample shared by the filters (:func:`shared_slope`);
        None: this filter's own.
    """

    filter: str | None
    counts: tuple
    variances: tuple
    bias2s: tuple
    times: tuple
    noise_scale: float = 1.0
    bias2_floor: float = 0.0
    slope: float | None = None

    def __post_init__(self):
        """ValueError unless counts are ascending ints >= 1 (two or more), each with finite values >= 0."""
        counts = [check_int(c, "counts", 1) for c in self.counts]
        if len(counts) < 2 or any(b <= a for a, b in zip(counts, counts[1:])):
            raise ValueError(f"counts must be at least two ascending sample counts, got {self.counts!r}")
        for name in ("variances", "bias2s", "times"):
            v = np.asarray(getattr(self, name), np.float64)
            if v.shape != (len(counts),) or not (np.isfinite(v) & (v >= 0)).all():
                raise ValueError(f"{name} must hold one finite value >= 0 per count ({len(counts)}), "
                                 f"got {getattr(self, name)!r}")

    @property
    def bias2(self) -> float:
        """Squared bias: the mean of the counts' estimates (at least :attr:`bias2_floor`)."""
        return max(self.bias2_floor, float(np.mean(self.bias2s)))

    @property
    def exponents(self) -> list:
        """The local ``p`` of ``v ~ S^-p`` between consecutive counts (1 where a variance is 0)."""
        out = []
        for s0, s1, v0, v1 in zip(self.counts, self.counts[1:], self.variances, self.variances[1:]):
            out.append(math.log(v0 / v1) / math.log(s1 / s0) if v0 > 0.0 and v1 > 0.0 else 1.0)
        return out

    @property
    def own_slope(self) -> float:
        """This filter's least-squares frame time per sample over the counts, seconds (may be < 0)."""
        S, t = np.asarray(self.counts, np.float64), np.asarray(self.times, np.float64)
        d = S - S.mean()
        return float(np.dot(d, t - t.mean()) / np.dot(d, d))

    @property
    def per_sample(self) -> float:
        """Frame time per sample ``c``, seconds: :attr:`slope` if set, else :attr:`own_slope`; at least 0."""
        return max(0.0, self.own_slope if self.slope is None else self.slope)

    @property
    def intercept(self) -> float:
        """Frame time at no samples ``a``, seconds: the least-squares intercept for :attr:`per_sample`."""
        c = self.per_sample
        return float(np.mean([t - c * s for s, t in zip(self.counts, self.times)]))

    def noise_variance(self, samples: int) -> float:
        """Predicted noise variance at ``samples``: ``v_k S_k / S`` from the nearest count ``S_k <= S``.

        Exact at the measured counts, conservative above each (variance falls
        at least as fast as 1/S). Below the lowest count, ``v_0 (S_0 / S)^max(1,
        p_0)`` with ``p_0`` the first local exponent: an extrapolation. Times
        :attr:`noise_scale`. ``samples`` is an int >= 1.
        """
        S = float(check_int(samples, "samples", 1))
        if S < self.counts[0]:
            v = self.variances[0] * (self.counts[0] / S) ** max(1.0, self.exponents[0])
        else:
            k = max(i for i, c in enumerate(self.counts) if c <= S)
            v = self.variances[k] * self.counts[k] / S
        return self.noise_scale * v

    def rmse(self, samples: int) -> float:
        """Predicted AO RMSE against the converged reference: ``sqrt(noise_variance(S) + bias2)``."""
        return math.sqrt(self.noise_variance(samples) + self.bias2)

    def frame_time(self, samples: int) -> float:
        """Predicted frame time ``a + c S``, seconds (at least 0)."""
        return max(0.0, self.intercept + self.per_sample * samples)

    def correct(self, samples: int, measured_rmse: float) -> None:
        """Correct the model after a verification at ``samples`` measured ``measured_rmse``.

        Scales the noise term (:attr:`noise_scale`) so that the predicted RMSE
        at ``samples`` becomes the measured one when that raises it; where the
        predicted noise is 0 the excess becomes a bias floor instead. The
        model never predicts less error than before. ``measured_rmse`` must
        be finite and >= 0 (ValueError: a NaN would leave the model unchanged).
        """
        if not measured_rmse >= 0.0 or not math.isfinite(measured_rmse):
            raise ValueError(f"measured_rmse must be a finite number >= 0, got {measured_rmse!r}")
        m2, noise = measured_rmse * measured_rmse, self.noise_variance(samples)
        if noise > 0.0:
            self.noise_scale *= max(1.0, (m2 - self.bias2) / noise)
        else:
            self.bias2_floor = max(self.bias2_floor, m2)

    def as_dict(self) -> dict:
        """The ``model`` record of one filter in ``max_error.json``."""
        return {
            "filter": self.filter, "counts": list(self.counts),
            "noise_variance": [_fig(v, "AO^2", f"noise variance at {s} samples")
                               for s, v in zip(self.counts, self.variances)],
            "exponents": [_fig(p, "1", f"local p of noise variance ~ S^-p from {s0} to {s1} samples")
                          for s0, s1, p in zip(self.counts, self.counts[1:], self.exponents)],
            "bias2": _fig(self.bias2, "AO^2", "squared bias vs the converged reference (mean of the counts)"),
            "bias2_by_count": [_fig(b, "AO^2", f"squared bias at {s} samples")
                               for s, b in zip(self.counts, self.bias2s)],
            "frame_time": [_fig(t, "s", f"frame time at {s} samples (median)")
                           for s, t in zip(self.counts, self.times)],
            "time_intercept": _fig(self.intercept, "s", "frame time model a of a + c S"),
            "time_per_sample": _fig(self.per_sample, "s", "frame time model c of a + c S"),
            "own_time_per_sample": _fig(self.own_slope, "s", "this filter's own least-squares slope"),
            "noise_scale": self.noise_scale, "bias2_floor": self.bias2_floor,
        }


def shared_slope(models: dict) -> float:
    """The frame time per sample of all filters: the mean of their own slopes.

    A filter runs on the finished AO image, so its cost does not depend on
    the sample count: every filter's frame time is ``a_f + c S`` with one
    ``c``. Measured at the same counts, the mean of the filters' least-squares
    slopes is the joint least-squares ``c``; it averages out part of a shared
    machine's timing noise. Each filter keeps its own intercept ``a_f``
    (:attr:`FilterModel.intercept`).
    """
    return float(np.mean([m.own_slope for m in models.values()]))


def predictions(models: dict, ladder, max_error: float, margin: float = MARGIN) -> list[dict]:
    """Every (samples, filter) candidate's predicted RMSE and frame time.

    Parameters
    ----------
    models : dict
        Filter -> :class:`FilterModel`.
    ladder : iterable of int
        Sample counts.
    max_error, margin : float
        A candidate is predicted to meet the target when its predicted RMSE
        is at most ``max_error / margin``.

    Returns
    -------
    list of dict
        ``samples``, ``filter``, ``rmse``, ``frame_time`` (predicted) and
        ``meets`` (bool), by filter then samples.
    """
    out = []
    for f, m in models.items():
        for S in sorted(set(ladder)):
            e = m.rmse(S)
            out.append({"samples": int(S), "filter": f, "rmse": e, "frame_time": m.frame_time(S),
                        "meets": e <= max_error / margin})
    return out


def choose(preds: list[dict], exclude=()) -> dict | None:
    """The fastest predicted candidate predicted to meet the target, not in ``exclude``.

    ``exclude`` holds ``(samples, filter)`` pairs. Ties go to fewer samples,
    then to the unfiltered image. None when no candidate is left.
    """
    ok = [p for p in preds if p["meets"] and (p["samples"], p["filter"]) not in exclude]
    if not ok:
        return None
    return min(ok, key=lambda p: (p["frame_time"], p["samples"], p["filter"] is not None))


def choose_within_time(preds: list[dict], budget: float, time_scale: float = 1.0, exclude=()) -> dict | None:
    """The other direction: the least predicted RMSE among candidates predicted within ``budget``.

    A candidate fits when its predicted frame time times ``time_scale`` (raised
    by a verification that ran slower than predicted) is at most ``budget /
    TIME_MARGIN``. Ties go to the faster. None when none fits.
    """
    ok = [p for p in preds if p["frame_time"] * time_scale <= budget / TIME_MARGIN
          and (p["samples"], p["filter"]) not in exclude]
    if not ok:
        return None
    return min(ok, key=lambda p: (p["rmse"], p["frame_time"]))


def _reference(cache, scene, gb, args, log):
    """(ao, seconds, source) of the converged reference; Embree is started only when not cached."""
    key = _reference_key(scene, gb, args.reference_samples, args.strategy, args.seed, args.patterns)
    ao = cached_ao(cache, key, gb.n)          # no note: converged_reference reads it again and says why
    if ao is not None:
        return ao, None, "cached"
    tracer = EmbreeTracer(scene, args.threads)
    try:
        return converged_reference(cache, tracer, scene, gb, args.reference_samples, args.strategy,
                                   args.seed, args.patterns, log)
    finally:
        tracer.close()


def run_max_error(args, base: Config, factory: SceneFactory, cache: CSMCache, log) -> dict:
    """Answer ``--max-error args.max_error`` from the model of this module, then verify it.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line with the preset filled in (``max_error``,
        ``strategy``, ``seed``, ``patterns``, ``threads``, ``repeats``: the
        renders per model configuration, at least 2, the first untimed,
        ``reference_samples``).
    base : Config
        Its CSMs (maps, resolution, depth bits) and lookup are kept; its
        sample count is one of the model's counts (:func:`model_counts`).
    factory : SceneFactory
    cache : pyshadow.cache.CSMCache
        CSMs and the converged reference.
    log : callable

    Returns
    -------
    dict
        The ``max_error.json`` record (schema :data:`MAX_ERROR_SCHEMA`):
        ``model`` (per filter, :meth:`FilterModel.as_dict`, after any
        correction), ``candidates`` (every prediction before verification),
        ``attempts`` (every verification: predicted and
        measured RMSE and frame time, ``met``), ``max_error`` (the answer:
        ``label``, ``config``, ``predicted``, ``measured``, ``met``; ``label``
        None when no candidate is predicted to meet the target) and
        ``runtime``.

    Raises
    ------
    RuntimeError
        When the camera sees no surface, or a render sees other objects than
        the first.
    """
    t_start = time.perf_counter()
    budget = getattr(args, "frame_budget", None)
    E = float(args.max_error) if budget is None else math.inf
    strat, pat, seed = args.strategy, args.patterns, args.seed
    R = max(2, int(args.repeats))
    counts = model_counts(base.samples)
    ladder = sorted(set(SAMPLE_LADDER) | set(counts))
    seeds = [(seed + 1 + k) % 2**31 for k in range(R)]       # not the run's seed: verified on that one
    base = dataclasses.replace(base, filter=None)
    scene, camera, infos = factory(base)
    csm = _csm_summary(infos)
    log(f"{'--max-error' if budget is None else '--frame-budget'} {E if budget is None else budget:g}: model from {R} renders at {', '.join(map(str, counts))} samples, filters "
        f"{', '.join(str(f or 'none') for f in MODEL_FILTERS)}, on the CSMs of {base.label}")

    def render(S, f, sd):
        return scene.render(camera, sampling=Sampling(S, strat, pat, sd), denoise=f, lookup=base.lookup)

    # the G-buffer and the converged reference first: a traced reference does not sit between timings
    gb = GBuffer.from_render(render(1, None, seed), camera, scene)
    if gb.n == 0:
        raise RuntimeError("the camera sees no surface: nothing to measure")
    conv, conv_s, conv_src = _reference(cache, scene, gb, args, log)
    ao = {(S, f): [] for S in counts for f in MODEL_FILTERS}
    times = {k: [] for k in ao}
    for r, sd in enumerate(seeds):        # rounds interleaved over the configurations
        for S, f in ao:
            t0 = time.perf_counter()
            out = render(S, f, sd)
            dt = time.perf_counter() - t0
            if not np.array_equal(out["object_id"], gb.object_id):
                raise RuntimeError(f"s{S} {f}: the G-buffer differs from the first render")
            ao[S, f].append(out["ao"].reshape(-1)[gb.sel])
            if r > 0:                     # the first round builds the kernels: untimed
                times[S, f].append(dt)
    models = {}
    for f in MODEL_FILTERS:
        fits = [noise_and_bias(ao[S, f], conv) for S in counts]
        models[f] = FilterModel(f, counts, tuple(v for v, _ in fits), tuple(b for _, b in fits),
                                tuple(statistics.median(times[S, f]) for S in counts))
    c = shared_slope(models)
    for m in models.values():
        m.slope = c
    preds = initial = predictions(models, ladder, E)
    for p in initial if budget is not None else ():    # --frame-budget: meets = predicted within T
        p["meets"] = p["frame_time"] <= budget / TIME_MARGIN
    log(f"model fitted in {time.perf_counter() - t_start:.1f} s")

    attempts, tried, answer, time_scale = [], set(), None, 1.0
    for _ in range(MAX_ATTEMPTS):
        pick = choose(preds, tried) if budget is None else choose_within_time(preds, budget, time_scale, tried)
        if pick is None:
            break
        S, f = pick["samples"], pick["filter"]
        pred_t = pick["frame_time"] * time_scale    # the model's prediction, corrected by slower verifications
        tried.add((S, f))
        cfg = dataclasses.replace(base, samples=S, filter=f)
        log(f"verifying {cfg.label}: predicted RMSE {pick['rmse']:.4f}, "
            f"{pred_t * 1e3:.0f} ms/frame")
        out = render(S, f, seed)
        if not np.array_equal(out["object_id"], gb.object_id):
            raise RuntimeError(f"{cfg.label}: the G-buffer differs from the first render")
        rmse, mae = _errors(out["ao"].reshape(-1)[gb.sel], conv)
        dts = []
        for _ in range(VERIFY_TIMED):
            t0 = time.perf_counter()
            render(S, f, seed)
            dts.append(time.perf_counter() - t0)
        att = {"label": cfg.label, "config": cfg.as_dict(),
               "predicted_rmse": _fig(pick["rmse"], "AO", "predicted AO RMSE vs converged"),
               "predicted_frame_time": _fig(pred_t, "s", "predicted frame time"),
               "measured_rmse": _fig(rmse, "AO", "AO RMSE vs converged, the run's seed"),
               "measured_mae": _fig(mae, "AO", "AO MAE vs converged, the run's seed"),
               "measured_frame_time": _fig(statistics.median(dts), "s",
                                           f"Scene.render frame time (median of {VERIFY_TIMED})"),
               "met": bool(rmse <= E if budget is None else statistics.median(dts) <= budget),
               "noise_scale": None}
        attempts.append(att)
        if att["met"]:
            answer = att
            break
        if budget is not None:          # slower than predicted: every prediction by as much
            time_scale = max(time_scale, statistics.median(dts) / max(pick["frame_time"], 1e-12))
            log(f"  over budget: {statistics.median(dts) * 1e3:.0f} ms; frame times x{time_scale:.2f}")
            continue
        # a miss: the noise term of this filter was too small by the measured excess
        m = models[f]
        m.correct(S, rmse)
        att["noise_scale"] = m.noise_scale
        log(f"  missed: RMSE {rmse:.4f} > {E:g}; noise term of filter {f or 'none'} x{m.noise_scale:.2f}")
        preds = predictions(models, ladder, E)
    if answer is None and attempts:
        key = "measured_rmse" if budget is None else "measured_frame_time"
        answer = min(attempts, key=lambda a: a[key]["value"])
    verdict = {
        "label": answer["label"] if answer else None,
        "config": answer["config"] if answer else None,
        "predicted": {k: answer[f"predicted_{k}"] for k in ("rmse", "frame_time")} if answer else None,
        "measured": {k: answer[f"measured_{k}"] for k in ("rmse", "mae", "frame_time")} if answer else None,
        "met": bool(answer is not None and answer["met"])}
    if budget is None:
        verdict["threshold"] = _fig(E, "AO", "largest AO RMSE vs the converged reference allowed")
    else:
        verdict["budget"] = _fig(float(budget), "s", "largest frame time allowed")
        verdict["time_scale"] = time_scale

    return {
        "schema": MAX_ERROR_SCHEMA,
        "environment": environment(args.threads),
        "scene": factory.description,
        "base": base.as_dict(),
        "image": {"width": factory.size[0], "height": factory.size[1]},
        "strategy": strat, "seed": seed, "patterns": pat, "model_seeds": seeds,
        "reference_samples": args.reference_samples, "converged_source": conv_src,
        "converged_time": _fig(conv_s, "s", "converged reference (null when cached)"),
        "csm_source": csm["source"], "margin": MARGIN,
        "model": {str(f or "none"): m.as_dict() for f, m in models.items()},
        "candidates": [_candidate(base, p) for p in initial],
        "time_margin": TIME_MARGIN, "attempts": attempts,
        ("max_error" if budget is None else "frame_budget"): verdict,
        "runtime": _fig(time.perf_counter() - t_start, "s", "wall time of the model, choice and verification"),
    }


def _candidate(base: Config, p: dict) -> dict:
    """The ``candidates`` record of one prediction of :func:`predictions`."""
    cfg = dataclasses.replace(base, samples=p["samples"], filter=p["filter"])
    return {"label": cfg.label, "samples": p["samples"], "filter": p["filter"],
            "predicted_rmse": _fig(p["rmse"], "AO", "predicted AO RMSE vs converged"),
            "predicted_frame_time": _fig(p["frame_time"], "s", "predicted frame time"),
            "meets": bool(p["meets"])}


def answer_text(rec: dict) -> str:
    """The ``--max-error`` answer of a :func:`run_max_error` record as text: the answer, the
    model, every candidate's prediction, the verifications and the total time."""
    if "frame_budget" in rec:
        return _budget_text(rec)
    ans = rec["max_error"]
    E = ans["threshold"]["value"]
    if ans["label"] is None:
        head = (f"no configuration (samples x filter on the CSMs of {_label(rec['base'])}) is predicted "
                f"to reach AO RMSE <= {E:g}")
    else:
        p, m = ({k: v["value"] for k, v in ans[x].items()} for x in ("predicted", "measured"))
        head = (f"fastest configuration with AO RMSE <= {E:g} (model, verified): {ans['label']} -- "
                f"{m['frame_time'] * 1e3:.0f} ms/frame (predicted {p['frame_time'] * 1e3:.0f}), "
                f"RMSE {m['rmse']:.4f} (predicted {p['rmse']:.4f}): "
                + ("target met" if ans["met"] else "target MISSED"))
    return "\n".join([head, ""] + _model_lines(rec, f"RMSE <= {E:g} / {rec['margin']:g}"))


def _budget_text(rec: dict) -> str:
    """:func:`answer_text` of a ``--frame-budget`` record."""
    ans = rec["frame_budget"]
    T = ans["budget"]["value"]
    if ans["label"] is None:
        head = f"no configuration is predicted to render within {T * 1e3:g} ms a frame"
    else:
        p, m = ({k: v["value"] for k, v in ans[x].items()} for x in ("predicted", "measured"))
        head = (f"least AO RMSE within {T * 1e3:g} ms a frame (model, verified): {ans['label']} -- "
                f"{m['frame_time'] * 1e3:.0f} ms/frame (predicted {p['frame_time'] * 1e3:.0f}), "
                f"RMSE {m['rmse']:.4f} (predicted {p['rmse']:.4f}): " + ("within" if ans["met"] else "OVER budget"))
    return "\n".join([head, ""] + _model_lines(rec, None))


def _model_lines(rec: dict, star) -> list:
    """The model, the candidates' predictions, the verifications and the total time, as text lines."""
    lines = [f"model: {len(rec['model_seeds'])} renders per configuration (seeds "
                       f"{rec['model_seeds'][0]}..{rec['model_seeds'][-1]}), reference "
                       f"{rec['reference_samples']} spp ({rec['converged_source']})"]
    for name, fm in rec["model"].items():
        var = ", ".join(f"{x['value']:.3g} @ {S}" for S, x in zip(fm["counts"], fm["noise_variance"]))
        ps = ", ".join(f"{x['value']:.2f}" for x in fm["exponents"])
        lines.append(f"  {name:9s} noise variance {var} spp (local p {ps}), bias^2 {fm['bias2']['value']:.3g}; "
                     f"frame {fm['time_intercept']['value'] * 1e3:.0f} ms + "
                     f"{fm['time_per_sample']['value'] * 1e3:.2f} ms/sample")
    filters = list(dict.fromkeys(c["filter"] for c in rec["candidates"]))
    lines += ["", "candidates, predicted" + (f" (* : {star}):" if star else ":"),
              "| samples | " + " | ".join(f"{f or 'none'} RMSE | {f or 'none'} ms" for f in filters) + " |",
              "| ---: |" + " ---: | ---: |" * len(filters)]
    by = {(c["samples"], c["filter"]): c for c in rec["candidates"]}
    for S in sorted({c["samples"] for c in rec["candidates"]}):
        cells = []
        for f in filters:
            c = by[S, f]
            cells += [f"{c['predicted_rmse']['value']:.4f}{' *' if star and c['meets'] else ''}",
                      f"{c['predicted_frame_time']['value'] * 1e3:.0f}"]
        lines.append(f"| {S} | " + " | ".join(cells) + " |")
    lines.append("")
    for a in rec["attempts"]:
        lines.append(f"verified {a['label']}: RMSE {a['measured_rmse']['value']:.4f} (predicted "
                     f"{a['predicted_rmse']['value']:.4f}), {a['measured_frame_time']['value'] * 1e3:.0f} "
                     f"ms/frame (predicted {a['predicted_frame_time']['value'] * 1e3:.0f}): "
                     + ("met" if a["met"] else "missed"))
    lines.append(f"total {rec['runtime']['value']:.1f} s")
    return lines


def _label(cfg: dict) -> str:
    """``Config.label`` of a ``Config.as_dict()`` record."""
    return _config_of(cfg).label

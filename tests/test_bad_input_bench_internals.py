"""The benchmark's internals and the AO method comparison under bad input and at the edges.

Missing figures (a measurement that was not finite is None in the records), NaN measurements,
sweeps with no positive error, no rays at all, arrays of the wrong shape, estimator options that
are no numbers. Each test's docstring says what happened before the fix. Nothing here runs a
benchmark: the functions are called on small hand-made records and arrays.
"""
from __future__ import annotations

import math
import types

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.bench import method_sweep as ms
from pyshadow.bench.answer import FilterModel, noise_and_bias
from pyshadow.bench.config import Config
from pyshadow.bench.measure import GBuffer, _errors, visibility_pass
from pyshadow.bench.methods import _agreement, embree_limited, time_rows
from pyshadow.bench.report import difference_rgb, pareto_plot
from pyshadow.bench.sweep import sweep_configs
from pyshadow.cubemap import march_defaults


def _pt(label, frame_time, limited, unlimited, precompute=0.5):
    """A point of :func:`pyshadow.bench.method_sweep.point` (None: a figure that was not finite)."""
    return {"method": label, "definition": "limited", "label": label, "setting": "4", "samples": 4,
            "probe_resolution": None, "frame_time": frame_time, "precompute_time": precompute,
            "rmse_limited": limited, "rmse_unlimited": unlimited}


#: b is fastest but its limited RMSE is missing; c's unlimited one is
POINTS = [_pt("a", 0.02, 0.05, 0.06), _pt("b", 0.01, None, 0.03), _pt("c", 0.03, 0.015, None)]


# ---------------------------------------------------------------------------
# the methods' points: fronts, winners, plot
# ---------------------------------------------------------------------------
def test_front_and_winners_skip_points_with_a_missing_error():
    """A point whose RMSE was not finite (None in the records) crashed front(), winners() and so
    summary() -- the 'methods' entry of sweep.json -- with "TypeError: '<' not supported between
    instances of 'NoneType' and 'float'"."""
    assert ms.front(POINTS, "rmse_limited") == [0, 2]
    assert ms.front(POINTS, "rmse_unlimited") == [1]
    win = {w["target"]: w["winner"] and w["winner"]["label"] for w in ms.winners(POINTS, "rmse_limited")}
    assert win == {0.01: None, 0.02: "c", 0.03: "c", 0.05: "a", 0.1: "a", 0.2: "a"}
    s = ms.summary(POINTS)
    assert s["front_limited"] == ["a 4", "c 4"] and s["front_unlimited"] == ["b 4"]
    assert [w["winner"] and w["winner"]["label"] for w in s["winners_unlimited"]] == [None, None, "b", "b", "b", "b"]


def test_front_leaves_out_a_point_with_a_nan_time():
    """A point with a NaN frame time was put on the front, alone (it sorted first), and the real one
    it does not dominate was left out: front() answered [0]."""
    pts = [_pt("a", math.nan, 0.01, 0.01), _pt("b", 0.02, 0.03, 0.03)]
    assert ms.front(pts, "rmse_limited") == [1]
    assert [w["winner"] and w["winner"]["label"] for w in ms.winners(pts, "rmse_limited")] == \
        [None, None, "b", "b", "b", "b"]


def test_plot_points_draws_only_measured_points():
    """plot_points() crashed on a point with a missing RMSE ("TypeError: '<' not supported
    between instances of 'NoneType' and 'float'")."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    try:
        ms.plot_points(ax, POINTS, "rmse_limited")
        drawn = {c.get_label(): np.asarray(c.get_offsets()).tolist() for c in ax.collections}
        front = [(list(ln.get_xdata()), list(ln.get_ydata())) for ln in ax.lines]
    finally:
        plt.close(fig)
    assert drawn == {"a": [[20.0, 0.05]], "b": [], "c": [[30.0, 0.015]]}
    assert front == [([20.0, 30.0], [0.05, 0.015])]


# ---------------------------------------------------------------------------
# the sweep's Pareto plot
# ---------------------------------------------------------------------------
def _sweep(rows, methods=None):
    sw = {"rows": [{"label": f"c{i}", "pareto": on, "figures": {"frame_time": {"value": t},
                                                              "ao_rmse_converged": {"value": e}}}
                   for i, (t, e, on) in enumerate(rows)],
          "scene": "test", "image": {"width": 32, "height": 24}, "environment": {"device": "cpu"}}
    if methods:
        sw["methods"] = {"points": methods, "distance": {"value": 0.5}}
    return sw


def _png_shape(path):
    import matplotlib.image

    return matplotlib.image.imread(path).shape


def test_pareto_plot_with_a_missing_frame_time(tmp_path):
    """A row or method point without a frame time (None in sweep.json) crashed pareto_plot:
    "TypeError: unsupported operand type(s) for *: 'NoneType' and 'float'", and a method point
    without an RMSE "TypeError: '<' not supported between instances of 'NoneType' and 'float'"."""
    pareto_plot(_sweep([(0.1, 0.05, True), (None, 0.02, False)]), tmp_path / "a.png")
    assert _png_shape(tmp_path / "a.png") == (715, 1100, 4)            # 10 x 6.5 inches at 110 dpi
    pareto_plot(_sweep([(0.1, 0.05, True)], POINTS), tmp_path / "b.png", 0.05)
    assert _png_shape(tmp_path / "b.png") == (715, 1760, 4)            # two panels, 16 inches wide


@pytest.mark.parametrize("rmse, logx", [(None, False), (0.0, True)])
def test_pareto_plot_with_no_positive_error(tmp_path, rmse, logx):
    """A sweep with no positive RMSE could not be drawn on log axes: every RMSE missing raised
    "ValueError: Data cannot be log-scaled because all values are <= 0"; every RMSE 0 (a scene
    the CSMs answer exactly) warned "Data has no positive values, and therefore cannot be
    log-scaled" (an error under the tests' filterwarnings). That axis is linear now (and the
    frame-time axis too where no point is drawn: a point missing one figure is not)."""
    sw = _sweep([(0.1, rmse, rmse is not None), (0.2, rmse, False)])
    pareto_plot(sw, tmp_path / "p.png")
    assert _png_shape(tmp_path / "p.png") == (715, 1100, 4)
    from pyshadow.bench.report import _log_axes

    assert _log_axes([(100.0, rmse), (200.0, rmse)]) == (logx, False)
    assert _log_axes([(100.0, rmse)], 0.05) == (logx, True)             # the --max-error line is drawn
    assert _log_axes([(None, 0.1), (100.0, None)]) == (False, False)   # no point with both figures


# ---------------------------------------------------------------------------
# the --max-error model
# ---------------------------------------------------------------------------
def test_noise_and_bias_refuses_nan_and_mismatched_reference():
    """A NaN in the converged reference gave a squared bias of exactly 0 (max(0, nan) is 0), so the
    model predicted no bias at all; a reference of another length was broadcast against every
    pixel; no pixels at all gave "RuntimeWarning: Mean of empty slice"."""
    renders = np.array([[0.5, 0.6], [0.52, 0.58]])
    assert noise_and_bias(renders, [0.5, 0.6]) == pytest.approx((2e-4, 1e-4 - 1e-4))
    with pytest.raises(ValueError, match=r"conv: 1 values are not finite"):
        noise_and_bias(renders, [math.nan, 0.6])
    with pytest.raises(ValueError, match=r"renders: 1 values are not finite"):
        noise_and_bias([[math.nan, 0.6], [0.5, 0.6]], [0.5, 0.6])
    with pytest.raises(ValueError, match=r"conv must have shape \(2,\) .*got \(1,\)"):
        noise_and_bias(renders, [0.5])
    with pytest.raises(ValueError, match="at least one pixel"):
        noise_and_bias(np.zeros((2, 0)), [])


def _model():
    return FilterModel(None, (4, 16, 36), (0.01, 0.002, 0.001), (1e-4, 1e-4, 1e-4), (0.01, 0.02, 0.04))


@pytest.mark.parametrize("samples, error", [(0, ValueError), (-2, ValueError), (True, TypeError)])
def test_noise_variance_below_one_sample(samples, error):
    """noise_variance(0) raised a bare ZeroDivisionError and noise_variance(-2) returned a complex
    number ((c / S) ** p of a negative base); True was read as 1 sample."""
    with pytest.raises(error, match="samples must be"):
        _model().noise_variance(samples)
    assert _model().noise_variance(1) == pytest.approx(0.01 * 4 ** math.log(5, 4))   # p_0 = log 5 / log 4


@pytest.mark.parametrize("kwargs, message", [
    (dict(counts=(16, 4)), r"counts must be at least two ascending sample counts, got \(16, 4\)"),
    (dict(counts=(16,), variances=(0.01,), bias2s=(0.0,), times=(0.1,)), "at least two ascending"),
    (dict(counts=(4, 4)), "at least two ascending"),
    (dict(variances=(0.01, 0.002, 0.001)), r"variances must hold one finite value >= 0 per count \(2\)"),
    (dict(times=(0.1,)), r"times must hold one finite value >= 0 per count \(2\)"),
    (dict(bias2s=(math.nan, 0.0)), "bias2s must hold one finite value >= 0"),
])
def test_filter_model_checks_its_counts_and_measurements(kwargs, message):
    """Counts out of order gave wrong predictions (counts (16, 4): noise_variance(16) 0.0025 for
    the measured 0.002, noise_variance(8) 0.0045 for 0.005); a single or repeated count raised
    IndexError or "RuntimeWarning: invalid value encountered in scalar divide"; measurements of
    another length than the counts were cut off by zip() or raised deep in NumPy."""
    args = dict(filter=None, counts=(4, 16), variances=(0.01, 0.002), bias2s=(0.0, 0.0), times=(0.1, 0.2))
    bad = {**args, **kwargs}
    if kwargs.get("counts") == (16, 4):             # the same measurements, listed the other way round
        bad.update(variances=(0.002, 0.01), times=(0.2, 0.1))
    with pytest.raises(ValueError, match=message):
        FilterModel(**bad).noise_variance(8)
    assert [FilterModel(**args).noise_variance(S) for S in (4, 8, 16)] == pytest.approx([0.01, 0.005, 0.002])


def test_correct_refuses_a_nan_measurement():
    """correct(S, nan) changed nothing (max(1, nan) is 1): a verification that measured NaN was
    taken as a hit of the model."""
    m = _model()
    with pytest.raises(ValueError, match="measured_rmse must be a finite number >= 0, got nan"):
        m.correct(16, math.nan)
    m.correct(16, 0.1)
    assert m.noise_scale == pytest.approx((0.01 - 1e-4) / 0.002)


# ---------------------------------------------------------------------------
# the cube-map estimators' options
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, name", [
    (dict(max_distance=True), "max_distance"),
    (dict(max_distance=np.complex128(2 + 3j)), "max_distance"),
    (dict(max_distance=2 + 0j), "max_distance"),
    (dict(max_distance=np.array([2.0])), "max_distance"),
    (dict(max_distance=1.0, step=True), "step"),
    (dict(max_distance=1.0, thickness="abc"), "thickness"),
    (dict(max_distance=1.0, bias=None), "bias"),
])
def test_march_defaults_refuses_what_is_no_real_number(kwargs, name):
    """True was read as 1 (max_distance, step), NumPy's complex numbers lost their imaginary part
    (with only a ComplexWarning), and a string, None, a complex or an array gave float()'s message,
    which names no argument."""
    with pytest.raises(TypeError, match=f"^{name}: must be a number"):
        march_defaults(**kwargs)
    assert march_defaults(np.float32(2.0), step=np.int64(2)) == dict(
        max_distance=2.0, thickness=0.5, step=2.0, bias=1e-3, max_steps=512)


# ---------------------------------------------------------------------------
# rays, agreement, errors
# ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def tracer():
    from pyshadow.embree import EmbreeTracer

    sc = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    wall = trimesh.creation.box((40.0, 10.0, 0.5))
    wall.apply_translation([0.0, 5.0, -0.25])          # front face z = 0
    sc.add(wall)
    tr = EmbreeTracer(sc, 1)
    yield tr
    tr.close()


P, W = [[0.0, 1.0, 1.0]], [[0.0, 0.0, -1.0]]           # the wall is 1 away along W


@pytest.mark.parametrize("points, directions, D, error, message", [
    (P, W, -1.0, ValueError, r"max_distance: must be a finite number > 0 \(got -1.0\)"),
    (P, W, math.nan, ValueError, r"max_distance: must be a finite number > 0 \(got nan\)"),
    (P, W, True, TypeError, r"max_distance: must be a number \(got True\)"),
    (P, [[0.0, 0.0, 0.0]], 2.0, ValueError, "directions: 1 rows are zero vectors"),
    ([[0.0, 1.0, 1.0, 0.0, 1.0, 1.0]], [[0.0, 0.0, -1.0, 0.0, 0.0, -1.0]], 2.0, ValueError,
     r"points must have shape \(N, 3\), got \(1, 6\)"),
    ([[0.0, 1.0, 1.0]] * 2, W, 2.0, ValueError, "directions has 1 rows but points has 2"),
])
def test_embree_limited_checks_its_rays(tracer, points, directions, D, error, message):
    """embree_limited answered a negative ray length (every ray open), read True as 1, divided a
    zero direction into NaN (RuntimeWarning), flattened (1, 6) arrays into two rays and raised a
    bare IndexError for directions fewer than the points."""
    with pytest.raises(error, match=message):
        embree_limited(tracer, points, directions, D)
    assert embree_limited(tracer, P, W, 2.0).tolist() == [True]
    assert embree_limited(tracer, P, [[0.0, 0.0, -5.0]], 0.5).tolist() == [False]


def test_agreement_of_no_rays_is_nan_and_mismatched_answers_refused():
    """With no rays _agreement reported 100 % agreement; answers of different lengths were
    broadcast (8 rays against 1 gave an agreement of -7.0)."""
    a = _agreement(np.zeros(0, bool), np.zeros(0, bool), 4)
    assert all(math.isnan(a[k]) for k in ("agreement", "false_visible", "false_occluded"))
    assert a["disagree"].shape == (0,)
    with pytest.raises(ValueError, match=r"both be \(N \* 4,\) rays, got shapes \(8,\) and \(1,\)"):
        _agreement(np.zeros(8, bool), np.zeros(1, bool), 4)
    with pytest.raises(ValueError, match=r"got shapes \(6,\) and \(6,\)"):
        _agreement(np.zeros(6, bool), np.zeros(6, bool), 4)
    b = _agreement(np.array([True, True, False, False]), np.array([False, True, True, False]), 2)
    assert (b["agreement"], b["false_visible"], b["false_occluded"]) == (0.5, 0.25, 0.25)
    assert b["disagree"].tolist() == [1, 1]


def test_visibility_pass_of_no_pixels_is_nan():
    """With no covered pixels visibility_pass reported 0 % agreement (0 / max(1, 0)) for rays it
    never compared."""
    gb = GBuffer(4, 4, np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int32),
                 np.full((4, 4), -1, np.int32))
    v = visibility_pass(None, gb, 4, "hammersley", 0, 64, np.zeros(0, bool))
    assert all(math.isnan(v[k]) for k in ("agreement", "false_visible", "false_occluded"))
    assert v["ao"].shape == (0,) and v["disagree"].shape == (0,)


@pytest.mark.parametrize("repeats, error", [(0, ValueError), (-1, ValueError), (2.0, TypeError)])
def test_time_rows_needs_a_timed_round(repeats, error):
    """time_rows(repeats=0) (benchmarks/methods.py --repeats 0) ran every method untimed, then raised
    statistics.StatisticsError "no median for empty data"; repeats=2.0 was read as 2 rounds."""
    ctx = types.SimpleNamespace(scene=types.SimpleNamespace(draw_items=lambda: ([], None)), camera=None)
    with pytest.raises(error, match="repeats must be"):
        time_rows(ctx, [{"ao": lambda: [0.5]}], repeats)


def test_errors_refuse_arrays_of_different_shapes():
    """_errors broadcast (N, 1) against (N,) -- every pixel against every other -- and (N,) against
    (1,), and reported those RMSEs."""
    with pytest.raises(ValueError, match=r"different shapes: \(3, 1\) and \(3,\)"):
        _errors(np.zeros((3, 1)), np.ones(3))
    with pytest.raises(ValueError, match=r"different shapes: \(3,\) and \(1,\)"):
        _errors(np.zeros(3), np.ones(1))
    assert _errors([0.0, 0.5, 1.0], [0.0, 0.0, 0.0]) == pytest.approx((math.sqrt(1.25 / 3), 0.5))


# ---------------------------------------------------------------------------
# the difference image, the sweep's grid
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("vmax", [0.0, -0.1, math.nan, math.inf])
def test_difference_rgb_refuses_a_range_that_is_no_positive_number(vmax):
    """vmax=0 divided by zero (RuntimeWarning; every difference at full strength, a zero one black),
    a negative vmax swapped red and blue (pyshadow darker drawn as lighter), NaN gave a black image
    and inf a white one."""
    d = np.array([[0.1, -0.1]])
    with pytest.raises(ValueError, match=r"vmax: must be a finite number > 0"):
        difference_rgb(d, np.ones((1, 2), bool), vmax)
    rgb, v = difference_rgb(d, np.ones((1, 2), bool), 0.1)
    # diff = pyshadow - reference: -0.1 (pyshadow darker) red, +0.1 blue
    assert v == 0.1 and rgb[0, 1, 0] > rgb[0, 1, 2] and rgb[0, 0, 2] > rgb[0, 0, 0]


def test_sweep_configs_of_an_unknown_grid():
    """An unknown grid name raised a bare KeyError: 'nope'."""
    base = Config((8, 16), 32, 16, 4)
    with pytest.raises(ValueError, match="grid must be one of full, quick, tiny, got 'nope'"):
        sweep_configs(base, "nope")
    rows = sweep_configs(base, "tiny")
    assert rows[0] == (base, "base") and len({c for c, _ in rows}) == len(rows)


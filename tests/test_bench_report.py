"""What pyshadow-bench prints from its records when a figure is missing (``null`` in results.json or
sweep.json: not finite, or not measured): "n/a", as format_table does, in every table and markdown
(pyshadow/bench/report.py, lit.py, light.py, methods.py, method_sweep.py, sweep.py). Records are built
by hand: no device needed."""
from __future__ import annotations

import re


def _f(value, unit="1"):
    return {"value": value, "unit": unit, "label": "test"}


def _sweep_row(label, varies, pareto, **values):
    keys = ("build_time", "csm_bytes", "csm_ratio", "frame_time", "ao_throughput", "visibility_agreement",
            "ao_rmse_converged", "ao_mae_converged", "ao_rmse_identical")
    return {"label": label, "varies": varies, "pareto": pareto,
            "figures": {k: _f(values.get(k)) for k in keys}}


def _sweep(runtime=12.3):
    from pyshadow.bench.config import Config

    full = _sweep_row("8x16 r32 16b s8", "base", True, build_time=1.5, csm_bytes=2_500_000, csm_ratio=12.3,
                      frame_time=0.0456, ao_throughput=7.891, visibility_agreement=0.97531,
                      ao_rmse_converged=0.01234, ao_mae_converged=0.00987, ao_rmse_identical=0.00456)
    empty = _sweep_row("8x16 r32 16b s4", "samples", False)        # every figure null
    return {"grid": "tiny", "scene": "two bodies", "image": {"width": 64, "height": 48},
            "environment": {"device": "cpu", "platform": "pocl", "pyshadow": "0.0"},
            "base": Config((8, 16), 32, 16, 8).as_dict(), "strategy": "hammersley", "reference_samples": 64,
            "runtime": _f(runtime, "s"), "repeats": 1, "rows": [full, empty]}


def test_sweep_markdown_prints_missing_figures_as_na():
    from pyshadow.bench import sweep_markdown

    md = sweep_markdown(_sweep()).splitlines()
    assert "| 8x16 r32 16b s8 | base | 1.5 | 2.50 | 12.3 | 46 | 7.89 | 97.531 | 0.0123 | 0.0099 | 0.0046 " \
           "| **yes** |" in md                                      # as before
    assert "| 8x16 r32 16b s4 | samples | n/a | n/a | n/a | n/a | n/a | n/a | n/a | n/a | n/a |  |" in md
    assert "- runtime: 12 s; frame and AO times are medians of 1 runs after a warm-up, taken in rounds " \
           "interleaved over all rows" in md
    md = sweep_markdown(_sweep(runtime=None)).splitlines()
    assert "- runtime: n/a s; frame and AO times are medians of 1 runs after a warm-up, taken in rounds " \
           "interleaved over all rows" in md


def test_sweep_markdown_max_error_answer_with_missing_figures():
    from pyshadow.bench import sweep_markdown

    sw = _sweep()
    row = _sweep_row("8x16 r32 16b s8", "base", True, ao_rmse_converged=0.01234)   # only the RMSE measured
    sw["max_error"] = {"threshold": _f(0.05, "AO"), "label": row["label"], "row": row}
    assert "fastest configuration with AO RMSE <= 0.05: 8x16 r32 16b s8 -- n/a ms/frame, RMSE 0.0123, " \
           "n/a MB of CSMs, agreement n/a %" in sweep_markdown(sw).splitlines()
    sw["max_error"]["row"] = sw["rows"][0]                          # every figure measured: as before
    assert "fastest configuration with AO RMSE <= 0.05: 8x16 r32 16b s8 -- 46 ms/frame, RMSE 0.0123, " \
           "2.50 MB of CSMs, agreement 97.53 %" in sweep_markdown(sw).splitlines()


def _point(label, setting, frame_time, rmse_limited, rmse_unlimited, precompute=None, probe_resolution=None):
    return {"method": label, "definition": "limited", "label": label, "setting": setting, "samples": 8,
            "probe_resolution": probe_resolution, "frame_time": frame_time, "precompute_time": precompute,
            "rmse_limited": rmse_limited, "rmse_unlimited": rmse_unlimited}


def test_sweep_markdown_methods_with_missing_figures():
    from pyshadow.bench import sweep_markdown

    known = _point("ssao", "8", 0.0123, 0.0456, 0.0789, precompute=0.5)
    lost = _point("ssao", "16", None, None, None)                  # same label: sorted after the timed one
    other = _point("cubemap", "R32", 0.2, 0.015, None, precompute=1.25, probe_resolution=32)
    sw = _sweep()
    sw["methods"] = {"distance": _f(None, "world"), "points": [lost, known, other],
                     "winners_limited": [{"target": 0.01, "winner": None},
                                         {"target": 0.02, "winner": _point("ssao", "8", None, 0.015, None)}],
                     "winners_unlimited": [{"target": 0.1, "winner": known}]}
    md = sweep_markdown(sw)
    lines = md.splitlines()
    assert "## Methods (D = n/a for the distance-limited definition; frame time: G-buffer raster + AO, " \
           "vtk-ssao its own render)" in lines
    table = [ln for ln in lines if ln.startswith("| cubemap |") or ln.startswith("| ssao |")]
    assert table == ["| cubemap | R32 | 200 | 1.25 | 0.0150 | n/a |",
                     "| ssao | 8 | 12 | 0.50 | 0.0456 | 0.0789 |",
                     "| ssao | 16 | n/a | 0.00 | n/a | n/a |"]
    assert "  RMSE <= 0.01 : none of the measured settings" in lines
    assert "  RMSE <= 0.02 : ssao (8 spp), n/a ms, RMSE 0.0150" in lines
    assert "  RMSE <= 0.1  : ssao (8 spp), 12 ms, RMSE 0.0789" in lines
    sw["methods"]["distance"] = _f(0.123456, "world")
    assert "## Methods (D = 0.1235 for the distance-limited definition" in sweep_markdown(sw)


def _lighting(value):
    modes = ("radiance_rmse_relative", "lit_frame_time", "lit_throughput", "ao_frame_time", "ao_throughput",
             "embree_lit_frame_time")
    return {"sky": "clear", "sun": {"direction": [0.1, 0.8, 0.2]}, "exposure": _f(value(1.23456)),
            "modes": {"bent": {k: _f(value(v)) for k, v in zip(modes, (0.04321, 0.0456, 7.89, 0.0123, 12.34,
                                                                       0.789))}}}


def test_format_lighting_prints_missing_figures_as_na():
    from pyshadow.bench.lit import format_lighting

    assert format_lighting(_lighting(lambda v: v)) == [
        ("lighting", "clear sky, sun dir (0.100, 0.800, 0.200); exposure 1.23"),
        ("  bent vs Embree bent", "rel. RMSE 0.0432 (same dirs); lit frame 46 ms (7.9 Msamples/s) vs AO alone "
                                  "12 ms (12.3); Embree lit 789 ms")]
    assert format_lighting(_lighting(lambda v: None)) == [
        ("lighting", "clear sky, sun dir (0.100, 0.800, 0.200); exposure n/a"),
        ("  bent vs Embree bent", "rel. RMSE n/a (same dirs); lit frame n/a ms (n/a Msamples/s) vs AO alone "
                                  "n/a ms (n/a); Embree lit n/a ms")]


def test_format_light_prints_missing_figures_as_na():
    from pyshadow.bench.light import format_light

    def rec(v):
        return {"kind": "sun", "direction": [0.1, 0.8, 0.2], "pixels": 100, "shadowed": _f(v(0.25)),
                "methods": {"csm": {"agreement": _f(v(0.98765)), "bytes": _f(v(3 * 2**20)),
                                    "frame_time_moving": _f(v(0.004)), "frame_time_static": _f(v(0.002))}}}

    assert format_light(rec(lambda v: v)) == [
        ("light", "sun (0.1, 0.8, 0.2): 100 pixels facing it, 25.0 % shadowed (Embree)"),
        ("  csm", "agreement 98.77 %; 3.0 MiB; moving 4 ms, static 2 ms a frame")]
    assert format_light(rec(lambda v: None)) == [
        ("light", "sun (0.1, 0.8, 0.2): 100 pixels facing it, n/a % shadowed (Embree)"),
        ("  csm", "agreement n/a %; n/a MiB; static n/a ms a frame")]


def _methods(value):
    row = {"method": "ssao", "definition": "limited", "setting": {"samples": 8},
           "precompute_time": _f(value(0.5)), "memory": _f(value(2_000_000)), "frame_time": _f(value(0.0123)),
           "visibility_agreement": "n/a (answers no rays)", "coverage": _f(value(1.0)),
           "ao_rmse_limited": _f(value(0.0456)), "ao_rmse_unlimited": _f(value(0.0789))}
    return {"distance": _f(value(0.75)), "limit_effect_rmse": _f(value(0.0321)), "rows": [row]}


def test_methods_table_prints_missing_figures_as_na():
    from pyshadow.bench.methods import methods_table

    assert methods_table(_methods(lambda v: v)).splitlines()[::3] == [
        "methods (D = 0.75; limit moves the reference by RMSE 0.032)",
        "| ssao | limited | 8 spp | 0.50 | 2.00 | 12 | n/a | 1.000 | 0.0456 | 0.0789 | n/a |"]
    assert methods_table(_methods(lambda v: None)).splitlines()[::3] == [
        "methods (D = n/a; limit moves the reference by RMSE n/a)",
        "| ssao | limited | 8 spp | n/a | n/a | n/a | n/a | n/a | n/a | n/a | n/a |"]


def test_format_table_with_lighting_and_light_missing():
    """The whole printed table of a results.json whose lighting and light figures are all null."""
    from pyshadow.bench import format_table

    r = {"mode": "custom", "scene": "two bodies", "csm": {"source": "built"}, "converged_source": "computed",
         "config": {"width": 64, "height": 48, "samples": 8, "strategy": "hammersley", "maps": "8x16",
                    "resolution": 32, "depth_bits": 16, "filter": None, "reference_samples": 64},
         "environment": {"device": "cpu", "platform": "pocl", "device_type": "CPU", "compute_units": 2,
                         "embree_threads": 2},
         "figures": {}, "surfaces": [],
         "lighting": _lighting(lambda v: None),
         "light": {"kind": "point", "position": [1.0, 2.0, 3.0], "pixels": 7, "shadowed": _f(None),
                   "methods": {}}}
    for k in ("csm_time", "csm_size", "csm_ratio", "ao_throughput", "frame_time", "ao_time", "covered_pixels",
              "embree_ray_rate", "embree_throughput", "speedup", "visibility_agreement", "false_visible",
              "false_occluded", "ao_rmse_identical", "ao_mae_identical", "ao_rmse_converged", "ao_mae_converged",
              "reference_noise_rmse", "converged_time", "total_time"):
        r["figures"][k] = _f(None)
    table = format_table(r).splitlines()
    rows = dict(re.fullmatch(r"  (.+?)  +(\S.*)", ln).groups() for ln in table[2:])      # label, text
    assert rows["lighting"] == "clear sky, sun dir (0.100, 0.800, 0.200); exposure n/a"
    assert rows["  bent vs Embree bent"] == ("rel. RMSE n/a (same dirs); lit frame n/a ms (n/a Msamples/s) vs AO "
                                           "alone n/a ms (n/a); Embree lit n/a ms")
    assert rows["light"] == "point (1.0, 2.0, 3.0): 7 pixels facing it, n/a % shadowed (Embree)"
    assert rows["AO vs Embree 64 spp"] == "RMSE n/a  MAE n/a  (Embree 8 spp itself: RMSE n/a)"


def test_records_name_the_versions_that_can_move_a_figure():
    # the mesh loader, Embree and PoCL decide answers (a run on another machine read 0.026 points
    # more agreement on the same code): every record names the versions it ran with
    from importlib.metadata import version

    import numpy
    import trimesh

    from pyshadow.bench.common import PACKAGES, package_versions

    v = package_versions()
    assert tuple(v) == PACKAGES
    assert v["numpy"] == numpy.__version__ and v["trimesh"] == trimesh.__version__
    assert v["embreex"] == version("embreex")

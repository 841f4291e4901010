"""Every AO method on the speed/accuracy axes: settings, Pareto fronts, the winner at each error target.

The methods of :mod:`pyshadow.bench.methods` are each run at a few settings
(samples per pixel; the cube map's probe resolution) on one
:class:`~pyshadow.bench.methods.Context`, timed interleaved within a setting,
and reduced to points: frame time against AO RMSE versus the converged
unlimited and the converged distance-limited Embree references. Used by
``pyshadow-bench --sweep --method ...`` (beside the CSM configurations of the
sweep, on the same axes) and by ``benchmarks/methods.py``.
"""
from __future__ import annotations

import math

from .common import _num
from .methods import measure_row, method_runs, time_rows

#: AO RMSE targets of the "which method wins" answer.
TARGETS = (0.01, 0.02, 0.03, 0.05, 0.1, 0.2)
#: Methods whose setting is the probe resolution (the samples per texel stay fixed).
PROBE_METHODS = ("cubemap", "cubemap-horizon")
#: Methods that answer both definitions (their limited rows are labelled "<method> D").
BOTH_DEFINITIONS = ("csm", "csm-vote", "embree")


def method_points(ctx, methods, samples, probe_resolutions, repeats, *, probe_samples=16, csm=None,
                  log=None) -> list:
    """Run ``methods`` at every setting and return their points (:func:`point`).

    Parameters
    ----------
    ctx : pyshadow.bench.methods.Context
    methods : sequence of str
        Names of :data:`pyshadow.bench.methods.METHODS`.
    samples : sequence of int
        Samples per pixel of the sampling methods (the kernel size of ``vtk-ssao``).
    probe_resolutions : sequence of int
        Probe resolutions of the cube-map methods.
    repeats : int
        Timed rounds per setting (medians).
    probe_samples : int, optional
        Samples per texel of the raymarch cube map.
    csm : dict, optional
        :func:`pyshadow.bench.scenes._csm_summary` of the scene's CSMs.
    log : callable, optional

    Returns
    -------
    list of dict
    """
    say = log or (lambda msg: None)
    pts = []
    flat = [m for m in methods if m not in PROBE_METHODS]
    cubes = [m for m in methods if m in PROBE_METHODS]
    for S in (samples if flat else ()):
        say(f"methods: {', '.join(flat)} at {S} samples")
        rows = [r for m in flat for r in method_runs(ctx, m, S, csm=csm)]
        ctx.gbuffer_time = time_rows(ctx, rows, repeats)
        pts += [point(measure_row(ctx, {**r, "visible": None})) for r in rows]
    for R in (probe_resolutions if cubes else ()):
        say(f"methods: {', '.join(cubes)} at probe resolution {R}")
        rows = [r for m in cubes for r in method_runs(ctx, m, probe_samples, probe_resolution=R)]
        ctx.gbuffer_time = time_rows(ctx, rows, repeats)
        pts += [point(measure_row(ctx, {**r, "visible": None})) for r in rows]
    return pts


def point(rec) -> dict:
    """One point of a :func:`pyshadow.bench.methods.measure_row` record: label, setting, time, both errors."""
    st = rec["setting"]
    both = rec["method"] in BOTH_DEFINITIONS
    label = rec["method"] + (" D" if both and rec["definition"] == "limited" else "")
    setting = f"R{st['probe_resolution']}" if "probe_resolution" in st else f"{st['samples']}"
    return {"method": rec["method"], "definition": rec["definition"], "label": label, "setting": setting,
            "samples": st["samples"], "probe_resolution": st.get("probe_resolution"),
            "frame_time": rec["frame_time"]["value"], "precompute_time": rec["precompute_time"]["value"],
            "rmse_limited": rec["ao_rmse_limited"]["value"], "rmse_unlimited": rec["ao_rmse_unlimited"]["value"]}


def _measured(p, key) -> bool:
    """Whether point ``p`` has a frame time and a ``key`` error (a figure not finite is None in the records)."""
    return all(p[k] is not None and math.isfinite(p[k]) for k in ("frame_time", key))


def front(pts, key) -> list:
    """Indices of the Pareto front (no other point both faster and more accurate), by frame time.

    A point with a missing frame time or ``key`` (None or not finite) is never on the front.
    """
    order = sorted((i for i in range(len(pts)) if _measured(pts[i], key)),
                   key=lambda i: (pts[i]["frame_time"], pts[i][key]))
    out, best = [], math.inf
    for i in order:
        if pts[i][key] < best:
            out.append(i)
            best = pts[i][key]
    return out


def winners(pts, key) -> list:
    """For each of :data:`TARGETS`: the fastest point with ``key`` <= target (None if none).

    A point with a missing frame time or ``key`` (None or not finite) wins no target.
    """
    res = []
    for e in TARGETS:
        ok = [p for p in pts if _measured(p, key) and p[key] <= e]
        res.append({"target": e, "winner": min(ok, key=lambda p: p["frame_time"]) if ok else None})
    return res


def winners_text(w, what) -> str:
    """The :func:`winners` answer as lines of text (``what``: 'limited' or 'unlimited')."""
    lines = [f"fastest method within each AO RMSE target ({what} reference):"]
    for r in w:
        p = r["winner"]
        lines.append(f"  RMSE <= {r['target']:<5g}: " + (
            "none of the measured settings" if p is None else
            f"{p['label']}{_setting(p)}, "
            f"{_num(p['frame_time'], '.0f', 1e3)} ms, RMSE {_num(p[f'rmse_{what}'], '.4f')}"))
    return "\n".join(lines)


def _setting(p) -> str:
    if not p["setting"]:
        return ""
    return f" ({p['setting']}{' spp' if p['probe_resolution'] is None else ''})"


def points_markdown(pts) -> str:
    """The points as a markdown table, by label then frame time (a missing one last, "n/a")."""
    lines = ["| method | setting | frame ms | precompute s | RMSE vs limited | RMSE vs unlimited |",
             "|---|---|---|---|---|---|"]
    for p in sorted(pts, key=lambda p: (p["label"], p["frame_time"] is None, p["frame_time"] or 0.0)):
        lines.append(f"| {p['label']} | {p['setting']} | {_num(p['frame_time'], '.0f', 1e3)} | "
                     f"{p['precompute_time'] or 0:.2f} | {_num(p['rmse_limited'], '.4f')} | "
                     f"{_num(p['rmse_unlimited'], '.4f')} |")
    return "\n".join(lines)


#: Colours of the methods' labels: none red or grey, which the sweep's own rows use.
PALETTE = ("C0", "C1", "C2", "C4", "C5", "C6", "C8", "C9", "navy", "olive", "teal", "black")


def plot_points(ax, pts, key):
    """Scatter ``pts`` on ``ax`` (frame ms against ``key``), one marker per label, and their front's line.

    A point with a missing frame time or ``key`` (None or not finite) is not drawn.
    """
    labels = sorted({p["label"] for p in pts})
    marks = dict(zip(labels, "os^vDP*Xph<>"))
    for j, lab in enumerate(labels):
        q = [p for p in pts if p["label"] == lab and _measured(p, key)]
        ax.scatter([1e3 * p["frame_time"] for p in q], [p[key] for p in q], marker=marks[lab],
                   color=PALETTE[j % len(PALETTE)], label=lab, zorder=3)
        for p in q:
            ax.annotate(p["setting"], (1e3 * p["frame_time"], p[key]), fontsize=6, xytext=(3, 3),
                        textcoords="offset points")
    f = front(pts, key)
    ax.plot([1e3 * pts[i]["frame_time"] for i in f], [pts[i][key] for i in f], "k--", lw=0.8,
            label="Pareto front (methods)")


def summary(pts) -> dict:
    """Winners and fronts of ``pts`` for both references (the JSON record)."""
    return {"points": pts,
            "winners_limited": winners(pts, "rmse_limited"), "winners_unlimited": winners(pts, "rmse_unlimited"),
            "front_limited": [pts[i]["label"] + " " + pts[i]["setting"] for i in front(pts, "rmse_limited")],
            "front_unlimited": [pts[i]["label"] + " " + pts[i]["setting"] for i in front(pts, "rmse_unlimited")]}


def sweep_probe_resolutions(resolution: int) -> list:
    """Probe resolutions of the cube-map methods in ``pyshadow-bench --sweep --method``: R/2, R and 2R
    (``--probe-resolution R``, default 128), within the probes' valid range."""
    from ..cubemap.probe import MAX_RESOLUTION, MIN_RESOLUTION

    return sorted({min(MAX_RESOLUTION, max(MIN_RESOLUTION, int(r)))
                   for r in (resolution // 2, resolution, 2 * resolution)})


def check_camera(methods, camera, samples=()) -> None:
    """Refuse, before any work, an image or a sample count that ``vtk-ssao`` among ``methods`` cannot render.

    :func:`pyshadow.viz.ssao_pass.vtk_ssao` renders in a VTK window of the camera's size, with at
    most VTK's largest kernel (1000 samples).

    Raises
    ------
    pyshadow.bench.common.UsageError
        ``vtk-ssao`` in ``methods`` and the camera narrower or lower than 16 pixels, or wider or
        higher than :data:`pyshadow.viz.plotter.MAX_WINDOW_SIDE`, or one of ``samples`` above VTK's
        largest kernel (the run failed at the vtk-ssao row, after the other methods' work).
    """
    from ..viz.plotter import MAX_WINDOW_SIDE
    from .common import UsageError

    if "vtk-ssao" not in methods:
        return
    w, h = camera.width, camera.height
    if not (16 <= w <= MAX_WINDOW_SIDE and 16 <= h <= MAX_WINDOW_SIDE):
        raise UsageError(f"--size {w}x{h}: --method vtk-ssao renders in a VTK window of the image's size, "
                         f"which must be 16..{MAX_WINDOW_SIDE} pixels wide and high")
    if samples:
        from vtkmodules.vtkRenderingOpenGL2 import vtkSSAOPass

        most = int(vtkSSAOPass().GetKernelSizeMaxValue())
        if max(samples) > most:
            raise UsageError(f"--samples {max(samples)}: --method vtk-ssao takes at most {most} samples "
                             "(VTK's largest SSAO kernel)")


def sweep_methods(args, scene, camera, gb, tracer, cache, conv, csm, samples, log) -> dict:
    """The ``methods`` entry of ``sweep.json``: every ``--method`` at the sweep's sample counts.

    Parameters
    ----------
    args : argparse.Namespace
        ``method``, ``ao_distance``, ``samples`` (the cube map's samples per
        texel), ``probe_resolution`` (:func:`sweep_probe_resolutions`),
        ``repeats`` and the sampling options of the sweep.
    scene, camera, gb, tracer, cache, conv :
        The sweep's base scene, camera, covered pixels, open Embree tracer,
        CSM cache and converged unlimited reference.
    csm : dict
        :func:`pyshadow.bench.scenes._csm_summary` of the base configuration.
    samples : sequence of int
        The sample counts of the sweep's grid.
    log : callable

    Returns
    -------
    dict
        ``distance``, ``rule``, ``limited_reference_source``,
        ``probe_resolutions`` and :func:`summary` of the points.

    Raises
    ------
    pyshadow.bench.common.UsageError
        ``vtk-ssao`` asked of an image VTK cannot render (:func:`check_camera`), before any work.
    """
    from .common import _fig
    from .methods import method_context, selected_methods

    methods = selected_methods(args.method)
    check_camera(methods, camera, samples)
    ctx, rule, _, src = method_context(args, scene, camera, gb, tracer, cache, conv, log)
    log(f"sweep: methods {', '.join(methods)} at D = {ctx.D:.4g} ({rule})")
    res = sweep_probe_resolutions(args.probe_resolution)
    pts = method_points(ctx, methods, samples, res, args.repeats, probe_samples=args.samples, csm=csm, log=log)
    return {"distance": _fig(ctx.D, "world", f"D of the distance-limited definition ({rule})"),
            "limited_reference_source": src, "probe_resolutions": res,
            **summary(pts)}

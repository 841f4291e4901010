"""The speed/accuracy sweep: many configurations on one G-buffer, their Pareto front, answers."""
from __future__ import annotations

import dataclasses
import math
import statistics
import time

import numpy as np

from ..cache import CSMCache
from ..embree import EmbreeTracer
from ..sampling import Sampling
from .common import _bar, _fig, _num, environment
from .config import SWEEP_GRIDS, Config
from .measure import GBuffer, _errors, converged_reference, embree_pass, visibility_pass
from .scenes import SceneFactory, _csm_summary

SWEEP_SCHEMA = "pyshadow-bench-sweep/1"


def pareto_front(points) -> list[int]:
    """Indices of the non-dominated (time, error) pairs (both minimised), by time.

    A point is dominated when another is no worse in both and better in one.
    Points with a missing value are never on the front.
    """
    pts = [(i, t, e) for i, (t, e) in enumerate(points)
           if t is not None and e is not None and math.isfinite(t) and math.isfinite(e)]
    front = []
    for i, t, e in pts:
        if not any((t2 <= t and e2 <= e) and (t2 < t or e2 < e) for j, t2, e2 in pts if j != i):
            front.append(i)
    return sorted(front, key=lambda i: points[i][0])


def sweep_configs(base: Config, grid: str) -> list[tuple[Config, str]]:
    """(config, what it varies) rows of a grid, duplicates dropped.

    Raises
    ------
    ValueError
        ``grid`` is not a name of :data:`pyshadow.bench.config.SWEEP_GRIDS`.
    """
    if not isinstance(grid, str) or grid not in SWEEP_GRIDS:
        raise ValueError(f"grid must be one of {', '.join(sorted(SWEEP_GRIDS))}, got {grid!r}")
    rows, seen = [], set()
    for over in SWEEP_GRIDS[grid]:
        cfg = dataclasses.replace(base, **over)
        if cfg in seen:
            continue
        seen.add(cfg)
        varies = "base" if not over else (next(iter(over)) if len(over) == 1 else "combination")
        rows.append((cfg, varies))
    return rows


def run_sweep(args, base: Config, factory: SceneFactory, cache: CSMCache, log) -> dict:
    """The speed/accuracy trade study around ``base`` (grid ``args.sweep_grid``).

    One G-buffer and one converged reference serve every row (the
    G-buffer does not depend on the CSMs; a row whose render sees other
    objects is an error). Pass 1 builds or loads every configuration and
    measures its accuracy; pass 2 times all of them in ``args.repeats``
    rounds interleaved over the rows (medians).

    Parameters
    ----------
    args : argparse.Namespace
        As :func:`pyshadow.bench.single.run_main`, with ``sweep_grid``.
    base : Config
    factory : SceneFactory
    cache : pyshadow.cache.CSMCache
    log : callable

    Returns
    -------
    dict
        The ``sweep.json`` record (schema :data:`SWEEP_SCHEMA`): ``rows``
        (each with figure records and a ``pareto`` flag) and ``pareto``
        (the labels of the front, by frame time), among others; with
        ``args.method``, ``methods``
        (:func:`pyshadow.bench.method_sweep.sweep_methods`).
    """
    t_start = time.perf_counter()
    configs = sweep_configs(base, args.sweep_grid)
    strat, seed, pat = args.strategy, args.seed, args.patterns
    log(f"sweep '{args.sweep_grid}': {len(configs)} configurations around {base.label}, "
        f"{factory.size[0]}x{factory.size[1]}, {args.repeats} timed runs each")
    # the G-buffer does not depend on the CSMs: one G-buffer, one converged reference
    scene0, camera, infos0 = factory(base)
    gb = GBuffer.from_render(scene0.render(camera, sampling=Sampling(1, strat, pat, seed)), camera, scene0)
    if gb.n == 0:
        raise RuntimeError("the camera sees no surface: nothing to measure")
    tracer = EmbreeTracer(scene0, args.threads)
    embree = {}
    rows = []
    try:
        conv, conv_s, conv_src = converged_reference(cache, tracer, scene0, gb, args.reference_samples,
                                                     strat, seed, pat, log)
        # pass 1: build (or load) every configuration, warm its kernels up, measure its accuracy
        entries = []
        bar = _bar(len(configs), "sweep: accuracy", "config")
        try:
            for cfg, varies in configs:
                log(f"  {cfg.label}")
                scene, camera, infos = factory(cfg)
                csm = _csm_summary(infos)
                sampling = Sampling(cfg.samples, strat, pat, seed)
                out = scene.render(camera, sampling=sampling, denoise=cfg.filter, lookup=cfg.lookup)
                if not np.array_equal(out["object_id"], gb.object_id):
                    raise RuntimeError(f"{cfg.label}: the G-buffer differs from the base render")
                raw = scene.ambient_occlusion(gb.points, gb.normals, sampling=sampling, return_bent_normals=True,
                                              indices=gb.sel, surface_ids=gb.ids, lookup=cfg.lookup)[0]
                if cfg.samples not in embree:
                    embree[cfg.samples] = embree_pass(tracer, gb, cfg.samples, strat, seed, pat,
                                                      desc=f"Embree {cfg.samples} spp")
                ident = embree[cfg.samples]
                vis = visibility_pass(scene, gb, cfg.samples, strat, seed, pat, ident["occluded"],
                                      cfg.lookup)
                rmse_c, mae_c = _errors(out["ao"].reshape(-1)[gb.sel], conv)
                rmse_i, _ = _errors(raw, ident["ao"])
                entries.append({"cfg": cfg, "varies": varies, "scene": scene, "camera": camera,
                                "csm": csm, "vis": vis, "rmse_c": rmse_c, "mae_c": mae_c,
                                "rmse_i": rmse_i, "frame": [], "ao": []})
                bar.update(1)
        finally:
            bar.close()
        embree.clear()
        # pass 2: timing, in interleaved rounds over all configurations, so that a slow
        # stretch of a shared machine slows every configuration alike
        log(f"timing: {args.repeats} interleaved rounds over {len(entries)} configurations")
        bar = _bar(args.repeats * len(entries), "sweep: timing", "run")
        try:
            for _ in range(args.repeats):
                for ent in entries:
                    cfg, scene = ent["cfg"], ent["scene"]
                    t0 = time.perf_counter()
                    sampling = Sampling(cfg.samples, strat, pat, seed)
                    scene.render(ent["camera"], sampling=sampling, denoise=cfg.filter, lookup=cfg.lookup)
                    ent["frame"].append(time.perf_counter() - t0)
                    t0 = time.perf_counter()
                    scene.ambient_occlusion(gb.points, gb.normals, sampling=sampling, return_bent_normals=True,
                                            indices=gb.sel, surface_ids=gb.ids, lookup=cfg.lookup)
                    ent["ao"].append(time.perf_counter() - t0)
                    bar.update(1)
        finally:
            bar.close()
        methods = None
        if getattr(args, "method", None):      # every --method on the same pixels and axes
            from .method_sweep import sweep_methods

            methods = sweep_methods(args, scene0, camera, gb, tracer, cache, conv, _csm_summary(infos0),
                                    sorted({cfg.samples for cfg, _ in configs}), log)
    finally:
        tracer.close()
    for ent in entries:
        cfg, csm, vis = ent["cfg"], ent["csm"], ent["vis"]
        frame_time, ao_time = statistics.median(ent["frame"]), statistics.median(ent["ao"])
        nS = gb.n * cfg.samples
        rows.append({
            "label": cfg.label, "varies": ent["varies"], "config": cfg.as_dict(),
            "csm_source": csm["source"],
            "figures": {
                "build_time": _fig(csm["build_seconds"], "s", "CSM build (all casters)"),
                "csm_bytes": _fig(csm["bytes"], "B", "CSM size (all casters)"),
                "csm_ratio": _fig(csm["ratio"], "1", "compression ratio"),
                "frame_time": _fig(frame_time, "s", "Scene.render frame time (median)"),
                "ao_time": _fig(ao_time, "s", "Scene.ambient_occlusion time (median)"),
                "ao_throughput": _fig(nS / ao_time / 1e6, "Msamples/s", "AO samples per second"),
                "visibility_agreement": _fig(vis["agreement"], "fraction",
                                             "per-ray agreement with Embree"),
                "ao_rmse_converged": _fig(ent["rmse_c"], "AO", "AO RMSE vs converged Embree"),
                "ao_mae_converged": _fig(ent["mae_c"], "AO", "AO MAE vs converged Embree"),
                "ao_rmse_identical": _fig(ent["rmse_i"], "AO", "unfiltered AO RMSE vs Embree on "
                                                               "identical rays"),
            }})
    front = pareto_front([(r["figures"]["frame_time"]["value"], r["figures"]["ao_rmse_converged"]["value"])
                          for r in rows])
    for i, r in enumerate(rows):
        r["pareto"] = i in front
    extra = {}
    if methods is not None:         # which wins at each target: the methods and the sweep's CSM rows together
        from .method_sweep import winners

        csm_pts = [{"label": f"csm {r['label']}", "setting": "", "probe_resolution": None,
                    "frame_time": r["figures"]["frame_time"]["value"],
                    "rmse_unlimited": r["figures"]["ao_rmse_converged"]["value"]} for r in rows]
        methods["winners_unlimited"] = winners(methods["points"] + csm_pts, "rmse_unlimited")
        extra["methods"] = methods
    return {
        "schema": SWEEP_SCHEMA,
        "environment": environment(args.threads),
        "scene": factory.description,
        "grid": args.sweep_grid,
        "base": base.as_dict(),
        "image": {"width": factory.size[0], "height": factory.size[1]},
        "strategy": strat, "seed": seed, "patterns": pat, "repeats": args.repeats,
        "reference_samples": args.reference_samples,
        "converged_source": conv_src,
        "converged_time": _fig(conv_s, "s", "converged reference (null when cached)"),
        "rows": rows,
        "pareto": [rows[i]["label"] for i in front],
        "runtime": _fig(time.perf_counter() - t_start, "s", "wall time of the sweep"),
        **extra,
    }


def best_under(sweep: dict, max_error: float):
    """The fastest row (frame time) with AO RMSE vs the converged reference <= max_error."""
    ok = [r for r in sweep["rows"]
          if r["figures"]["ao_rmse_converged"]["value"] is not None
          and r["figures"]["ao_rmse_converged"]["value"] <= max_error]
    return min(ok, key=lambda r: r["figures"]["frame_time"]["value"]) if ok else None


def _answer(sweep: dict, max_error: float) -> dict:
    """The ``max_error`` record of a sweep: ``threshold``, ``label`` and ``row`` (None if none)."""
    row = best_under(sweep, max_error)
    return {"threshold": _fig(max_error, "AO", "largest AO RMSE vs the converged reference allowed"),
            "label": row["label"] if row else None, "row": row}


def _answer_text(ans: dict) -> str:
    """One line answering ``--max-error`` from an :func:`_answer` record."""
    e = ans["threshold"]["value"]
    row = ans["row"]
    if row is None:
        return f"no configuration of the sweep reaches AO RMSE <= {e:g}"
    f = {k: v["value"] for k, v in row["figures"].items()}
    mb = None if f["csm_bytes"] is None else f["csm_bytes"] / 1e6
    return (f"fastest configuration with AO RMSE <= {e:g}: {row['label']} -- "
            f"{_num(f['frame_time'], '.0f', 1e3)} ms/frame, RMSE {_num(f['ao_rmse_converged'], '.4f')}, "
            f"{_num(mb, '.2f')} MB of CSMs, agreement {_num(f['visibility_agreement'], '.2f', 100)} %")

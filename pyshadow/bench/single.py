"""The single benchmark: one configuration rendered, timed and measured against Embree."""
from __future__ import annotations

import statistics
import time
from pathlib import Path

import numpy as np

from ..cache import CSMCache
from ..embree import EmbreeTracer
from ..sampling import Sampling
from .common import UsageError, _bar, _fig, drop_earlier_record, environment
from .config import Config
from .measure import (GBuffer, _errors, by_surface, converged_reference, embree_pass, time_rays,
                      visibility_pass)
from .report import difference_rgb
from .scenes import SceneFactory, _csm_summary

SCHEMA = "pyshadow-bench/1"
#: The single benchmark times pyshadow and Embree on at most this many samples
#: (all covered pixels at the presets; the first pixels of bigger custom runs).
TIMED_SAMPLES = 1 << 25


def run_main(args, cfg: Config, factory: SceneFactory, cache: CSMCache, log, lighting=None) -> dict:
    """The single benchmark of one configuration; writes its images into ``args.out``.

    An earlier ``results.json`` there is removed before the first image is
    written (:func:`pyshadow.bench.common.drop_earlier_record`): the caller
    writes the new one last.

    Renders AO with pyshadow, traces the identical rays with Embree, times
    both in ``args.repeats`` interleaved rounds (medians; AO and Embree on
    the first pixels whose samples fit :data:`TIMED_SAMPLES`), compares them
    ray by ray, and measures the AO against the converged reference.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line with the preset filled in (``out``,
        ``strategy``, ``seed``, ``patterns``, ``threads``, ``repeats``,
        ``reference_samples``, ``mode``).
    cfg : Config
    factory : SceneFactory
    cache : pyshadow.cache.CSMCache
        CSMs and the converged reference.
    log : callable
        ``log(message)`` for progress on stderr.
    lighting : (pyshadow.lighting.Lighting, dict), optional
        ``--sky``'s lighting and its record (:func:`pyshadow.bench.lit.sky_lighting`):
        also render the lit frame with the CSMs and with Embree
        (:func:`pyshadow.bench.lit.lit_pass`), write ``radiance.exr`` and
        ``lit.png``, and add a ``"lighting"`` entry. None: no lighting, no entry.

    Returns
    -------
    dict
        The ``results.json`` record (schema :data:`SCHEMA`): every figure a
        ``{"value", "unit", "label"}`` record (see benchmarks/README.md).
        ``ao.png``, ``reference.png``, ``difference.png``, ``ao.exr``,
        ``reference.exr`` and ``converged.exr`` are written.

    Raises
    ------
    RuntimeError
        When the camera sees no surface.
    pyshadow.bench.common.UsageError
        ``args.light`` cannot be measured on this scene
        (:func:`pyshadow.bench.light.check_light`); raised before any output is written.
    """
    import pyshadow

    t_start = time.perf_counter()
    out_dir = Path(args.out)
    S, strat, seed, pat = cfg.samples, args.strategy, args.seed, args.patterns
    scene, camera, infos = factory(cfg)
    csm = _csm_summary(infos)
    light = getattr(args, "light", None)
    if light is not None:                 # a light the pass cannot measure: before any work or output
        from .light import check_light

        try:
            light = check_light(light, scene, camera)
        except ValueError as e:
            raise UsageError(str(e)) from None

    log(f"rendering {camera.width}x{camera.height}, {S} samples ({strat})")

    sampling = Sampling(S, strat, pat, seed)

    def render():
        return scene.render(camera, sampling=sampling, denoise=cfg.filter, lookup=cfg.lookup)

    out = render()                       # also the warm-up: kernel builds
    gb = GBuffer.from_render(out, camera, scene)
    N = gb.n
    if N == 0:
        raise RuntimeError("the camera sees no surface: nothing to measure")

    def ao_call(sl=slice(None)):         # what Scene.render asks of the AO kernel
        return scene.ambient_occlusion(gb.points[sl], gb.normals[sl], sampling=sampling, return_bent_normals=True,
                                       indices=gb.sel[sl], surface_ids=gb.ids[sl], lookup=cfg.lookup)[0]

    raw = ao_call()
    ao_img = out["ao"]
    tracer = EmbreeTracer(scene, args.threads)
    try:
        log(f"tracing the identical {N * S / 1e6:.1f} M rays with Embree ({tracer.threads} threads)")
        ident = embree_pass(tracer, gb, S, strat, seed, pat, keep_rays=TIMED_SAMPLES,
                            desc=f"Embree {S} spp")
        # timed pixels: all of them unless that is more than TIMED_SAMPLES samples
        K = ident["rays_pixels"]
        sub = slice(0, K)
        log(f"timing: {args.repeats} frames in a row (a render loop), then {args.repeats} interleaved rounds "
            "of render, pyshadow AO and Embree" + ("" if K == N else f" (AO and Embree on the first {K} pixels)"))
        times = {"frame": [], "frame_interleaved": [], "ao": [], "embree": []}
        bar = _bar(2 * args.repeats, "timing", "round")
        try:
            for _ in range(args.repeats):   # the frame rate: frames one after another, as a viewer renders
                t0 = time.perf_counter()
                render()
                times["frame"].append(time.perf_counter() - t0)
                bar.update(1)
            for _ in range(args.repeats):   # interleaved, so machine noise hits all three alike
                t0 = time.perf_counter()
                render()
                times["frame_interleaved"].append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                ao_call(sub)
                times["ao"].append(time.perf_counter() - t0)
                times["embree"].append(time_rays(tracer, ident["rays"]))
                bar.update(1)
        finally:
            bar.close()
        ident["rays"] = None
        frame_time, frame_mixed, ao_time, embree_time = (statistics.median(times[k]) for k in
                                                         ("frame", "frame_interleaved", "ao", "embree"))
        vis = visibility_pass(scene, gb, S, strat, seed, pat, ident["occluded"], cfg.lookup)
        conv, conv_s, conv_src = converged_reference(cache, tracer, scene, gb, args.reference_samples,
                                                     strat, seed, pat, log)
        methods = None
        if getattr(args, "method", None):
            from .methods import methods_pass

            methods = methods_pass(args, scene, camera, gb, tracer, cache, csm, conv, vis, cfg.lookup,
                                   factory.names, log)
    finally:
        tracer.close()

    # primary rays: does the rasterised G-buffer see what Embree's primary rays see?
    from pyshadow import embree

    items, item_ids = scene.draw_items()
    eg = embree.gbuffer(items, camera)["object_id"]
    eg = np.where(eg >= 0, item_ids[np.maximum(eg, 0)] if len(item_ids) else -1, -1)
    prim_agree = float(np.mean(eg == out["object_id"]))

    final = ao_img.reshape(-1)[gb.sel]                 # the image as rendered (filtered if asked)
    rmse_i, mae_i = _errors(raw, ident["ao"])
    rmse_c, mae_c = _errors(final, conv)
    noise_rmse, noise_mae = _errors(ident["ao"], conv)
    consistency = float(np.max(np.abs(vis["ao"] - raw))) if N else 0.0

    # images
    ref_img = gb.image(ident["ao"])
    conv_img = gb.image(conv)
    diff = gb.image(raw - ident["ao"], 0.0)
    rgb, vmax = difference_rgb(diff, gb.object_id != -1)
    files = {}
    drop_earlier_record(out_dir / "results.json")      # the caller writes the new one last
    for name, img in (("ao.png", ao_img), ("reference.png", ref_img), ("difference.png", rgb),
                      ("ao.exr", ao_img.astype(np.float32)), ("reference.exr", ref_img),
                      ("converged.exr", conv_img)):
        pyshadow.write_image(out_dir / name, img)
        files[name] = str(out_dir / name)

    nS = N * S
    figures = {
        "csm_build_time": _fig(csm["build_seconds"], "s", "CSM build (all casters)"),
        "csm_time": _fig(csm["seconds"], "s", "time to obtain the CSMs in this run (build or cache load)"),
        "csm_size": _fig(csm["bytes"] / 1e6, "MB", "CSM size (all casters, 10^6 bytes)"),
        "csm_bytes": _fig(csm["bytes"], "B", "CSM size (all casters)"),
        "csm_ratio": _fig(csm["ratio"], "1", "compression ratio (D*R^2*depth bytes / stored bytes)"),
        "covered_pixels": _fig(N, "px", "pixels covered by a surface"),
        "ao_samples": _fig(nS, "samples", "AO samples per frame (samples x covered pixels)"),
        "frame_time": _fig(frame_time, "s", "Scene.render frame time (median of frames rendered one after "
                                            "another)"),
        "frame_time_interleaved": _fig(frame_mixed, "s", "Scene.render frame time, each frame after the "
                                                         "timing of Embree (median)"),
        "timed_pixels": _fig(K, "px", "pixels whose AO is timed (pyshadow and Embree alike)"),
        "ao_time": _fig(ao_time, "s", "Scene.ambient_occlusion on the timed pixels (median)"),
        "ao_throughput": _fig(K * S / ao_time / 1e6, "Msamples/s", "pyshadow AO samples per second"),
        "frame_throughput": _fig(nS / frame_time / 1e6, "Msamples/s",
                                 "AO samples per second of whole frames"),
        "embree_time": _fig(embree_time, "s", "Embree on the identical rays of the timed pixels "
                                              "(median)"),
        "embree_throughput": _fig(K * S / embree_time / 1e6 if embree_time else None,
                                  "Msamples/s", "Embree AO samples per second (same samples)"),
        "embree_ray_rate": _fig(ident["rays_traced"] / embree_time / 1e6 if embree_time else None,
                                "Mrays/s", "Embree occlusion rays traced per second"),
        "embree_rays": _fig(ident["traced"], "rays", "rays traced by Embree per frame (the others "
                                                     "the ground plane decides analytically)"),
        "embree_threads": _fig(tracer.threads, "threads", "Embree worker threads"),
        "speedup": _fig(embree_time / ao_time if ao_time else None, "x",
                        "pyshadow / Embree throughput on the same samples"),
        "visibility_agreement": _fig(vis["agreement"], "fraction",
                                     "rays on which pyshadow and Embree agree"),
        "false_visible": _fig(vis["false_visible"], "fraction",
                              "rays pyshadow calls unoccluded that Embree finds occluded"),
        "false_occluded": _fig(vis["false_occluded"], "fraction",
                               "rays pyshadow calls occluded that Embree finds unoccluded"),
        "ao_rmse_identical": _fig(rmse_i, "AO", f"AO RMSE vs Embree, identical {S} directions"),
        "ao_mae_identical": _fig(mae_i, "AO", f"AO MAE vs Embree, identical {S} directions"),
        "ao_rmse_converged": _fig(rmse_c, "AO",
                                  f"AO RMSE vs converged Embree ({args.reference_samples} spp)"),
        "ao_mae_converged": _fig(mae_c, "AO", f"AO MAE vs converged Embree ({args.reference_samples} spp)"),
        "reference_noise_rmse": _fig(noise_rmse, "AO", f"Embree {S} spp vs converged: RMSE "
                                                        "(sampling noise alone)"),
        "converged_time": _fig(conv_s, "s", "time of the converged reference (null when cached)"),
        "primary_agreement": _fig(prim_agree, "fraction",
                                  "pixels where raster and Embree primary rays see the same object"),
        "difference_range": _fig(vmax, "AO", "difference.png colour range (+-)"),
    }
    lit_record = None
    if lighting is not None:
        from .lit import lit_pass

        lit_record, lit_files = lit_pass(args, cfg, scene, camera, sampling, lighting[0], lighting[1],
                                         out_dir, log)
        files.update(lit_files)
    result = {
        "schema": SCHEMA,
        "mode": args.mode,
        "environment": environment(args.threads),
        "scene": factory.description,
        "config": {**cfg.as_dict(), "width": camera.width, "height": camera.height,
                   "strategy": strat, "seed": seed, "patterns": pat,
                   "reference_samples": args.reference_samples, "repeats": args.repeats},
        "csm": {"source": csm["source"], "casters": [
            {"name": i["name"], "source": i["source"], "file": i["file"],
             "seconds": _fig(i["seconds"], "s", "time in this run"),
             "build_time": _fig(i["build_seconds"], "s", "original build time"),
             "bytes": _fig(i["stats"]["bytes"], "B", "stored size"),
             "ratio": _fig(i["stats"]["ratio"], "1", "compression ratio"),
             "segments": i["stats"]["segments"], "layer_rule": i["stats"]["layer_rule"]}
            for i in infos]},
        "converged_source": conv_src,
        "figures": figures,
        "surfaces": by_surface(gb, factory.names, S, vis["disagree"], raw, ident["ao"], conv),
        "checks": {"ao_equals_render": bool(cfg.filter is not None or np.array_equal(raw, final)),
                   "ao_vs_visible_max_abs": consistency},
        "files": files,
    }
    if lit_record is not None:
        result["lighting"] = lit_record
    if light is not None:
        from .light import light_pass

        result["light"], light_files = light_pass(args, scene, camera, csm["bytes"], light, out_dir, log)
        files.update(light_files)
    figures["total_time"] = _fig(time.perf_counter() - t_start, "s", "wall time of this run")   # light pass included
    if methods is not None:
        result["methods"] = methods
    return result

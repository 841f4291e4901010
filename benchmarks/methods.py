"""AO methods side by side (issue 23): CSM, CSM vote, cube-map AO (two estimators), SSAO (ours and
pyvista's pass) and Embree.

Three parts, all through :mod:`pyshadow.bench.methods` (the code of
``pyshadow-bench --method``):

1. **The methods table** on the bundled scene (``pyshadow.data.default_scene``)
   and on the two-object scene (bunny + turned fandisk, as in
   ``benchmarks/direct_light.py``): precompute time, memory, frame time,
   agreement with Embree on identical rays, AO RMSE against the converged
   unlimited and distance-limited Embree references, per surface.
2. **The Pareto study** on the bundled scene: every method at a few settings
   (samples 9/16/36/64 for csm, csm-vote, embree, ssao, and the kernel size
   of pyvista's SSAO pass; probe resolution 64/128/256 for both cube-map
   estimators), AO RMSE against frame time, two panels (vs
   the limited and the unlimited reference), written to
   ``benchmarks/out/methods_pareto.png``; the fastest method under each error
   target is printed.
3. **The moving-body study**: 30 frames while the torus circles beside the
   bunny. Each frame's reference is Embree at 64 samples on that frame; the
   CSMs need no update, the cube-map probe is either used stale (placed at
   frame 0) or refreshed every frame (its cost counted), SSAO (ours and
   pyvista's pass) sees only the screen.

Usage::

    python benchmarks/methods.py [--size 320x240] [--samples 16] [--json] [--skip-pareto] [--skip-study]

The frame time of every method is the G-buffer raster plus its AO of the
covered pixels (``pyshadow.bench.methods``).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import REPO, check_counts, check_out_folder, environment, load_mesh  # noqa: E402

OUT = REPO / "benchmarks" / "out"


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def bundled(cache, width, height, maps, resolution):
    """(scene, camera, csm summary, surface names) of the bundled scene, CSMs from the cache."""
    from pyshadow.bench.config import Config
    from pyshadow.bench.scenes import SceneFactory, _csm_summary

    f = SceneFactory(None, (width, height), cache, False)
    scene, cam, infos = f(Config(maps, resolution, 16, 16))
    return scene, cam, _csm_summary(infos), f.names


def two_objects(cache, width, height, maps, resolution):
    """The bunny and the turned fandisk of benchmarks/direct_light.py, CSMs from the cache."""
    import trimesh

    import pyshadow
    from pyshadow.bench.scenes import _csm_summary
    from pyshadow.scene import GROUND_ID

    views = pyshadow.ViewSet.zigzag(*maps)
    bunny, fandisk = load_mesh("stanford-bunny.obj"), load_mesh("fandisk.obj")
    scene = pyshadow.Scene(ground=0.0)
    infos = []
    rot = trimesh.transformations.rotation_matrix(0.9, [0.3, 1.0, 0.2])[:3, :3]
    for name, mesh, T in (("bunny", bunny, pyshadow.stand_on_ground(bunny)),
                          ("fandisk", fandisk, pyshadow.stand_on_ground(fandisk, radius=0.8, position=(1.7, 0.4),
                                                                        rotation=rot))):
        csm, info = cache.csm(name, mesh, views, resolution, 16)
        infos.append(info)
        scene.add(csm, T, mesh=mesh)
    cam = pyshadow.Camera([3.0, 2.6, 4.6], [0.85, 0.5, 0.2], fov_y=45.0, width=width, height=height)
    return scene, cam, _csm_summary(infos), {0: "bunny", 1: "fandisk", GROUND_ID: "ground"}


def context(scene, cam, cache, tracer, ref_samples, D=None):
    """A pyshadow.bench.methods.Context of the camera's pixels, both references from the cache."""
    from pyshadow.bench.measure import converged_reference
    from pyshadow.bench.methods import Context, default_distance, limited_reference
    from pyshadow.gbuffer import render_gbuffer

    D = default_distance(scene) if D is None else D
    g = render_gbuffer(scene.draw_items()[0], cam)
    gb = _gbuffer(scene, cam, g)
    conv, _, _ = converged_reference(cache, tracer, scene, gb, ref_samples, "hammersley", 0, 256, log)
    conv_d, _, _ = limited_reference(cache, tracer, scene, gb, D, ref_samples, "hammersley", 0, 256, log)
    return Context(scene, cam, gb, g, D, "hammersley", 0, 256, tracer, conv, conv_d)


def _gbuffer(scene, cam, g):
    """The bench's GBuffer of the covered pixels of the G-buffer ``g``."""
    from pyshadow.bench.measure import GBuffer
    from pyshadow.render import surface_points

    sp = surface_points(scene, cam, gbuffer=g)
    n = np.asarray(sp.normals, np.float64)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    return GBuffer(cam.height, cam.width, sp.index.astype(np.int64), np.asarray(sp.points, np.float64), n,
                   sp.surface_ids.astype(np.int32), None)


# ---------------------------------------------------------------------------
# 1. the methods table
# ---------------------------------------------------------------------------
def methods_table(name, scene, cam, csm, names, cache, args):
    from pyshadow.bench.methods import METHODS, run_methods
    from pyshadow.embree import EmbreeTracer

    t0 = time.perf_counter()
    with EmbreeTracer(scene, args.threads) as tracer:
        ctx = context(scene, cam, cache, tracer, args.reference_samples)
        rows = run_methods(ctx, METHODS, args.samples, args.repeats, probe_resolution=128, csm=csm, names=names)
    from pyshadow.bench.measure import _errors

    return {"scene": name, "width": cam.width, "height": cam.height, "pixels": ctx.gb.n, "distance": ctx.D,
            "limit_effect_rmse": _errors(ctx.conv, ctx.conv_d)[0], "gbuffer_time": ctx.gbuffer_time,
            "rows": rows, "seconds": time.perf_counter() - t0}


def table_md(t):
    from pyshadow.bench.methods import methods_table as md

    m = {"distance": {"value": t["distance"]}, "limit_effect_rmse": {"value": t["limit_effect_rmse"]},
         "rows": t["rows"]}
    return f"### {t['scene']} ({t['width']}x{t['height']}, {t['pixels']} px)\n" + md(m)


# ---------------------------------------------------------------------------
# 2. Pareto
# ---------------------------------------------------------------------------
def pareto(scene, cam, csm, cache, args):
    from pyshadow.bench.method_sweep import method_points
    from pyshadow.bench.methods import METHODS
    from pyshadow.embree import EmbreeTracer

    with EmbreeTracer(scene, args.threads) as tracer:
        ctx = context(scene, cam, cache, tracer, args.reference_samples)
        return method_points(ctx, METHODS, args.pareto_samples, args.probe_resolutions, args.repeats,
                             probe_samples=args.samples, csm=csm, log=log)


def pareto_png(pts, path, title):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pyshadow._files import atomic_path
    from pyshadow.bench.method_sweep import plot_points

    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    for ax, key, what in ((axes[0], "rmse_limited", "distance-limited"), (axes[1], "rmse_unlimited", "unlimited")):
        plot_points(ax, pts, key)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("frame time, ms (G-buffer + AO; vtk-ssao: its render)")
        ax.set_ylabel(f"AO RMSE vs converged {what} Embree")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=120)
    finally:
        plt.close(fig)


# ---------------------------------------------------------------------------
# 3. moving body
# ---------------------------------------------------------------------------
def torus_path(T0, k, frames, radius=1.4, centre=(2.6, 1.0)):
    """Frame ``k``'s transform of the torus: its start ``T0`` moved to a circle of ``radius`` about
    ``centre`` (x, z) on the ground and turned about its own vertical axis by the same angle."""
    th = 2 * math.pi * k / frames
    c, s = math.cos(th), math.sin(th)
    Ry = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    T = np.eye(4)
    T[:3, :3] = Ry @ T0[:3, :3]
    T[:3, 3] = [centre[0] + radius * c, T0[1, 3], centre[1] + radius * s]
    return T


def moving_study(cache, args):
    import pyshadow
    from pyshadow import visibility
    from pyshadow.bench.measure import _errors, embree_pass
    from pyshadow.bench.methods import default_distance, limited_pass
    from pyshadow.cubemap import CubeMapAO
    from pyshadow.embree import EmbreeTracer
    from pyshadow.gbuffer import render_gbuffer
    from pyshadow.ssao import screen_space_ao
    from pyshadow.viz.ssao_pass import vtk_ssao

    W, H = args.study_size
    scene, cam, _, _ = bundled(cache, W, H, tuple(args.maps), 128)
    D = default_distance(scene)
    S, Sref, R = args.samples, args.study_reference_samples, args.study_resolution
    smp = pyshadow.Sampling(S)
    torus = 1
    T0 = scene.transform(torus)
    scene.set_transform(torus, torus_path(T0, 0, args.frames))
    stale = CubeMapAO(scene, D, resolution=R, sampling=smp)
    fresh = CubeMapAO(scene, D, resolution=R, sampling=smp)
    stale.place(cam)
    fresh.place(cam)
    rows = []
    for k in range(args.frames):
        if k:
            scene.set_transform(torus, torus_path(T0, k, args.frames))
        t0 = time.perf_counter()
        g = render_gbuffer(scene.draw_items()[0], cam)            # the items carry the moved transform
        t_g = time.perf_counter() - t0
        from pyshadow.render import surface_points

        sp = surface_points(scene, cam, gbuffer=g)
        n = np.asarray(sp.normals, np.float64)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        p, ids, sel = np.asarray(sp.points, np.float64), sp.surface_ids, sp.index
        t0 = time.perf_counter()
        tracer = EmbreeTracer(scene, args.threads)        # Embree's BVH follows the moved body
        t_bvh = time.perf_counter() - t0
        try:
            gbk = _gb(cam, sel, p, n, ids)
            ref_d, _ = limited_pass(tracer, gbk, Sref, "hammersley", 0, 256, D, keep=False)
            ref_u = embree_pass(tracer, gbk, Sref, "hammersley", 0, 256, keep=False)["ao"]
            t0 = time.perf_counter()
            emb, _ = limited_pass(tracer, gbk, S, "hammersley", 0, 256, D, keep=False)
            t_emb = time.perf_counter() - t0 + t_bvh
        finally:
            tracer.close()
        res = {"frame": k, "pixels": len(sel), "gbuffer_s": t_g, "torus_pixels": int(np.count_nonzero(ids == torus))}

        c_t, r_t = scene.instances[torus].world_sphere()
        near = (np.linalg.norm(p - c_t, axis=1) < r_t + D) & (ids != torus)    # what the torus shades
        res["near_pixels"] = int(near.sum())

        def timed(name, fn, ref, extra=0.0):
            t0 = time.perf_counter()
            a = np.asarray(fn(), np.float32)
            res[name] = {"seconds": time.perf_counter() - t0 + extra, "rmse": _errors(a, ref)[0],
                         "rmse_near": _errors(a[near], ref[near])[0]}

        timed("csm", lambda: visibility.ambient_occlusion(scene, p, n, backend="csm", sampling=smp, indices=sel,
                                                          surface_ids=ids), ref_u)
        timed("csm D", lambda: visibility.ambient_occlusion(scene, p, n, backend="csm", sampling=smp, indices=sel,
                                                            surface_ids=ids, max_distance=D, straddle="embree"),
              ref_d)
        res["embree D"] = {"seconds": t_emb, "rmse": _errors(emb, ref_d)[0],
                           "rmse_near": _errors(emb[near], ref_d[near])[0]}
        def stale_project():            # stale on purpose: its error is what this row measures
            with warnings.catch_warnings():
                warnings.filterwarnings("ignore", "CubeMapAO.project: the probes are stale", UserWarning)
                return stale.project(cam, gbuffer=g, fallback=1.0, on_empty="fallback")

        pr = stale_project()
        timed("cubemap stale", lambda: stale_project().ao.reshape(-1)[sel], ref_d)
        res["cubemap stale"]["coverage"] = pr.coverage
        t0 = time.perf_counter()
        fresh.refresh()
        t_ref = time.perf_counter() - t0
        timed("cubemap refreshed", lambda: fresh.project(cam, gbuffer=g, fallback=1.0,
                                                         on_empty="fallback").ao.reshape(-1)[sel], ref_d, t_ref)
        res["cubemap refreshed"]["refresh_s"] = t_ref
        timed("ssao", lambda: screen_space_ao(g, cam, D, samples=S, seed=0).reshape(-1)[sel], ref_d)
        vtk = vtk_ssao(scene, cam, D, kernel_size=S)            # pyvista's pass: its own render is its cost
        res["vtk-ssao"] = {"seconds": vtk.render_s, "rmse": _errors(vtk.ao.reshape(-1)[sel], ref_d)[0],
                           "rmse_near": _errors(vtk.ao.reshape(-1)[sel][near], ref_d[near])[0]}
        rows.append(res)
        log(f"frame {k}: " + ", ".join(f"{m} {res[m]['rmse']:.3f}" for m in STUDY))
    scene.set_transform(torus, T0)
    return {"size": [W, H], "frames": args.frames, "samples": S, "reference_samples": Sref, "distance": D,
            "probe_resolution": R, "rows": rows}


STUDY = ("csm", "csm D", "embree D", "cubemap stale", "cubemap refreshed", "ssao", "vtk-ssao")


def _gb(cam, sel, p, n, ids):
    from pyshadow.bench.measure import GBuffer

    return GBuffer(cam.height, cam.width, np.asarray(sel, np.int64), p, n, np.asarray(ids, np.int32), None)


def study_md(st):
    lines = [f"moving torus: {st['frames']} frames, {st['size'][0]}x{st['size'][1]}, {st['samples']} spp, "
             f"D = {st['distance']:.3g}, reference Embree {st['reference_samples']} spp each frame "
             f"(csm: unlimited reference; the others: limited), probe R = {st['probe_resolution']}",
             "| method | RMSE frame 0 | RMSE median | RMSE max | RMSE last | cost per frame ms (median) |",
             "|---|---|---|---|---|---|"]
    for m in STUDY:
        e = [r[m]["rmse"] for r in st["rows"]]
        c = [r[m]["seconds"] for r in st["rows"]]
        lines.append(f"| {m} | {e[0]:.4f} | {np.median(e):.4f} | {max(e):.4f} | {e[-1]:.4f} | "
                     f"{1e3 * np.median(c):.0f} |")
    most = max(r["torus_pixels"] for r in st["rows"])
    off = [r for r in st["rows"] if r["torus_pixels"] < 0.1 * most]
    on = [r for r in st["rows"] if r["torus_pixels"] >= 0.1 * most]
    lines.append(f"RMSE on the pixels within D of the torus's bounding sphere (not the torus), median over the "
                 f"frames with the torus on screen ({len(on)}) / mostly off screen (< 10 % of its largest pixel "
                 f"count; {len(off)}):")
    for m in STUDY:
        lines.append(f"  {m}: {_med(on, m, 'rmse_near')} / {_med(off, m, 'rmse_near')}")
    lines.append("per frame (every 3rd) -- frame: torus px, RMSE stale / refreshed cube map / ssao: " + "; ".join(
        f"{r['frame']}: {r['torus_pixels']} px, {r['cubemap stale']['rmse']:.3f} / "
        f"{r['cubemap refreshed']['rmse']:.3f} / {r['ssao']['rmse']:.3f}" for r in st["rows"][::3]))
    return "\n".join(lines)


def _med(rows, m, key="rmse"):
    v = [r[m][key] for r in rows if r[m][key] is not None and np.isfinite(r[m][key])]
    return f"{np.median(v):.4f}" if v else "n/a"


def _size(text):
    w, h = text.lower().split("x")
    return int(w), int(h)


def main(argv=None):
    import os

    from pyshadow._files import write_bytes_atomic
    from pyshadow.bench.method_sweep import points_markdown, summary, winners_text
    from pyshadow.cache import CSMCache, default_cache_dir

    ap = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))
    ap.add_argument("--size", type=_size, default=(320, 240), help="image of the tables and the Pareto study")
    ap.add_argument("--samples", type=int, default=16, help="samples per pixel of the tables and the study")
    ap.add_argument("--reference-samples", type=int, default=256, help="converged references' samples")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--maps", type=_size, default=(32, 64), help="CSM zigzag grid (default 32x64, at 128^2)")
    ap.add_argument("--pareto-samples", type=int, nargs="+", default=[9, 16, 36, 64])
    ap.add_argument("--probe-resolutions", type=int, nargs="+", default=[64, 128, 256])
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--study-size", type=_size, default=(240, 180))
    ap.add_argument("--study-resolution", type=int, default=64, help="probe resolution of the study")
    ap.add_argument("--study-reference-samples", type=int, default=64)
    ap.add_argument("--skip-tables", action="store_true")
    ap.add_argument("--skip-pareto", action="store_true")
    ap.add_argument("--skip-study", action="store_true")
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument("--json", action="store_true", help="print everything as JSON on stdout")
    args = ap.parse_args(argv)
    check_counts(ap, args, "samples", "reference_samples", "study_reference_samples", most=4096)
    check_counts(ap, args, "repeats", "frames", "threads")
    check_counts(ap, args, "study_resolution", least=16, most=2048)
    if not all(1 <= k <= 4096 for k in args.pareto_samples):
        ap.error(f"--pareto-samples must each be in 1..4096, got {args.pareto_samples}")
    if not all(16 <= r <= 2048 for r in args.probe_resolutions):
        ap.error(f"--probe-resolutions must each be in 16..2048 (pyshadow.CubeProbe), got {args.probe_resolutions}")
    for skip, options in (("--skip-pareto", ("pareto_samples", "probe_resolutions")),
                          ("--skip-study", ("frames", "study_size", "study_resolution", "study_reference_samples"))):
        given = [f"--{o.replace('_', '-')}" for o in options if getattr(args, o) != ap.get_default(o)]
        if getattr(args, skip[2:].replace("-", "_")) and given:
            ap.error(f"{', '.join(given)}: {skip} skips the part that takes {'it' if len(given) == 1 else 'them'}")
    check_out_folder(ap, "--out", args.out)
    cache = CSMCache(default_cache_dir(), lambda m: None)
    W, H = args.size
    t_all = time.perf_counter()
    result = {"environment": environment(), "tables": [], "pareto": None, "study": None}
    text = []
    if not args.skip_tables:
        for name, make in (("bundled scene", bundled), ("two-object scene", two_objects)):
            log(f"methods table: {name}")
            scene, cam, csm, names = make(cache, W, H, tuple(args.maps), 128)
            t = methods_table(name, scene, cam, csm, names, cache, args)
            result["tables"].append(t)
            text.append(table_md(t))
    if not args.skip_pareto:
        scene, cam, csm, _ = bundled(cache, W, H, tuple(args.maps), 128)
        pts = pareto(scene, cam, csm, cache, args)
        png = args.out / "methods_pareto.png"
        pareto_png(pts, png, f"AO methods on the bundled scene, {W}x{H}, {environment()['device']}")
        result["pareto"] = {**summary(pts), "png": str(png)}
        lines = ["### Pareto points (bundled scene)", points_markdown(pts)]
        text += ["\n".join(lines), winners_text(result["pareto"]["winners_limited"], "limited"),
                 winners_text(result["pareto"]["winners_unlimited"], "unlimited"), f"plot: {png}"]
    if not args.skip_study:
        st = moving_study(cache, args)
        result["study"] = st
        text.append(study_md(st))
    result["seconds"] = time.perf_counter() - t_all
    text.append(f"total {result['seconds']:.0f} s")
    body = "\n\n".join(text)
    if args.json:
        print(json.dumps(result, indent=1, default=float))
        print(body, file=sys.stderr)
    else:
        print(body)
    args.out.mkdir(parents=True, exist_ok=True)
    write_bytes_atomic(args.out / "methods.json", json.dumps(result, indent=1, default=float).encode())
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Benchmark: cube-map AO (seed 002) against distance-limited Embree, closed forms and its own cost.

Two scenes: the bundled scene (``pyshadow.data.default_scene``: bunny and
torus as casters, two receiver walls, ground plane) and the analytic floor in
front of a wall (ground y = 0 and a 40 x 10 x 0.5 box wall with its front face
at z = 0, a caster; AO within D of a floor point at distance a from the wall,
and of a wall point at height a, is ``1 - (acos h - h sqrt(1 - h^2)) / pi``,
``h = a / D``). One probe at the camera's eye (the thesis places cube maps at
the camera).

(a) per-ray agreement of the raymarch estimator with Embree on identical rays
    (same points -- the camera's pixels the probe sees --, same directions --
    pyshadow's samples, pattern = pixel index --, same D), at probe
    resolutions 128, 256, 512; disagreements split into rays through space
    the probe does not see (``unseen``), rays within the probe's resolution
    of an edge (``ambiguous``) and the rest; and a sweep of the thickness rule.
(b) AO RMSE of the projected per-texel AO (horizon and raymarch estimators,
    nearest lookup, and after the seed's 7x7 filter) against Embree AO with
    ``max_distance=D`` and unlimited (256 samples each), on the covered
    pixels, overall and per surface; on the wall scene also against the
    closed form.
(c) cost: probe render time, per-texel AO time, memory, projection time
    per frame (nearest / bilinear), the 7x7 filter; and the coverage rule
    (a probe placed when under 75 % of an 8x8 grid is shaded) along a camera orbit.

    python benchmarks/cubemap.py [--distance 1.0] [--resolutions 128 256 512]
                                 [--ao-resolutions 64 128] [--json] [--out FILE]
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np
import trimesh

import pyshadow
from pyshadow.cubemap import CubeMapAO, raymarch_visible, seed_box_filter
from pyshadow.cubemap.analysis import ambiguous_rays, unseen_rays
from _common import check_counts, check_out_file, check_positive, emit, environment, median_time


def wall_scene(width, height):
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    wall = trimesh.creation.box((40.0, 10.0, 0.5))
    wall.apply_translation([0.0, 5.0, -0.25])
    scene.add(wall)
    cam = pyshadow.Camera([0.3, 1.2, 2.6], [0.0, 0.3, 0.0], fov_y=60.0, width=width, height=height)
    return scene, cam


def closed_form(points, normals, D):
    """Floor-in-front-of-wall AO within D: the distance to the other plane is z (floor) or y (wall)."""
    a = np.where(normals[:, 1] > 0.5, points[:, 2], points[:, 1])
    h = np.clip(a / D, 0.0, 1.0)
    return 1.0 - (np.arccos(h) - h * np.sqrt(1.0 - h * h)) / np.pi


def surfaces(scene_name, sp):
    ids = sp.surface_ids
    if scene_name == "wall":
        return {"floor": ids == pyshadow.scene.GROUND_ID, "wall": ids == 0}
    return {"bunny": ids == 0, "torus": ids == 1, "walls": (ids == 2) | (ids == 3),
            "ground": ids == pyshadow.scene.GROUND_ID}


def embree_ao(scene, sp, D, samples):
    n = sp.normals.astype(np.float64)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    dirs = pyshadow.Sampling(samples).directions(n, indices=sp.index).astype(np.float64)
    P = np.repeat(sp.points, samples, axis=0)
    out = {}
    for key, dist in (("limited", D), ("unlimited", None)):
        vis = pyshadow.embree.visible(scene, P, dirs.reshape(-1, 3), max_distance=dist)
        out[key] = vis.reshape(-1, samples).mean(1)
    return out


def rmse(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2))) if len(a) else float("nan")


def agreement(name, scene, cam, D, resolutions, n_points, samples, rng):
    """(a): per-ray agreement on the camera's pixels the probe sees."""
    sp = pyshadow.render.surface_points(scene, cam)
    rows = []
    for R in resolutions:
        maps = CubeMapAO(scene, D, resolution=R, estimator=None)     # the probe only
        maps.add_probe(cam.eye)
        probe, t_probe = maps.probes[0], maps.timings[0]["render_s"]
        n = sp.normals.astype(np.float64)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        seen = maps.assign(sp.points, n, sp.surface_ids)[0] >= 0
        idx = np.flatnonzero(seen)
        sel = rng.choice(idx, min(n_points, len(idx)), replace=False)
        dirs = pyshadow.Sampling(samples).directions(n[sel], indices=sp.index[sel]).astype(np.float64)
        P = np.repeat(sp.points[sel], samples, axis=0)
        N = np.repeat(n[sel], samples, axis=0)
        W = dirs.reshape(-1, 3)
        ref = pyshadow.embree.visible(scene, P, W, max_distance=D)
        raymarch_visible(probe, P[:10], W[:10], D)                  # build the kernel
        t0 = time.perf_counter()
        got = raymarch_visible(probe, P, W, D)
        t_march = time.perf_counter() - t0
        unseen = unseen_rays(scene, probe, P, W, D)
        amb = ambiguous_rays(scene, probe, P, N, W, D, ref) & ~unseen
        dis = got != ref
        rest = ~unseen & ~amb
        rows.append({
            "scene": name, "resolution": R, "rays": int(len(P)), "points": int(len(sel)),
            "pixels_seen": float(seen.mean()), "agreement": float(1 - dis.mean()),
            "open_embree": float(ref.mean()), "open_probe": float(got.mean()),
            "false_open": float((got & ~ref).mean()), "false_occluded": float((~got & ref).mean()),
            "unseen_share": float(unseen.mean()),
            "agreement_unseen": float(1 - dis[unseen].mean()) if unseen.any() else 1.0,
            "ambiguous_share": float(amb.mean()),
            "agreement_ambiguous": float(1 - dis[amb].mean()) if amb.any() else 1.0,
            "agreement_resolved": float(1 - dis[rest].mean()), "disagree_resolved": int(dis[rest].sum()),
            "probe_render_s": t_probe, "march_s": t_march, "march_mrays_per_s": len(P) / t_march / 1e6,
        })
        if R == resolutions[len(resolutions) // 2]:
            sweep = []
            for frac in (0.0, 0.1, 0.25, 0.5, 1.0):
                g = raymarch_visible(probe, P, W, D, thickness=frac * D)
                sweep.append({"scene": name, "resolution": R, "thickness_over_D": frac,
                              "agreement": float((g == ref).mean()), "false_open": float((g & ~ref).mean()),
                              "false_occluded": float((~g & ref).mean())})
            rows[-1]["thickness_sweep"] = sweep
    return rows


def ao_errors(name, scene, cam, D, resolutions, ao_samples, ref_samples):
    """(b) and (c): projected AO against the references, with the cost of each step."""
    sp = pyshadow.render.surface_points(scene, cam)
    refs = embree_ao(scene, sp, D, ref_samples)
    noise = embree_ao(scene, sp, D, ao_samples)["limited"]
    exact = closed_form(sp.points, sp.normals, D) if name == "wall" else None
    parts = surfaces(name, sp)
    rows = []
    for R in resolutions:
        for est in ("raymarch", "horizon"):
            maps = CubeMapAO(scene, D, resolution=R, estimator=est, sampling=pyshadow.Sampling(ao_samples))
            maps.add_probe(cam.eye)
            t_near, _ = median_time(lambda: maps.project(cam), repeats=3)
            t_bil, _ = median_time(lambda: maps.project(cam, lookup="bilinear"), repeats=3)
            pr = maps.project(cam)
            t_filt, _ = median_time(lambda: seed_box_filter(pr.ao, pr.depth, pr.normal), repeats=3)
            filt = seed_box_filter(pr.ao, pr.depth, pr.normal).reshape(-1)[sp.index]
            ao = pr.ao.reshape(-1)[sp.index]
            cov = np.isfinite(ao)
            row = {"scene": name, "resolution": R, "estimator": est, "coverage": float(cov.mean()),
                   "rmse_limited": rmse(ao[cov], refs["limited"][cov]),
                   "bias_limited": float(np.mean(ao[cov] - refs["limited"][cov])),
                   "rmse_unlimited": rmse(ao[cov], refs["unlimited"][cov]),
                   "rmse_limited_filtered": rmse(filt[cov], refs["limited"][cov]),
                   "per_surface_rmse_limited": {k: rmse(ao[cov & m], refs["limited"][cov & m])
                                                for k, m in parts.items()},
                   "render_s": maps.timings[0]["render_s"], "texel_ao_s": maps.timings[0]["ao_s"],
                   "probe_bytes": maps.probes[0].nbytes, "ao_map_bytes": maps.ao_maps[0].nbytes,
                   "thesis_runtime_bytes": 7 * 6 * R * R,
                   "project_nearest_s": t_near, "project_bilinear_s": t_bil, "filter7x7_s": t_filt,
                   "pixels": int(len(sp.index))}
            if exact is not None:
                row["rmse_closed_form"] = rmse(ao[cov], exact[cov])
                row["bias_closed_form"] = float(np.mean(ao[cov] - exact[cov]))
                row["per_surface_bias_closed_form"] = {k: float(np.mean(ao[cov & m] - exact[cov & m]))
                                                       for k, m in parts.items()}
                # floor pixels by their distance a from the wall (the "too open in front of a wall")
                a = sp.points[:, 2]
                row["floor_bias_by_distance"] = {
                    f"{lo:.2f}-{hi:.2f}": float(np.mean(ao[m] - exact[m])) for lo, hi in
                    ((0.0, 0.1), (0.1, 0.25), (0.25, 0.5), (0.5, 1.0))
                    for m in [cov & parts["floor"] & (a >= lo) & (a < hi) & (np.abs(sp.points[:, 0]) < 1.0)]}
            rows.append(row)
    refrow = {"scene": name, "rmse_limited_vs_unlimited": rmse(refs["limited"], refs["unlimited"]),
              f"rmse_embree_{ao_samples}_samples_vs_{ref_samples}": rmse(noise, refs["limited"])}
    if exact is not None:
        refrow["rmse_embree_limited_vs_closed_form"] = rmse(refs["limited"], exact)
    return rows, refrow


def placement(scene, D, width, height, frames):
    """The coverage rule along an orbit of the camera around the bundled scene."""
    maps = CubeMapAO(scene, D, resolution=64, estimator="horizon")
    out = []
    for k in range(frames):
        a = 2 * np.pi * k / frames
        cam = pyshadow.Camera([0.8 + 4.5 * np.sin(a), 2.0, 0.2 + 4.5 * np.cos(a)], [0.8, 0.4, 0.2],
                              width=width, height=height)
        try:
            placed = maps.place(cam)
        except ValueError as exc:            # an eye inside a body or below ground: no probe there
            placed = f"refused: {exc}"
        pr = maps.project(cam, on_empty="fallback")
        out.append({"frame": k, "placed": placed, "probes": len(maps.probes), "coverage": pr.coverage})
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--distance", type=float, default=1.0, help="AO distance limit D, world units")
    ap.add_argument("--resolutions", type=int, nargs="+", default=[128, 256, 512])
    ap.add_argument("--ao-resolutions", type=int, nargs="+", default=[64, 128])
    ap.add_argument("--points", type=int, default=4000, help="pixels per agreement run")
    ap.add_argument("--samples", type=int, default=16, help="directions per pixel in (a)")
    ap.add_argument("--ao-samples", type=int, default=36, help="directions per texel of the raymarch AO")
    ap.add_argument("--ref-samples", type=int, default=256)
    ap.add_argument("--width", type=int, default=160)
    ap.add_argument("--height", type=int, default=120)
    ap.add_argument("--orbit", type=int, default=8, help="camera positions of the placement run")
    ap.add_argument("--json", action="store_true", help="print the result as JSON")
    ap.add_argument("--out", help="also write the JSON result to this file")
    args = ap.parse_args(argv)
    check_positive(ap, args, "distance")
    check_counts(ap, args, "points", "samples", "ao_samples", "ref_samples", "width", "height", "orbit")
    for option, values in (("--resolutions", args.resolutions), ("--ao-resolutions", args.ao_resolutions)):
        if not all(16 <= r <= 2048 for r in values):
            ap.error(f"{option} must each be in 16..2048 (pyshadow.CubeProbe), got {values}")
    if args.out:
        check_out_file(ap, "--out", args.out)
    t_start = time.perf_counter()
    rng = np.random.default_rng(0)
    D = args.distance
    bundled, cam = pyshadow.data.default_scene(views=pyshadow.ViewSet.zigzag(4, 8), resolution=16,
                                               width=args.width, height=args.height)
    wall, wcam = wall_scene(args.width, args.height)
    result = {"environment": environment(), "distance": D, "agreement": [], "ao": [], "references": []}
    for name, sc, cm in (("bundled", bundled, cam), ("wall", wall, wcam)):
        result["agreement"] += agreement(name, sc, cm, D, args.resolutions, args.points, args.samples, rng)
        rows, refrow = ao_errors(name, sc, cm, D, args.ao_resolutions, args.ao_samples, args.ref_samples)
        result["ao"] += rows
        result["references"].append(refrow)
    result["placement"] = placement(bundled, D, args.width, args.height, args.orbit)
    result["runtime_s"] = time.perf_counter() - t_start
    if args.out:
        from pyshadow._files import write_bytes_atomic

        write_bytes_atomic(args.out, json.dumps(result, indent=2).encode())
    if args.json:
        emit(result, True)
        return result
    print(f"device: {result['environment']['device']}   D = {D}")
    print("(a) raymarch vs Embree(max_distance=D), identical rays")
    print(f"{'scene':8} {'R':>4} {'rays':>7} {'agree':>7} {'f.open':>7} {'f.occ':>7} {'unseen':>7} "
          f"{'ag.uns':>7} {'ambig':>7} {'ag.amb':>7} {'ag.res':>8} {'Mray/s':>7}")
    for r in result["agreement"]:
        print(f"{r['scene']:8} {r['resolution']:4d} {r['rays']:7d} {r['agreement']:7.4f} {r['false_open']:7.4f} "
              f"{r['false_occluded']:7.4f} {r['unseen_share']:7.4f} {r['agreement_unseen']:7.4f} "
              f"{r['ambiguous_share']:7.4f} {r['agreement_ambiguous']:7.4f} {r['agreement_resolved']:8.5f} "
              f"{r['march_mrays_per_s']:7.2f}")
        for s in r.get("thickness_sweep", []):
            print(f"    thickness {s['thickness_over_D']:.2f} D: agree {s['agreement']:.4f} "
                  f"false open {s['false_open']:.4f} false occluded {s['false_occluded']:.4f}")
    print("(b, c) projected AO (one probe at the eye), RMSE over covered pixels")
    for r in result["ao"]:
        extra = ""
        if "rmse_closed_form" in r:
            extra = f" closed {r['rmse_closed_form']:.4f} (bias {r['bias_closed_form']:+.4f})"
        print(f"{r['scene']:8} R={r['resolution']:4d} {r['estimator']:8} cov {r['coverage']:.3f} "
              f"D-lim {r['rmse_limited']:.4f} (bias {r['bias_limited']:+.4f}) filt {r['rmse_limited_filtered']:.4f} "
              f"unlim {r['rmse_unlimited']:.4f}{extra}")
        print(f"{'':8} per surface {', '.join(f'{k} {v:.4f}' for k, v in r['per_surface_rmse_limited'].items())}")
        if "floor_bias_by_distance" in r:
            print(f"{'':8} floor bias vs closed form by distance from the wall: "
                  f"{', '.join(f'{k}: {v:+.3f}' for k, v in r['floor_bias_by_distance'].items())}")
        print(f"{'':8} render {r['render_s']:.2f} s, texel AO {r['texel_ao_s']:.2f} s, "
              f"probe {r['probe_bytes'] / 1e6:.1f} MB"
              f" + AO {r['ao_map_bytes'] / 1e6:.1f} MB, project {r['project_nearest_s'] * 1e3:.0f} ms"
              f" (bilinear {r['project_bilinear_s'] * 1e3:.0f} ms), 7x7 filter {r['filter7x7_s'] * 1e3:.0f} ms")
    for r in result["references"]:
        print("references:", ", ".join(f"{k} {v:.4f}" if isinstance(v, float) else f"{k} {v}" for k, v in r.items()))
    print("placement along an orbit:", [(p["probes"], round(p["coverage"], 3)) for p in result["placement"]])
    print(f"runtime {result['runtime_s']:.0f} s")
    return result


if __name__ == "__main__":
    main()

"""Filtering study: noisy AO images of the bunny on the ground, filtered.

Renders the Stanford bunny standing on a ground plane with hammersley
sampling at 16 and 36 samples per pixel, and a converged Embree reference
(1024 samples by default) on the same G-buffer. For the unfiltered image and
each filter of pyshadow.filters (bilateral, separable bilateral, the seed's
7x7 edge-aware box) prints RMSE against the reference over all surface
pixels, the RMSE within 2 pixels of a depth discontinuity (relative depth
jump above 5 %, or a surface next to the background), and the filter's
throughput in Mpixel/s (median of several runs). Then AO computed at 1/2 and
1/4 resolution and brought back with joint bilateral upsampling: its time and its
RMSE against the converged reference, beside the full-resolution image's.

    python benchmarks/filtering.py [--width 640 --height 480] [--reference-samples 1024] [--json]
"""
from __future__ import annotations

import argparse
import time

import numpy as np
from scipy import ndimage

import pyshadow
from pyshadow import Sampling, embree, filters
from _common import check_counts, emit, environment, load_mesh, median_time


def edge_mask(depth, width=2, jump=0.05):
    """Surface pixels within ``width`` pixels of a depth discontinuity."""
    surf = np.isfinite(depth)
    z = np.where(surf, depth, 0.0)
    edge = np.zeros_like(surf)
    for dy, dx in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = z[max(dy, 0):, max(dx, 0):z.shape[1] + min(dx, 0)]
        b = z[: z.shape[0] - dy, max(-dx, 0): z.shape[1] - max(dx, 0)]
        sa = surf[max(dy, 0):, max(dx, 0):z.shape[1] + min(dx, 0)]
        sb = surf[: z.shape[0] - dy, max(-dx, 0): z.shape[1] - max(dx, 0)]
        big = (sa != sb) | (sa & sb & (np.abs(a - b) > jump * np.minimum(a, b)))
        edge[max(dy, 0):, max(dx, 0):z.shape[1] + min(dx, 0)] |= big
        edge[: z.shape[0] - dy, max(-dx, 0): z.shape[1] - max(dx, 0)] |= big
    return ndimage.binary_dilation(edge, iterations=width) & surf


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--reference-samples", type=int, default=1024)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    check_counts(ap, args, "repeats", "width", "height", "reference_samples")

    bunny = load_mesh("stanford-bunny.obj")
    T = pyshadow.stand_on_ground(bunny)
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(64, 128), resolution=128)
    scene.add(bunny, T)
    cam = pyshadow.Camera([1.6, 1.5, 3.2], [0.0, 0.55, 0.0], width=args.width, height=args.height)
    g = scene.render(cam, sampling=Sampling(1))
    depth, normal = g.depth, g.normal
    surf = np.isfinite(depth)
    edges = edge_mask(depth)
    t0 = time.perf_counter()
    conv = embree.render(scene, cam, sampling=Sampling(args.reference_samples, seed=12345)).ao
    ref_s = time.perf_counter() - t0

    def rmse(img, mask=surf):
        return float(np.sqrt(np.mean((img[mask] - conv[mask]) ** 2)))

    rows = []
    for samples in (16, 36):
        ao = scene.render(cam, sampling=Sampling(samples)).ao
        variants = {
            "none": (lambda a: a),
            "bilateral": (lambda a: filters.bilateral(a, depth, normal)),
            "separable": (lambda a: filters.bilateral(a, depth, normal, separable=True)),
            "box 7x7": (lambda a: filters.edge_aware_box(a, depth, normal)),
        }
        for name, fn in variants.items():
            out = fn(ao)
            sec = median_time(lambda: fn(ao), args.repeats)[0] if name != "none" else 0.0
            rows.append({"samples": samples, "filter": name, "rmse": rmse(out), "edge_rmse": rmse(out, edges),
                         "Mpixel_per_s": (depth.size / sec / 1e6) if sec else None})

    # AO at lower resolution, upsampled with the full-resolution G-buffer
    full_s, _ = median_time(lambda: scene.render(cam, sampling=Sampling(36)), max(1, args.repeats // 2))
    full = scene.render(cam, sampling=Sampling(36)).ao
    up = []
    for s in (2, 4):
        sec, _ = median_time(lambda: scene.render(cam, sampling=Sampling(36), ao_scale=s), max(1, args.repeats // 2))
        img = scene.render(cam, sampling=Sampling(36), ao_scale=s).ao
        up.append({"ao_scale": s, "render_s": sec, "full_render_s": full_s, "rmse": rmse(img),
                   "edge_rmse": rmse(img, edges), "full_rmse": rmse(full), "full_edge_rmse": rmse(full, edges)})
    result = {"benchmark": "filtering", **environment(), "width": args.width, "height": args.height,
              "surface_pixels": int(surf.sum()), "edge_pixels": int(edges.sum()),
              "reference_samples": args.reference_samples, "reference_seconds": ref_s,
              "filters": rows, "upsampling": up}
    if args.json:
        emit(result, True)
        return
    print(f"device: {result['device']}; {args.width}x{args.height}, {surf.sum()} surface pixels, "
          f"{edges.sum()} within 2 px of a depth edge; reference: Embree {args.reference_samples} samples "
          f"({ref_s:.0f} s)")
    print(f"{'samples':>7} {'filter':>10} {'RMSE':>8} {'edge RMSE':>10} {'Mpixel/s':>9}")
    for r_ in rows:
        mp = f"{r_['Mpixel_per_s']:.2f}" if r_["Mpixel_per_s"] else "-"
        print(f"{r_['samples']:>7} {r_['filter']:>10} {r_['rmse']:>8.4f} {r_['edge_rmse']:>10.4f} {mp:>9}")
    for s16 in (16, 36):
        base = next(x for x in rows if x["samples"] == s16 and x["filter"] == "none")
        bil = next(x for x in rows if x["samples"] == s16 and x["filter"] == "bilateral")
        print(f"  {s16} samples: bilateral cuts RMSE {base['rmse'] / bil['rmse']:.2f}x; edge RMSE "
              f"{(bil['edge_rmse'] / base['edge_rmse'] - 1) * 100:+.1f}% vs unfiltered")
    for u in up:
        print(f"AO at 1/{u['ao_scale']} + upsampling: {u['render_s']:.3f} s vs {u['full_render_s']:.3f} s full; "
              f"RMSE {u['rmse']:.4f} (edge {u['edge_rmse']:.4f}) vs full {u['full_rmse']:.4f} "
              f"(edge {u['full_edge_rmse']:.4f})")


if __name__ == "__main__":
    main()

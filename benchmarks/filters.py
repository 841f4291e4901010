"""Benchmark: the edge-aware AO filters on a synthetic 640x480 G-buffer.

Times each public filter of pyshadow.filters end to end (validation, upload,
kernel, read-back) on a synthetic G-buffer -- a tilted floor, a box in front
of it, a spherical bump, 3 % background, noisy AO -- and reports the median
of several runs in output Mpixel/s. The first call of each filter (which
builds its kernel) is a warm-up and is not timed.

    python benchmarks/filters.py [--width 640 --height 480] [--repeats 5] [--json]
"""
from __future__ import annotations

import argparse

import numpy as np

import pyshadow.filters as F
from _common import check_counts, emit, environment, median_time


def synthetic_gbuffer(height: int, width: int, seed: int = 1):
    """(ao, depth, normal) of a small analytic scene, float32."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    u, v = x / width, y / height
    depth = 10.0 + 3.0 * u - 2.0 * v
    normal = np.broadcast_to([0.0, 0.8, 0.6], (height, width, 3)).copy()
    box = (v > 0.2) & (v < 0.6) & (u > 0.15) & (u < 0.45)
    depth[box] = 6.0 + u[box]
    normal[box] = [0.0, 0.0, 1.0]
    r2 = ((u - 0.7) / 0.15) ** 2 + ((v - 0.6) / 0.2) ** 2
    bump = r2 < 1.0
    h = np.sqrt(np.clip(1.0 - r2, 0.0, None))
    depth[bump] = 8.0 - h[bump]
    n = np.stack([(u - 0.7) / 0.15, (v - 0.6) / 0.2, h + 1e-3], -1)
    normal[bump] = (n / np.linalg.norm(n, axis=-1, keepdims=True))[bump]
    bg = rng.random((height, width)) < 0.03
    depth[bg] = np.inf
    normal[bg] = 0.0
    ao = np.clip(0.6 + 0.25 * np.sin(8 * u) * np.cos(6 * v) + rng.uniform(-0.2, 0.2, u.shape), 0, 1)
    return ao.astype(np.float32), depth.astype(np.float32), normal.astype(np.float32)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", action="store_true", help="print the result as JSON")
    args = ap.parse_args(argv)
    check_counts(ap, args, "repeats", "width", "height")

    ao, depth, normal = synthetic_gbuffer(args.height, args.width)
    low2 = ao[::2, ::2].copy()
    low4 = ao[::4, ::4].copy()
    cases = {
        "bilateral_9x9": lambda: F.bilateral(ao, depth, normal),
        "bilateral_separable_9": lambda: F.bilateral(ao, depth, normal, separable=True),
        "edge_aware_box_7x7": lambda: F.edge_aware_box(ao, depth, normal),
        "upsample_x2_4x4": lambda: F.upsample(low2, depth, normal, scale=2),
        "upsample_x4_4x4": lambda: F.upsample(low4, depth, normal, scale=4),
    }
    mpix = args.width * args.height / 1e6
    rows = {}
    for name, fn in cases.items():
        med, times = median_time(fn, repeats=args.repeats, warmup=1)
        rows[name] = {"seconds_median": med, "seconds_all": times, "mpixels_per_second": mpix / med}
    result = {
        "benchmark": "filters",
        **environment(),
        "width": args.width,
        "height": args.height,
        "repeats": args.repeats,
        "filters": rows,
    }
    if args.json:
        emit(result, True)
    else:
        print(f"device   {result['device']} ({result['platform']}, "
              f"{result['compute_units']} compute units)")
        print(f"image    {args.width}x{args.height}, median of {args.repeats} runs after a warm-up")
        for name, r in rows.items():
            print(f"{name:24s} {r['seconds_median'] * 1e3:8.2f} ms  {r['mpixels_per_second']:8.2f} Mpixel/s")


if __name__ == "__main__":
    main()

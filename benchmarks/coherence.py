"""Coherent ray order (issue 25, item 1): M queries/s of ``visible`` with and without the reorder.

Workloads on the bundled scene (``pyshadow.data.default_scene``, CSMs from
the cache):

- ``ao``: the AO pattern, every covered pixel of a ``--size`` camera times
  36 cosine-weighted directions of ``pyshadow.sample_directions``;
- ``sun``: camera-coherent, one sun direction for every covered pixel of a
  ``--sun-size`` camera;
- ``random``: ``--random`` rays from uniform points in the bounding box of
  the casters' bounding spheres above the ground, uniform directions.

Each of ``csm`` and ``csm-vote`` is timed in three variants, interleaved
round by round (medians of ``--rounds``):

- ``off``: the rays in their given order (``order.COHERENT = False``);
- ``on``: ``_visible`` sorts them (:mod:`pyshadow.visibility.order`), host
  key, sort, gathers and scatter included;
- ``presorted``: the rays handed over already sorted (reorder off): the
  kernel's own gain, an upper bound of what the reorder can buy.

Then a threshold sweep: random rays at the ``--sweep`` batch sizes, ``csm``,
reordered whatever the size (``order.MIN_RAYS = 0``).

Usage: ``python benchmarks/coherence.py [--json] [--rounds 7]``.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def bundled_scene(width, height):
    import pyshadow
    from pyshadow.cache import CSMCache, default_cache_dir

    views = pyshadow.ViewSet.zigzag(64, 128)
    cache = CSMCache(default_cache_dir(), log=log)
    return pyshadow.data.default_scene(views=views, width=width, height=height,
                                       csm_for=lambda name, mesh: cache.csm(name, mesh, views, 128, 16)[0])


def ao_rays(scene, cam, samples=36):
    import pyshadow
    from pyshadow import render

    sp = render.surface_points(scene, cam)
    n = np.asarray(sp.normals, np.float64)
    d = pyshadow.sample_directions(n, sampling=pyshadow.Sampling(samples), indices=sp.index)
    return (np.repeat(np.asarray(sp.points, np.float64), samples, axis=0),
            np.ascontiguousarray(d.reshape(-1, 3), np.float32),
            np.repeat(np.asarray(sp.surface_ids, np.int32), samples))


def sun_rays(scene, cam, sun=(0.4, 1.0, 0.3)):
    from pyshadow import render

    sp = render.surface_points(scene, cam)
    w = np.asarray(sun, np.float64) / np.linalg.norm(sun)
    P = np.asarray(sp.points, np.float64)
    return P, np.ascontiguousarray(np.broadcast_to(w, P.shape), np.float32), np.asarray(sp.surface_ids, np.int32)


def random_rays(scene, n, seed=0):
    from pyshadow.scene_arrays import scene_arrays

    arr = scene_arrays(scene)
    c, r = arr["world_centre"][arr["casts"]], arr["world_radius"][arr["casts"]]
    lo, hi = (c - r[:, None]).min(axis=0), (c + r[:, None]).max(axis=0)
    if scene.ground is not None:
        lo[1] = max(lo[1], scene.ground)
    rng = np.random.default_rng(seed)
    P = lo + (hi - lo) * rng.random((n, 3))
    W = rng.normal(size=(n, 3))
    W /= np.linalg.norm(W, axis=1, keepdims=True)
    return P, W.astype(np.float32), np.full(n, -1, np.int32)


def measure(scene, P, W, ids, backend, rounds):
    """Interleaved rounds of off / on / presorted; medians (s), and whether the answers agree."""
    from pyshadow.visibility import order, visible

    perm = order.coherent_order(P, W)
    Ps, Ws, ids_s = P[perm], np.ascontiguousarray(W[perm]), ids[perm]
    inv = order.inverse_permutation(perm)
    held = order.COHERENT

    def run(variant):
        order.COHERENT = variant == "on"
        if variant == "presorted":
            t0 = time.perf_counter()
            a = visible(scene, Ps, Ws, backend=backend, surface_ids=ids_s)
            return time.perf_counter() - t0, a[inv]
        t0 = time.perf_counter()
        a = visible(scene, P, W, backend=backend, surface_ids=ids)
        return time.perf_counter() - t0, a

    variants = ("off", "on", "presorted")
    times = {v: [] for v in variants}
    answers = {}
    try:
        for v in variants:                      # warm-up: compile, atlas, caches
            answers[v] = run(v)[1]
        for _ in range(rounds):
            for v in variants:
                times[v].append(run(v)[0])
    finally:
        order.COHERENT = held
    same = all(np.array_equal(answers["off"], answers[v]) for v in variants)
    med = {v: statistics.median(t) for v, t in times.items()}
    return med, same


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="320x240", help="AO camera, WxH (default %(default)s)")
    ap.add_argument("--sun-size", default="1280x960", help="sun camera, WxH (default %(default)s)")
    ap.add_argument("--random", type=int, default=2_000_000, help="random rays (default %(default)s)")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--workloads", default="ao,sun,random")
    ap.add_argument("--backends", default="csm,csm-vote")
    ap.add_argument("--sweep", default="4096,16384,65536,262144,1048576",
                    help="random-ray batch sizes for the threshold sweep, csm only ('' for none)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    from _common import check_counts, emit, environment, parse_grid, parse_ints

    check_counts(ap, args, "rounds", "random")
    from pyshadow.visibility import backends

    bad = [w for w in args.workloads.split(",") if w and w not in ("ao", "sun", "random")]
    if bad:
        ap.error(f"--workloads: unknown workload {bad[0]!r} (of ao, sun, random)")
    bad = [b for b in args.backends.split(",") if b not in backends()]
    if bad:
        ap.error(f"--backends: unknown backend {bad[0]!r} (of {', '.join(backends())})")
    for option, dest, workload in (("--random", "random", "random"), ("--sun-size", "sun_size", "sun")):
        if getattr(args, dest) != ap.get_default(dest) and workload not in args.workloads.split(","):
            ap.error(f"{option} sizes the {workload!r} workload, which --workloads {args.workloads!r} leaves out")
    if args.sweep.strip(", "):             # '' for none
        parse_ints(ap, args.sweep, "--sweep")

    from pyshadow.camera import Camera
    from pyshadow.visibility import order

    W, H = parse_grid(ap, args.size, "--size")
    SW, SH = parse_grid(ap, args.sun_size, "--sun-size")
    scene, cam = bundled_scene(W, H)
    rows = []
    for wl in (x for x in args.workloads.split(",") if x):
        if wl == "ao":
            P, D, ids = ao_rays(scene, cam)
        elif wl == "sun":
            P, D, ids = sun_rays(scene, Camera(cam.eye, cam.target, cam.up, cam.fov_y, SW, SH))
        elif wl == "random":
            P, D, ids = random_rays(scene, args.random)
        else:
            raise SystemExit(f"unknown workload {wl!r}")
        t0 = time.perf_counter()
        order.coherent_order(P, D)
        t_sort = time.perf_counter() - t0
        for backend in args.backends.split(","):
            med, same = measure(scene, P, D, ids, backend, args.rounds)
            row = {"workload": wl, "backend": backend, "rays": len(P), "identical": same,
                   "sort_s": t_sort, **{f"{v}_s": t for v, t in med.items()},
                   **{f"{v}_mqps": len(P) / t / 1e6 for v, t in med.items()},
                   "on_vs_off": med["off"] / med["on"], "presorted_vs_off": med["off"] / med["presorted"]}
            rows.append(row)
            log(f"{wl:7s} {backend:9s} {len(P):>9d} rays  off {row['off_mqps']:6.1f}  on {row['on_mqps']:6.1f}  "
                f"presorted {row['presorted_mqps']:6.1f} M/s  on/off {row['on_vs_off']:.3f}  "
                f"presorted/off {row['presorted_vs_off']:.3f}  key+sort {t_sort * 1e3:.0f} ms  identical {same}")
    sweep, min_rays = [], order.MIN_RAYS
    for n in (int(x) for x in args.sweep.split(",") if x):
        P, D, ids = random_rays(scene, n, seed=1)
        order.MIN_RAYS = 0                      # "on" reorders whatever the size
        try:
            med, same = measure(scene, P, D, ids, "csm", args.rounds)
        finally:
            order.MIN_RAYS = min_rays
        sweep.append({"rays": n, "identical": same, **{f"{v}_s": t for v, t in med.items()},
                      "on_vs_off": med["off"] / med["on"], "presorted_vs_off": med["off"] / med["presorted"]})
        log(f"sweep random csm {n:>9d} rays  off {med['off'] * 1e3:8.2f} ms  on {med['on'] * 1e3:8.2f} ms  "
            f"presorted {med['presorted'] * 1e3:8.2f} ms  on/off {sweep[-1]['on_vs_off']:.3f}")
    result = {"benchmark": "coherence", "environment": environment(), "rounds": args.rounds,
              "min_rays": order.MIN_RAYS, "default": order.DEFAULT,
              "dir_bins": order.DIR_BINS, "cells": order.CELLS, "rows": rows, "sweep": sweep}
    if args.json:
        emit(result, True)
    else:
        for r in rows:
            print(f"{r['workload']:7s} {r['backend']:9s} off {r['off_mqps']:6.1f} on {r['on_mqps']:6.1f} "
                  f"presorted {r['presorted_mqps']:6.1f} M queries/s; on/off {r['on_vs_off']:.3f}")
        for r in sweep:
            print(f"sweep {r['rays']:>9d} rays: on/off {r['on_vs_off']:.3f} presorted/off {r['presorted_vs_off']:.3f}")


if __name__ == "__main__":
    main()

"""Batch baking throughput (issue 24): assets per minute for 1 and 2 Dask workers, the
serial fraction, and frames per minute for a 60-frame sequence of the bundled scene.

Assets: the 9 bundled test meshes (pyshadow.data.MESHES, written as their
original files) baked with the default parameters (64x128 maps @ 128^2,
16-bit, 64 samples per vertex, PLY), each run into a fresh folder, on a Dask
LocalCluster of

- 1 worker with 1 OpenCL CPU thread,
- 2 workers with 1 thread each (the default on a 2-core machine),
- 1 worker with 2 threads (the whole machine in one process),

interleaved over ``--rounds`` rounds; medians. The serial fraction comes two
ways: Amdahl's law from the 1- and 2-worker times at 1 thread each
(``s = 2 T2 / T1 - 1``), and directly, as the share of the 1-worker wall
time not spent inside tasks (cluster start, hashing, writing); with it the
speed-up on N machines is estimated as ``1 / (s + (1 - s) / N)`` (per-machine
throughput of 2 workers, tasks of this size).

Frames: ``--frames`` frames (default 60) of the bundled scene turning
(``pyshadow.bake.motion.default_motion``) at 640x480, 36 samples, CSMs from
the cache (built once before timing), on 2 workers x 1 thread and 1 worker x
2 threads; frames per minute of rendering and writing (CSM preparation
excluded, reported apart).

    python benchmarks/bake.py [--rounds 2] [--frames 60] [--json]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

from _common import check_counts, emit, environment


def _assets_run(src, workers, threads):
    from pyshadow.bake import AssetParams, bake_assets

    with tempfile.TemporaryDirectory(prefix="bake-bench-") as d:
        t0 = time.perf_counter()
        m = bake_assets(src, d, AssetParams(), executor="dask", workers=workers, threads=threads, progress=False)
        wall = time.perf_counter() - t0
    baked = [a for a in m["assets"] if a["action"] == "baked"]
    assert len(baked) == 9, m["summary"]
    return {"wall_s": wall, "task_s": sum(a["timings"]["total_s"] for a in baked),
            "assets_per_minute": 60.0 * len(baked) / wall}


def _frames_run(frames, workers, threads, cache):
    import pyshadow
    from pyshadow.bake.frames import bake_frames
    from pyshadow.bake.motion import default_motion

    T, _ = default_motion(frames)
    parts = [(n, m, c) for n, m, _, c in pyshadow.data.default_parts()]
    cam = pyshadow.Camera([2.4, 2.1, 4.8], [0.8, 0.5, 0.0], fov_y=45.0, width=640, height=480)
    views = pyshadow.ViewSet.zigzag(64, 128)

    def csm_for(name, mesh):
        return cache.csm(name, mesh, views, 128, 16)[0]

    with tempfile.TemporaryDirectory(prefix="bake-bench-") as d:
        m = bake_frames(d, parts, cam, T, samples=36, csm_for=csm_for, executor="dask", workers=workers,
                        threads=threads, progress=False)
    assert m["summary"]["rendered"] == frames, m["summary"]
    return {"wall_s": m["seconds"], "prepare_s": m["prepare_seconds"], "frames_per_minute": m["frames_per_minute"],
            "render_s_median": statistics.median(f["seconds"] for f in m["frames"])}


def main(argv=None) -> int:
    import pyshadow
    from pyshadow.cache import CSMCache, default_cache_dir

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    check_counts(ap, args, "rounds", "frames")
    configs = [("1 worker x 1 thread", 1, 1), ("2 workers x 1 thread", 2, 1), ("1 worker x 2 threads", 1, 2)]
    with tempfile.TemporaryDirectory(prefix="bake-src-") as d:
        src = Path(d)
        for name in pyshadow.data.MESHES:
            pyshadow.data.mesh_file(name, src)
        runs = {c[0]: [] for c in configs}
        for r in range(args.rounds):
            for label, w, t in configs:
                runs[label].append(_assets_run(src, w, t))
                print(f"round {r + 1} {label}: {runs[label][-1]['wall_s']:.1f} s", file=sys.stderr, flush=True)
    assets = {}
    for label, rs in runs.items():
        assets[label] = {k: statistics.median(x[k] for x in rs) for k in rs[0]}
        assets[label]["walls_s"] = [x["wall_s"] for x in rs]
    T1, T2 = assets[configs[0][0]]["wall_s"], assets[configs[1][0]]["wall_s"]
    s_amdahl = 2.0 * T2 / T1 - 1.0
    one = assets[configs[0][0]]
    s_direct = max(0.0, one["wall_s"] - one["task_s"]) / one["wall_s"]
    scaling = {n: 1.0 / (s_amdahl + (1.0 - s_amdahl) / n) for n in (2, 4, 8, 16, 64)} if 0 <= s_amdahl < 1 else {}
    cache = CSMCache(default_cache_dir())
    frames = {}
    for label, w, t in (configs[1], configs[2]):
        frames[label] = _frames_run(args.frames, w, t, cache)
        print(f"frames {label}: {frames[label]['frames_per_minute']:.1f} frames/min", file=sys.stderr, flush=True)
    result = {"benchmark": "bake", **environment(), "rounds": args.rounds, "assets": assets,
              "serial_fraction_amdahl": s_amdahl, "serial_fraction_direct": s_direct,
              "speedup_estimate_machines": scaling, "frames": frames, "frame_count": args.frames}
    if args.json:
        emit(result, True)
        return 0
    print(f"assets: the 9 bundled meshes, default parameters; medians of {args.rounds} rounds")
    for label, a in assets.items():
        print(f"  {label:22s} {a['assets_per_minute']:6.1f} assets/min  wall {a['wall_s']:6.1f} s  "
              f"in tasks {a['task_s']:6.1f} s")
    print(f"serial fraction: {s_amdahl:.3f} (Amdahl, 1 vs 2 workers), {s_direct:.3f} (1 worker, outside tasks)")
    if scaling:
        print("estimated speed-up on N such machines: "
              + ", ".join(f"N={n}: {v:.1f}x" for n, v in scaling.items()))
    print(f"frames: {args.frames} frames of the bundled scene, 640x480, 36 samples")
    for label, f in frames.items():
        print(f"  {label:22s} {f['frames_per_minute']:6.1f} frames/min  wall {f['wall_s']:6.1f} s "
              f"(CSMs {f['prepare_s']:.1f} s)  render median {f['render_s_median'] * 1e3:.0f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())

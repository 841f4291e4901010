"""What one frame of a moving scene costs: the moves, the scene's change, the query.

N boxes (0.3 m, with their meshes, one CSM) rest on the ground 1 m apart;
every frame each box slides 1 mm and turns 0.5 degrees about the vertical,
and the AO of ``--points`` ground points (up normals, 16 samples) is asked.
Per count, medians of ``--rounds`` frames:

* **moves, one call each**: ``Scene.set_transform(i, T)`` for every box;
* **moves, one call**: ``Scene.set_transform(ids, transforms)`` (the same poses;
  the held transforms are the same, bit for bit);
* **change**: what the first query after a move pays beyond a second query
  of the same points (the scene's arrays, the instance grid, the contact
  footprints of the boxes on the ground);
* **query**: the second query;
* **frame**: moves in one call + change + query, and its frames per second;
* with ``--render``: ``Scene.render`` (640x480, 16 samples, a camera 0.6 N^(1/2) m
  off seeing the whole field and the ground to the horizon) right after a
  move, and again.

    python benchmarks/moving_frame.py [--counts 1000 10000] [--points 20000] [--rounds 5] [--render] [--json]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

from _common import check_counts, emit, environment


def main(argv=None) -> int:
    import trimesh

    import pyshadow

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--counts", type=int, nargs="+", default=[1000, 10000])
    ap.add_argument("--points", type=int, default=20000)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--render", action="store_true", help="also time Scene.render after a move, and again")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    check_counts(ap, args, "points", "rounds")
    if min(args.counts) < 1:
        ap.error(f"every --counts must be >= 1, got {args.counts}")
    box = trimesh.creation.box((0.3, 0.3, 0.3))
    csm = pyshadow.CoherentShadowMap.build(box, pyshadow.ViewSet.zigzag(8, 16), resolution=32, progress=False)
    sampling = pyshadow.Sampling(16)
    rows = []
    for n in args.counts:
        k = int(np.ceil(np.sqrt(n)))
        xz = np.column_stack([np.arange(n) % k, np.arange(n) // k]) - (k - 1) / 2.0
        scene = pyshadow.Scene(ground=0.0)
        scene.add(csm, np.stack([trimesh.transformations.translation_matrix([x, 0.15, z]) for x, z in xz]), mesh=box)
        rng = np.random.default_rng(0)
        half = k / 2.0
        p = np.column_stack([rng.uniform(-half, half, args.points), np.zeros(args.points),
                             rng.uniform(-half, half, args.points)])
        up = np.tile([0.0, 1.0, 0.0], (args.points, 1))
        ids = np.arange(n)

        def poses(f):
            a = np.radians(0.5 * f)
            T = np.tile(np.eye(4), (n, 1, 1))
            T[:, 0, 0] = T[:, 2, 2] = np.cos(a)
            T[:, 0, 2], T[:, 2, 0] = np.sin(a), -np.sin(a)
            T[:, :3, 3] = np.column_stack([xz[:, 0] + 1e-3 * f, np.full(n, 0.15), xz[:, 1]])
            return T

        scene.ambient_occlusion(p, up, sampling=sampling)         # builds and compiles outside the timing
        t = {"one_call_each": [], "one_call": [], "change": [], "query": []}
        same = True
        for f in range(1, args.rounds + 1):
            T = poses(f)
            t0 = time.perf_counter()
            for i in range(n):
                scene.set_transform(i, T[i])
            t1 = time.perf_counter()
            held = np.stack([x.transform for x in scene.instances])
            scene.set_transform(ids, T)
            t2 = time.perf_counter()
            same &= np.array_equal(held, np.stack([x.transform for x in scene.instances]))
            scene.ambient_occlusion(p, up, sampling=sampling)
            t3 = time.perf_counter()
            scene.ambient_occlusion(p, up, sampling=sampling)
            t4 = time.perf_counter()
            t["one_call_each"].append(t1 - t0)
            t["one_call"].append(t2 - t1)
            t["change"].append((t3 - t2) - (t4 - t3))
            t["query"].append(t4 - t3)
        if args.render:
            k0 = 0.6 * np.sqrt(n)
            cam = pyshadow.Camera(eye=[0.0, 0.5 * k0, k0], target=[0.0, 0.0, 0.0], width=640, height=480)
            scene.render(cam, sampling=sampling)
            t["render_after_move"], t["render_again"] = [], []
            for f in range(args.rounds + 1, 2 * args.rounds + 1):
                scene.set_transform(ids, poses(f))
                t0 = time.perf_counter()
                scene.render(cam, sampling=sampling)
                t1 = time.perf_counter()
                scene.render(cam, sampling=sampling)
                t["render_after_move"].append(t1 - t0)
                t["render_again"].append(time.perf_counter() - t1)
        med = {key: statistics.median(v) for key, v in t.items()}
        frame = med["one_call"] + med["change"] + med["query"]
        rows.append({"bodies": n, "points": args.points, "seconds": med, "frame_s": frame,
                     "frames_per_s": 1.0 / frame, "same_transforms": bool(same)})
        print(f"{n} bodies done", file=sys.stderr, flush=True)
    result = {"benchmark": "moving_frame", **environment(), "rounds": args.rounds, "rows": rows}
    if args.json:
        emit(result, True)
        return 0
    print(f"a frame of N moving boxes on the ground, AO of {args.points} ground points (16 samples); "
          f"medians of {args.rounds} frames, seconds")
    print(f"{'N':>6} {'moves, one call each':>21} {'moves, one call':>16} {'change':>8} {'query':>8} "
          f"{'frame':>8} {'frames/s':>9} {'same':>5}"
          + (f" {'render after move':>18} {'again':>7}" if args.render else ""))
    for r in rows:
        s = r["seconds"]
        print(f"{r['bodies']:>6} {s['one_call_each']:>21.4f} {s['one_call']:>16.4f} {s['change']:>8.4f} "
              f"{s['query']:>8.4f} {r['frame_s']:>8.4f} {r['frames_per_s']:>9.2f} {str(r['same_transforms']):>5}"
              + (f" {s['render_after_move']:>18.3f} {s['render_again']:>7.3f}" if args.render else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())

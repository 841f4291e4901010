"""A body parked far from the others: the instance grid against the tree (issue 22, cost that follows the scene).

The workload of ``instances.py`` (``--count`` Spots of bounding radius 0.3 m
on a 1 m grid over the ground; the AO of 25,000 ground points in the 4 m
square around the origin at 16 samples), alone and with one more Spot at
each ``--stray`` position. Each scene's AO is timed on the grid and on the
tree (``USE_GRID`` off), interleaved, medians of ``--rounds``; every answer
must be identical to the scene's first. The grid sets strays apart
(``pyshadow.visibility.grid.isolated_casters``) and asks them of every ray.

    python benchmarks/stray_caster.py [--count 10000] [--stray 1e4,0.3,0 0,-1000,0] [--rounds 9]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

from instances import scene_of


def _position(text):
    try:
        v = [float(x) for x in text.split(",")]
    except ValueError:
        v = []
    if len(v) != 3 or not np.isfinite(v).all():
        raise argparse.ArgumentTypeError(f"a position is three finite numbers x,y,z (m), got {text!r}")
    return v


def main(argv=None) -> int:
    import pyshadow
    from pyshadow.visibility import csm as backend

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--count", type=int, default=10_000)
    ap.add_argument("--stray", type=_position, nargs="+", default=[[1e4, 0.3, 0.0], [0.0, -1000.0, 0.0]])
    ap.add_argument("--rounds", type=int, default=9)
    args = ap.parse_args(argv)
    if args.count < 16 or args.rounds < 1:
        ap.error(f"--count must be >= 16 (fewer casters take neither grid nor tree) and --rounds >= 1, "
                 f"got {args.count} and {args.rounds}")
    mesh = pyshadow.data.mesh("spot")
    csm = pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(16, 32), resolution=64, progress=False)
    rng = np.random.default_rng(1)
    pts = np.c_[rng.uniform(-2, 2, 25000), np.zeros(25000), rng.uniform(-2, 2, 25000)]
    up = np.tile([0.0, 1.0, 0.0], (len(pts), 1))
    sampling = pyshadow.Sampling(16)
    scenes = {"none": scene_of(args.count, csm, mesh)}
    for where in args.stray:
        s = scene_of(args.count, csm, mesh)
        T = np.eye(4)
        T[:3, :3] *= 0.3 / csm.radius
        T[:3, 3] = where
        s.add(csm, T, mesh=mesh)
        scenes[",".join(f"{v:g}" for v in where)] = s
    times, first, accel = {}, {}, {}
    for r in range(args.rounds):
        for name, s in scenes.items():
            for mode in ("grid", "tree"):
                backend.USE_GRID = mode == "grid"
                accel[name, mode] = backend.instance_accel(s)
                t0 = time.perf_counter()
                ao = s.ambient_occlusion(pts, up, sampling=sampling)
                times.setdefault((name, mode), []).append(time.perf_counter() - t0)
                if not np.array_equal(first.setdefault(name, ao), ao):
                    print(f"error: answers differ for stray {name}, {mode}", file=sys.stderr)
                    return 1
        backend.USE_GRID = True
        print(f"round {r + 1} done", file=sys.stderr, flush=True)
    print(f"AO of 25,000 points x 16 among {args.count} casters and one stray; medians of {args.rounds} rounds (ms)")
    print(f"{'stray at':>16} {'default':>8} {'ms':>8} {'tree ms':>8}")
    for name in scenes:
        print(f"{name:>16} {accel[name, 'grid']:>8} {1e3 * statistics.median(times[name, 'grid']):>8.2f} "
              f"{1e3 * statistics.median(times[name, 'tree']):>8.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Query cost against the number of instances of one CSM (issue 22, "cost that follows the scene").

Instances of Spot (CSM 16x32 maps @ 64^2, scaled to bounding radius 0.3)
stand on a grid of 1 m over the ground plane, centred on the origin (1: one
body at the origin). The same rays for every count: 25,000 ground points in
the 4 m x 4 m square around the origin, 16 cosine-weighted directions each
(400,000 rays), asked through ``Scene.visible`` (one-texel lookup), and the
same points' AO (16 samples). Each count is timed with the instance tree
(``INSTANCE_BVH``, the default from 16 casters) and without it (every caster
visited, as before), interleaved, medians of ``--rounds``; answers must be
identical. Memory: the instance table (104 bytes a caster) and the tree.

    python benchmarks/instances.py [--counts 1 100 10000] [--rounds 3] [--json]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

from _common import emit, environment


def scene_of(n, csm, mesh):
    import pyshadow

    s = pyshadow.Scene(ground=0.0)
    k = int(np.ceil(np.sqrt(n)))
    rng = np.random.default_rng(0)
    sc = 0.3 / csm.radius
    lift = 0.3 - csm.centre[1] * sc                       # every body on the ground: sphere bottom at y = 0
    for i in range(n):
        T = np.eye(4)
        T[:3, :3] *= sc
        x, z = (i % k - (k - 1) / 2, i // k - (k - 1) / 2) if n > 1 else (0.0, 0.0)
        T[:3, 3] = [x + rng.uniform(-0.2, 0.2) * (n > 1), lift, z + rng.uniform(-0.2, 0.2) * (n > 1)]
        s.add(csm, T, mesh=mesh)
    return s


def main(argv=None) -> int:
    import pyshadow
    from pyshadow.visibility import csm as backend
    from pyshadow.visibility.bvh import instance_bvh

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--counts", type=int, nargs="+", default=[1, 100, 10000])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    mesh = pyshadow.data.mesh("spot")
    csm = pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(16, 32), resolution=64, progress=False)
    rng = np.random.default_rng(1)
    pts = np.c_[rng.uniform(-2, 2, 25000), np.zeros(25000), rng.uniform(-2, 2, 25000)]
    up = np.tile([0.0, 1.0, 0.0], (len(pts), 1))
    D = pyshadow.sample_directions(up, sampling=pyshadow.Sampling(16)).reshape(-1, 3).astype(np.float64)
    P = np.repeat(pts, 16, axis=0)
    default_min = backend.BVH_MIN_INSTANCES
    rows = []
    for n in args.counts:
        s = scene_of(n, csm, mesh)
        times = {"tree": {"visible": [], "ao": []}, "flat": {"visible": [], "ao": []}}
        answers = {}
        for r in range(args.rounds):
            for mode in ("tree", "flat"):
                if mode == "flat" and n >= 5000 and r > 0:
                    continue                             # minutes a round; one is enough to see it
                backend.BVH_MIN_INSTANCES = default_min if mode == "tree" else 10 ** 9
                s.visible(P[:64], D[:64])                # compile outside the timing
                s.ambient_occlusion(pts[:8], up[:8], sampling=pyshadow.Sampling(16))
                t0 = time.perf_counter()
                v = s.visible(P, D)
                t1 = time.perf_counter()
                ao = s.ambient_occlusion(pts, up, sampling=pyshadow.Sampling(16))
                t2 = time.perf_counter()
                times[mode]["visible"].append(t1 - t0)
                times[mode]["ao"].append(t2 - t1)
                answers.setdefault(mode, (v, ao))
        backend.BVH_MIN_INSTANCES = default_min
        same = all(np.array_equal(a, b) for a, b in zip(answers["tree"], answers["flat"]))
        wc = pyshadow.scene_arrays.scene_arrays(s)["world_centre"]
        nodes, order, depth = instance_bvh(wc, np.full(len(wc), 0.3))
        med = {m: {q: statistics.median(t) for q, t in d.items()} for m, d in times.items()}
        rows.append({"instances": n, "tree_used": n >= default_min, "identical": same,
                     "visible_ns_per_ray": {m: 1e9 * med[m]["visible"] / len(P) for m in med},
                     "ao_ns_per_sample": {m: 1e9 * med[m]["ao"] / (16 * len(pts)) for m in med},
                     "visible_fraction": float(answers["tree"][0].mean()),
                     "instance_table_bytes": 104 * n,
                     "tree_bytes": int(nodes.nbytes + order.nbytes) if n >= default_min else 0, "tree_depth": depth})
        print(f"{n} instances done", file=sys.stderr, flush=True)
    one = rows[0]
    for r in rows:
        r["visible_vs_first"] = r["visible_ns_per_ray"]["tree"] / one["visible_ns_per_ray"]["tree"]
        r["ao_vs_first"] = r["ao_ns_per_sample"]["tree"] / one["ao_ns_per_sample"]["tree"]
    result = {"benchmark": "instances", **environment(), "rays": len(P), "rows": rows}
    if args.json:
        emit(result, True)
        return 0
    print(f"{len(P)} rays (25,000 ground points x 16 directions) among n instances of one CSM; "
          f"medians of {args.rounds} rounds")
    print(f"{'n':>6} {'visible ns/ray':>22} {'AO ns/sample':>22} {'vs n=1':>12} {'same':>5} {'tree bytes':>11}")
    for r in rows:
        v, a = r["visible_ns_per_ray"], r["ao_ns_per_sample"]
        print(f"{r['instances']:>6} {v['tree']:>9.1f} (flat {v['flat']:>7.1f}) {a['tree']:>9.1f} "
              f"(flat {a['flat']:>7.1f}) {r['visible_vs_first']:>5.1f}x/{r['ao_vs_first']:>4.1f}x "
              f"{str(r['identical']):>5} {r['tree_bytes']:>11}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Queries whose points fall in many anchor groups: tiny casters spread over a scene (issue 22, cost).

100 instances of Spot stand on the ground on a 10 x 10 grid 1 m apart
(jittered by up to 0.3 m), scaled to a bounding radius of ``--radius``
metres. 20,000 ground points lie at random in the 10 m square, each with its
16 cosine-weighted directions about the up normal. Timed: the points' AO (16
samples) and ``Scene.visible`` of their 320,000 rays, medians of
``--rounds`` calls after one untimed call. With 1 mm casters a point farther
than 512 radii (0.5 m) from the scene's anchor and near a caster needs an
anchor of its own (``pyshadow.anchor_reach``): about a hundred groups, each a
launch with its anchor's instance tables. With 10 cm casters every point is
asked at the scene's anchor: one group, the cost of the same query without
the split. Printed: the groups and the time of ``anchor_groups`` itself.

    python benchmarks/anchor_groups.py [--radius 0.001 0.1] [--rounds 5] [--json]
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from _common import emit, environment, median_time


def scene_of(radius, csm, mesh):
    import pyshadow

    s = pyshadow.Scene(ground=0.0)
    sc = radius / csm.radius
    rng = np.random.default_rng(0)
    for i in range(100):
        T = np.eye(4)
        T[:3, :3] *= sc
        T[:3, 3] = [i % 10 - 4.5 + rng.uniform(-0.3, 0.3), radius - csm.centre[1] * sc,
                    i // 10 - 4.5 + rng.uniform(-0.3, 0.3)]
        s.add(csm, T, mesh=mesh)
    return s


def main(argv=None) -> int:
    import pyshadow
    from pyshadow.scene_arrays import anchor_groups

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--radius", type=float, nargs="+", default=[0.001, 0.1],
                    help="the casters' bounding radius, metres (default: %(default)s)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.rounds < 1 or not all(0 < r < 0.5 for r in args.radius):
        ap.error(f"--rounds must be >= 1 and every --radius in (0, 0.5), got {args.rounds} and {args.radius}")
    mesh = pyshadow.data.mesh("spot")
    csm = pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(16, 32), resolution=64, progress=False)
    rng = np.random.default_rng(1)
    pts = np.c_[rng.uniform(-5, 5, 20000), np.zeros(20000), rng.uniform(-5, 5, 20000)]
    up = np.tile([0.0, 1.0, 0.0], (len(pts), 1))
    sampling = pyshadow.Sampling(16)
    D = pyshadow.sample_directions(up, sampling=sampling).reshape(-1, 3).astype(np.float64)
    P = np.repeat(pts, 16, axis=0)
    rows = []
    for radius in args.radius:
        s = scene_of(radius, csm, mesh)
        ao_s, _ = median_time(lambda: s.ambient_occlusion(pts, up, sampling=sampling), args.rounds)
        vis_s, _ = median_time(lambda: s.visible(P, D), args.rounds)
        groups_ao = len(anchor_groups(s, pts))
        groups_vis = len(anchor_groups(s, P))
        split_s, _ = median_time(lambda: anchor_groups(s, P), args.rounds)
        rows.append({"radius": radius, "groups_ao": groups_ao, "groups_visible": groups_vis,
                     "ao_ms": 1e3 * ao_s, "visible_ms": 1e3 * vis_s, "anchor_groups_visible_ms": 1e3 * split_s,
                     "ao_mean": float(s.ambient_occlusion(pts, up, sampling=sampling).mean())})
    result = {"benchmark": "anchor_groups", **environment(), "points": len(pts), "rays": len(P),
              "rounds": args.rounds, "rows": rows, "first": rows[0]}
    if args.json:
        emit(result, True)
        return 0
    print(f"100 casters over 10 m x 10 m; AO of {len(pts)} ground points x 16, visible of {len(P)} rays; "
          f"medians of {args.rounds}")
    print(f"{'radius m':>9} {'groups AO/vis':>14} {'AO ms':>8} {'visible ms':>11} {'anchor_groups ms':>17} "
          f"{'mean AO':>8}")
    for r in rows:
        print(f"{r['radius']:>9g} {r['groups_ao']:>6} / {r['groups_visible']:<5} {r['ao_ms']:>8.2f} "
              f"{r['visible_ms']:>11.2f} {r['anchor_groups_visible_ms']:>17.2f} {r['ao_mean']:>8.5f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Rays through a body from far away: agreement with Embree against the distance (issue 21).

Spot alone, CSMs of 16x32 maps @ 64^2 and 64x128 @ 128^2; 4,000 rays aimed at
points within about 0.25 bounding radii of its centre, from 1.5, 5, 50 and
5000 radii away, asked of the CSM (both lookups) and of Embree; beside them the
same rays started on the bounding sphere (distance 1), the CSM's own accuracy.

    python benchmarks/far_points.py [--json]
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from _common import emit, environment


def main(argv=None) -> int:
    import pyshadow
    from pyshadow import embree

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    mesh = pyshadow.data.mesh("spot")
    rows = []
    for grid, res in (((16, 32), 64), ((64, 128), 128)):
        csm = pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(*grid), resolution=res, progress=False)
        s = pyshadow.Scene()
        s.add(csm, np.eye(4), mesh=mesh)
        c, r = s.instances[0].world_sphere()
        rng = np.random.default_rng(1)
        target = c + rng.normal(size=(4000, 3)) * 0.25 * r
        d = rng.normal(size=(4000, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        near = target + d * r
        t1 = embree.visible(s, near, -d)
        from_sphere = float(np.mean(s.visible(near, -d) == t1))
        for dist in (1.5, 5.0, 50.0, 5000.0):
            P = target + d * dist * r
            t = embree.visible(s, P, -d)
            rows.append({"maps": list(grid), "resolution": res, "distance_radii": dist, "open": float(t.mean()),
                         "agreement": float(np.mean(s.visible(P, -d) == t)),
                         "agreement_vote": float(np.mean(s.visible(P, -d, lookup="vote") == t)),
                         "agreement_from_sphere": from_sphere})
    if args.json:
        emit({"benchmark": "far_points", **environment(), "rows": rows}, True)
        return 0
    print("maps      res  distance  open   agree  vote   (from the sphere)")
    for x in rows:
        print(f"{x['maps'][0]}x{x['maps'][1]:<5} {x['resolution']:>4} {x['distance_radii']:>8} {x['open']:.3f}  "
              f"{x['agreement']:.4f} {x['agreement_vote']:.4f} ({x['agreement_from_sphere']:.4f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())

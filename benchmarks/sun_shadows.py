"""Sun shadows against Embree on identical pixels of the bundled scene (issue 19's acceptance).

For each sun direction: the covered pixels of the bundled scene (640x480,
CSMs of 64x128 maps @ 128^2) whose normal has n.l >= 0.1, the ray towards
the sun from each, asked of the CSM (both lookups, with the pixels' normals:
the surface rule) and of Embree; the agreement is printed. Suns: 45 deg N on
21 June at 10:00 and 17:00 solar time, and (0.6, 0.5, 0.4) normalised.

    python benchmarks/sun_shadows.py [--width 640 --height 480] [--maps 64x128 --resolution 128] [--json]
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from _common import check_counts, emit, environment, parse_grid


def main(argv=None) -> int:
    import pyshadow
    from pyshadow import embree, render, visibility
    from pyshadow.lighting import sun_position

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--maps", default="64x128", help="zigzag map grid THETAxPHI of the casters' CSMs")
    ap.add_argument("--resolution", type=int, default=128, help="CSM texels per side")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    check_counts(ap, args, "width", "height", "resolution")
    t, p = parse_grid(ap, args.maps)
    scene, cam = pyshadow.data.default_scene(width=args.width, height=args.height,
                                             views=pyshadow.ViewSet.zigzag(t, p), resolution=args.resolution)
    sp = render.surface_points(scene, cam)
    n = np.asarray(sp.normals, np.float64)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    suns = [("45N 21 June 10:00", sun_position(45, 172, 10)), ("45N 21 June 17:00", sun_position(45, 172, 17)),
            ("(0.6, 0.5, 0.4)", np.array([0.6, 0.5, 0.4]) / np.linalg.norm([0.6, 0.5, 0.4]))]
    rows = []
    for name, sun in suns:
        sel = n @ sun >= 0.1
        P, N = sp.points[sel], n[sel]
        D = np.tile(sun, (len(P), 1))
        truth = embree.visible(scene, P, D)
        row = {"sun": name, "elevation_deg": float(np.degrees(np.arcsin(sun[1]))), "pixels": int(sel.sum())}
        for backend in ("csm", "csm-vote"):
            v = visibility.visible(scene, P, D, backend=backend, surface_ids=sp.surface_ids[sel], normals=N)
            row[backend] = float(np.mean(v == truth))
        rows.append(row)
        if not args.json:
            print(f"{name:20s} elevation {row['elevation_deg']:5.1f} deg, {row['pixels']} pixels: "
                  f"one-texel {100 * row['csm']:.2f} %, vote {100 * row['csm-vote']:.2f} %", flush=True)
    if args.json:
        emit({"benchmark": "sun_shadows", **environment(), "maps": args.maps, "resolution": args.resolution,
              "rows": rows}, True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

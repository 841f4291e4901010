"""Benchmark: layered depth maps of the Stanford bunny for the thesis's view set.

Renders all maps of ``ViewSet.zigzag(64, 128)`` (8192 maps) of the Stanford
bunny (69,451 faces), two layers at 128^2 -- the input of the 64x128 CSM of
thesis Table 5.1 -- and reports the median wall time of several runs and the
rate in triangle-views per second.

    python benchmarks/raster.py [--repeats 3] [--theta 64 --phi 128] [--json]
"""
from __future__ import annotations

import argparse

import numpy as np

import pyshadow
from _common import MESH_HELP, check_counts, check_meshes, emit, environment, load_mesh, median_time


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mesh", default="stanford-bunny.obj", help=MESH_HELP)
    ap.add_argument("--theta", type=int, default=64)
    ap.add_argument("--phi", type=int, default=128)
    ap.add_argument("--resolution", type=int, default=128)
    ap.add_argument("--layers", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", action="store_true", help="print the result as JSON")
    args = ap.parse_args(argv)
    check_counts(ap, args, "repeats", "theta", "phi")
    check_counts(ap, args, "layers", most=3)
    check_meshes(ap, "--mesh", [args.mesh])
    check_counts(ap, args, "resolution", most=4096)

    mesh = load_mesh(args.mesh)
    views = pyshadow.ViewSet.zigzag(args.theta, args.phi)
    out = {}

    def run():
        out["depth"] = pyshadow.render_depth(mesh, views, resolution=args.resolution, layers=args.layers)

    med, times = median_time(run, repeats=args.repeats, warmup=1)
    d = out["depth"]
    tv = len(mesh.faces) * len(views)
    result = {
        "benchmark": "raster",
        **environment(),
        "mesh": args.mesh,
        "faces": int(len(mesh.faces)),
        "maps": len(views),
        "resolution": args.resolution,
        "layers": args.layers,
        "seconds_median": med,
        "seconds_all": times,
        "triangle_views_per_second": tv / med,
        "texels_covered_layer1": float(np.isfinite(d[:, 0]).mean()),
    }
    if args.json:
        emit(result, True)
    else:
        print(f"device            {result['device']} ({result['platform']}, {result['lanes']} lanes)")
        print(f"mesh              {args.mesh} ({result['faces']} faces)")
        print(f"maps              {len(views)} x {args.layers} layers at {args.resolution}^2")
        print(f"time (median {args.repeats})  {med:.2f} s   runs: " + ", ".join(f"{t:.2f}" for t in times))
        print(f"rate              {tv / med / 1e6:.1f} M triangle-views/s")


if __name__ == "__main__":
    main()

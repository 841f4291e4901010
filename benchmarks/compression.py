"""Compression study: thesis Table 5.1 beside pyshadow's CSMs of the Stanford bunny.

For the bunny with holes (and the hole-filled bunny at 64x128 maps), 128^2
texels, 16-bit depth: the thesis's compressed size and ratio next to ours
for the zigzag layout (the thesis's grid and order) and for the hilbert
layout at equal or nearly equal map count. Ratio = D * R^2 * 2 bytes /
(segments * 4 bytes + offset table).

The maps frame the mesh's minimal bounding sphere. The thesis does not state
its orthographic frustum (its files carry it as an attribute); --frame-scale F
frames a sphere F times wider, to show how much the ratio owes to framing:
empty texels around the object cost one segment each. --bases lookat gives the
zigzag maps look-at camera bases with a y-up vector (the usual OpenGL camera)
instead of pyshadow's parallel-transported ones, for comparison only (such a
CSM is not saved: a file rebuilds its views from the layout). --footprint
builds every CSM with footprint intervals (``build(..., footprint=True)``),
to show what that accuracy option costs in size. --pole-axis z (or x) turns
the mesh so that its z (x) axis points along the grid's pole (+y) before it
is built: the thesis notes that an object's orientation in the view sphere
changes the ratio (section 5.2.1); the scan's own y-up is the default.

    python benchmarks/compression.py [--json] [--quick] [--frame-scale F] [--bases lookat] [--footprint]
                                     [--pole-axis {y,z,x}]
"""
from __future__ import annotations

import argparse

import numpy as np
import trimesh

import pyshadow
from _common import MESHES, emit, environment

# thesis 000, Table 5.1: (theta, phi) -> (compressed MB, ratio); bunny with holes. Its MB are
# 2^20 bytes (8192 maps of 128^2 16-bit texels are its "256,0 MB"); ours are printed the same way.
MB = 2 ** 20
THESIS = {(32, 32): (3.7, 8.7), (32, 64): (5.1, 12.5), (45, 45): (6.0, 10.5),
          (45, 90): (8.5, 14.9), (64, 64): (10.1, 12.6), (64, 128): (14.6, 17.5)}
THESIS_FILLED = (8.4, 30.5)     # 64 x 128, holes filled (section 5.2.1)


def hilbert_for(maps):
    """The hilbert view set with the map count nearest ``maps``."""
    options = [pyshadow.ViewSet.hilbert(l, h) for l in (4, 5, 6, 7) for h in (False, True)]
    return min(options, key=lambda v: (abs(len(v) - maps), len(v)))


def lookat_zigzag(theta, phi):
    """The zigzag view set with look-at bases: u points east, ``(-sin p, 0, cos p)``
    (defined on the poles too), ``v = d x u``."""
    views = pyshadow.ViewSet.zigzag(theta, phi)
    d = views.directions
    az = np.arctan2(d[:, 2], d[:, 0])
    pole = np.hypot(d[:, 0], d[:, 2]) < 1e-9       # row 0, on the pole: maps 0 .. phi-1, phi rising
    az[pole] = np.flatnonzero(pole) * 2.0 * np.pi / phi
    u = np.stack([-np.sin(az), np.zeros_like(az), np.cos(az)], axis=1)
    bases = np.stack([u, np.cross(d, u), d], axis=1)
    return pyshadow.ViewSet(d, bases, layout="zigzag", params=views.params)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mesh", default=str(MESHES / "stanford-bunny.obj"))
    ap.add_argument("--resolution", type=int, default=128)
    ap.add_argument("--quick", action="store_true", help="only the 32x32 and 64x128 rows")
    ap.add_argument("--frame-scale", type=float, default=1.0,
                    help="frame a sphere this many times the minimal bounding sphere (default 1)")
    ap.add_argument("--bases", choices=("transport", "lookat"), default="transport",
                    help="camera bases of the zigzag maps (default: pyshadow's parallel transport)")
    ap.add_argument("--footprint", action="store_true",
                    help="footprint intervals (CoherentShadowMap.build(..., footprint=True))")
    ap.add_argument("--pole-axis", choices=("y", "z", "x"), default="y",
                    help="the mesh axis turned onto the grid's pole, +y (default y: the mesh as stored)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if not (args.frame_scale >= 1.0):
        ap.error("--frame-scale must be >= 1 (a smaller sphere would cut the mesh)")

    holes = pyshadow.load_mesh(args.mesh)
    filled = pyshadow.load_mesh(args.mesh, fill_holes=True)
    if args.pole_axis != "y":
        # a quarter turn about -x takes +z to +y; about +z, +x to +y
        axis = [-1.0, 0.0, 0.0] if args.pole_axis == "z" else [0.0, 0.0, 1.0]
        turn = trimesh.transformations.rotation_matrix(np.pi / 2, axis)
        holes.apply_transform(turn)
        filled.apply_transform(turn)
    grids = [(32, 32), (64, 128)] if args.quick else list(THESIS)
    rows = []
    cache = {}

    def build(mesh, views, layers="auto"):
        key = (id(mesh), views.layout, tuple(sorted(views.params.items())), layers, views.bases.tobytes())
        if key not in cache:
            centre, radius = pyshadow.bounding_sphere(mesh)
            csm = pyshadow.CoherentShadowMap.build(mesh, views, args.resolution, layers=layers, progress=False,
                                                   frame=(centre, radius * args.frame_scale),
                                                   footprint=args.footprint)
            cache[key] = csm.stats
        return cache[key]

    def zigzag(t, p):
        return lookat_zigzag(t, p) if args.bases == "lookat" else pyshadow.ViewSet.zigzag(t, p)

    for (t, p) in grids:
        z = build(holes, zigzag(t, p))
        hv = hilbert_for(t * p)
        h = build(holes, hv)
        rows.append({"mesh": "bunny (holes)", "grid": f"{t}x{p}", "maps": t * p,
                     "thesis_mb": THESIS[(t, p)][0], "thesis_ratio": THESIS[(t, p)][1],
                     "zigzag": z, "hilbert_maps": len(hv), "hilbert": h,
                     "layer_rule": z["layer_rule"]})
    for rule in ("auto", 2):
        z = build(filled, zigzag(64, 128), rule)
        hv = hilbert_for(8192)
        h = build(filled, hv, rule)
        rows.append({"mesh": "bunny (filled)", "grid": "64x128", "maps": 8192,
                     "thesis_mb": THESIS_FILLED[0], "thesis_ratio": THESIS_FILLED[1],
                     "zigzag": z, "hilbert_maps": len(hv), "hilbert": h,
                     "layer_rule": z["layer_rule"]})
    result = {"benchmark": "compression", **environment(), "resolution": args.resolution,
              "frame_scale": args.frame_scale, "bases": args.bases, "footprint": args.footprint,
              "pole_axis": args.pole_axis, "rows": rows}
    if args.json:
        emit(result, True)
        return
    print(f"device: {result['device']}; {args.resolution}^2 texels, 16-bit depth, "
          "ratio = D*R^2*2 B / (4 B per segment + offset table); frame: "
          + ("the minimal bounding sphere" if args.frame_scale == 1.0
             else f"{args.frame_scale:g} x the minimal bounding sphere")
          + ("; zigzag maps with look-at bases" if args.bases == "lookat" else "")
          + ("; footprint intervals" if args.footprint else "")
          + (f"; mesh turned so that its {args.pole_axis} axis points along the pole (+y)"
             if args.pole_axis != "y" else ""))
    hdr = (f"{'mesh':15} {'maps':>7} {'rule':>4} | {'thesis MB':>9} {'ratio':>6} | "
           f"{'zigzag MB':>9} {'ratio':>6} {'build s':>7} | {'hilbert D':>9} {'MB':>6} {'ratio':>6} | winner")
    print(hdr)
    print("-" * len(hdr))
    for r in rows:
        z, h = r["zigzag"], r["hilbert"]
        zr = z["ratio"]
        hr = h["ratio"]
        if r["hilbert_maps"] == r["maps"]:
            win = f"{'zigzag' if zr >= hr else 'hilbert'} +{abs(zr / hr - 1) * 100:.0f}%"
        else:
            win = "(D differs)"
        print(f"{r['mesh']:15} {r['grid']:>7} {r['layer_rule']:>4} | {r['thesis_mb']:>9.1f} "
              f"{r['thesis_ratio']:>5.1f}:1 | {z['bytes'] / MB:>9.2f} {zr:>5.1f}:1 "
              f"{z['build_seconds']:>7.1f} | {r['hilbert_maps']:>9} {h['bytes'] / MB:>6.2f} "
              f"{hr:>5.1f}:1 | {win}")


if __name__ == "__main__":
    main()

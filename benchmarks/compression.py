"""Compression study: thesis Table 5.1 beside pyshadow's CSMs of the Stanford bunny.

For the bunny with holes (and the hole-filled bunny at 64x128 maps), 128^2
texels, 16-bit depth: the thesis's compressed size and ratio next to ours
for the zigzag layout (the thesis's grid and order) and for the hilbert
layout at equal or nearly equal map count. Ratio = D * R^2 * 2 bytes /
(segments * 4 bytes + offset table).

Every CSM is built at two frames -- the sphere its orthographic maps frame:
the mesh's minimal bounding sphere (pyshadow's default, the most texels on
the object) and the sphere around its bounding box (the box's centre, half
its diagonal: 1.25x the bunny's minimal radius). The thesis does not state
its frame (its files carry it as an attribute), and the ratio depends on it:
every empty texel costs one segment. So each frame also gets a calibration
column: the zigzag maps with the thesis's own camera bases (eq. 5.4, a
look-at basis from the world's up vector y; on the pole row, where that is
undefined, turned with phi) instead of pyshadow's parallel-transported ones.
Where that column matches the thesis, the frame is close to the thesis's.
Such CSMs are built for comparison only (a file rebuilds its views from the
layout). --frame-scale F widens both spheres F times. --footprint builds
every CSM with footprint intervals (``build(..., footprint=True)``), to show
what that accuracy option costs in size. --pole-axis z (or x) turns the
mesh so that its z (x) axis points along the grid's pole (+y) before it is
built: the thesis notes that an object's orientation in the view sphere
changes the ratio (section 5.2.1); the scan's own y-up is the default.

    python benchmarks/compression.py [--json] [--quick] [--frame-scale F] [--footprint] [--pole-axis {y,z,x}]
"""
from __future__ import annotations

import argparse

import numpy as np
import trimesh

import pyshadow
from _common import MESH_HELP, check_counts, check_meshes, emit, environment, load_mesh

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
    """The zigzag view set with the thesis's camera bases (eq. 5.4, up vector y):
    ``u`` points east, ``(-sin p, 0, cos p)`` (on the pole, where eq. 5.4 is
    undefined, turned with the map's phi), ``v = d x u``. Eq. 5.4's ``x = o x z``
    is ``-u``; turning every map by half a turn changes no segment count."""
    views = pyshadow.ViewSet.zigzag(theta, phi)
    d = views.directions
    az = np.arctan2(d[:, 2], d[:, 0])
    pole = np.hypot(d[:, 0], d[:, 2]) < 1e-9       # row 0, on the pole: maps 0 .. phi-1, phi rising
    az[pole] = np.flatnonzero(pole) * 2.0 * np.pi / phi
    u = np.stack([-np.sin(az), np.zeros_like(az), np.cos(az)], axis=1)
    bases = np.stack([u, np.cross(d, u), d], axis=1)
    return pyshadow.ViewSet(d, bases, layout="zigzag", params=views.params)


FRAMES = ("box", "minimal")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mesh", default="stanford-bunny.obj", help=MESH_HELP)
    ap.add_argument("--resolution", type=int, default=128)
    ap.add_argument("--quick", action="store_true", help="only the 32x32 and 64x128 rows")
    ap.add_argument("--frame-scale", type=float, default=1.0,
                    help="widen both framing spheres this many times (default 1)")
    ap.add_argument("--footprint", action="store_true",
                    help="footprint intervals (CoherentShadowMap.build(..., footprint=True))")
    ap.add_argument("--pole-axis", choices=("y", "z", "x"), default="y",
                    help="the mesh axis turned onto the grid's pole, +y (default y: the mesh as stored)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if not (args.frame_scale >= 1.0):
        ap.error("--frame-scale must be >= 1 (a smaller sphere would cut the mesh)")
    check_counts(ap, args, "resolution")
    check_meshes(ap, "--mesh", [args.mesh])

    holes = load_mesh(args.mesh)
    filled = load_mesh(args.mesh, fill_holes=True)
    if args.pole_axis != "y":
        # a quarter turn about -x takes +z to +y; about +z, +x to +y
        axis = [-1.0, 0.0, 0.0] if args.pole_axis == "z" else [0.0, 0.0, 1.0]
        turn = trimesh.transformations.rotation_matrix(np.pi / 2, axis)
        holes.apply_transform(turn)
        filled.apply_transform(turn)
    grids = [(32, 32), (64, 128)] if args.quick else list(THESIS)

    def sphere(mesh, frame):
        if frame == "minimal":
            centre, radius = pyshadow.bounding_sphere(mesh)
        else:
            lo, hi = mesh.bounds
            # every vertex lies within half the box diagonal of its centre; the
            # slack keeps the farthest corner vertex inside after rounding
            centre, radius = (lo + hi) / 2.0, float(np.linalg.norm(hi - lo)) / 2.0 * (1.0 + 1e-9)
        return centre, radius * args.frame_scale

    built = {}

    def build(mesh, views, frame, layers="auto"):
        # hilbert sets of 2048 and 4096 maps serve two rows each: build them once
        key = (id(mesh), views.layout, tuple(sorted(views.params.items())), views.bases.tobytes(), frame, layers)
        if key not in built:
            built[key] = pyshadow.CoherentShadowMap.build(
                mesh, views, resolution=args.resolution, layers=layers, progress=False,
                frame=sphere(mesh, frame), footprint=args.footprint).stats
        return built[key]

    def row(mesh, t, p, layers="auto"):
        hv = hilbert_for(t * p)
        out = {"grid": f"{t}x{p}", "maps": t * p, "hilbert_maps": len(hv)}
        for frame in FRAMES:
            out[frame] = {"zigzag": build(mesh, pyshadow.ViewSet.zigzag(t, p), frame, layers),
                          "hilbert": build(mesh, hv, frame, layers),
                          "zigzag_thesis_bases": build(mesh, lookat_zigzag(t, p), frame, layers)}
        out["layer_rule"] = out["minimal"]["zigzag"]["layer_rule"]
        return out

    rows = []
    for (t, p) in grids:
        rows.append({"mesh": "bunny (holes)", "thesis_mb": THESIS[(t, p)][0], "thesis_ratio": THESIS[(t, p)][1],
                     **row(holes, t, p)})
    for rule in ("auto", 2):
        rows.append({"mesh": "bunny (filled)", "thesis_mb": THESIS_FILLED[0], "thesis_ratio": THESIS_FILLED[1],
                     **row(filled, 64, 128, rule)})
    result = {"benchmark": "compression", **environment(), "resolution": args.resolution,
              "frame_scale": args.frame_scale, "footprint": args.footprint, "pole_axis": args.pole_axis,
              "rows": rows}
    if args.json:
        emit(result, True)
        return
    print(f"device: {result['device']}; {args.resolution}^2 texels, 16-bit depth, "
          "ratio = D*R^2*2 B / (4 B per segment + offset table), MB = 2^20 B"
          + ("" if args.frame_scale == 1.0 else f"; both spheres {args.frame_scale:g}x wider")
          + ("; footprint intervals" if args.footprint else "")
          + (f"; mesh turned so that its {args.pole_axis} axis points along the pole (+y)"
             if args.pole_axis != "y" else ""))
    print("thesis cams: the zigzag maps with the thesis's camera bases (eq. 5.4); zigzag, hilbert: pyshadow's")
    for frame, title in (("box", "the sphere around the bounding box"),
                         ("minimal", "the minimal bounding sphere (pyshadow's default)")):
        print(f"\nmaps framing {title}")
        hdr = (f"{'mesh':15} {'maps':>7} {'rule':>4} | {'thesis MB':>9} {'ratio':>6} | {'thesis cams':>11} | "
               f"{'zigzag MB':>9} {'ratio':>6} {'build s':>7} | {'hilbert D':>9} {'MB':>6} {'ratio':>6} | winner")
        print(hdr)
        print("-" * len(hdr))
        for r in rows:
            z, h, c = (r[frame][k] for k in ("zigzag", "hilbert", "zigzag_thesis_bases"))
            zr, hr = z["ratio"], h["ratio"]
            if r["hilbert_maps"] == r["maps"]:
                win = f"{'zigzag' if zr >= hr else 'hilbert'} +{abs(zr / hr - 1) * 100:.0f}%"
            else:
                win = "(D differs)"
            print(f"{r['mesh']:15} {r['grid']:>7} {r['layer_rule']:>4} | {r['thesis_mb']:>9.1f} "
                  f"{r['thesis_ratio']:>5.1f}:1 | {c['ratio']:>9.1f}:1 | {z['bytes'] / MB:>9.2f} {zr:>5.1f}:1 "
                  f"{z['build_seconds']:>7.1f} | {r['hilbert_maps']:>9} {h['bytes'] / MB:>6.2f} "
                  f"{hr:>5.1f}:1 | {win}")
        worst = min(min(r[frame]["zigzag"]["ratio"], r[frame]["hilbert"]["ratio"]) / r["thesis_ratio"]
                    for r in rows)
        zig = [r[frame]["zigzag"]["ratio"] / r["thesis_ratio"] for r in rows]
        cams = [r[frame]["zigzag_thesis_bases"]["ratio"] / r["thesis_ratio"] for r in rows]
        own = [r[frame]["zigzag"]["ratio"] / r[frame]["zigzag_thesis_bases"]["ratio"] for r in rows]
        print(f"ours / thesis: zigzag {min(zig):.2f}-{max(zig):.2f}x, lowest of both layouts {worst:.2f}x; "
              f"thesis cams / thesis: {min(cams):.2f}-{max(cams):.2f}x; "
              f"zigzag / thesis cams (same frame): {min(own):.2f}-{max(own):.2f}x")


if __name__ == "__main__":
    main()

# Segments per texel of a Coherent Shadow Map, as a heat map over the object's silhouette.
#
# Builds the CSM of a mesh (default: the bundled Stanford bunny) and shows how
# many (depth, last map) segments each texel's list holds after compression
# (thesis 000, 4.2.1): few where the object's depth changes smoothly from map to
# map, many along silhouettes, ears and holes. Texels whose list is one single
# miss segment -- no map ever sees the object through them -- are left out.
# The compression ratio (uncompressed 16-bit maps / stored bytes) is in the title.
#
#   python examples/csm_heatmap.py                      # interactive window
#   python examples/csm_heatmap.py spot.obj --fill-holes --screenshot heat.png
from __future__ import annotations

import argparse

import numpy as np


def count_range(most):
    """Colour range ``(0, top)`` and label count for counts up to ``most`` (>= 1): ``top`` the
    fewest whole steps of 1, 2 or 5 times a power of ten (at most 5 steps) that reach ``most``,
    so every label is a whole count at its place (371 -> 0 .. 400 by 100; 2 -> 0, 1, 2; a
    range of 0 .. 1 in quarters printed the labels 0, 0, 0, 1, 1)."""
    scale = 1.0
    while True:
        for unit in (1.0, 2.0, 5.0):
            step = unit * scale
            n = max(1, int(np.ceil(most / step)))
            if n <= 5:
                return n * step, n + 1
        scale *= 10.0


def main(argv=None):
    parser = argparse.ArgumentParser(
        description="Heat map of the segments per texel of a mesh's Coherent Shadow Map.")
    parser.add_argument("mesh", nargs="?", metavar="MESH",
                        help="mesh file (default: the bundled Stanford bunny)")
    parser.add_argument("--theta", type=int, help="zigzag rows of map directions (default 32)")
    parser.add_argument("--phi", type=int, help="zigzag columns of map directions (default 64)")
    parser.add_argument("--hilbert", type=int, metavar="LEVEL",
                        help="use a Hilbert view set of two hemisphere squares (2*4^LEVEL maps) "
                             "instead of zigzag")
    parser.add_argument("--resolution", type=int, default=64, help="texels per side")
    parser.add_argument("--depth-bits", type=int, default=16, choices=(16, 32))
    parser.add_argument("--fill-holes", action="store_true",
                        help="close the mesh's holes first (watertight: [z1, z3) runs)")
    from pyshadow import viz

    viz.add_window_options(parser, window=(900, 860))
    args = parser.parse_args(argv)
    if args.hilbert is not None and (args.theta, args.phi) != (None, None):     # they were ignored
        parser.error("--theta and --phi set a zigzag view set: give them or --hilbert, not both")
    args.theta = 32 if args.theta is None else args.theta
    args.phi = 64 if args.phi is None else args.phi

    import pyshadow
    import pyshadow.data

    try:
        if args.mesh:
            mesh = pyshadow.load_mesh(args.mesh, fill_holes=args.fill_holes)
        else:
            mesh = pyshadow.load_mesh(pyshadow.data.bunny(), fill_holes=args.fill_holes)
        if args.hilbert is not None:
            views = pyshadow.ViewSet.hilbert(args.hilbert, hemispheres=True)
            layout = f"hilbert level {args.hilbert}"
        else:
            views = pyshadow.ViewSet.zigzag(args.theta, args.phi)
            layout = f"zigzag {args.theta}x{args.phi}"
        csm = pyshadow.CoherentShadowMap.build(mesh, views, resolution=args.resolution,
                                               depth_bits=args.depth_bits, progress=False)
    except (FileNotFoundError, ValueError) as exc:
        parser.error(str(exc))
    name = args.mesh or "bunny"
    st = csm.stats
    heat = viz.segment_heatmap(csm)
    seen = heat[np.isfinite(heat)]
    print(f"{name}: {st['maps']} maps ({layout}), {st['resolution']}^2 texels, "
          f"{st['segments']} segments, {st['bytes'] / 2**20:.2f} MiB, ratio {st['ratio']:.1f}:1, "
          f"built in {st['build_seconds']:.2f} s")
    if seen.size:
        print(f"silhouette: {seen.size} texels ({100 * seen.size / heat.size:.0f}%); segments per "
              f"texel median {np.median(seen):.0f}, max {seen.max():.0f}")

    plotter = viz.script_plotter(parser, args, (2, 1), row_weights=[1.0, 0.12])
    plotter.subplot(0, 0)
    top, n_labels = count_range(float(seen.max()) if seen.size else 1.0)
    viz.image_panel(plotter, heat, cmap="inferno", clim=(0.0, top), origin="lower",
                    title=f"{name}: {layout}, {st['resolution']}x{st['resolution']} texels, "
                          f"{st['depth_bits']}-bit depth -- compression {st['ratio']:.1f}:1")
    plotter.subplot(1, 0)
    viz.colour_bar(plotter, "segments per texel", cmap="inferno", clim=(0.0, top), n_labels=n_labels,
                   fmt="%.0f")
    out = viz.finish(plotter, args.screenshot, title="pyshadow: CSM segments per texel")
    if out:
        print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

# Layered depth maps of a mesh and the order in which a CSM visits its map directions.
#
# Top: the first and second depth layers (pyshadow.render_depth, depth peeling)
# of a mesh (default: the bundled Stanford bunny) for a few map directions of a
# zigzag view set, in the object's normalised frame (depth 0 on the near side
# of the bounding sphere, 1 on the far side; texels with no surface are left
# out). Bottom: the directions of a zigzag and of a Hilbert view set on the
# unit sphere, coloured by compression order and joined in that order.
#
#   python examples/depth_maps.py                      # interactive window
#   python examples/depth_maps.py teapot.obj --maps 5 --screenshot depth.png
from __future__ import annotations

import argparse

import numpy as np


def polar_angles(d):
    """(theta, phi) in degrees of unit directions d (thesis eq. 5.1, y up)."""
    d = np.asarray(d, dtype=np.float64).reshape(-1, 3)
    theta = np.degrees(np.arccos(np.clip(d[:, 1], -1.0, 1.0)))
    phi = np.degrees(np.arctan2(d[:, 2], d[:, 0])) % 360.0
    return theta, phi


def pick_maps(views, count):
    """Indices of up to ``count`` maps spread evenly over a zigzag set's order, after its first row
    (from the first map where fewer than ``count`` follow that row; 2x1 maps had one map left)."""
    first = views.params["phi"] if views.params["theta"] > 1 else 0
    if len(views) - first < count:
        first = 0
    return np.unique(np.round(np.linspace(first, len(views) - 1, count)).astype(int))


def main(argv=None):
    parser = argparse.ArgumentParser(
        description="Depth layers of a mesh for several map directions, and view-set orders "
                    "(zigzag beside Hilbert) on the sphere.")
    parser.add_argument("mesh", nargs="?", metavar="MESH",
                        help="mesh file (default: the bundled Stanford bunny)")
    parser.add_argument("--maps", type=int, default=4, help="map directions shown (2 .. 8)")
    parser.add_argument("--resolution", type=int, default=128, help="depth-map texels per side")
    parser.add_argument("--theta", type=int, default=16, help="zigzag rows")
    parser.add_argument("--phi", type=int, default=32, help="zigzag columns")
    parser.add_argument("--level", type=int, default=4, help="Hilbert level")
    parser.add_argument("--single-square", action="store_true",
                        help="Hilbert: one octahedral square (4^level maps) instead of one "
                             "square per hemisphere (2*4^level, as many as zigzag 2^l x 2^(l+1))")
    from pyshadow import viz

    viz.add_window_options(parser, window=(1200, 1100))
    args = parser.parse_args(argv)
    if not 2 <= args.maps <= 8:
        parser.error(f"--maps must be in 2..8, got {args.maps}")

    import pyshadow
    import pyshadow.data

    try:
        mesh = pyshadow.load_mesh(args.mesh) if args.mesh else pyshadow.data.bunny()
        zigzag = pyshadow.ViewSet.zigzag(args.theta, args.phi)
        hilbert = pyshadow.ViewSet.hilbert(args.level, hemispheres=not args.single_square)
        idx = pick_maps(zigzag, args.maps)
        if len(idx) < 2:            # the layout has two columns at least (zigzag 1x1 crashed in pyvista)
            parser.error(f"zigzag {args.theta}x{args.phi} has {len(zigzag)} map; --theta and --phi "
                         "must give 2 or more")
        chosen = pyshadow.ViewSet(zigzag.directions[idx], zigzag.bases[idx])
        depth = pyshadow.render_depth(mesh, chosen, resolution=args.resolution, layers=2)   # (n, 2, R, R)
    except (FileNotFoundError, ValueError) as exc:
        parser.error(str(exc))
    name = args.mesh or "bunny"
    theta, phi = polar_angles(chosen.directions)
    for k, i in enumerate(idx):
        hit1 = np.isfinite(depth[k, 0]).mean()
        hit2 = np.isfinite(depth[k, 1]).mean()
        print(f"map {i:5d} (theta {theta[k]:5.1f}, phi {phi[k]:5.1f} deg): "
              f"layer 1 covers {100 * hit1:.1f}% of texels, layer 2 {100 * hit2:.1f}%")

    n = len(idx)
    half = max(1, n // 2)
    plotter = viz.script_plotter(parser, args, (5, n),
                                 groups=[(2, np.s_[:]), (3, np.s_[:half]), (3, np.s_[half:]), (4, np.s_[:])],
                                 row_weights=[1.0, 1.0, 0.2, 1.6, 0.2])
    titles = {(layer, k): f"map {i} layer {layer + 1}: theta {theta[k]:.0f}, phi {phi[k]:.0f}"
              for k, i in enumerate(idx) for layer in range(2)}
    longest = max(titles.values(), key=len)
    for (layer, k), title in titles.items():
        plotter.subplot(layer, k)
        viz.image_panel(plotter, depth[k, layer], cmap="viridis", clim=(0.0, 1.0), origin="lower",
                        title=title, title_fit=longest)
    plotter.subplot(2, 0)
    viz.colour_bar(plotter, f"{name}: depth (0 = near side of the bounding sphere, 1 = far side)",
                   cmap="viridis", clim=(0.0, 1.0))

    sets = [(zigzag, f"zigzag {args.theta}x{args.phi}: {len(zigzag)} maps"),
            (hilbert, f"hilbert level {args.level}"
                      f"{'' if args.single_square else ' (two hemispheres)'}: {len(hilbert)} maps")]
    renderers = []
    for col, (views, title) in zip((0, half), sets):
        plotter.subplot(3, col)
        viz.add_view_set(plotter, views, cmap="turbo")
        viz.add_title(plotter, title, fit=max((t for _, t in sets), key=len))
        viz.look_at_bodies(plotter, (0.0, 0.0, 0.0), 1.0, direction=(0.8, 0.9, 1.3), fill=0.85)
        renderers.append(plotter.renderers.loc_to_index((3, col)))
    plotter.link_views(renderers)
    plotter.subplot(4, 0)
    viz.colour_bar(plotter, "compression order (0 = first map, 1 = last map)", cmap="turbo",
                   clim=(0.0, 1.0), n_labels=5)
    out = viz.finish(plotter, args.screenshot, title="pyshadow: depth maps and view-set order")
    if out:
        print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

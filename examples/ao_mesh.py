# Per-vertex ambient occlusion of a mesh on a ground plane: pyshadow beside Embree.
#
# Builds a Coherent Shadow Map of each mesh (default: the bundled Stanford
# bunny), stands the meshes on a ground plane in a pyshadow.Scene with a
# receiver grid on the ground, and computes per-vertex AO with the CSM
# visibility kernel and with the embreex reference on the identical sample
# directions. Three linked 3-D views: pyshadow, Embree (one shared AO colour
# bar) and their difference (a diverging colour bar).
#
#   python examples/ao_mesh.py                       # interactive window
#   python examples/ao_mesh.py spot.obj cow.obj --screenshot ao.png
#   python examples/ao_mesh.py --footprint           # CSMs with footprint intervals
from __future__ import annotations

import argparse
import time

import numpy as np


def build_scene(meshes, theta, phi, resolution, ground_divisions, footprint=False):
    """Scene with the meshes (radius 1, side by side along x) and a ground receiver grid.

    Returns the scene, the caster ids and the ground grid's id.
    """
    import pyshadow
    from pyshadow import viz

    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(theta, phi),
                           resolution=resolution, footprint=footprint)
    spacing = 2.4
    xs = (np.arange(len(meshes)) - 0.5 * (len(meshes) - 1)) * spacing
    ids = [scene.add(m, viz.stand_on_ground(m, radius=1.0, position=(x, 0.0)))
           for m, x in zip(meshes, xs)]
    size = spacing * len(meshes) + 2.5
    grid = viz.ground_grid((0.0, 0.0), size, ground_divisions)
    gid = scene.add(grid, casts=False)
    return scene, ids, gid


def vertex_ao_both(scene, instance_id, sampling):
    """Per-vertex AO from pyshadow and from Embree on the same directions; (V,) float32 each."""
    from pyshadow import embree

    pts, nrm = scene.vertex_points(instance_id)
    bad = np.linalg.norm(nrm, axis=1) == 0      # isolated vertices: vertex_ao uses +y
    if bad.any():
        nrm = nrm.copy()
        nrm[bad] = [0.0, 1.0, 0.0]
    # one vertex first, untimed: the first query builds the kernels and uploads the CSMs
    # (10x a warm vertex_ao of the bunny), which the printed times leave out
    scene.ambient_occlusion(pts[:1], nrm[:1], sampling=sampling, surface_ids=instance_id)
    scene.visible(pts[:1], nrm[:1], surface_ids=instance_id, normals=nrm[:1])   # concave corners' samples
    embree.ambient_occlusion(scene, pts[:1], nrm[:1], sampling=sampling)
    t0 = time.perf_counter()
    ao = scene.vertex_ao(instance_id, sampling=sampling)
    t1 = time.perf_counter()
    ref = embree.ambient_occlusion(scene, pts, nrm, sampling=sampling)
    t2 = time.perf_counter()
    return ao, ref, t1 - t0, t2 - t1


def main(argv=None):
    parser = argparse.ArgumentParser(
        description="Per-vertex ambient occlusion of meshes on a ground plane: pyshadow beside Embree.")
    parser.add_argument("meshes", nargs="*", metavar="MESH",
                        help="mesh files (default: the bundled Stanford bunny)")
    parser.add_argument("--theta", type=int, default=32, help="zigzag rows of map directions")
    parser.add_argument("--phi", type=int, default=64, help="zigzag columns of map directions")
    parser.add_argument("--resolution", type=int, default=64, help="CSM texels per side")
    parser.add_argument("--samples", type=int, default=64, help="AO samples per vertex")
    parser.add_argument("--footprint", action="store_true",
                        help="CSMs with footprint intervals (CoherentShadowMap.build(..., footprint=True))")
    parser.add_argument("--ground-divisions", type=int, default=64,
                        help="quads per side of the ground receiver grid")
    from pyshadow import viz

    viz.add_window_options(parser, window=(1500, 620))
    args = parser.parse_args(argv)

    import pyshadow
    import pyshadow.data

    try:
        meshes = [pyshadow.load_mesh(p) for p in args.meshes] or [pyshadow.data.bunny()]
        sampling = pyshadow.Sampling(args.samples)
        t0 = time.perf_counter()
        scene, ids, gid = build_scene(meshes, args.theta, args.phi, args.resolution,
                                      args.ground_divisions, args.footprint)
        t_build = time.perf_counter() - t0
    except (FileNotFoundError, ValueError) as exc:
        parser.error(str(exc))
    names = [str(p) for p in args.meshes] or ["bunny"]
    ours, refs = {}, {}
    t_ours = t_ref = 0.0
    for i in ids + [gid]:
        ours[i], refs[i], a, b = vertex_ao_both(scene, i, sampling)
        t_ours += a
        t_ref += b
    diff = {i: ours[i] - refs[i] for i in ours}
    allo = np.concatenate([ours[i] for i in ids])
    allr = np.concatenate([refs[i] for i in ids])
    alld = allo - allr
    stats = scene.instances[ids[0]].csm.stats
    print(f"meshes: {', '.join(names)}; {stats['maps']} maps of {stats['resolution']}^2, "
          f"{args.samples} samples{', footprint intervals' if args.footprint else ''}; "
          f"CSMs built in {t_build:.2f} s")
    print(f"vertices {len(allo)}: mean AO pyshadow {allo.mean():.4f}, Embree {allr.mean():.4f}; "
          f"mean |diff| {np.abs(alld).mean():.4f}, max |diff| {np.abs(alld).max():.4f}")
    print(f"time: pyshadow {t_ours:.2f} s, Embree {t_ref:.2f} s")

    lim = float(max(0.05, np.percentile(np.abs(alld), 99.5)))
    plotter = viz.script_plotter(parser, args, (2, 3), groups=[(1, np.s_[0:2])], row_weights=[1.0, 0.13])
    spheres = [scene.instances[i].world_sphere() for i in ids]
    centre = np.mean([c for c, _ in spheres], axis=0)
    radius = max(float(np.linalg.norm(c - centre)) + r for c, r in spheres)
    panels = [
        (ours, "gray", (0.0, 1.0),
         f"pyshadow CSM ({stats['maps']} maps, {stats['resolution']}^2"
         f"{', footprint' if stats['footprint'] else ''}): mean AO {allo.mean():.3f}"),
        (refs, "gray", (0.0, 1.0), f"Embree reference: mean AO {allr.mean():.3f}"),
        (diff, "RdBu_r", (-lim, lim), f"pyshadow - Embree: mean abs. difference {np.abs(alld).mean():.3f}"),
    ]
    for col, (values, cmap, clim, title) in enumerate(panels):
        plotter.subplot(0, col)
        # AO unlit, so its grey reads straight off the colour bar; the difference lit, for shape
        viz.scene_to_plotter(scene, plotter, values, cmap=cmap, clim=clim, ground=False,
                             lighting=col == 2)
        viz.add_title(plotter, title, fit=max((p[3] for p in panels), key=len))
        viz.look_at_bodies(plotter, centre, 1.15 * radius)
    plotter.link_views([plotter.renderers.loc_to_index((0, c)) for c in range(3)])
    plotter.subplot(1, 0)
    viz.colour_bar(plotter, "ambient occlusion (1 = open)", cmap="gray", clim=(0.0, 1.0))
    plotter.subplot(1, 2)
    viz.colour_bar(plotter, "AO difference", cmap="RdBu_r", clim=(-lim, lim), n_labels=3)
    out = viz.finish(plotter, args.screenshot, title="pyshadow: vertex AO vs Embree")
    if out:
        print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

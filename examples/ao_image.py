# AO images of a scene from a camera: pyshadow's AO, bent normals, filtered AO, Embree.
#
# Renders the bundled scene (Stanford bunny and a torus on a ground plane
# between two walls, pyshadow.data.default_scene) with Scene.render: the raw
# per-pixel AO, the bent normals (world x, y, z mapped from [-1, 1] to red,
# green, blue), the AO after the joint bilateral filter guided by depth and
# normals, and the embreex reference on the identical sample directions.
# The three AO panels share one colour bar.
#
#   python examples/ao_image.py                          # interactive window
#   python examples/ao_image.py --width 320 --height 240 --screenshot ao.png
from __future__ import annotations

import argparse
import time

import numpy as np


def main(argv=None):
    parser = argparse.ArgumentParser(
        description="AO, bent normals, filtered AO and the Embree reference of the bundled scene.")
    parser.add_argument("--width", type=int, default=640, help="image width in pixels")
    parser.add_argument("--height", type=int, default=480, help="image height in pixels")
    parser.add_argument("--samples", type=int, default=36, help="AO samples per pixel")
    parser.add_argument("--theta", type=int, default=32, help="zigzag rows of the CSM maps")
    parser.add_argument("--phi", type=int, default=64, help="zigzag columns of the CSM maps")
    parser.add_argument("--resolution", type=int, default=64, help="CSM texels per side")
    from pyshadow import viz

    viz.add_window_options(parser, window=(1300, 1080))
    args = parser.parse_args(argv)

    import pyshadow
    import pyshadow.data
    from pyshadow import embree

    try:
        t0 = time.perf_counter()
        scene, camera = pyshadow.data.default_scene(
            views=pyshadow.ViewSet.zigzag(args.theta, args.phi), resolution=args.resolution,
            width=args.width, height=args.height)
        t_build = time.perf_counter() - t0
        sampling = pyshadow.Sampling(args.samples)
        # a tiny frame first, untimed: the first render builds the kernels and uploads the CSMs
        # (10x a warm 240x180 render), and Embree's builds its sample kernel; the printed times
        # leave that out
        tiny = pyshadow.Camera(camera.eye, camera.target, camera.up, camera.fov_y, width=16, height=12)
        scene.render(tiny, sampling=sampling, denoise="bilateral")
        embree.render(scene, tiny, sampling=sampling)
        t0 = time.perf_counter()
        raw = scene.render(camera, sampling=sampling)
        t_raw = time.perf_counter() - t0
    except ValueError as exc:
        parser.error(str(exc))
    t0 = time.perf_counter()
    filt = scene.render(camera, sampling=sampling, denoise="bilateral")
    t_filt = time.perf_counter() - t0
    t0 = time.perf_counter()
    ref = embree.render(scene, camera, sampling=sampling)
    t_ref = time.perf_counter() - t0

    empty = raw["object_id"] == -1
    hit = ~empty
    err = np.abs(raw["ao"] - ref["ao"])[hit]
    ferr = np.abs(filt["ao"] - ref["ao"])[hit]
    print(f"{args.width}x{args.height} pixels, {args.samples} samples, "
          f"{len(scene.casters)} casters ({args.theta}x{args.phi} maps of {args.resolution}^2, "
          f"built in {t_build:.2f} s)")
    print(f"time: pyshadow {t_raw:.2f} s, with bilateral filter {t_filt:.2f} s, Embree {t_ref:.2f} s")
    print(f"mean AO {raw['ao'][hit].mean():.4f} (Embree {ref['ao'][hit].mean():.4f}); "
          f"mean abs. difference to Embree: raw {err.mean():.4f}, filtered {ferr.mean():.4f}")

    plotter = viz.script_plotter(parser, args, (3, 2), groups=[(2, np.s_[:])], row_weights=[1.0, 1.0, 0.14])
    panels = [
        ((0, 0), raw["ao"], f"pyshadow AO, {args.samples} samples ({t_raw:.2f} s)"),
        ((0, 1), viz.bent_normal_rgb(raw["bent_normal"]), "bent normals: x, y, z as red, green, blue"),
        ((1, 0), filt["ao"], "AO after the joint bilateral filter"),
        ((1, 1), ref["ao"], f"Embree reference ({t_ref:.2f} s): mean abs. diff. {err.mean():.3f}"),
    ]
    for (r, c), image, title in panels:
        plotter.subplot(r, c)
        viz.image_panel(plotter, image, cmap="gray", clim=(0.0, 1.0), mask=empty, title=title,
                        title_fit=max((p[2] for p in panels), key=len))
    plotter.subplot(2, 0)
    viz.colour_bar(plotter, "ambient occlusion (1 = open)", cmap="gray", clim=(0.0, 1.0))
    out = viz.finish(plotter, args.screenshot, title="pyshadow: AO images")
    if out:
        print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

# The bundled scene lit by a clear sky and its sun, with the bunny moving between frames.
#
# Lighting.clear_sky gives the Preetham sky (turbidity --turbidity) as
# spherical harmonics and its sun, placed by sun_position(--latitude, --day,
# --hour), as a directional light. Each frame moves the bunny along a short
# path and turns it (Scene.set_transform; its Coherent Shadow Map is reused),
# then pyshadow.render.render(..., lighting=) fills Frame.radiance: the sky
# at the bent normal times AO ("bent" mode) plus the sun with its shadow
# from the CSMs. The radiance is tone-mapped (pyshadow.lighting.tonemap,
# sRGB curve) with one exposure for every frame, taken from the first: its
# 99th-percentile luminance maps to 0.8. The window shows the first and the
# last frame side by side.
#
#   python examples/lit_scene.py                                # interactive window
#   python examples/lit_scene.py --frames 8 --screenshot lit.png --save-frames
from __future__ import annotations

import argparse
import os
import time

import numpy as np

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])      # Rec. 709


def yaw_about(centre, deg):
    """4x4 rotation by ``deg`` about the vertical axis through ``centre``."""
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    T = np.eye(4)
    T[:3, :3] = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
    T[:3, 3] = centre - T[:3, :3] @ centre
    return T


def bunny_transform(start, frame, frames):
    """The bunny at ``frame`` of ``frames``: moved up to 0.6 to the left and 0.5 forward, turned 60 deg."""
    t = frame / max(frames - 1, 1)
    centre = start[:3, 3]
    move = np.eye(4)
    move[:3, 3] = [-0.6 * t, 0.0, 0.5 * t]
    return move @ yaw_about(centre, 60.0 * t) @ start


def main(argv=None):
    parser = argparse.ArgumentParser(
        description="The bundled scene lit by a clear sky and the sun, the bunny moving between frames.")
    parser.add_argument("--width", type=int, default=480, help="image width in pixels")
    parser.add_argument("--height", type=int, default=360, help="image height in pixels")
    parser.add_argument("--samples", type=int, default=36, help="AO samples per pixel")
    parser.add_argument("--theta", type=int, default=32, help="zigzag rows of the CSM maps")
    parser.add_argument("--phi", type=int, default=64, help="zigzag columns of the CSM maps")
    parser.add_argument("--resolution", type=int, default=64, help="CSM texels per side")
    parser.add_argument("--frames", type=int, default=4, help="frames of the bunny's motion (>= 2)")
    parser.add_argument("--latitude", type=float, default=45.0, help="degrees north")
    parser.add_argument("--day", type=float, default=172.0, help="day of the year (172: 21 June)")
    parser.add_argument("--hour", type=float, default=10.0, help="local solar time")
    parser.add_argument("--turbidity", type=float, default=3.0, help="Preetham turbidity (1.7 .. 10)")
    parser.add_argument("--save-frames", action="store_true",
                        help="also write every tone-mapped frame as OUT_0000.png, OUT_0001.png, ...")
    from pyshadow import viz

    viz.add_window_options(parser, window=(1300, 560))
    args = parser.parse_args(argv)
    if args.frames < 2:
        parser.error(f"--frames must be >= 2, got {args.frames}")
    if args.save_frames and not args.screenshot:
        parser.error("--save-frames needs --screenshot")

    import pyshadow
    import pyshadow.data
    from pyshadow import render as render_stage
    from pyshadow.lighting import Lighting, sun_position, tonemap

    try:
        sun = sun_position(args.latitude, args.day, args.hour)
        if sun[1] <= 0.0:
            parser.error(f"the sun is below the horizon at latitude {args.latitude}, day {args.day}, "
                         f"hour {args.hour}")
        lighting = Lighting.clear_sky(sun, args.turbidity)
        t0 = time.perf_counter()
        scene, camera = pyshadow.data.default_scene(
            views=pyshadow.ViewSet.zigzag(args.theta, args.phi), resolution=args.resolution,
            width=args.width, height=args.height)
        t_build = time.perf_counter() - t0
        sampling = pyshadow.Sampling(args.samples)
    except ValueError as exc:
        parser.error(str(exc))
    bunny = 0                                              # DEFAULT_PARTS order: bunny first
    start = scene.instances[bunny].transform.copy()
    elevation = np.degrees(np.arcsin(sun[1]))
    print(f"{args.width}x{args.height} pixels, {args.samples} samples, {len(scene.casters)} casters "
          f"({args.theta}x{args.phi} maps of {args.resolution}^2, built in {t_build:.2f} s)")
    print(f"clear sky, turbidity {args.turbidity:g}; sun at {elevation:.1f} deg elevation, direction "
          f"({sun[0]:.3f}, {sun[1]:.3f}, {sun[2]:.3f})")

    render_stage.render(scene, camera, sampling=sampling, lighting=lighting)   # warm-up: kernel builds
    images, times, exposure = [], [], None
    # OUT of OUT.jpg too (out.jpg wrote out.jpg_0000.png)
    stem = os.path.splitext(args.screenshot)[0] if args.screenshot else None
    for f in range(args.frames):
        t = time.perf_counter()
        scene.set_transform(bunny, bunny_transform(start, f, args.frames))
        frame = render_stage.render(scene, camera, sampling=sampling, lighting=lighting)
        times.append(time.perf_counter() - t)
        covered = frame.object_id != -1
        if exposure is None:                 # one exposure for all frames: no flicker
            lum = frame.radiance[covered].astype(np.float64) @ LUMINANCE
            p99 = float(np.percentile(lum, 99.0)) if lum.size else 0.0
            exposure = 0.8 / p99 if p99 > 0 else 1.0
        rgb = tonemap(frame.radiance, exposure)
        images.append((rgb, ~covered))
        if args.save_frames:
            pyshadow.write_image(f"{stem}_{f:04d}.png", rgb)
        lum = frame.radiance[covered].astype(np.float64) @ LUMINANCE
        print(f"frame {f + 1}/{args.frames}: mean luminance {lum.mean():.1f} cd/m^2, "
              f"{1e3 * times[-1]:.0f} ms")
    med = float(np.median(times))
    print(f"lit frames per second: {1.0 / med:.2f} (median {1e3 * med:.1f} ms: set_transform + render "
          f"with lighting; device {pyshadow.device_info()['name']}); exposure {exposure:.3g}")

    plotter = viz.script_plotter(parser, args, (1, 2))
    panels = [(0, images[0], f"frame 1/{args.frames}"),
              (1, images[-1], f"frame {args.frames}/{args.frames}: bunny moved and turned")]
    for c, (rgb, mask), title in panels:
        plotter.subplot(0, c)
        viz.image_panel(plotter, rgb, mask=mask, title=title,
                        title_fit=max((p[2] for p in panels), key=len))
    out = viz.finish(plotter, args.screenshot, title="pyshadow: lit scene")
    if out:
        print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

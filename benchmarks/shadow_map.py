"""Time per frame for a moving body under one sun: the CSM against the re-rendered shadow map (issue 20).

The bundled scene (``pyshadow.data.default_scene``: bunny and torus on the
ground, CSMs of 64x128 maps @ 128^2) at 640x480; the torus moves along a
circle around the bunny (and turns), one ``Scene.set_transform`` a frame.
Each frame the covered pixels (G-buffer re-rendered, not timed: the same for
every method) ask for the sun's visibility of every pixel, interleaved in
one run (the order turns each frame):

* ``csm`` / ``csm-vote``: the visibility kernel, nothing to redo after
  ``set_transform`` (the instance table is rewritten);
* ``sm1024`` / ``sm4096`` / ``smE`` (E: the resolution whose float32 map
  holds as many bytes as the scene's CSMs): the classic shadow map
  (:class:`pyshadow.lighting.shadow_map.ShadowMapVisibility`, hard lookup)
  rendered again after the move, then looked up; its render and its lookup
  are also timed apart (the lookup alone is what a static scene costs).

Printed: medians over the frames, the ratios to ``csm``, the bytes each
method keeps (the CSMs of the caster types; one depth map), and the
agreement with Embree per frame over the pixels with n.l >= 0.1.

    python benchmarks/shadow_map.py [--frames 12] [--width 640 --height 480] [--json]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

from _common import check_counts, emit, environment

SUN = (-30.0, 35.0)             # azimuth, elevation in degrees
RESOLUTIONS = (1024, 4096)


def sun_direction(azimuth, elevation):
    a, e = np.radians(azimuth), np.radians(elevation)
    return np.array([np.cos(e) * np.cos(a), np.sin(e), np.cos(e) * np.sin(a)])


def path(T0, centre, k, frames):
    """The moving body's transform at frame ``k``: a circle of radius 1.3 about ``centre`` in y = const, turned."""
    import trimesh

    a = 2 * np.pi * k / frames
    T = T0.copy()
    T[:3, :3] = trimesh.transformations.rotation_matrix(a, [0, 1, 0])[:3, :3] @ T0[:3, :3]
    T[0, 3] = centre[0] + 1.3 * np.cos(a)
    T[2, 3] = centre[2] + 1.3 * np.sin(a)
    return T


def main(argv=None) -> int:
    import pyshadow
    from pyshadow import _cl, embree, render, visibility
    from pyshadow.lighting.shadow_map import ShadowMapVisibility

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    check_counts(ap, args, "width", "height", "frames")
    scene, cam = pyshadow.data.default_scene(width=args.width, height=args.height)
    mover, still = scene.casters[1], scene.casters[0]
    T0 = scene.transform(mover)
    centre = scene.instances[still].world_sphere()[0]
    l = sun_direction(*SUN)
    types, _ = scene.caster_types()
    csm_bytes = int(sum(c.stats["bytes"] for c in types))
    equal = int(np.sqrt(csm_bytes / 4))         # the shadow map of the CSMs' memory (float32 texels)
    maps = {f"sm{r}": ShadowMapVisibility(r) for r in sorted({*RESOLUTIONS, equal})}
    methods = ["csm", "csm-vote", *maps]
    times = {m: [] for m in methods} | {f"{m}_render": [] for m in maps} | {f"{m}_lookup": [] for m in maps}
    agree = {m: [] for m in methods}
    npix = []
    for k in range(-1, args.frames):            # frame -1 warms every kernel up, not counted
        scene.set_transform(mover, path(T0, centre, k, args.frames))     # frame -1: a place of its own
        sp = render.surface_points(scene, cam)
        P = np.asarray(sp.points, np.float64)
        N = np.asarray(sp.normals, np.float64)
        N /= np.linalg.norm(N, axis=1, keepdims=True)
        W = np.ascontiguousarray(np.broadcast_to(l, P.shape))
        ids = sp.surface_ids
        sel = N @ l >= 0.1
        truth = embree.visible(scene, P[sel], W[sel])
        order = methods[k % len(methods):] + methods[:k % len(methods)]
        for m in order:
            backend = maps.get(m, m)
            _cl.queue().finish()
            t0 = time.perf_counter()
            v = visibility.visible(scene, P, W, backend=backend, normals=N, surface_ids=ids)
            dt = time.perf_counter() - t0
            if k < 0:
                continue
            times[m].append(dt)
            agree[m].append(float(np.mean(v[sel] == truth)))
            if m in maps:       # the parts apart: render again (cache cleared), then the lookup alone
                sm = maps[m]
                sm.clear()
                t0 = time.perf_counter()
                sm.shadow_map(scene, direction=l)
                _cl.queue().finish()
                t1 = time.perf_counter()
                sm.visible(scene, P, W, normals=N, surface_ids=ids)
                times[f"{m}_render"].append(t1 - t0)
                times[f"{m}_lookup"].append(time.perf_counter() - t1)
        if k >= 0:
            npix.append(len(P))
    med = {m: 1e3 * statistics.median(t) for m, t in times.items()}
    mem = {"csm": csm_bytes, "csm-vote": csm_bytes} | {m: int(sm.shadow_map(scene, direction=l).nbytes)
                                                      for m, sm in maps.items()}
    result = {"benchmark": "shadow_map", **environment(), "frames": args.frames, "width": args.width,
              "height": args.height, "sun_deg": list(SUN), "pixels_median": int(np.median(npix)),
              "median_ms": med, "ratio_to_csm": {m: med[m] / med["csm"] for m in med},
              "bytes": mem, "agreement": {m: {"min": min(a), "mean": float(np.mean(a)), "per_frame": a}
                                          for m, a in agree.items()}}
    if args.json:
        emit(result, True)
        return 0
    print(f"bundled scene, torus moving, sun {SUN} deg, {args.width}x{args.height} "
          f"({result['pixels_median']} covered pixels), medians over {args.frames} frames:")
    for m in methods:
        extra = (f" (render {med[m + '_render']:.1f} ms + lookup {med[m + '_lookup']:.1f} ms)" if m in maps else
                 " (no update after set_transform)")
        a = agree[m]
        print(f"  {m:9s} {med[m]:8.1f} ms/frame = {med[m] / med['csm']:6.2f} x csm{extra}; "
              f"{mem[m] / 2 ** 20:7.2f} MiB; agreement with Embree min/mean {100 * min(a):.2f}/"
              f"{100 * np.mean(a):.2f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Hard shadows of point and directional lights against Embree on identical shadow rays (issue 20's acceptance).

For each scene -- the bundled scene (``pyshadow.data.default_scene``) and the
two-object scene of benchmarks/accuracy.py section 2 (bunny and a turned
fandisk on the ground, CSMs of 64x128 maps @ 128^2) -- and each light:

* point lights (all outside every caster's bounding sphere): the segment
  from each pixel to the light (``max_distance`` = the distance to it);
* directional lights (three suns, one low at 25 degrees elevation): the
  unbounded ray towards the sun;

over the covered pixels (640x480) whose normal has n.l >= 0.1, asked of
the CSM (one-texel and vote, with the pixels' normals and surface ids: the
surface rule), of the classic shadow map re-rendered from the light
(:class:`pyshadow.lighting.shadow_map.ShadowMapVisibility`, hard lookup,
its receiver-plane bias rule; orthographic maps of 1024^2 and 4096^2 for
suns, cube maps of six 1024^2 / 4096^2 faces for point lights) and of
Embree. Printed: the agreement of each with Embree per light, the
shadowed fraction, the times (a shadow map's includes rendering it), min
and mean over the lights, and per scene the aggregate agreement over all
pixels of all its lights (point, directional, both).

    python benchmarks/direct_light.py [--width 640 --height 480] [--maps 64x128] [--json]
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from _common import check_counts, emit, environment, load_mesh, parse_grid

POINT_LIGHTS = {
    "bundled": [(0.8, 3.2, 1.6), (-1.6, 1.8, 2.2), (3.0, 1.4, 1.2)],
    "two-object": [(0.9, 3.0, 1.8), (-1.5, 1.6, 1.5), (3.4, 1.5, 1.6)],
}
#: suns as (azimuth about +y from +x, elevation), degrees; the same three on both scenes
SUNS = [(40.0, 60.0), (120.0, 40.0), (-30.0, 25.0)]
SM_RESOLUTIONS = (1024, 4096)
METHODS = ("csm", "csm-vote") + tuple(f"sm{r}" for r in SM_RESOLUTIONS)
TARGETS = {"csm": 0.995, "csm-vote": 0.997}


def sun_direction(azimuth, elevation):
    a, e = np.radians(azimuth), np.radians(elevation)
    return np.array([np.cos(e) * np.cos(a), np.sin(e), np.cos(e) * np.sin(a)])


def two_object_scene(width, height, maps=(64, 128)):
    """accuracy.py section 2's scene (CSMs of ``maps`` zigzag maps @ 128^2) and a camera looking at both bodies."""
    import trimesh

    import pyshadow

    bunny, fandisk = load_mesh("stanford-bunny.obj"), load_mesh("fandisk.obj")
    views = pyshadow.ViewSet.zigzag(*maps)
    two = pyshadow.Scene(ground=0.0)
    two.add(pyshadow.CoherentShadowMap.build(bunny, views, resolution=128, progress=False),
            pyshadow.stand_on_ground(bunny), mesh=bunny)
    rot = trimesh.transformations.rotation_matrix(0.9, [0.3, 1.0, 0.2])[:3, :3]
    two.add(pyshadow.CoherentShadowMap.build(fandisk, views, resolution=128, layers=2, progress=False),
            pyshadow.stand_on_ground(fandisk, radius=0.8, position=(1.7, 0.4), rotation=rot), mesh=fandisk)
    cam = pyshadow.Camera([3.0, 2.6, 4.6], [0.85, 0.5, 0.2], fov_y=45.0, width=width, height=height)
    return two, cam


def pixels(scene, cam):
    """World points, unit normals and surface ids of the covered pixels."""
    from pyshadow import render

    sp = render.surface_points(scene, cam)
    n = np.asarray(sp.normals, np.float64)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return np.asarray(sp.points, np.float64), n, sp.surface_ids


def _timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, 1e3 * (time.perf_counter() - t0)


def measure(scene, px, light, kind, maps):
    """One light: agreement of every method with Embree on the identical rays."""
    from pyshadow import embree, visibility

    points, normals, surface_ids = px
    if kind == "point":
        for i in scene.casters:
            c, r = scene.instances[i].world_sphere()
            if np.linalg.norm(np.asarray(light) - c) <= r * (1 + 1e-6):
                raise SystemExit(f"light {light} lies inside caster {i}'s bounding sphere")
        d = np.asarray(light, np.float64) - points
        dist = np.linalg.norm(d, axis=1)
        w = d / dist[:, None]
    else:
        w = np.broadcast_to(np.asarray(light, np.float64), points.shape)
        dist = None
    sel = np.einsum("ij,ij->i", normals, w) >= 0.1
    P, W, N, ids = points[sel], np.ascontiguousarray(w[sel]), normals[sel], surface_ids[sel]
    T = None if dist is None else dist[sel]
    truth = embree.visible(scene, P, W, max_distance=T)
    row = {"kind": kind, "light": [float(x) for x in light], "pixels": int(sel.sum()),
           "shadowed": float(1 - truth.mean())}
    if kind == "point":
        truth_inf = embree.visible(scene, P, W)
        row["occluded_only_beyond_light"] = float(np.mean(truth & ~truth_inf))
    for backend in ("csm", "csm-vote"):
        kw = dict(backend=backend, surface_ids=ids, normals=N)
        visibility.visible(scene, P, W, max_distance=T, **kw)          # warm: compile
        v, ms = _timed(lambda: visibility.visible(scene, P, W, max_distance=T, **kw))
        row[backend] = float(np.mean(v == truth))
        row[backend + "_false_shadow"] = float(np.mean(~v & truth))
        row[backend + "_ms"] = ms
        if kind == "point":             # the same rays unbounded, against Embree unbounded
            u = visibility.visible(scene, P, W, **kw)
            row[backend + "_unbounded"] = float(np.mean(u == truth_inf))
    for name, sm in maps.items():
        v, ms = _timed(lambda: visibility.visible(scene, P, W, max_distance=T, backend=sm, normals=N,
                                                  surface_ids=ids))
        _, ms_lookup = _timed(lambda: visibility.visible(scene, P, W, max_distance=T, backend=sm, normals=N))
        row[name] = float(np.mean(v == truth))
        row[name + "_false_shadow"] = float(np.mean(~v & truth))
        row[name + "_ms"] = ms
        row[name + "_lookup_ms"] = ms_lookup
        row[name + "_bytes"] = int(sm.shadow_map(scene, **({"position": light} if kind == "point" else
                                                            {"direction": light})).nbytes)
    return row


def aggregate(rows):
    """Pixel-weighted agreement of each method over ``rows``."""
    total = sum(r["pixels"] for r in rows)
    return {m: float(sum(r[m] * r["pixels"] for r in rows) / total) for m in METHODS} | {"pixels": total}


def describe(row) -> str:
    light = tuple(round(x, 3) for x in row["light"])
    extra = (f" ({100 * row['occluded_only_beyond_light']:.1f} % lit only because the segment ends at the light)"
             if row["kind"] == "point" else "")
    cols = ", ".join(f"{m} {100 * row[m]:.2f} % ({row[m + '_ms']:.0f} ms)" for m in METHODS)
    return f"{row['scene']:10s} {row['kind']:11s} {light}: {row['pixels']} pixels, " \
           f"{100 * row['shadowed']:.1f} % shadowed{extra}: {cols}"


def main(argv=None) -> int:
    import pyshadow
    from pyshadow.lighting.shadow_map import ShadowMapVisibility

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--maps", default="64x128", help="zigzag map grid THETAxPHI of every CSM (default 64x128)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    check_counts(ap, args, "width", "height")
    grid = parse_grid(ap, args.maps)
    rows, per_scene = [], {}
    for name, lights in POINT_LIGHTS.items():
        scene, cam = (pyshadow.data.default_scene(width=args.width, height=args.height,
                                                  views=pyshadow.ViewSet.zigzag(*grid)) if name == "bundled"
                      else two_object_scene(args.width, args.height, grid))
        px = pixels(scene, cam)
        maps = {f"sm{r}": ShadowMapVisibility(r) for r in SM_RESOLUTIONS}
        for sm in maps.values():        # compile the kernels outside the timings (a light not measured)
            sm.visible(scene, px[0][:1], np.array([[0.0, 1.0, 0.0]]), normals=px[1][:1])
        todo = [("point", light) for light in lights] + [("directional", sun_direction(*s)) for s in SUNS]
        mine = []
        for kind, light in todo:
            row = {"scene": name, **measure(scene, px, light, kind, maps)}
            if kind == "directional":
                row["sun_deg"] = list(SUNS[len(mine) - len(lights)])
            mine.append(row)
            if not args.json:
                print(describe(row), flush=True)
        rows += mine
        per_scene[name] = {k: aggregate([r for r in mine if k == "all" or r["kind"] == k])
                           for k in ("point", "directional", "all")}
        if not args.json:
            for k, agg in per_scene[name].items():
                print(f"{name:10s} aggregate over {k} lights ({agg['pixels']} pixels): "
                      + ", ".join(f"{m} {100 * agg[m]:.2f} %" for m in METHODS), flush=True)
    summary = {m: {"min": min(r[m] for r in rows), "mean": float(np.mean([r[m] for r in rows]))} for m in METHODS}
    if args.json:
        emit({"benchmark": "direct_light", **environment(), "rows": rows, "summary": summary,
              "per_scene": per_scene, "targets": TARGETS}, True)
    else:
        print("agreement min/mean over the lights: " + ", ".join(
            f"{m} {100 * s['min']:.2f}/{100 * s['mean']:.2f} %" for m, s in summary.items())
            + f" (targets: one-texel {100 * TARGETS['csm']:.1f}, vote {100 * TARGETS['csm-vote']:.1f} per scene)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

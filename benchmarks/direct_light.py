"""Hard shadows of point lights against Embree on identical shadow rays (issue 20's acceptance).

For each scene -- the bundled scene (``pyshadow.data.default_scene``) and the
two-object scene of benchmarks/accuracy.py section 2 (bunny and a turned
fandisk on the ground, CSMs of 64x128 maps @ 128^2) -- and each point light
(all outside every caster's bounding sphere): the covered pixels (640x480)
whose normal has n.l >= 0.1 towards the light, the segment from each to the
light (``max_distance`` = the distance to the light), asked of the CSM (both
lookups, with the pixels' normals and surface ids: the surface rule) and of
Embree; the agreement is printed, with the shadowed fraction and the times
of the finite query and of the same rays unbounded.

    python benchmarks/direct_light.py [--width 640 --height 480] [--json]
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from _common import emit, environment, load_mesh

SCENES = {
    "bundled": [(0.8, 3.2, 1.6), (-1.6, 1.8, 2.2), (3.0, 1.4, 1.2)],
    "two-object": [(0.9, 3.0, 1.8), (-1.5, 1.6, 1.5), (3.4, 1.5, 1.6)],
}


def two_object_scene(width, height):
    """accuracy.py section 2's scene and a camera looking at both bodies."""
    import trimesh

    import pyshadow

    bunny, fandisk = load_mesh("stanford-bunny.obj"), load_mesh("fandisk.obj")
    views = pyshadow.ViewSet.zigzag(64, 128)
    two = pyshadow.Scene(ground=0.0)
    two.add(pyshadow.CoherentShadowMap.build(bunny, views, resolution=128, progress=False),
            pyshadow.stand_on_ground(bunny), mesh=bunny)
    rot = trimesh.transformations.rotation_matrix(0.9, [0.3, 1.0, 0.2])[:3, :3]
    two.add(pyshadow.CoherentShadowMap.build(fandisk, views, resolution=128, layers=2, progress=False),
            pyshadow.stand_on_ground(fandisk, radius=0.8, position=(1.7, 0.4), rotation=rot), mesh=fandisk)
    cam = pyshadow.Camera([3.0, 2.6, 4.6], [0.85, 0.5, 0.2], fov_y=45.0, width=width, height=height)
    return two, cam


def measure(scene, cam, light):
    from pyshadow import embree, render, visibility

    for i in scene.casters:
        c, r = scene.instances[i].world_sphere()
        if np.linalg.norm(np.asarray(light) - c) <= r * (1 + 1e-6):
            raise SystemExit(f"light {light} lies inside caster {i}'s bounding sphere")
    sp = render.surface_points(scene, cam)
    n = np.asarray(sp.normals, np.float64)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    d = np.asarray(light, np.float64) - sp.points
    dist = np.linalg.norm(d, axis=1)
    w = d / dist[:, None]
    sel = np.einsum("ij,ij->i", n, w) >= 0.1
    P, W, N, T, ids = sp.points[sel], w[sel], n[sel], dist[sel], sp.surface_ids[sel]
    truth = embree.visible(scene, P, W, max_distance=T)
    truth_inf = embree.visible(scene, P, W)
    row = {"light": list(map(float, light)), "pixels": int(sel.sum()), "shadowed": float(1 - truth.mean()),
           "occluded_only_beyond_light": float(np.mean(truth & ~truth_inf))}
    for backend in ("csm", "csm-vote"):
        kw = dict(backend=backend, surface_ids=ids, normals=N)
        v = visibility.visible(scene, P, W, max_distance=T, **kw)
        row[backend] = float(np.mean(v == truth))
        row[backend + "_false_shadow"] = float(np.mean(~v & truth))
        t0 = time.perf_counter()
        visibility.visible(scene, P, W, max_distance=T, **kw)
        t1 = time.perf_counter()
        u = visibility.visible(scene, P, W, **kw)
        t2 = time.perf_counter()
        # the same rays unbounded, against Embree unbounded: the directional-light baseline
        row[backend + "_unbounded"] = float(np.mean(u == truth_inf))
        row[backend + "_ms"] = {"finite": 1e3 * (t1 - t0), "unbounded": 1e3 * (t2 - t1)}
    return row


def main(argv=None) -> int:
    import pyshadow

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    rows = []
    for name, lights in SCENES.items():
        scene, cam = (pyshadow.data.default_scene(width=args.width, height=args.height) if name == "bundled"
                      else two_object_scene(args.width, args.height))
        for light in lights:
            row = {"scene": name, **measure(scene, cam, light)}
            rows.append(row)
            if not args.json:
                print(f"{name:10s} light {tuple(row['light'])}: {row['pixels']} pixels, "
                      f"{100 * row['shadowed']:.1f} % shadowed ({100 * row['occluded_only_beyond_light']:.1f} % "
                      f"lit only because the segment ends at the light): one-texel {100 * row['csm']:.2f} %, "
                      f"vote {100 * row['csm-vote']:.2f} % (unbounded rays: {100 * row['csm_unbounded']:.2f}, "
                      f"{100 * row['csm-vote_unbounded']:.2f} %); finite/unbounded ms: "
                      f"{row['csm_ms']['finite']:.0f}/{row['csm_ms']['unbounded']:.0f} (one-texel), "
                      f"{row['csm-vote_ms']['finite']:.0f}/{row['csm-vote_ms']['unbounded']:.0f} (vote)",
                      flush=True)
    summary = {k: {"min": min(r[k] for r in rows), "mean": float(np.mean([r[k] for r in rows]))}
               for k in ("csm", "csm-vote")}
    if args.json:
        emit({"benchmark": "direct_light", **environment(), "rows": rows, "summary": summary,
              "targets": {"csm": 0.995, "csm-vote": 0.997}}, True)
    else:
        print(f"agreement min/mean: one-texel {100 * summary['csm']['min']:.2f}/{100 * summary['csm']['mean']:.2f} %"
              f" (target 99.5), vote {100 * summary['csm-vote']['min']:.2f}/{100 * summary['csm-vote']['mean']:.2f}"
              f" % (target 99.7)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

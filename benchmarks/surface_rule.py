"""What the surface rule costs and buys away from grazing light: every bundled mesh, with and without it.

Each mesh of ``pyshadow.data.MESHES`` alone on the ground, scaled to unit
bounding radius, 64x128 maps @ 128^2 (``--maps``, ``--resolution``):

1. visibility agreement with Embree on AO rays (4000 points uniform on its
   faces, 16 cosine directions of their face normals) for both lookups,
   asked without the normals (the lookup before the rule, bit-identical),
   with them (the rule, as AO asks) and with them but the constant
   self-bias alone (``-const``: ``pyshadow.visibility.csm.PLANE_BIAS =
   False``, the code before the plane's bias); false shadow and false light
   beside;
2. per-point AO (3000 points, 64 samples) against Embree on the identical
   directions, mean |dAO| and mean signed dAO, with the plane's bias and
   without (AO always applies the rule: run this script on the code before
   it, with ``PYTHONPATH``, for that column).

    python benchmarks/surface_rule.py [--meshes stanford-bunny.obj,cow.obj] [--json]
"""
from __future__ import annotations

import argparse
import sys
from contextlib import contextmanager

import numpy as np
import trimesh

from _common import check_counts, check_meshes, emit, environment, parse_grid


def _unit_on_ground(name, views, resolution):
    import pyshadow

    mesh = pyshadow.data.mesh(name).copy()
    mesh.apply_translation(-mesh.bounding_sphere.primitive.center)
    mesh.apply_scale(1.0 / mesh.bounding_sphere.primitive.radius)
    csm = pyshadow.CoherentShadowMap.build(mesh, views, resolution=resolution, progress=False)
    scene = pyshadow.Scene(ground=float(mesh.bounds[0, 1]))
    scene.add(csm, mesh=mesh)
    return mesh, scene


def mesh_row(name, views, resolution, samples=16, points=4000, ao_points=3000, ao_samples=64) -> dict:
    import pyshadow
    from pyshadow import embree, visibility

    mesh, scene = _unit_on_ground(name, views, resolution)
    row = {"mesh": name}
    pts, face = trimesh.sample.sample_surface(mesh, points, seed=1)
    nrm = mesh.face_normals[face]
    d = pyshadow.sample_directions(nrm, sampling=pyshadow.Sampling(samples)).reshape(-1, 3).astype(np.float64)
    P, N = np.repeat(pts, samples, axis=0), np.repeat(nrm, samples, axis=0)
    truth = embree.visible(scene, P, d)
    has_rule = "normals" in visibility.visible.__code__.co_varnames
    for backend in ("csm", "csm-vote"):
        for rule, plane in (((False, None), (True, False), (True, True)) if has_rule else ((False, None),)):
            extra = {"normals": N} if rule else {}
            with _plane_bias(plane):
                vis = visibility.visible(scene, P, d, backend=backend, surface_ids=0, **extra)
            key = f"{backend}{'+rule' if rule else ''}{'-const' if plane is False else ''}"
            row[key] = {"agreement": float(np.mean(vis == truth)), "false_shadow": float(np.mean(truth & ~vis)),
                        "false_light": float(np.mean(vis & ~truth))}
    pts, face = trimesh.sample.sample_surface(mesh, ao_points, seed=7)
    nrm = mesh.face_normals[face]
    s = pyshadow.Sampling(ao_samples)
    ref = embree.ambient_occlusion(scene, pts, nrm, sampling=s)
    for lookup in ("nearest", "vote"):
        for plane in (False, True):
            with _plane_bias(plane):
                ao = scene.ambient_occlusion(pts, nrm, sampling=s, surface_ids=0, lookup=lookup)
            key = f"ao-{lookup}{'-const' if plane is False else ''}"
            row[key] = {"mean_abs": float(np.abs(ao - ref).mean()), "mean": float((ao - ref).mean())}
    return row


@contextmanager
def _plane_bias(on):
    """The plane's bias switched on or off (``None``: as it is; code before it: no switch, no change)."""
    from pyshadow.visibility import csm as backend

    was = getattr(backend, "PLANE_BIAS", None)
    if on is not None and was is not None:
        backend.PLANE_BIAS = on
    try:
        yield
    finally:
        if was is not None:
            backend.PLANE_BIAS = was


def main(argv=None) -> int:
    import pyshadow

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--meshes", default=",".join(pyshadow.data.MESHES))
    ap.add_argument("--maps", default="64x128")
    ap.add_argument("--resolution", type=int, default=128)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    check_meshes(ap, "--meshes", args.meshes.split(","), files=False)
    check_counts(ap, args, "resolution", most=4096)
    t, p = parse_grid(ap, args.maps)
    views = pyshadow.ViewSet.zigzag(t, p)
    rows = []
    for name in args.meshes.split(","):
        r = mesh_row(name, views, args.resolution)
        rows.append(r)
        if not args.json:
            cells = [f"{k} {100 * v['agreement']:.2f} (fs {100 * v['false_shadow']:.2f} fl "
                     f"{100 * v['false_light']:.2f})" for k, v in r.items() if k.startswith("csm")]
            cells += [f"{k} |d| {v['mean_abs']:.4f} {v['mean']:+.4f}" for k, v in r.items() if k.startswith("ao-")]
            print(f"{name:20s} " + " | ".join(cells), flush=True)
    if args.json:
        emit({"benchmark": "surface_rule", **environment(), "maps": args.maps, "resolution": args.resolution,
              "rows": rows}, True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The exposed-backs rule of ``two_sided='auto'`` against the set it samples: counts and what they buy.

``pyshadow.csm.exposed_back_faces`` marks the faces whose back a ray from
just behind the centroid leaves the mesh along, over a 64-direction lattice.
Two measurements of that choice:

1. **Counts against the lattice**: per mesh (``--meshes``), the faces (and
   area) found at 32 ... 1024 directions, the faces a lattice finds that the
   one of half its size missed (the lattices are not nested), and the time.
2. **Points on the inner side** (``--inner``, default the bunny and the
   teapot): 6000 points area-uniform on the faces' back sides, 16 cosine
   directions of the back normal each, asked of the mesh alone (no ground)
   with ``surface_ids`` and the back normal, one-texel and vote lookups,
   against Embree on the identical rays. CSMs built four ways: ``False`` (no
   face marked), ``'auto'`` (the default, 64 directions), every face with
   an escaping ray at 1024 directions (the set the default samples, nearer
   converged), ``True`` (the margin before every second surface). Points
   split by their face's escape fraction at 1024 directions
   (``pyshadow.csm.escape_fractions``): sealed (0), narrow (at most 1/32),
   open (above). Disagreement and false light (lit where Embree is not), %.

    python benchmarks/exposure.py [--meshes stanford-bunny.obj,teapot.obj] [--inner stanford-bunny.obj]
                                  [--maps 32x64] [--resolution 128] [--json]
"""
from __future__ import annotations

import argparse
import sys
import time
from contextlib import contextmanager

import numpy as np

from _common import check_counts, check_meshes, emit, environment, load_mesh, parse_grid

LATTICES = (32, 64, 128, 256, 512, 1024)
STRATA = ("sealed", "narrow", "open")


def counts(mesh):
    """Faces and area found exposed at each lattice size, the faces the half-size lattice missed, seconds."""
    import pyshadow
    from pyshadow.csm import exposed_back_faces

    frame = pyshadow.bounding_sphere(mesh)
    area = np.asarray(mesh.area_faces)
    rows, prev = [], None
    for d in LATTICES:
        t0 = time.perf_counter()
        e = exposed_back_faces(mesh, frame, d)
        rows.append({"directions": d, "faces_pct": 100 * float(e.mean()), "area_pct": 100 * float(area[e].sum() / area.sum()),
                     "seconds": time.perf_counter() - t0,
                     "found_not_at_half": None if prev is None else int((e & ~prev).sum()),
                     "lost_from_half": None if prev is None else int((prev & ~e).sum())})
        prev = e
    return rows


@contextmanager
def marked(faces):
    """Builds inside mark ``faces`` (bool (F,)) as exposed, whatever ``exposed_back_faces`` would find."""
    from pyshadow.csm import exposure

    kept = exposure.exposed_back_faces
    exposure.exposed_back_faces = lambda mesh, frame, directions=None: faces
    try:
        yield
    finally:
        exposure.exposed_back_faces = kept


def inner_points(mesh, views, resolution, n=6000, samples=16):
    """Agreement with Embree on rays from the faces' back sides, per rule, lookup and stratum."""
    import pyshadow
    from pyshadow.csm import escape_fractions

    frame = pyshadow.bounding_sphere(mesh)
    share = escape_fractions(mesh, frame, LATTICES[-1])
    rng = np.random.default_rng(0)
    area = np.asarray(mesh.area_faces)
    fi = rng.choice(len(area), n, p=area / area.sum())
    u, v = rng.random((2, n))
    flip = u + v > 1.0
    u[flip], v[flip] = 1.0 - u[flip], 1.0 - v[flip]
    tri = np.asarray(mesh.triangles)[fi]
    points = tri[:, 0] + u[:, None] * (tri[:, 1] - tri[:, 0]) + v[:, None] * (tri[:, 2] - tri[:, 0])
    normals = -np.asarray(mesh.face_normals)[fi]
    dirs = pyshadow.sample_directions(normals, sampling=pyshadow.Sampling(samples)).reshape(-1, 3)
    P, N = np.repeat(points, samples, axis=0), np.repeat(normals, samples, axis=0)
    s = share[fi]
    strata = {"sealed": s == 0.0, "narrow": (s > 0.0) & (s <= 1 / 32), "open": s > 1 / 32}
    rules = {"False": (False, None), "auto": ("auto", None), "any escape at 1024": ("auto", share > 0.0),
             "True": (True, None)}
    truth, out = None, {}
    for name, (two_sided, faces) in rules.items():
        t0 = time.perf_counter()
        if faces is None:
            csm = pyshadow.CoherentShadowMap.build(mesh, views, resolution=resolution, progress=False,
                                                   two_sided=two_sided)
        else:
            with marked(faces):
                csm = pyshadow.CoherentShadowMap.build(mesh, views, resolution=resolution, progress=False)
        row = {"bytes": csm.stats["bytes"], "build_seconds": time.perf_counter() - t0}
        scene = pyshadow.Scene()
        scene.add(csm, mesh=mesh)
        if truth is None:
            truth = scene.visible(P, dirs, backend="embree", surface_ids=0).reshape(n, samples)
        for lookup in ("nearest", "vote"):
            got = scene.visible(P, dirs, lookup=lookup, surface_ids=0, normals=N).reshape(n, samples)
            for k, sel in strata.items():
                g, t = got[sel], truth[sel]
                row[f"{lookup}/{k}"] = {"disagreement_pct": 100 * float((g != t).mean()),
                                        "false_light_pct": 100 * float((g & ~t).mean())}
        out[name] = row
    return {"points": {k: int(v.sum()) for k, v in strata.items()}, "rules": out}


def main(argv=None) -> int:
    import pyshadow

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--meshes", default="stanford-bunny.obj,teapot.obj,suzanne.ply,cow.obj")
    ap.add_argument("--inner", default="stanford-bunny.obj,teapot.obj")
    ap.add_argument("--maps", default="32x64", help="zigzag rows x columns of the CSMs of part 2")
    ap.add_argument("--resolution", type=int, default=128)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    check_meshes(ap, "--meshes", filter(None, args.meshes.split(",")))
    check_meshes(ap, "--inner", filter(None, args.inner.split(",")))
    check_counts(ap, args, "resolution", most=4096)
    rows, cols = parse_grid(ap, args.maps)
    views = pyshadow.ViewSet.zigzag(rows, cols)
    res = {"benchmark": "exposure", **environment(), "counts": {}, "inner": {}}
    for name in filter(None, args.meshes.split(",")):
        res["counts"][name] = counts(load_mesh(name))
        if not args.json:
            for r in res["counts"][name]:
                print(f"{name:20s} {r['directions']:5d} directions: {r['faces_pct']:5.1f} % of faces, "
                      f"{r['area_pct']:5.1f} % of area, {r['seconds']:6.2f} s"
                      + ("" if r["lost_from_half"] is None else
                         f"; {r['found_not_at_half']} found that half as many missed, {r['lost_from_half']} lost"),
                      flush=True)
    for name in filter(None, args.inner.split(",")):
        got = res["inner"][name] = inner_points(load_mesh(name), views, args.resolution)
        if not args.json:
            print(f"\n{name}: points on the inner side, {args.maps} maps @ {args.resolution}^2; points per stratum "
                  + ", ".join(f"{k} {v}" for k, v in got["points"].items()) + "; disagreement / false light, %")
            print(f"{'rule':20s} {'MB':>6s} " + " ".join(f"{lk + ' ' + k:>16s}" for lk in ("nearest", "vote")
                                                       for k in STRATA))
            for rule, r in got["rules"].items():
                print(f"{rule:20s} {r['bytes'] / 1e6:6.2f} " + " ".join(
                    f"{r[f'{lk}/{k}']['disagreement_pct']:>7.2f} / {r[f'{lk}/{k}']['false_light_pct']:<6.2f}"
                    for lk in ("nearest", "vote") for k in STRATA))
    if args.json:
        emit(res, True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

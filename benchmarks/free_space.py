"""Free space inside a caster: points in a bowl's hollow, in a room, in a box without a lid, against Embree.

A CSM stores one depth per run of maps, anywhere in each map's interval of
valid depths. Between a first surface ``z1`` and a second ``z2`` that
interval is ``[z1, z2)``: right for a closed body (the space between is
solid), wrong where it is air that holds other things (a ball in a bowl,
anything in a room). The fold ends the interval near ``z1`` there
(:mod:`pyshadow.csm`, "free space behind z1"). Rows:

1. **A ball in a bowl** (the lower part of a unit sphere, open above y =
   0.2; a ball of radius 0.25 resting inside): 500 points on the ball, 32
   cosine directions each, with the ball's surface rule, as AO asks.
2. **The bowl's own surface**, outer and inner side (500 points, 32
   directions).
3. **Free points** in the bowl's hollow, in a closed 2 m room (a cube wound
   inwards) and in a 2 m box without a lid: 16 uniform directions each.
4. With ``--meshes``: every named mesh's own AO rays (800 points, 16
   directions, one-texel and vote lookups) and its CSM's bytes -- what the
   rule costs where nothing lies in free space.

Disagreement with Embree on the identical rays, %. Run it on this code and on
the code before to compare (the README's table).

    python benchmarks/free_space.py [--maps 16x32] [--resolution 64] [--meshes stanford-bunny.obj,...] [--json]
"""
from __future__ import annotations

import argparse
import sys

import numpy as np
import trimesh

from _common import check_meshes, emit, environment, load_mesh, parse_grid

import pyshadow
from pyshadow import embree


def bowl_and_ball():
    sp = trimesh.creation.icosphere(4)
    bowl = trimesh.Trimesh(sp.vertices, sp.faces[sp.triangles_center[:, 1] < 0.2], process=False)
    bowl.remove_unreferenced_vertices()
    ball = trimesh.creation.icosphere(3, radius=0.25)
    ball.vertices += [0.3, -0.6, 0.0]
    return bowl, ball


def lidless_box():
    box = trimesh.creation.box(extents=[2.0, 2.0, 2.0])
    out = trimesh.Trimesh(box.vertices, box.faces[box.triangles_center[:, 1] < 0.99], process=False)
    out.remove_unreferenced_vertices()
    return out


def surface_points(rng, mesh, n):
    """Area-uniform points on ``mesh`` and their winding normals (the room's cached normals point out)."""
    f = rng.choice(len(mesh.faces), n, p=mesh.area_faces / mesh.area_faces.sum())
    tri = mesh.triangles[f]
    p = np.einsum("ij,ijk->ik", rng.dirichlet([1, 1, 1], n), tri)
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return p, nrm / np.linalg.norm(nrm, axis=1, keepdims=True)


def ao_rays(p, nrm, k):
    D = pyshadow.sample_directions(nrm, sampling=pyshadow.Sampling(k)).reshape(-1, 3)
    return np.repeat(p, k, axis=0), D, np.repeat(nrm, k, axis=0)


def free_rays(rng, q, k):
    P = np.repeat(q, k, axis=0)
    D = rng.normal(size=(len(P), 3))
    return P, D / np.linalg.norm(D, axis=1, keepdims=True)


def row(name, scene, P, D, **kw):
    truth = embree.visible(scene, P, D)
    out = {"rays": len(P), "embree_open": float(truth.mean())}
    for lookup in ("nearest", "vote"):
        ours = scene.visible(P, D, lookup=lookup, **kw)
        out[lookup] = {"open": float(ours.mean()), "disagreement_pct": 100.0 * float(np.mean(ours != truth))}
    return name, out


def scenes(views, R, rng):
    build = lambda m: pyshadow.CoherentShadowMap.build(m, views, resolution=R, progress=False)  # noqa: E731
    bowl, ball = bowl_and_ball()
    cbowl = build(bowl)
    scene = pyshadow.Scene()
    scene.add(cbowl, mesh=bowl)
    scene.add(build(ball), mesh=ball)
    rows, sizes = [], {"bowl": cbowl.stats["bytes"]}
    p, n = surface_points(rng, ball, 500)
    P, D, N = ao_rays(p + 1e-4 * n, n, 32)
    rows.append(row("ball in the bowl: the ball's AO rays", scene, P, D, surface_ids=1, normals=N))
    p, n = surface_points(rng, bowl, 500)
    for side, s in (("outer", 1.0), ("inner", -1.0)):
        P, D, N = ao_rays(p + 1e-4 * s * n, s * n, 32)
        rows.append(row(f"the bowl's own AO rays, {side} side", scene, P, D, surface_ids=0, normals=N))
    q = rng.uniform(-0.95, 0.95, (8000, 3))
    q = q[(np.linalg.norm(q, axis=1) < 0.95) & (q[:, 1] < 0.15) & (np.linalg.norm(q - [0.3, -0.6, 0], axis=1) > 0.27)]
    rows.append(row("free points in the bowl's hollow", scene, *free_rays(rng, q[:600], 16)))
    room = trimesh.creation.box(extents=[2.0, 2.0, 2.0]).invert()
    for name, mesh in (("room", room), ("lidless box", lidless_box())):
        csm = build(mesh)
        sizes[name] = csm.stats["bytes"]
        one = pyshadow.Scene()
        one.add(csm, mesh=mesh)
        rows.append(row(f"free points in the {name}", one, *free_rays(rng, rng.uniform(-0.95, 0.95, (600, 3)), 16)))
    return rows, sizes


def own_rays(views, R, rng, names):
    out = {}
    for name in names:
        mesh = load_mesh(name)
        csm = pyshadow.CoherentShadowMap.build(mesh, views, resolution=R, progress=False)
        scene = pyshadow.Scene()
        scene.add(csm, mesh=mesh)
        p, n = surface_points(rng, mesh, 800)
        P, D, N = ao_rays(p, n, 16)
        truth = embree.visible(scene, P + 1e-5 * csm.radius * N, D)
        out[name] = {"bytes": csm.stats["bytes"]}
        for lookup in ("nearest", "vote"):
            ours = scene.visible(P, D, surface_ids=0, normals=N, lookup=lookup)
            out[name][lookup] = 100.0 * float(np.mean(ours != truth))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", default="16x32", help="zigzag maps THETAxPHI (default 16x32)")
    ap.add_argument("--resolution", type=int, default=64)
    ap.add_argument("--meshes", default="", help="comma-separated meshes for their own AO rays and bytes")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    t, p = parse_grid(ap, a.maps)
    if a.resolution < 1:
        ap.error("--resolution must be >= 1")
    check_meshes(ap, "--meshes", [m for m in a.meshes.split(",") if m])
    views = pyshadow.ViewSet.zigzag(t, p)
    rng = np.random.default_rng(a.seed)
    rows, sizes = scenes(views, a.resolution, rng)
    meshes = own_rays(views, a.resolution, rng, [m for m in a.meshes.split(",") if m])
    result = {"environment": environment(), "maps": a.maps, "resolution": a.resolution, "rows": dict(rows),
              "bytes": sizes, "meshes": meshes}
    if a.json:
        emit(result, True)
        return 0
    print(f"free space, {a.maps} maps @ {a.resolution}^2; disagreement with Embree (%), open fraction")
    for name, r in rows:
        print(f"  {name:42s} Embree open {r['embree_open']:.3f}   one-texel {r['nearest']['disagreement_pct']:6.2f}"
              f"   vote {r['vote']['disagreement_pct']:6.2f}")
    print("  CSM bytes: " + ", ".join(f"{k} {v:,}" for k, v in sizes.items()))
    for name, r in meshes.items():
        print(f"  {name:24s} own AO rays: one-texel {r['nearest']:.2f} %, vote {r['vote']:.2f} %; {r['bytes']:,} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())

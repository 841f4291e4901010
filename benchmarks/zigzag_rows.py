"""The thesis's zigzag grid against centred rows, on every bundled mesh (issue 21, the pole rows).

Each mesh alone (its own unit frame), CSMs of ``ViewSet.zigzag(T, P,
row_offset=0)`` (Listing 5.1: row 0 on the north pole) and ``row_offset=0.5``
(the default) at the same resolution, asked the identical rays: AO rays from
3,000 surface points (8 cosine directions each, with the points' normals, as
AO asks them) and 6,000 rays from 3 bounding radii at points near the
centre; agreement with Embree per lookup. Beside it, the angle from uniform
directions to their nearest map on both grids.

    python benchmarks/zigzag_rows.py [--maps 64x128] [--resolution 128] [--json]
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from _common import check_counts, emit, environment, parse_grid

OFFSETS = (0.0, 0.5)


def nearest_angles(T, P, n=400_000, seed=0):
    """{row_offset: (mean, max)} angle, radians, from uniform directions to their nearest map."""
    import pyshadow

    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    out = {}
    for off in OFFSETS:
        v = pyshadow.ViewSet.zigzag(T, P, row_offset=off)
        a = np.arccos(np.clip(np.einsum("ij,ij->i", v.directions[v.nearest(d)], d), -1.0, 1.0))
        out[off] = (float(a.mean()), float(a.max()))
    return out


def mesh_row(name, T, P, resolution):
    """Agreement with Embree on both ray sets, per grid and lookup, and the CSMs' segment counts."""
    import trimesh

    import pyshadow
    from pyshadow import embree

    mesh = pyshadow.data.mesh(name)
    rng = np.random.default_rng(7)
    pts, face = trimesh.sample.sample_surface(mesh, 3000, seed=3)
    n = mesh.face_normals[face]
    d = pyshadow.sample_directions(n, sampling=pyshadow.Sampling(8, seed=1)).reshape(-1, 3)
    p, normals = np.repeat(pts, 8, axis=0), np.repeat(n, 8, axis=0)
    sphere = mesh.bounding_sphere.primitive
    target = sphere.center + rng.normal(size=(6000, 3)) * 0.25 * sphere.radius
    u = rng.normal(size=(6000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    far = target + 3.0 * sphere.radius * u
    row = {"mesh": name}
    for off in OFFSETS:
        csm = pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(T, P, row_offset=off),
                                               resolution=resolution, progress=False)
        scene = pyshadow.Scene()
        scene.add(csm, np.eye(4), mesh=mesh)
        t_ao, t_far = embree.visible(scene, p, d), embree.visible(scene, far, -u)
        ids = np.zeros(len(p), np.int32)
        row[f"segments {off}"] = int(len(csm.depth))
        for lookup in ("nearest", "vote"):
            row[f"ao {lookup} {off}"] = float(np.mean(
                scene.visible(p, d, surface_ids=ids, normals=normals, lookup=lookup) == t_ao))
            row[f"far {lookup} {off}"] = float(np.mean(scene.visible(far, -u, lookup=lookup) == t_far))
    return row


def main(argv=None) -> int:
    import pyshadow

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", default="64x128", help="zigzag grid THETAxPHI (default %(default)s)")
    ap.add_argument("--resolution", type=int, default=128)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    check_counts(ap, args, "resolution", most=4096)
    T, P = parse_grid(ap, args.maps)
    angles = nearest_angles(T, P)
    rows = [mesh_row(name, T, P, args.resolution) for name in pyshadow.data.MESHES]
    if args.json:
        emit({"benchmark": "zigzag_rows", **environment(), "maps": [T, P], "resolution": args.resolution,
              "nearest_angle": {str(k): v for k, v in angles.items()}, "rows": rows}, True)
        return 0
    for off, (mean, mx) in angles.items():
        print(f"row_offset {off}: angle to the nearest map, mean {mean:.4f} rad, max {mx:.4f} rad")
    print("agreement with Embree, %: thesis grid (row_offset 0) -> centred (0.5)")
    print(f"{'mesh':<20} {'AO one-texel':>17} {'AO vote':>17} {'far one-texel':>17} {'far vote':>17}")
    for r in rows:
        cells = [f"{100 * r[f'{k} 0.0']:.2f} -> {100 * r[f'{k} 0.5']:.2f}"
                 for k in ("ao nearest", "ao vote", "far nearest", "far vote")]
        print(f"{r['mesh']:<20} " + " ".join(f"{c:>17}" for c in cells))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The vote's four maps at the poles of a zigzag view set, on every bundled mesh (issue 21, the pole rows).

Centred zigzag rows leave a cap of directions around each pole (``theta``
within half a row step of it) beyond the first and the last row; every map
of that row lies on the cap's rim, ``2 pi / phi`` apart in ``phi`` but only
``pi / theta * sin(pi / 2 theta)`` apart on the sphere (0.07 degrees at
64x128). The vote's window there was the row's two maps on the direction's
side and the two opposite them across the pole: two pairs of nearly one
direction each, so the vote weighed two views. It now takes four of the
row's maps a quarter turn apart, from the one nearest the direction
(``ViewSet.filter_window``, ``kernels/views_zigzag.h``): the four sides of
the pole.

Each mesh alone (its own unit frame), one CSM (``--maps``, ``--resolution``);
directions exactly at both poles, and ``--directions`` uniform over each
cap; for each direction, surface points facing it (more than 10 degrees
above their tangent plane) and a disk of points behind the body, all asked
along it. Agreement with Embree of the vote: the float64 mirror with the
previous window ("two pairs") and with the new one, and the kernel (the new
window). The one-texel lookup is not changed (its nearest map is the same).

    python benchmarks/pole_window.py [--maps 64x128] [--resolution 128] [--directions 4] [--json]
"""
from __future__ import annotations

import argparse
import contextlib
import sys

import numpy as np

from _common import check_counts, emit, environment, parse_grid
from extremes_params import _direction_rays


@contextlib.contextmanager
def previous_window():
    """``ViewSet.filter_window`` with the window before the quarter turns (two pairs across the pole)."""
    from pyshadow.views import ViewSet

    own = ViewSet._zigzag_window
    ViewSet._zigzag_window = lambda self, d, cap=False: own(self, d, cap=False)
    try:
        yield
    finally:
        ViewSet._zigzag_window = own


def cap_directions(T, k, rng):
    """``k`` directions uniform over each polar cap (theta below half a row step of either pole),
    then the two poles exactly: (2 k + 2, 3)."""
    from pyshadow.views import polar_direction

    half = 0.5 * np.pi / T
    out = []
    for north in (True, False):
        th = half * np.sqrt(rng.uniform(0.0, 1.0, k))          # uniform over the cap's area
        for t, p in zip(th, rng.uniform(0.0, 2.0 * np.pi, k)):
            out.append(polar_direction(t if north else np.pi - t, p))
    return np.vstack(out + [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]])


def mesh_row(name, T, P, resolution, k, seed=5):
    import trimesh

    import pyshadow
    from pyshadow import embree, visibility

    mesh = pyshadow.data.mesh(name)
    csm = pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(T, P), resolution=resolution,
                                           progress=False)
    scene = pyshadow.Scene()                        # no ground: only the body decides
    scene.add(csm, np.eye(4), mesh=mesh)
    pts, face = trimesh.sample.sample_surface(mesh, 3000, seed=seed)
    surface = (pts, mesh.face_normals[face])
    rng = np.random.default_rng(seed)
    count = {"cap": {}, "poles": {}}
    for i, d in enumerate(cap_directions(T, k, rng)):
        P_, D, ids = _direction_rays(scene, d, 3000, rng, surface)
        truth = embree.visible(scene, P_, D)
        with previous_window():
            before = visibility.visible(scene, P_, D, backend="numpy-vote", surface_ids=ids)
        after = visibility.visible(scene, P_, D, backend="numpy-vote", surface_ids=ids)
        kernel = visibility.visible(scene, P_, D, backend="csm-vote", surface_ids=ids)
        part = count["poles" if i >= 2 * k else "cap"]
        for key, v in (("two pairs", before), ("quarter turns", after), ("kernel", kernel)):
            part[key] = part.get(key, 0) + int(np.sum(v != truth))
        part["kernel vs mirror"] = part.get("kernel vs mirror", 0) + int(np.sum(kernel != after))
        part["rays"] = part.get("rays", 0) + len(P_)
    return {"mesh": name, **{f"{g} {key}": (v if key == "rays" else v / c["rays"])
                             for g, c in count.items() for key, v in c.items()}}


def main(argv=None) -> int:
    import pyshadow

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", default="64x128", help="zigzag grid THETAxPHI (default %(default)s)")
    ap.add_argument("--resolution", type=int, default=128)
    ap.add_argument("--directions", type=int, default=4, help="random directions in each cap")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    check_counts(ap, args, "directions")
    check_counts(ap, args, "resolution", most=4096)
    T, P = parse_grid(ap, args.maps)
    rows = [mesh_row(name, T, P, args.resolution, args.directions) for name in pyshadow.data.MESHES]
    if args.json:
        emit({"benchmark": "pole_window", **environment(), "maps": [T, P], "resolution": args.resolution,
              "directions": args.directions, "rows": rows}, True)
        return 0
    print(f"vote lookup, {T}x{P} maps @ {args.resolution}^2: rays disagreeing with Embree, %")
    heads = [f"{g}: two pairs -> quarter turns (kernel)" for g in ("poles", "caps")]
    print(f"{'mesh':<16} " + " ".join(f"{h:>44}" for h in heads))
    for r in rows:
        cells = [f"{100 * r[f'{g} two pairs']:.3f} -> {100 * r[f'{g} quarter turns']:.3f} "
                 f"({100 * r[f'{g} kernel']:.3f})" for g in ("poles", "cap")]
        print(f"{r['mesh']:<16} " + " ".join(f"{c:>44}" for c in cells))
    for g in ("poles", "cap"):
        a = np.mean([r[f"{g} two pairs"] for r in rows])
        b = np.mean([r[f"{g} quarter turns"] for r in rows])
        print(f"mean, {g}: {100 * a:.3f} -> {100 * b:.3f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())

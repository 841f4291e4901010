"""What the body-on-body contact rule costs a moving scene and a query (README "bodies resting on bodies").

A point on a closed caster's face that touches another body's face is
closed in (``pyshadow.contact_bodies``). The touching faces are found once
per scene change, which a moving scene pays every frame; a query pays for
its points near touching faces. Three scenes, every caster a box with its
mesh (the rule needs meshes):

=========  ==========================================================  ==========
apart      ``--apart`` 0.3 m boxes on the ground, 1 m apart (none       ground y=0
           touches another)
floor      ``--floor`` 0.3 m boxes resting on a 200 x 0.1 x 200 m box   no ground
           added as a receiver (a floor *mesh*), 1 m apart
pile       ``--pile`` x ``--pile`` columns of 4 unit boxes, stacked     ground y=0
           and side by side (every box touches its neighbours)
tiles      ``--tiles`` x ``--tiles`` unit boxes side by side on the     ground y=0
           ground (each touches its 2-4 neighbours)
=========  ==========================================================  ==========

Per scene: **change**, the time to find the touching faces after a scene
change: one body slid 1 mm along x, and back (``scene.set_transform``, then
``contact_bodies.body_patches`` each time: bodies on bodies, searched again for
the moved body and its neighbours only), and **full**, every body searched
(the scene's last search forgotten, ``contact_bodies._SEARCHED``); and
``contact.footprints``: bodies on the ground; medians of ``--rounds``; **query**, AO
of ``--points`` points on the floor, the ground or the plane between the pile's second and third layers (up
normals, 16 samples) with the faces already found, against **no rule**:
the same CSMs added without meshes (nothing to close in), interleaved
rounds, medians. The AO of the two differs only on closed-in points.

    python benchmarks/contact_cost.py [--apart 10000] [--floor 2500] [--pile 10] [--tiles 60]
                                      [--points 20000] [--rounds 5] [--json]
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from _common import check_counts, emit, environment

SAMPLES = 16
BOX = 0.3                   # the apart and floor scenes' boxes' side (m)


def _grid(n: int) -> np.ndarray:
    """(n, 2) x, z of ``n`` places 1 m apart on a square grid centred on the origin."""
    k = int(np.ceil(np.sqrt(n)))
    i = np.arange(n)
    return np.column_stack([i % k, i // k]) - (k - 1) / 2.0


def scenes(apart: int, floor: int, pile: int, tiles: int = 0) -> dict:
    """``{name: (scene with meshes, the same scene without meshes, points (M, 3) region (2, 2) x, z, height)}``."""
    import trimesh

    import pyshadow

    views = pyshadow.ViewSet.zigzag(8, 16)
    small = trimesh.creation.box((BOX,) * 3)
    unit = trimesh.creation.box((1.0, 1.0, 1.0))
    csm = {id(m): pyshadow.CoherentShadowMap.build(m, views, resolution=32, progress=False) for m in (small, unit)}
    out = {}

    def pose(x, y, z):
        T = np.eye(4)
        T[:3, 3] = x, y, z
        return T

    def pair(ground, receiver, placed):
        got = []
        for with_mesh in (True, False):
            s = pyshadow.Scene(ground=ground)
            if receiver is not None:
                s.add(receiver, casts=False)
            for mesh, T in placed:
                s.add(csm[id(mesh)], T, mesh=mesh if with_mesh else None)
            got.append(s)
        return got

    xz = _grid(apart)
    out["apart"] = (*pair(0.0, None, [(small, pose(x, BOX / 2, z)) for x, z in xz]), np.ptp(xz, axis=0), 0.0)
    plate = trimesh.creation.box((200.0, 0.1, 200.0))
    plate.vertices[:, 1] -= 0.05
    xz = _grid(floor)
    out["floor"] = (*pair(None, plate, [(small, pose(x, BOX / 2, z)) for x, z in xz]), np.ptp(xz, axis=0), 0.0)
    xz = _grid(pile * pile)
    out["pile"] = (*pair(0.0, None, [(unit, pose(x, y + 0.5, z)) for x, z in xz for y in range(4)]),
                   np.ptp(xz, axis=0) + 1.0, 2.0)
    if tiles:
        xz = _grid(tiles * tiles)
        out["tiles"] = (*pair(0.0, None, [(unit, pose(x, 0.5, z)) for x, z in xz]), np.ptp(xz, axis=0) + 1.0, 1.0)
    return out


def points(extent, height: float, n: int, seed: int = 0) -> np.ndarray:
    """``n`` points uniform over the ``extent`` (x, z widths, centred on the origin) at ``height``."""
    rng = np.random.default_rng(seed)
    xz = rng.uniform(-0.5, 0.5, (n, 2)) * extent
    return np.column_stack([xz[:, 0], np.full(n, height), xz[:, 1]])


def measure(entry, n_points: int, rounds: int) -> dict:
    """Medians (s) of the scene change and of the AO query with and without the rule; closed-in points."""
    import pyshadow
    from pyshadow.contact import footprints
    from pyshadow import contact_bodies
    from pyshadow.contact_bodies import body_patches

    ruled, bare, extent, height = entry
    p = points(extent, height, n_points)
    up = np.tile([0.0, 1.0, 0.0], (n_points, 1))
    sampling = pyshadow.Sampling(SAMPLES)
    change, full, ground, query, plain = [], [], [], [], []
    patches = body_patches(ruled)
    body = min(1, len(ruled.instances) - 1)    # the second instance (the floor's first box); a lone box itself
    home = ruled.transform(body)
    slid = home.copy()
    slid[0, 3] += 1e-3
    for r in range(-1, rounds):                 # one untimed round: kernel builds
        moves = []
        for T in (slid, home):                  # one body slid 1 mm, then back
            ruled.set_transform(body, T)
            t0 = time.perf_counter()
            patches = body_patches(ruled)
            moves.append(time.perf_counter() - t0)
        contact_bodies._SEARCHED.pop(ruled, None)
        ruled.set_transform(body, home)
        t0 = time.perf_counter()
        whole = body_patches(ruled)
        t1 = time.perf_counter()
        assert len(whole) == len(patches)
        feet = footprints(ruled)
        ground_s = time.perf_counter() - t1
        order = ((ruled, query), (bare, plain)) if r % 2 else ((bare, plain), (ruled, query))
        for scene, times in order:
            t2 = time.perf_counter()
            ao = scene.ambient_occlusion(p, up, sampling=sampling)
            if r >= 0:
                times.append(time.perf_counter() - t2)
            if scene is ruled:
                ao_ruled = ao
            else:
                ao_bare = ao
        if r >= 0:
            change.extend(moves)
            full.append(t1 - t0)
            ground.append(ground_s)
    return {"instances": len(ruled.instances), "patches": len(patches), "footprints": len(feet),
            "closed_in_points": int(np.count_nonzero(ao_ruled != ao_bare)),
            "change_s": statistics.median(change), "full_search_s": statistics.median(full),
            "ground_change_s": statistics.median(ground),
            "query_s": statistics.median(query),
            "query_without_rule_s": statistics.median(plain)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--apart", type=int, default=10_000)
    ap.add_argument("--floor", type=int, default=2_500)
    ap.add_argument("--pile", type=int, default=10)
    ap.add_argument("--tiles", type=int, default=60)
    ap.add_argument("--points", type=int, default=20_000)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    check_counts(ap, args, "apart", "floor", "pile", "tiles", "points", "rounds")
    rows = {name: measure(entry, args.points, args.rounds)
            for name, entry in scenes(args.apart, args.floor, args.pile, args.tiles).items()}
    emit({"environment": environment(), "points": args.points, "rounds": args.rounds, "scenes": rows}, args.json)
    if not args.json:               # was: nothing printed without --json
        print(f"medians of {args.rounds} rounds (ms); query: AO of {args.points} points, {SAMPLES} samples")
        print(f"{'scene':6s} {'bodies':>7s} {'patches':>8s} {'feet':>6s} {'change':>8s} {'full':>8s} "
              f"{'ground':>8s} {'query':>8s} {'no rule':>8s} {'closed in':>9s}")
        for name, r in rows.items():
            print(f"{name:6s} {r['instances']:7d} {r['patches']:8d} {r['footprints']:6d} "
                  + " ".join(f"{1e3 * r[k]:8.2f}" for k in ("change_s", "full_search_s", "ground_change_s",
                                                           "query_s", "query_without_rule_s"))
                  + f" {r['closed_in_points']:9d}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

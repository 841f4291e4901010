"""Empty runs of maps (``EMPTY_RUNS``): the lookups they spare, and their time, in one process.

On ``instances.py``'s scene (Spot, CSM 16x32 maps @ 64^2) and rays, among
``--casters`` instances: the share of one-texel lookups whose (map, texel)
stores a miss, counted with the NumPy mirror on a sample of the rays, and the
share the scene's empty-run bits catch; then the ``visible`` and AO calls
with the kernels compiled with ``EMPTY_RUNS`` 1 and 0, alternated in every
round (answers compared bit for bit), paired medians. ``--bunny`` adds the
peers' bunny workload with the bits forced on, where few lookups are empty.

    python benchmarks/empty_runs.py [--casters 10000] [--rounds 11] [--bunny] [--json]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

from _common import emit, environment


def _forced(backend, mode):
    """Make every CSM query kernel compile with ``EMPTY_RUNS = mode["on"]`` (None: the scene's own rule)."""
    own = backend.CSMVisibility._defines

    def defines(self, scene, atlas, **extra):
        d = own(self, scene, atlas, **extra)
        if mode["on"] is not None:
            d["EMPTY_RUNS"] = int(mode["on"])
        return d
    backend.CSMVisibility._defines = defines


def lookup_shares(scene, csm, P, D):
    """(empty, caught, known, lookups): the share of the mirror's one-texel lookups on a missing (map, texel),
    the share on a run the bits mark empty, the share the bits answer occluded (a point behind every surface,
    depth 2, over a (map, texel) with a surface, where the bits hold one per map: ``instance_v``), and their
    number."""
    import pyshadow.csm.reference as ref
    from pyshadow.csm import device
    from pyshadow.visibility.mirror import visible_reference

    taps, own = [], ref.shadow_taps

    def record(*a, **k):
        for t in own(*a, **k):
            b = np.broadcast_to(t[5], t[4].shape)
            taps.append((t[0][t[6]], t[1][t[6]], t[4][t[6]], b[t[6]]))   # map, texel, depth, bias: inside
            yield t
    ref.shadow_taps = record
    try:
        visible_reference(scene, P, D)
    finally:
        ref.shadow_taps = own
    k = np.concatenate([t[0] for t in taps])
    tex = np.concatenate([t[1] for t in taps])
    seg = np.asarray(csm.segment_index(k, tex // csm.resolution, tex % csm.resolution), np.int64)
    empty = np.isinf(csm.stored_to_depth(np.asarray(csm.depth)[seg]))
    bits, shift = device.empty_bits(csm, device.empty_words(csm.resolution, csm.maps))
    run = k >> shift
    caught = (bits[tex, run >> 5] >> (run & 31).astype(np.uint32)) & 1
    depth, bias = np.concatenate([t[2] for t in taps]), np.concatenate([t[3] for t in taps])
    top = np.float32(1.0 if csm.depth_bits == 16 else 2.0)    # STORED_MAX_DEPTH
    known = (shift == 0) & (caught == 0) & (depth == 2.0) & (top + bias.astype(np.float32) < np.float32(2.0))
    return float(empty.mean()), float(caught.mean()), float(known.mean()), int(len(k))


def timed(calls, rounds, mode):
    """Each call with the bits off and on, alternated round by round: medians, paired ratio, identical."""
    out = {}
    for name, call in calls.items():
        t = {False: [], True: []}
        ans = {}
        for r in range(rounds):
            for on in ((False, True) if r % 2 == 0 else (True, False)):
                mode["on"] = on
                call()                                        # compile and warm outside the timing
                t0 = time.perf_counter()
                a = call()
                t[on].append(time.perf_counter() - t0)
                ans[on] = a
        mode["on"] = None
        same = all(np.array_equal(x, y) for x, y in zip(np.atleast_1d(ans[False]), np.atleast_1d(ans[True])))
        out[name] = {"off_ms": 1e3 * statistics.median(t[False]), "on_ms": 1e3 * statistics.median(t[True]),
                     "paired_on_over_off": statistics.median(b / a for a, b in zip(t[False], t[True])),
                     "identical": bool(same)}
    return out


def main(argv=None) -> int:
    import pyshadow
    from pyshadow.visibility import csm as backend
    from instances import scene_of, workload

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--casters", type=int, default=10000)
    ap.add_argument("--rounds", type=int, default=11)
    ap.add_argument("--bunny", action="store_true")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.rounds < 1 or args.casters < 1:
        ap.error(f"--rounds and --casters must be >= 1, got {args.rounds} and {args.casters}")
    mode = {"on": None}
    _forced(backend, mode)
    mesh, csm, pts, up, P, D = workload()
    S = pyshadow.Sampling(16)
    scene = scene_of(args.casters, csm, mesh)
    sub = slice(0, len(P), 200)                               # 2,000 rays through the mirror
    empty, caught, known, n = lookup_shares(scene_of(min(args.casters, 100), csm, mesh), csm, P[sub], D[sub])
    calls = {"visible": lambda: scene.visible(P, D),
             "ao": lambda: scene.ambient_occlusion(pts, up, sampling=S)}
    result = {"benchmark": "empty_runs", **environment(), "casters": args.casters, "rounds": args.rounds,
              "mirror_lookups": n, "lookups_on_misses": empty, "lookups_on_empty_runs": caught,
              "lookups_known_occluded": known,
              "timings": timed(calls, args.rounds, mode)}
    if args.bunny:
        from peers import bunny_workload
        from pyshadow.cache import CSMCache, default_cache_dir

        s, bp, bd, ids = bunny_workload(3_600_000, CSMCache(default_cache_dir()))
        result["bunny"] = timed({"visible one-texel": lambda: s.visible(bp, bd, surface_ids=ids)}, args.rounds, mode)
    if args.json:
        emit(result, True)
        return 0
    print(f"mirror: {n} one-texel lookups among {min(args.casters, 100)} casters: {100 * empty:.1f} % on a missing "
          f"(map, texel), {100 * caught:.1f} % on runs the bits mark empty, {100 * known:.1f} % answered occluded "
          f"from them (behind every surface)")
    for group, rows in (("instances", result["timings"]), ("bunny", result.get("bunny", {}))):
        for name, r in rows.items():
            print(f"{group:9s} {name:18s} off {r['off_ms']:8.2f} ms  on {r['on_ms']:8.2f} ms  "
                  f"paired on/off {r['paired_on_over_off']:.3f}  identical {r['identical']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""What a scene's unused features cost: the ground plane and the casters ("unused features cost nothing").

Four scenes hold the same receiver (a unit box at the origin, added with
``casts=False``: no CSM) and differ only in what could occlude:

============  ================================================  =====================
open sky      nothing                                           no kernel launched
ground        the ground plane y = -10                          NTYPES=0, GROUND=1
far caster    one caster (a unit box, CSM 4x8 maps @ 16^2)      NTYPES=1, GROUND=0
              1000 m below the origin
both          the far caster and the ground plane               NTYPES=1, GROUND=1
============  ================================================  =====================

The same rays for all: ``--rays`` points uniform in the 10 m cube around the
origin, directions uniform over the upper hemisphere, so that neither the
ground nor the caster stops any of them (every scene answers all True: the
answers are checked equal), asked through ``Scene.visible``; and AO
(``Scene.ambient_occlusion``, 16 samples, no bent normals) of ``--rays`` / 16
of the points with up normals (every sample open: all 1). The four scenes are
timed in interleaved rounds, one call each per round, each round starting at
the next scene, after one untimed round; medians of ``--rounds``, and the
medians of the per-round ratios the tests bound (``tests/test_scene_cost.py``).

    python benchmarks/scene_cost.py [--rays 200000] [--rounds 9] [--json]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

from _common import emit, environment

SCENES = ("open sky", "ground", "far caster", "both")
GROUND_Y = -10.0
CASTER_Y = -1000.0
SAMPLES = 16
# (fewer features, more features) pairs of the comparisons: the first has a feature less, and must not cost more
RATIOS = {"no ground / ground (far caster)": ("far caster", "both"),
          "no caster / far caster (ground)": ("ground", "both"),
          "nothing / ground only": ("open sky", "ground")}


def scenes() -> dict:
    """The four scenes of the module docstring, by name."""
    import trimesh

    import pyshadow

    box = trimesh.creation.box((1.0, 1.0, 1.0))
    caster = pyshadow.CoherentShadowMap.build(box, pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)
    below = np.eye(4)
    below[1, 3] = CASTER_Y
    out = {}
    for name in SCENES:
        s = pyshadow.Scene(ground=GROUND_Y if name in ("ground", "both") else None)
        s.add(box, casts=False)
        if name in ("far caster", "both"):
            s.add(caster, below, mesh=box)
        out[name] = s
    return out


def workload(n: int, seed: int = 0):
    """``n`` rays (points, upward directions), float64, and AO points with up normals (n // 16 of them)."""
    rng = np.random.default_rng(seed)
    P = rng.uniform(-5.0, 5.0, (n, 3))
    D = rng.normal(size=(n, 3))
    D[:, 1] = np.abs(D[:, 1]) + 1e-3
    m = max(1, n // SAMPLES)
    return P, D, P[:m].copy(), np.tile([0.0, 1.0, 0.0], (m, 1))


def query_defines(scene) -> dict:
    """``NTYPES``, ``GROUND``, ``INSTANCE_BVH`` and ``INSTANCE_GRID`` of the visible and AO kernels of ``scene``
    (None: no kernel)."""
    from pyshadow.visibility import CSMVisibility

    b = CSMVisibility("nearest")
    out = {}
    for query, kernel, extra in (("visible", "scene_visible", {}),
                                 ("ao", "scene_ao", {"SAMPLES": SAMPLES, "BENT_NORMALS": 0, "TRANSFER": 0})):
        d = b.query_defines(scene, kernel, **extra)
        out[query] = None if d is None else {k: d[k] for k in ("NTYPES", "GROUND", "INSTANCE_BVH", "INSTANCE_GRID")}
    return out


def measure(scenes_: dict, P, D, pts, nrm, rounds: int) -> dict:
    """Times (s) of ``visible`` and AO per scene, interleaved over ``rounds``; raises if the answers differ.

    One untimed round first (kernel builds, the device compiler's first launch at full size); each
    round starts at the next scene, so that no scene always follows the same one (a scene after
    one that launches no kernel may find the device's threads asleep).
    """
    import pyshadow

    sampling = pyshadow.Sampling(SAMPLES)
    names = list(scenes_)
    times = {name: {"visible": [], "ao": []} for name in names}
    want = None
    for r in range(-1, rounds):
        for name in names[r % len(names):] + names[:r % len(names)]:
            s = scenes_[name]
            t0 = time.perf_counter()
            v = s.visible(P, D)
            t1 = time.perf_counter()
            ao = s.ambient_occlusion(pts, nrm, sampling=sampling)
            t2 = time.perf_counter()
            if r >= 0:
                times[name]["visible"].append(t1 - t0)
                times[name]["ao"].append(t2 - t1)
            if want is None:
                want = (v, ao)
            if not (np.array_equal(v, want[0]) and np.array_equal(ao, want[1])):
                raise AssertionError(f"scene {name!r} answers differently")
    return times


def ratios(times: dict, query: str = "visible") -> dict:
    """Median over the rounds of the per-round time ratio of each pair of :data:`RATIOS`."""
    return {label: statistics.median(a / b for a, b in zip(times[x][query], times[y][query]))
            for label, (x, y) in RATIOS.items()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rays", type=int, default=200_000)
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.rays < 1 or args.rounds < 1:
        ap.error(f"--rays and --rounds must be >= 1, got {args.rays} and {args.rounds}")
    sc = scenes()
    P, D, pts, nrm = workload(args.rays)
    times = measure(sc, P, D, pts, nrm, args.rounds)
    rows = [{"scene": name, **query_defines(s),
             "visible_ms": 1e3 * statistics.median(times[name]["visible"]),
             "ao_ms": 1e3 * statistics.median(times[name]["ao"])} for name, s in sc.items()]
    result = {"benchmark": "scene_cost", **environment(), "rays": len(P), "ao_points": len(pts),
              "ao_samples": SAMPLES, "rounds": args.rounds, "rows": rows,
              "visible_ratios": ratios(times, "visible"), "ao_ratios": ratios(times, "ao")}
    if args.json:
        emit(result, True)
        return 0
    print(f"{len(P)} rays, AO of {len(pts)} points x {SAMPLES} samples; medians of {args.rounds} interleaved "
          f"rounds; every ray and sample open")
    print(f"{'scene':<12} {'visible ms':>11} {'AO ms':>9}  defines (visible; AO)")
    for r in rows:
        def show(d):
            return "no kernel" if d is None else " ".join(f"{k}={v}" for k, v in d.items())
        print(f"{r['scene']:<12} {r['visible_ms']:>11.2f} {r['ao_ms']:>9.2f}  {show(r['visible'])}; {show(r['ao'])}")
    for label in RATIOS:
        print(f"{label:<34} visible {result['visible_ratios'][label]:.2f}x  AO {result['ao_ratios'][label]:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())

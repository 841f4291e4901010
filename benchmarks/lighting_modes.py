"""The shading modes against a converged Embree reference, at equal samples and at equal time (issue 19).

On the bundled scene (``pyshadow.data.default_scene``, 640x480 by default)
under the clear sky with its sun (``pyshadow-bench --sky clear``'s sky) and
under the overcast sky, each shading mode ("bent", "transfer", "sampled")
is rendered with the CSM backend (one-texel lookup unless ``--lookup vote``)
and compared with a converged reference:
``pyshadow.lighting.reference_radiance`` (Embree) at ``--reference-samples``
(1024) sky samples with another seed and 1024 directions over the sun's
disc, i.e. the shadowed sky and sun integrals the three modes approximate
(the renders trace one ray to the sun's centre in modes "bent" and
"transfer", and ``pyshadow.lighting.SAMPLED_SUN_SAMPLES`` rays over its disc
in mode "sampled", unless ``--sun-samples`` says how many for every mode). The figure is the relative RMSE of radiance over the covered
pixels (``pyshadow.bench.lit.relative_rmse``).

Rows:

* every mode at 36 samples, with its frame time (median of ``--repeats``
  interleaved renders) and the AO frame alone beside it, in Msamples/s;
* equal time: for each budget (each mode's 36-sample frame time), every
  mode at the sample count whose frame time fits it; frame time is modelled
  as ``a + b * samples`` (least squares over the renders at 16, 36 and 64
  samples) for a first guess, then bracketed on measured times
  (:func:`fit_budget`: the largest count found within 10 % over the
  budget, at most 5 renders); the measured time is printed;
* "sampled" at 256 samples with the CSM against "sampled" at 256 samples
  with Embree on the identical directions (the 2 % acceptance), and both
  against the reference; with a sun also the sky's term alone, and the
  share of the squared error carried by the pixels whose sun ray(s) the two
  answer differently (the sun term's difference over 1e-3 of its largest).

``--identical-only`` measures only the last row (no reference, no 36-sample
or equal-time rows). ``--maps``, ``--resolution`` (the casters' CSMs, as in
``benchmarks/sun_shadows.py``) and ``--lookup`` (the backend of every CSM
render) change the CSM renders; ``--sun-samples`` (``Lighting(sun_samples=)``:
rays over the sun's real disc; 1: the hard sun of the earlier figures) those of both
backends, on identical rays.

    python benchmarks/lighting_modes.py [--width 640 --height 480] [--reference-samples 1024] [--json]
    python benchmarks/lighting_modes.py --identical-only [--maps 64x128] [--resolution 128] [--lookup nearest|vote]
        [--sun-samples K]
"""
from __future__ import annotations

import argparse
import copy
import statistics
import sys
import time

import numpy as np

from _common import check_counts, emit, environment, parse_grid

MODES = ("bent", "transfer", "sampled")


def frame_time(fn, repeats):
    """Median wall time of ``repeats`` calls after one untimed call; the last result too."""
    out = fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def fit_budget(timed, s, budget, tries=5):
    """The largest sample count found whose measured frame time is within 10 % over ``budget``.

    Starts from ``s`` (the linear model's guess) and brackets: a count over
    budget bounds it from above, one under from below; the next count is the
    geometric mean of the bounds (twice the count while unbounded above).
    Returns ``(samples, time, frame)`` of the best count measured (the
    smallest, when every count measured is over budget)."""
    lo, hi, best, fallback = 0, None, None, None
    for _ in range(tries):
        t, f = timed(s)
        if t <= 1.1 * budget:
            lo = s
            if best is None or s > best[0]:
                best = (s, t, f)
            if t >= 0.9 * budget:
                break
        else:
            hi = s
            if fallback is None or s < fallback[0]:
                fallback = (s, t, f)
        nxt = min(2 * s, 4096) if hi is None else int(np.sqrt(max(lo, 1) * hi))
        if nxt in (lo, hi, s) or nxt < 1:
            break
        s = nxt
    return best if best is not None else fallback


def covered_pixels(sp, cam):
    """(H, W) bool: the pixels of ``sp`` (``pyshadow.render.surface_points``)."""
    covered = np.zeros(cam.height * cam.width, bool)
    covered[sp.index] = True
    return covered.reshape(cam.height, cam.width)


def reference(scene, sp, lighting, samples, chunk=8192):
    """Converged radiance of the covered pixels of ``sp`` (``pyshadow.lighting.reference_radiance`` over
    chunks of pixels, seed 1), in the row-major order of the covered pixels."""
    import pyshadow
    from pyshadow.lighting import reference_radiance

    order = np.argsort(sp.index)
    out = np.empty((len(order), 3), np.float32)
    sampling = pyshadow.Sampling(samples, seed=1)
    for a in range(0, len(order), chunk):
        i = order[a:a + chunk]
        out[a:a + len(i)] = reference_radiance(scene, sp.points[i], sp.normals[i], lighting, samples=samples,
                                               sampling=sampling, surface_ids=sp.surface_ids[i],
                                               indices=sp.index[i])
    return out


def identical_256(scene, cam, lighting, csm, covered, ground, log, name):
    """"sampled" at 256 samples, the CSM backend ``csm`` against Embree on identical directions.

    Returns the two frames and a record: the relative RMSE between them and,
    with a sun, that of the sky's term alone and the part of the squared
    error on the pixels whose sun ray(s) the two answer differently
    (``ground``: which covered pixels, in row-major order, are the ground)."""
    import pyshadow
    from pyshadow.bench.lit import relative_rmse

    def render(light, vis):
        return pyshadow.render.render(scene, cam, visibility=vis, lighting=light, sampling=pyshadow.Sampling(256))

    c, e = render(lighting, csm), render(lighting, "embree")
    C, E = c.radiance[covered].astype(np.float64), e.radiance[covered].astype(np.float64)
    rec = {"csm_vs_embree_same_dirs": relative_rmse(C, E)}
    if lighting.sun is not None:        # the sky's term alone: the sun's hard shadow edges weigh heavily above
        sky_only = copy.copy(lighting)
        sky_only.sun = None
        sc, se = (render(sky_only, v).radiance[covered].astype(np.float64) for v in (csm, "embree"))
        rec["sky_only_csm_vs_embree_same_dirs"] = relative_rmse(sc, se)
        sun_c, sun_e = C - sc, E - se           # the sun terms (float32 rounding aside)
        diff = np.linalg.norm(sun_c - sun_e, axis=1)
        bad = diff > 1e-3 * np.linalg.norm(sun_e, axis=1).max()
        sq = np.sum((C - E) ** 2, axis=1)
        rec["sun_disagree"] = {"pixels": int(bad.sum()), "fraction": float(bad.mean()),
                               "share_of_squared_error": float(sq[bad].sum() / max(sq.sum(), 1e-300)),
                               "on_ground": float(ground[bad].mean()) if bad.any() else 0.0,
                               "rmse_relative_without": relative_rmse(C[~bad], E[~bad])}
        d = rec["sun_disagree"]
        log(f"{name}: sampled @256, sky term alone: CSM vs Embree {rec['sky_only_csm_vs_embree_same_dirs']:.4f}; "
            f"sun ray(s) answered differently on {d['pixels']} pixels ({100 * d['fraction']:.2f} %, "
            f"{100 * d['on_ground']:.0f} % of them ground), {100 * d['share_of_squared_error']:.1f} % of the "
            f"squared error (without them {d['rmse_relative_without']:.4f})")
    return c, e, rec


def measure_sky(sky, scene, cam, args, log):
    import pyshadow
    from pyshadow.bench.lit import relative_rmse, sky_lighting
    from pyshadow.scene import GROUND_ID

    lighting, rec = sky_lighting(sky)
    asked = {} if args.sun_samples is None else {"sun_samples": args.sun_samples}
    lights = {m: lighting.with_mode(m, **asked) for m in MODES}
    csm = "csm" if args.lookup == "nearest" else "csm-vote"
    sp = pyshadow.render.surface_points(scene, cam)
    covered = covered_pixels(sp, cam)
    ground = sp.surface_ids[np.argsort(sp.index)] == GROUND_ID
    if args.identical_only:
        _, _, same = identical_256(scene, cam, lights["sampled"], csm, covered, ground, log, sky)
        log(f"{sky}: sampled @256: CSM vs Embree on identical directions {same['csm_vs_embree_same_dirs']:.4f}"
            f" (target <= 0.02)")
        return {**rec, "covered_pixels": int(covered.sum()), "sampled_256": same}

    def render(mode, samples, vis=csm, seed=0):
        return pyshadow.render.render(scene, cam, visibility=vis, lighting=lights[mode],
                                      sampling=pyshadow.Sampling(samples, seed=seed))

    t0 = time.perf_counter()
    R = reference(scene, sp, lighting, args.reference_samples)
    log(f"{sky}: reference ({args.reference_samples} sky samples, 1024 over the sun's disc, Embree) in "
        f"{time.perf_counter() - t0:.0f} s")
    n = int(covered.sum())

    def err(frame):
        return relative_rmse(frame.radiance[covered], R)

    row = {**rec, "covered_pixels": n, "reference_samples": args.reference_samples, "at_36": {}}
    ao_t, _ = frame_time(lambda: pyshadow.render.render(scene, cam, visibility=csm,
                                                         sampling=pyshadow.Sampling(36)), args.repeats)
    row["ao_frame_s"] = ao_t
    row["ao_msamples_s"] = n * 36 / ao_t / 1e6
    fits = {}
    for m in MODES:
        t36, f36 = frame_time(lambda: render(m, 36), args.repeats)
        t16, _ = frame_time(lambda: render(m, 16), args.repeats)
        t64, _ = frame_time(lambda: render(m, 64), args.repeats)
        b, a = np.polyfit([16.0, 36.0, 64.0], [t16, t36, t64], 1)
        fits[m] = (max(float(a), 0.0), max(float(b), 1e-9))
        row["at_36"][m] = {"rmse_relative": err(f36), "frame_s": t36, "msamples_s": n * 36 / t36 / 1e6,
                           "frame_s_16": t16, "frame_s_64": t64}
        log(f"{sky}: {m:8s} 36 samples: rel. RMSE {row['at_36'][m]['rmse_relative']:.4f}, frame {t36 * 1e3:.0f} ms "
            f"({n * 36 / t36 / 1e6:.1f} Msamples/s; AO alone {ao_t * 1e3:.0f} ms, {row['ao_msamples_s']:.1f})")
    row["equal_time"] = []
    for budget_mode in MODES:
        budget = row["at_36"][budget_mode]["frame_s"]
        entry = {"budget_of": budget_mode, "budget_s": budget, "modes": {}}
        for m in MODES:
            a, b = fits[m]
            s, t, f = fit_budget(lambda k: frame_time(lambda: render(m, k), max(1, args.repeats // 2)),
                                 int(np.clip(np.floor((budget - a) / b), 1, 1024)), budget)
            entry["modes"][m] = {"samples": s, "frame_s": t, "rmse_relative": err(f)}
            log(f"{sky}: budget {budget * 1e3:.0f} ms ({budget_mode} @36): {m:8s} {s:4d} samples, "
                f"{t * 1e3:.0f} ms, rel. RMSE {entry['modes'][m]['rmse_relative']:.4f}")
        row["equal_time"].append(entry)
    s256, e256, row["sampled_256"] = identical_256(scene, cam, lights["sampled"], csm, covered, ground, log, sky)
    row["sampled_256"].update(csm_vs_reference=err(s256), embree_vs_reference=err(e256))
    log(f"{sky}: sampled @256: CSM vs Embree on identical directions {row['sampled_256']['csm_vs_embree_same_dirs']:.4f}"
        f" (target <= 0.02); vs reference CSM {row['sampled_256']['csm_vs_reference']:.4f}, "
        f"Embree {row['sampled_256']['embree_vs_reference']:.4f}")
    return row


def main(argv=None) -> int:
    import pyshadow

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--reference-samples", type=int, default=1024)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--sky", action="append", choices=("clear", "overcast"))
    ap.add_argument("--maps", default="64x128", help="zigzag map grid THETAxPHI of the casters' CSMs")
    ap.add_argument("--resolution", type=int, default=128, help="CSM texels per side")
    ap.add_argument("--lookup", choices=("nearest", "vote"), default="nearest",
                    help="the CSM lookup of every CSM render (backend 'csm' or 'csm-vote')")
    ap.add_argument("--sun-samples", type=int, default=None,
                    help="rays over the sun's disc a pixel (Lighting(sun_samples=); 1: its centre; default: "
                         "Lighting's, SAMPLED_SUN_SAMPLES in mode 'sampled', 1 in the others)")
    ap.add_argument("--identical-only", action="store_true",
                    help="only 'sampled' at 256 samples, CSM against Embree on identical directions")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    check_counts(ap, args, "repeats", "width", "height")
    check_counts(ap, args, "reference_samples", most=4096)
    check_counts(ap, args, "resolution", most=4096)
    if args.sun_samples is not None:
        check_counts(ap, args, "sun_samples", most=1024)
    if args.identical_only:         # its one render pair has no reference and no timing
        given = [o for o, d in (("--reference-samples", "reference_samples"), ("--repeats", "repeats"))
                 if getattr(args, d) != ap.get_default(d)]
        if given:
            ap.error(f"{', '.join(given)}: --identical-only compares CSM and Embree on the same directions, "
                     "without the reference or the timed renders")

    def log(msg):
        print(msg, file=sys.stderr if args.json else sys.stdout, flush=True)

    t, p = parse_grid(ap, args.maps)
    scene, cam = pyshadow.data.default_scene(width=args.width, height=args.height,
                                             views=pyshadow.ViewSet.zigzag(t, p), resolution=args.resolution)
    rows = [measure_sky(s, scene, cam, args, log) for s in (args.sky or ["clear", "overcast"])]
    checks = {}
    for r in rows:
        a = r.get("at_36")
        checks[r["sky"]] = {} if a is None else {
            "transfer_beats_bent_at_36": a["transfer"]["rmse_relative"] < a["bent"]["rmse_relative"],
            "sampled_beats_bent_at_36": a["sampled"]["rmse_relative"] < a["bent"]["rmse_relative"]}
        checks[r["sky"]].update({
            "sampled_256_within_2pct_of_embree": r["sampled_256"]["csm_vs_embree_same_dirs"] <= 0.02,
            "sampled_256_sky_within_2pct_of_embree": r["sampled_256"].get(
                "sky_only_csm_vs_embree_same_dirs", r["sampled_256"]["csm_vs_embree_same_dirs"]) <= 0.02})
    log(f"checks: {checks}")
    if args.json:
        emit({"benchmark": "lighting_modes", **environment(), "width": args.width, "height": args.height,
              "maps": args.maps, "resolution": args.resolution, "lookup": args.lookup,
              "sun_samples": args.sun_samples, "identical_only": args.identical_only,
              "rows": rows, "checks": checks}, True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

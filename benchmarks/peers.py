"""Benchmark: pyshadow's shadow queries against other ray tracers on identical rays, two threads each.

Two workloads, each a batch of (point, direction) shadow queries against a
scene's casters and its analytic ground plane:

* ``bunny``: the AO workload of benchmarks/visibility.py -- points sampled on
  the Stanford bunny's faces (ground plane under it), 36 cosine-weighted
  directions each from ``pyshadow.sample_directions``, ``--rays`` queries;
* ``two-object``: the bunny and the turned fandisk on the ground
  (``two_object_scene`` of benchmarks/direct_light.py), the covered pixels of
  its 640x480 camera (bodies and ground), a random subset of
  ``--rays / 36`` of them with their 36 AO directions.

pyshadow answers every query (``Scene.visible``, one-texel and vote lookups),
the ground test inside its time. The ray tracers trace only the rays the
ground plane does not stop (decided analytically beforehand, as
``pyshadow.embree`` does, untimed), from the point moved along the ray by
``pyshadow.embree.surface_epsilon``, float32 origins relative to the casters'
anchor; their inputs are built before the clock starts. Every figure is
"workload queries per second": all queries of the batch / the method's time.

Peers, each optional (skipped with the reason when it does not import or
fails), each limited to ``--threads`` threads:

* embreex: ``pyshadow.embree.EmbreeTracer`` (a pool of ``--threads`` Python
  threads; embreex releases the GIL);
* Mitsuba 3 ``Scene.ray_test``, Dr.Jit LLVM backend (``drjit.set_thread_count``);
* Open3D ``RaycastingScene.test_occlusions(..., nthreads=...)``;
* Warp ``mesh_query_ray`` on the CPU (closest hit; the batch split into
  ``--threads`` launches from as many Python threads);
* pyshadow on PoCL: ``POCL_CPU_MAX_CU_NUM`` is set to ``--threads`` before
  the OpenCL device opens (the device's compute units are printed).

Methods run in interleaved rounds (the order rotates each round), so that
the noise of a shared machine meets all alike; the figures are medians.
Agreement is counted against embreex on identical rays: on the traced rays
and on all queries (the ground's answers count as agreeing for the ray
tracers, which share that test). ``pip install -e .[peers]`` installs the
peers (Open3D also needs the system's libusb-1.0, and it imports dash, whose
pytest plugin breaks this repository's test run under filterwarnings=error:
``pytest -p no:dash``, or keep Open3D in a separate environment).

    python benchmarks/peers.py [--rays 3600000] [--rounds 9] [--threads 2] [--scenes bunny,two-object] [--json]
"""
from __future__ import annotations

import argparse
import contextlib
import os
import statistics
import sys
import threading
import time

import numpy as np

SAMPLES = 36
PEERS = ("embreex", "mitsuba", "open3d", "warp")


# ---------------------------------------------------------------------------
# the arithmetic of the table (tested in tests/test_peers.py)
# ---------------------------------------------------------------------------
def agreement(answers, reference, ground=None) -> dict:
    """Agreement of occlusion answers with a reference, on traced rays and on all queries.

    Parameters
    ----------
    answers, reference : ndarray of bool, shape (m,)
        Occluded flags of the same m traced rays.
    ground : int, optional
        Queries of the batch the ground decided (not traced): they count as
        agreeing in ``all``. None: ``all`` is the traced agreement.

    Returns
    -------
    dict
        ``traced`` (fraction of the m rays with equal answers), ``all``
        (equal answers plus ``ground``, over m + ``ground``), ``differ``
        (count of unequal answers).
    """
    a, r = np.asarray(answers, bool), np.asarray(reference, bool)
    if a.shape != r.shape or a.ndim != 1:
        raise ValueError(f"answers and reference must be equal 1-d shapes, got {a.shape} and {r.shape}")
    same = int(np.count_nonzero(a == r))
    m, g = len(a), int(ground or 0)
    return {"traced": same / m if m else 1.0, "all": (same + g) / (m + g) if m + g else 1.0,
            "differ": m - same}


def summarize(times: dict, queries: int, reference: str = "embreex") -> dict:
    """Median time, workload queries per second and speed ratio of each method.

    Parameters
    ----------
    times : dict of str -> list of float
        Seconds of each round, per method.
    queries : int
        Queries of the workload (every method answers all of them).
    reference : str
        The method the ratios are taken against (absent: ratios are None).

    Returns
    -------
    dict of str -> dict
        ``median_s``, ``Mq_per_s`` (``queries / median_s / 1e6``),
        ``ratio`` (reference median / this median: > 1 is faster) and
        ``ratio_rounds`` (the median over rounds of the reference's time /
        this method's time in the same round, which a load that changes
        between rounds disturbs less; None without the reference or with
        unequal round counts).
    """
    med = {k: statistics.median(v) for k, v in times.items() if v}
    ref = med.get(reference)
    rt = times.get(reference, [])
    return {k: {"median_s": s, "Mq_per_s": queries / s / 1e6,
                "ratio": ref / s if ref is not None else None,
                "ratio_rounds": statistics.median(a / b for a, b in zip(rt, times[k]))
                if ref is not None and len(rt) == len(times[k]) else None} for k, s in med.items()}


# ---------------------------------------------------------------------------
# peers: builder(scene, triangles float32 (T, 3, 3), threads) -> (occluded, close or None,
# note[, prepare]); occluded(o32, d32) -> bool (m,), or occluded(prepare(o32, d32)) with the
# peer's own ray arrays built before the clock starts
# ---------------------------------------------------------------------------
def _embreex(scene, tris, threads):
    from pyshadow.embree import EmbreeTracer

    tracer = EmbreeTracer(scene, threads)
    return tracer.occluded, tracer.close, "EmbreeTracer pool of %d threads" % threads


def _mitsuba(scene, tris, threads):
    import drjit as dr
    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")
    dr.set_thread_count(threads)
    v = tris.reshape(-1, 3)
    mesh = mi.Mesh("casters", len(v), len(tris), has_vertex_normals=False, has_vertex_texcoords=False)
    p = mi.traverse(mesh)
    p["vertex_positions"] = mi.Float(np.ascontiguousarray(v).ravel())
    p["faces"] = mi.UInt32(np.arange(len(v), dtype=np.uint32))
    p.update()
    ms = mi.load_dict({"type": "scene", "casters": mesh})

    def prepare(o, d):
        ray = mi.Ray3f(mi.Point3f(*(np.ascontiguousarray(o[:, i]) for i in range(3))),
                       mi.Vector3f(*(np.ascontiguousarray(d[:, i]) for i in range(3))))
        dr.eval(ray)
        dr.sync_thread()
        return ray

    return (lambda ray: np.array(ms.ray_test(ray), dtype=bool)), None, \
        f"Dr.Jit LLVM, drjit.thread_count() = {dr.thread_count()}", prepare


def _open3d(scene, tris, threads):
    import open3d as o3d

    rs = o3d.t.geometry.RaycastingScene()
    v = np.ascontiguousarray(tris.reshape(-1, 3), dtype=np.float32)
    rs.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(np.arange(len(v), dtype=np.uint32).reshape(-1, 3)))

    def prepare(o, d):
        return o3d.core.Tensor(np.ascontiguousarray(np.hstack([o, d]), dtype=np.float32))

    return (lambda rays: rs.test_occlusions(rays, nthreads=threads).numpy().astype(bool)), None, \
        f"test_occlusions(nthreads={threads})", prepare


_WARP_KERNEL = None


def _warp_kernel():
    import warp as wp

    global _WARP_KERNEL
    if _WARP_KERNEL is None:
        @wp.kernel
        def occluded(mesh: wp.uint64, o: wp.array(dtype=wp.vec3), d: wp.array(dtype=wp.vec3),
                     out: wp.array(dtype=wp.int32)):
            tid = wp.tid()
            q = wp.mesh_query_ray(mesh, o[tid], d[tid], 1.0e30)
            out[tid] = wp.where(q.result, 1, 0)

        _WARP_KERNEL = occluded
    return _WARP_KERNEL


def _warp(scene, tris, threads):
    import warp as wp

    if hasattr(wp, "LOG_WARNING"):
        wp.config.log_level = wp.LOG_WARNING        # no greeting or module-load lines
    with contextlib.redirect_stdout(sys.stderr):    # whatever it prints stays out of --json
        wp.init()
    kernel = _warp_kernel()
    v = np.ascontiguousarray(tris.reshape(-1, 3), dtype=np.float32)
    mesh = wp.Mesh(points=wp.array(v, dtype=wp.vec3, device="cpu"),
                   indices=wp.array(np.arange(len(v), dtype=np.int32), dtype=wp.int32, device="cpu"))

    def prepare(o, d):
        n = len(o)
        arrays = (wp.array(np.ascontiguousarray(o), dtype=wp.vec3, device="cpu"),
                  wp.array(np.ascontiguousarray(d), dtype=wp.vec3, device="cpu"),
                  wp.zeros(n, dtype=wp.int32, device="cpu"))
        cuts = np.linspace(0, n, threads + 1).astype(int)
        return arrays, [(a, b) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]

    def occluded(prepared):
        (O, D, out), parts = prepared

        def go(a, b):
            wp.launch(kernel, dim=b - a, inputs=[mesh.id, O[a:b], D[a:b], out[a:b]], device="cpu")

        ts = [threading.Thread(target=go, args=p) for p in parts]
        with contextlib.redirect_stdout(sys.stderr):
            for t in ts:
                t.start()
            for t in ts:
                t.join()
            wp.synchronize_device("cpu")
        return out.numpy().astype(bool)

    return occluded, None, f"{threads} concurrent CPU launches", prepare


BUILDERS = {"embreex": _embreex, "mitsuba": _mitsuba, "open3d": _open3d, "warp": _warp}


def caster_triangles(scene, anchor):
    """World triangles of every caster minus ``anchor``, float32 (T, 3, 3): what each peer traces."""
    tris = []
    for inst in scene.instances:
        if inst.casts:
            T = inst.transform
            w = np.asarray(inst.mesh.vertices, np.float64) @ T[:3, :3].T + T[:3, 3] - anchor
            tris.append(w[np.asarray(inst.mesh.faces)])
    return np.ascontiguousarray(np.concatenate(tris), dtype=np.float32)


# ---------------------------------------------------------------------------
# workloads
# ---------------------------------------------------------------------------
def bunny_workload(rays, cache):
    """The visibility.py scene and workload: (scene, P (N,3) f64, D (N,3) f32, ids (N,) int32)."""
    import pyshadow
    from _common import load_mesh
    from visibility import workload

    mesh = load_mesh("stanford-bunny.obj")
    views = pyshadow.ViewSet.zigzag(64, 128)
    scene = pyshadow.Scene(ground=float(mesh.bounds[0, 1]), views=views, resolution=128)
    csm, _ = cache.csm("bunny", mesh, views, 128, 16)
    scene.add(csm, mesh=mesh)
    _, _, P, D = workload(scene, max(1, rays // SAMPLES), SAMPLES)
    return scene, P, np.ascontiguousarray(D, np.float32), np.zeros(len(P), np.int32)


def two_object_workload(rays, cache, seed=0):
    """direct_light.py's two-object scene; AO queries of a random subset of its covered pixels."""
    import pyshadow
    from direct_light import two_object_scene
    from pyshadow import render

    scene, cam = two_object_scene(640, 480)
    sp = render.surface_points(scene, cam)
    k = min(len(sp.points), max(1, rays // SAMPLES))
    pick = np.sort(np.random.default_rng(seed).choice(len(sp.points), k, replace=False))
    n = np.asarray(sp.normals[pick], np.float64)
    d = pyshadow.sample_directions(n, sampling=pyshadow.Sampling(SAMPLES), indices=sp.index[pick])
    return (scene, np.repeat(sp.points[pick], SAMPLES, axis=0),
            np.ascontiguousarray(d.reshape(-1, 3), np.float32), np.repeat(sp.surface_ids[pick], SAMPLES))


# ---------------------------------------------------------------------------
# one scene: build every method, interleave the rounds, count the agreement
# ---------------------------------------------------------------------------
def run_scene(name, scene, P, D, ids, args, log):
    from pyshadow import embree

    anchor = scene.anchor()
    N = len(P)
    ground = embree.ground_occludes(scene, P - anchor, D, anchor)
    todo = np.flatnonzero(~ground)
    eps = embree.surface_epsilon(scene)
    o32 = (P[todo] - anchor + eps * D[todo]).astype(np.float32)
    d32 = np.ascontiguousarray(D[todo], np.float32)
    tris = caster_triangles(scene, anchor)

    methods, notes, skipped, closers = {}, {}, {}, []
    methods["pyshadow one-texel"] = lambda: scene.visible(P, D, surface_ids=ids)
    methods["pyshadow vote"] = lambda: scene.visible(P, D, surface_ids=ids, lookup="vote")
    for peer in args.peers:
        try:
            built = BUILDERS[peer](scene, tris, args.threads)
            fn, close, note = built[:3]
            if close is not None:
                closers.append(close)
            arg = built[3](o32, d32) if len(built) > 3 else None
            call = (lambda f=fn, a=arg: f(a)) if arg is not None else (lambda f=fn: f(o32, d32))
            methods[peer], notes[peer] = call, note
        except Exception as e:              # a missing or broken peer: skip it, say why
            skipped[peer] = f"{type(e).__name__}: {e}".splitlines()[0][:200]
            log(f"{name}: skipping {peer} ({skipped[peer]})")

    answers, bad = {}, []
    for k, fn in methods.items():           # warm-up: JIT compiles, BVH commits; keeps the answers
        try:
            answers[k] = fn()
        except Exception as e:
            skipped[k] = f"{type(e).__name__}: {e}".splitlines()[0][:200]
            log(f"{name}: skipping {k} ({skipped[k]})")
            bad.append(k)
    for k in bad:
        del methods[k]
    order = list(methods)
    times = {k: [] for k in order}
    log(f"{name}: {N} queries, {len(todo)} traced; {args.rounds} rounds of {', '.join(order)}")
    for r in range(args.rounds):
        for k in order[r % len(order):] + order[:r % len(order)]:
            t0 = time.perf_counter()
            methods[k]()
            times[k].append(time.perf_counter() - t0)
    for c in closers:
        c()
    stats = summarize(times, N)
    ref = answers.get("embreex")
    rows = []
    for k in order:
        row = {"method": k, **stats[k], "times_s": times[k], "note": notes.get(k, "")}
        if ref is not None:
            if k.startswith("pyshadow"):      # visible flags of all N; it decides the ground itself
                a = agreement(~answers[k][todo], ref)
                truth = np.ones(N, bool)
                truth[ground] = False
                truth[todo] = ~ref
                a["all"] = float(np.mean(answers[k] == truth))
            else:
                a = agreement(answers[k], ref, N - len(todo))
            row["agreement_traced"], row["agreement_all"] = a["traced"], a["all"]
        rows.append(row)
    rows.sort(key=lambda r: -r["Mq_per_s"])
    return {"scene": name, "queries": N, "traced": int(len(todo)), "rounds": args.rounds,
            "rows": rows, "skipped": skipped}


def print_table(res):
    print(f"\n{res['scene']}: {res['queries'] / 1e6:.2f} M queries ({res['traced'] / 1e6:.2f} M traced by the "
          f"ray tracers), medians of {res['rounds']} interleaved rounds")
    print(f"{'method':22s} {'M queries/s':>11s} {'vs embreex':>10s} {'per round':>9s} {'agree traced':>12s} "
          f"{'agree all':>10s}  note")
    for r in res["rows"]:
        ratio = f"{r['ratio']:.2f}x" if r["ratio"] is not None else "-"
        ratio = f"{ratio:>10s} " + (f"{r['ratio_rounds']:.2f}x" if r["ratio_rounds"] is not None else "-").rjust(9)
        at = f"{100 * r['agreement_traced']:.4f}%" if "agreement_traced" in r else "-"
        aa = f"{100 * r['agreement_all']:.4f}%" if "agreement_all" in r else "-"
        print(f"{r['method']:22s} {r['Mq_per_s']:11.2f} {ratio} {at:>12s} {aa:>10s}  {r['note']}")
    for k, why in res["skipped"].items():
        print(f"{k:22s} skipped: {why}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rays", type=int, default=3_600_000, help="queries per workload (default %(default)s)")
    ap.add_argument("--rounds", type=int, default=9, help="interleaved timed rounds (default %(default)s)")
    ap.add_argument("--threads", type=int, default=2, help="threads of every method (default %(default)s)")
    ap.add_argument("--scenes", default="bunny,two-object", help="comma-separated: bunny, two-object")
    ap.add_argument("--peers", default=",".join(PEERS), help="comma-separated subset of " + ", ".join(PEERS))
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.rays < SAMPLES or args.rounds < 1 or args.threads < 1:
        ap.error("--rays must be >= 36, --rounds and --threads >= 1")
    args.peers = [p for p in args.peers.split(",") if p]
    scenes = [s for s in args.scenes.split(",") if s]
    for p in args.peers:
        if p not in PEERS:
            ap.error(f"--peers: unknown peer {p!r} (one of {', '.join(PEERS)})")
    for s in scenes:
        if s not in ("bunny", "two-object"):
            ap.error(f"--scenes: unknown scene {s!r}")
    os.environ["POCL_CPU_MAX_CU_NUM"] = str(args.threads)    # before the OpenCL device opens

    from _common import emit, environment
    from pyshadow.cache import CSMCache, default_cache_dir

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    cache = CSMCache(default_cache_dir())
    t0 = time.perf_counter()
    results = []
    for s in scenes:
        scene, P, D, ids = (bunny_workload if s == "bunny" else two_object_workload)(args.rays, cache)
        results.append(run_scene(s, scene, P, D, ids, args, log))
        if not args.json:
            print_table(results[-1])
    out = {"benchmark": "peers", **environment(), "threads": args.threads, "rounds": args.rounds,
           "samples": SAMPLES, "wall_s": time.perf_counter() - t0, "scenes": results}
    if args.json:
        emit(out, True)
    else:
        print(f"\npyshadow device {out['device']} ({out['compute_units']} compute units, "
              f"POCL_CPU_MAX_CU_NUM={args.threads}, {out['lanes']} lanes); wall {out['wall_s']:.0f} s")
        print("packages: " + ", ".join(f"{k} {v}" for k, v in out["packages"].items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())

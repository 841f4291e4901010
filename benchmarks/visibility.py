"""Benchmark: shadow queries per second, pyshadow against Embree on identical rays.

The bunny AO workload: points sampled on the Stanford bunny's faces (on a
ground plane), 36 cosine-weighted directions each from
``pyshadow.sample_directions`` (the AO kernel's own directions), at least
3.6 M rays. Timed, as medians of several runs after a warm-up, in one process
on all cores:

* ``Scene.visible(points, directions)`` end to end (host checks, kernel reading
  the caller's arrays, results) and the kernel alone on device-resident float32
  inputs;
* ``Scene.ambient_occlusion(points, normals, 36)`` (the same workload through
  the AO kernel, which makes the directions on the device);
* ``Scene.visible(..., filtered=True)``, the filtered lookup (four maps x four
  texels, up to 16 segment searches a query), and its agreement with Embree;
* Embree occlusion rays on the identical (origin, direction) pairs, spread over
  a thread pool with one thread per core (embreex releases the GIL);
* a second pose after ``set_transform`` (no rebuild; same time expected),
  timed in alternation with the first pose.

``--profile`` also times the kernel with the nearest-map choice or the
segment search replaced by trivial stand-ins (compile-time macros), to show
what limits it.

    python benchmarks/visibility.py [--points 100000] [--samples 36] [--repeats 5] [--profile] [--json]
"""
from __future__ import annotations

import argparse
import os
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import trimesh

import pyshadow
from pyshadow import _cl, embree
from pyshadow._cl import launch
from _common import MESH_HELP, check_counts, check_meshes, emit, environment, load_mesh, median_time


def workload(scene, n_points, samples, seed=0):
    inst = scene.instances[0]
    local, face = trimesh.sample.sample_surface(inst.mesh, n_points, seed=seed)
    T = inst.transform
    p = local @ T[:3, :3].T + T[:3, 3]
    n = inst.mesh.face_normals[face] @ inst.rotation.T
    d = pyshadow.sample_directions(n, sampling=pyshadow.Sampling(samples, seed=seed)).reshape(-1, 3)
    return p, n, np.repeat(p, samples, axis=0), d


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mesh", default="stanford-bunny.obj", help=MESH_HELP)
    ap.add_argument("--points", type=int, default=100_000)
    ap.add_argument("--samples", type=int, default=36)
    ap.add_argument("--theta", type=int, default=64)
    ap.add_argument("--phi", type=int, default=128)
    ap.add_argument("--resolution", type=int, default=128)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--profile", action="store_true", help="ablation timings of the kernel")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    check_counts(ap, args, "points", "samples", "repeats", "theta", "phi", "threads")
    check_meshes(ap, "--mesh", [args.mesh])
    check_counts(ap, args, "resolution", most=4096)

    mesh = load_mesh(args.mesh)
    t0 = time.perf_counter()
    scene = pyshadow.Scene(ground=float(mesh.bounds[0, 1]), views=pyshadow.ViewSet.zigzag(args.theta, args.phi),
                           resolution=args.resolution)
    scene.add(mesh)
    build_s = time.perf_counter() - t0
    p, n, P, D = workload(scene, args.points, args.samples)
    N = len(P)
    ids = np.zeros(N, np.int32)

    out = {}
    vis_s, vis_all = median_time(lambda: out.__setitem__("vis", scene.visible(P, D, surface_ids=ids)),
                                 args.repeats)
    ao_s, _ = median_time(lambda: out.__setitem__("ao", scene.ambient_occlusion(
        p, n, sampling=pyshadow.Sampling(args.samples), surface_ids=0)),
                          args.repeats)
    filt_s, _ = median_time(lambda: out.__setitem__("filtered", scene.visible(P, D, surface_ids=ids, lookup="vote")),
                            args.repeats)

    # the kernel alone, on device-resident inputs (anchor-relative float32)
    backend = pyshadow.visibility.CSMVisibility("nearest")
    anchor = scene.anchor(P)
    atlas, kargs = backend._scene_args(scene, anchor, None)
    dev_p = _cl.to_device(np.ascontiguousarray(P - anchor, dtype=np.float32))
    dev_w = _cl.to_device(np.ascontiguousarray(D, dtype=np.float32))
    own = _cl.to_device(np.zeros(N, np.int32))
    buf = _cl.empty(N)
    q = _cl.queue()
    fp64 = _cl.has_fp64()
    zero = [np.float64(0.0) if fp64 else np.float32(0.0)] * 3

    def kernel_time(extra=None):
        k = _cl.kernel("visibility.cl", "scene_visible",
                       backend._defines(scene, atlas, HAVE_FP64=int(fp64), POINTS_F64=0, DIRS_F64=0, **(extra or {})))

        def run():
            shape = launch.shape()
            k(q, *launch.grid(-(-N // shape.query_batch), shape.query_group), *kargs, np.int32(N), dev_p, dev_w, *zero, own, buf)
            q.finish()
        return median_time(run, args.repeats)[0]

    kernel_s = kernel_time()
    profile = {}
    if args.profile:
        profile = {"kernel_s": kernel_s,
                   "without_nearest_map_s": kernel_time({"PROFILE_SKIP_NEAREST": 1}),
                   "without_segment_search_s": kernel_time({"PROFILE_SKIP_SEARCH": 1}),
                   "without_both_s": kernel_time({"PROFILE_SKIP_NEAREST": 1, "PROFILE_SKIP_SEARCH": 1})}

    # Embree on the identical rays, one thread per core
    rays, ranchor = embree.caster_scene(scene)
    eps = embree.surface_epsilon(scene)
    ground = embree.ground_occludes(scene, P - ranchor, D, ranchor)
    todo = np.flatnonzero(~ground)
    origins = (P[todo] - ranchor + eps * D[todo]).astype(np.float32)
    dirs = D[todo].astype(np.float32)
    chunks = np.array_split(np.arange(len(todo)), 8 * args.threads)
    emb = {}
    with ThreadPoolExecutor(args.threads) as pool:
        def embree_all():
            parts = list(pool.map(lambda c: rays.occluded(origins[c], dirs[c]), chunks))
            emb["occ"] = np.concatenate(parts)
        embree_s, embree_all_t = median_time(embree_all, args.repeats)
    truth = np.ones(N, bool)
    truth[ground] = False
    truth[todo] = ~emb["occ"]
    agreement = float((out["vis"] == truth).mean())
    agreement_filtered = float((out["filtered"] == truth).mean())

    # a second pose: move the body, nothing is rebuilt. Both poses are timed in
    # alternation, each call right after its set_transform, so that they meet the
    # same machine state (the Embree threads above, other jobs)
    shift = np.array([0.3 * scene.scale(), 0.0, 0.1 * scene.scale()])
    T1 = scene.transform(0)
    T2 = T1.copy()
    T2[:3, 3] += shift
    moved = P + shift
    pose_t = {1: [], 2: []}
    for _ in range(max(args.repeats, 5)):
        for pose, T, pts in ((1, T1, P), (2, T2, moved)):
            scene.set_transform(0, T)
            t0 = time.perf_counter()
            scene.visible(pts, D, surface_ids=ids)
            pose_t[pose].append(time.perf_counter() - t0)
    pose1_s, pose2_s = float(np.median(pose_t[1])), float(np.median(pose_t[2]))

    result = {
        "benchmark": "visibility",
        **environment(),
        "mesh": args.mesh,
        "maps": args.theta * args.phi,
        "resolution": args.resolution,
        "csm_build_s": build_s,
        "queries": N,
        "threads_embree": args.threads,
        "visible_s": vis_s,
        "visible_Mq_per_s": N / vis_s / 1e6,
        "kernel_s": kernel_s,
        "kernel_Mq_per_s": N / kernel_s / 1e6,
        "ambient_occlusion_s": ao_s,
        "ambient_occlusion_Mq_per_s": N / ao_s / 1e6,
        "filtered_s": filt_s,
        "filtered_Mq_per_s": N / filt_s / 1e6,
        "embree_s": embree_s,
        "embree_Mrays_per_s": len(todo) / embree_s / 1e6,
        "embree_rays_traced": int(len(todo)),
        "ratio_visible_vs_embree": embree_s / vis_s,
        "ratio_ao_vs_embree": embree_s / ao_s,
        "ratio_kernel_vs_embree": embree_s / kernel_s,
        "ratio_filtered_vs_embree": embree_s / filt_s,
        "visibility_agreement": agreement,
        "visibility_agreement_filtered": agreement_filtered,
        "first_pose_alternating_s": pose1_s,
        "second_pose_visible_s": pose2_s,
        "profile": profile,
    }
    if args.json:
        emit(result, True)
        return
    r = result
    print(f"device          {r['device']} ({r['platform']}, {r['lanes']} lanes); "
          f"Embree on {args.threads} threads")
    print(f"workload        {N / 1e6:.2f} M rays ({args.points} points x {args.samples}), "
          f"CSM {args.theta}x{args.phi} @ {args.resolution}^2 (built in {build_s:.1f} s)")
    print(f"Scene.visible   {r['visible_Mq_per_s']:6.2f} M queries/s  (median {vis_s:.3f} s; kernel alone "
          f"{r['kernel_Mq_per_s']:.2f} M/s)")
    print(f"ambient_occl.   {r['ambient_occlusion_Mq_per_s']:6.2f} M queries/s  (median {ao_s:.3f} s)")
    print(f"filtered        {r['filtered_Mq_per_s']:6.2f} M queries/s  (median {filt_s:.3f} s; "
          "Scene.visible(..., lookup='vote'))")
    print(f"Embree          {r['embree_Mrays_per_s']:6.2f} M rays/s     (median {embree_s:.3f} s; "
          f"{len(todo)} rays not stopped by the ground)")
    print(f"ratio           visible {r['ratio_visible_vs_embree']:.2f}x, ambient_occlusion "
          f"{r['ratio_ao_vs_embree']:.2f}x, kernel {r['ratio_kernel_vs_embree']:.2f}x, "
          f"filtered {r['ratio_filtered_vs_embree']:.2f}x Embree")
    print(f"agreement       {agreement:.4%} of rays (filtered: {agreement_filtered:.4%})")
    print(f"second pose     {pose2_s:.3f} s after set_transform, first pose {pose1_s:.3f} s "
          f"(medians, timed in alternation; ratio {pose2_s / pose1_s:.2f})")
    if profile:
        print("kernel profile  " + ", ".join(f"{k} {v:.3f}" for k, v in profile.items()))


if __name__ == "__main__":
    main()

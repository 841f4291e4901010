"""Accuracy study: pyshadow's CSM visibility and AO against Embree.

Prints (and with --json returns):

1. visibility agreement with Embree on identical (point, direction) pairs --
   points sampled uniformly on the Stanford bunny's faces (standing on a ground
   plane), cosine-weighted AO directions of their face normals, and uniform
   hemisphere directions -- for CSMs of several map counts D and resolutions R;
2. the same for a two-object scene (bunny and fandisk, the fandisk rotated,
   scaled and moved, both on the ground) at 64x128 maps, 128^2;
3. per-vertex AO of the bunny on the ground, 256 samples, against Embree on
   the identical directions (mean and 99th percentile of |dAO|);
4. AO RMSE at 36 samples against a 4096-sample Embree reference over 2000
   bunny vertices, for every sampling strategy (thesis 5.3.1, Fig. 5.7);
5. the agreement of 1. for every other bundled test mesh (pyshadow.data.MESHES),
   each alone on the ground at 64x128 maps, 128^2, default settings (nothing
   was tuned on them);
6. an error budget for the bunny: on identical rays, the 64x128 CSM against
   one uncompressed map exactly along each ray's own direction (same
   resolution, interval rule, margin, quantisation and default bias; runs one
   map long). What that exact map gets wrong is the resolution's share, which
   no number of maps and no compression can remove; the rest is the CSM's.
   The same for a map whose intervals span the texel footprint (below);
7. footprint intervals (``CoherentShadowMap.build(..., footprint=True)``) on
   the rays of sections 1 and 5: agreement, ratio and build time of every
   mesh at 64x128 maps @ 128^2 beside the default (centre-ray) intervals.
8. what the vote lookup buys: ``Scene.visible(..., lookup="vote")`` (a
   vote over the four maps of ``ViewSet.filter_window`` and the four texels
   around the point in each, up to 16 searches per query instead of one) on
   the rays of section 1 for the bunny's 64x128 CSMs (both kinds of
   intervals) and on the rays of section 2 for the two-object scene.

    python benchmarks/accuracy.py [--quick] [--json]
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import trimesh

import pyshadow
from pyshadow import Sampling, embree
from pyshadow.csm import DEPTH_Q, both_sided_faces, compress_reference, footprint_corners, open_sheet
from pyshadow.csm.core import DEFAULT_BIAS_TEXELS
from pyshadow.csm.reference import shadow_vote
from pyshadow.visibility import visible_reference
from _common import emit, environment, load_mesh


def surface_rays(scene, inst_id, n_points, samples, seed, uniform):
    inst = scene.instances[inst_id]
    local, face = trimesh.sample.sample_surface(inst.mesh, n_points, seed=seed)
    T = inst.transform
    p = local @ T[:3, :3].T + T[:3, 3]
    n = inst.mesh.face_normals[face] @ inst.rotation.T
    if uniform:
        rng = np.random.default_rng(seed)
        d = rng.normal(size=(n_points * samples, 3))
        nr = np.repeat(n, samples, axis=0)
        d = np.where(np.einsum("ij,ij->i", d, nr)[:, None] < 0, -d, d)
    else:
        d = pyshadow.sample_directions(n, sampling=Sampling(samples, seed=seed))
        d = d.reshape(-1, 3).astype(np.float64)
    return np.repeat(p, samples, axis=0), d


def agreement(scene, inst_id, n_points, samples, seed, uniform=False, vote=False):
    """Share of rays from the instance's surface that ``Scene.visible`` answers
    as Embree does; with ``vote=True`` a pair (one-texel lookup, vote lookup
    ``lookup="vote"``) on the same rays."""
    P, D = surface_rays(scene, inst_id, n_points, samples, seed, uniform)
    ids = np.full(len(P), inst_id)
    truth = embree.visible(scene, P, D)
    plain = float((scene.visible(P, D, surface_ids=ids) == truth).mean())
    if not vote:
        return plain
    return plain, float((scene.visible(P, D, surface_ids=ids, lookup="vote") == truth).mean())


def fibonacci_sphere(n):
    """``n`` nearly evenly spread unit vectors (y up)."""
    k = np.arange(n) + 0.5
    y = 1.0 - 2.0 * k / n
    phi = k * np.pi * (3.0 - np.sqrt(5.0))
    s = np.sqrt(1.0 - y * y)
    return np.stack([s * np.cos(phi), y, s * np.sin(phi)], axis=1)


def map_basis(d):
    """Rows ``(u, v, d)`` of an orthonormal camera basis with ``u x v = d``."""
    a = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    u = np.cross(a, d)
    u /= np.linalg.norm(u)
    return np.stack([u, np.cross(d, u), d])


def pcf_visible(scene, points, directions, bias_texels=DEFAULT_BIAS_TEXELS):
    """``Scene.visible`` of a one-caster scene asked by a four-texel vote, in NumPy.

    For each ray, the map nearest it (``ViewSet.nearest``, any layout) and
    the four texels around the point (bilinear weights of the texel centres;
    border texels repeated at the map's edges), each saying shadowed or not
    with the self-bias of ``Scene.visible`` (``bias_texels`` plus the angle
    term); the ray is shadowed when the weights of the shadowing votes sum to
    more than one half (:func:`pyshadow.csm.reference.shadow_vote`, ``texels=4``):
    percentage-closer filtering of the nearest map, where
    ``Scene.visible`` asks the one texel holding the point (and
    ``Scene.visible(..., lookup="vote")`` four maps of a zigzag or hilbert
    grid like this). The scene's caster must be instance 0; the ground plane
    is analytic, as there.
    """
    inst = scene.instances[0]
    csm = inst.csm
    P = np.asarray(points, np.float64)
    W = np.asarray(directions, np.float64)
    W = W / np.linalg.norm(W, axis=1, keepdims=True)
    pn = ((P - inst.transform[:3, 3]) @ inst.rotation) / (inst.scale * csm.radius) - csm.centre / csm.radius
    wn = W @ inst.rotation
    quantum = (1.0 / DEPTH_Q if csm.depth_bits == 16 else 0.0) + 1e-7
    shadowed = shadow_vote(csm, pn, wn, csm.views.nearest(wn)[:, None].astype(np.int64), np.ones((len(P), 1)),
                           quantum=quantum, texels=4, bias_texels=bias_texels)
    ground_only = pyshadow.Scene(ground=scene.ground)
    return (shadowed <= 0.5) & visible_reference(ground_only, P, W)


def error_budget(scene, inst_id, n_dirs, n_points, seed):
    """Agreement with Embree of the instance's CSM and of exact single maps, on identical rays.

    Rays: ``n_dirs`` Fibonacci directions times ``n_points`` surface points,
    the pairs with ``n . w > 0``. That is the joint distribution of uniform
    hemisphere rays from uniform surface points; weighting each pair by
    ``n . w`` gives the AO's cosine-weighted rays. The exact map of direction
    ``w`` is rendered along ``w`` itself and compressed alone (its stored
    depth is the one the CSM's rule would pick for a run of that one map),
    then asked by the NumPy reference of ``Scene.visible`` -- the same
    projection, default bias and ground plane -- in a scene of its own.
    The scene must hold that one caster (and may have a ground plane).

    ``exact_map_footprint`` is the same map built with footprint intervals
    (the corner maps of ``CoherentShadowMap.build(..., footprint=True)``).
    ``pcf`` and ``pcf_footprint``: the same two maps asked by a bilinear vote
    of the four texels around the point (:func:`pcf_visible`) with self-biases
    of 0.5, 1 and 1.5 texels, a lookup that takes 4 searches per query
    instead of one.

    ``wrongly_lit``: the exact map's rays that Embree finds blocked but the
    map lights, as a share of all rays, and the distance to their blocker
    in texels (``2 r / R`` in world units) at the 10/25/50/75/90th
    percentiles; ``grazing``: the share of its wrong answers from rays
    within 6 degrees of the surface (``n . w < 0.1``).

    Returns ``{'csm': (uniform, cosine), 'exact_map': (uniform, cosine),
    'exact_map_footprint': (uniform, cosine), 'pcf': {bias: (uniform, cosine)},
    'pcf_footprint': {...}, 'wrongly_lit': ...,
    'blocker_texels': [...], 'grazing': ...}``.
    """
    inst = scene.instances[inst_id]
    csm, mesh = inst.csm, inst.mesh
    local, face = trimesh.sample.sample_surface(mesh, n_points, seed=seed)
    n_local = mesh.face_normals[face]
    T = inst.transform
    P = local @ T[:3, :3].T + T[:3, 3]
    agree = {"csm": np.zeros(2), "exact_map": np.zeros(2), "exact_map_footprint": np.zeros(2)}
    pcf_biases = (0.5, 1.0, 1.5)
    pcf = {name: {b: np.zeros(2) for b in pcf_biases} for name in ("pcf", "pcf_footprint")}
    R = csm.resolution
    texel = 2.0 * inst.scale * csm.radius / R
    rays, anchor = embree.caster_scene(scene)
    eps = embree.surface_epsilon(scene)
    blocker, n_wrong, n_grazing, n_rays = [], 0, 0, 0
    total = np.zeros(2)
    both = both_sided_faces(mesh, (csm.centre, csm.radius), csm.layer_rule)     # the build's (two_sided='auto')
    for w in fibonacci_sphere(n_dirs):
        wl = w @ inst.rotation                       # the direction in the mesh's frame
        cos = n_local @ wl
        m = cos > 0
        if not m.any():
            continue
        one = pyshadow.ViewSet(wl[None], map_basis(wl)[None])
        layers, front = pyshadow.render_depth(mesh, one, resolution=csm.resolution, layers=csm.layer_rule,
                                              frame=(csm.centre, csm.radius), facing=True, both_sides=both)
        corners, cfront = footprint_corners(mesh, one, R, csm.layer_rule, (csm.centre, csm.radius), both)
        k = int(m.sum())
        W = np.broadcast_to(w, (k, 3))
        truth = embree.visible(scene, P[m], W)
        ours = scene.visible(P[m], W, surface_ids=np.full(k, inst_id))
        weights = np.stack([np.ones(k), cos[m]])
        total += weights.sum(axis=1)
        agree["csm"] += weights[:, ours == truth].sum(axis=1)
        for name, corner_maps in (("exact_map", {}), ("exact_map_footprint",
                                                      {"corners": corners, "corner_front": cfront})):
            offsets, iend, depth = compress_reference(layers, front, csm.layer_rule, csm.depth_bits,
                                                      open_air=open_sheet(mesh, both), **corner_maps)
            exact_map = pyshadow.CoherentShadowMap(
                views=one, resolution=R, depth_bits=csm.depth_bits, layer_rule=csm.layer_rule,
                centre=csm.centre, radius=csm.radius, mesh_hash=csm.mesh_hash, offsets=offsets, iend=iend,
                depth=depth, front_margin_texels=csm.front_margin_texels, footprint=bool(corner_maps))
            alone = pyshadow.Scene(ground=scene.ground)
            alone.add(exact_map, T, mesh=mesh)
            exact = visible_reference(alone, P[m], W, surface_ids=np.zeros(k, int))
            agree[name] += weights[:, exact == truth].sum(axis=1)
            for b in pcf_biases:
                filtered = pcf_visible(alone, P[m], W, bias_texels=b)
                pcf["pcf" if name == "exact_map" else "pcf_footprint"][b] += weights[:, filtered == truth].sum(axis=1)
            if name == "exact_map":
                lit = exact & ~truth
                t, _, _ = rays.intersect(P[m][lit] - anchor + eps * W[lit], W[lit])
                blocker.append(t / texel)
                n_wrong += int((exact != truth).sum())
                n_grazing += int(((exact != truth) & (cos[m] < 0.1)).sum())
                n_rays += k
    out = {k: tuple(float(x) for x in v / total) for k, v in agree.items()}
    for name, by_bias in pcf.items():
        out[name] = {b: tuple(float(x) for x in v / total) for b, v in by_bias.items()}
    blocker = np.concatenate(blocker)
    out["wrongly_lit"] = len(blocker) / n_rays
    out["blocker_texels"] = [float(x) for x in np.quantile(blocker, [0.1, 0.25, 0.5, 0.75, 0.9])]
    out["grazing"] = n_grazing / max(n_wrong, 1)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer configurations and rays")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    t_start = time.perf_counter()
    bunny = load_mesh("stanford-bunny.obj")
    fandisk = load_mesh("fandisk.obj")
    Tb = pyshadow.stand_on_ground(bunny)
    n_pts = 5000 if args.quick else 20000

    # 1. agreement against D and R
    grids = [(16, 32), (32, 64), (64, 128)]
    resolutions = [64, 128] if args.quick else [32, 64, 128, 256]
    table = []
    csm_64x128 = None
    budget_scenes = {}
    for grid in grids:
        for R in resolutions:
            csm = pyshadow.CoherentShadowMap.build(bunny, pyshadow.ViewSet.zigzag(*grid), resolution=R,
                                                   progress=False)
            scene = pyshadow.Scene(ground=0.0)
            scene.add(csm, Tb, mesh=bunny)
            row = {"maps": grid[0] * grid[1], "grid": f"{grid[0]}x{grid[1]}", "resolution": R,
                   "ratio": csm.stats["ratio"],
                   "agreement_ao_rays": agreement(scene, 0, n_pts, 16, 1),
                   "agreement_uniform_rays": agreement(scene, 0, n_pts // 2, 16, 2, uniform=True)}
            table.append(row)
            if grid == (64, 128) and R == 128:
                csm_64x128 = csm
            if grid == (64, 128) and R in (128, 256):
                budget_scenes[R] = scene

    # 2. two bodies on the ground
    rot = trimesh.transformations.rotation_matrix(0.9, [0.3, 1.0, 0.2])[:3, :3]
    two = pyshadow.Scene(ground=0.0)
    two.add(csm_64x128, Tb, mesh=bunny)
    fan_csm = pyshadow.CoherentShadowMap.build(fandisk, pyshadow.ViewSet.zigzag(64, 128), resolution=128,
                                               layers=2, progress=False)
    two.add(fan_csm, pyshadow.stand_on_ground(fandisk, radius=0.8, position=(1.7, 0.4), rotation=rot), mesh=fandisk)
    # (one-texel lookup, vote lookup of section 8) on the same rays
    two_both = {"bunny_ao_rays": agreement(two, 0, n_pts, 16, 3, vote=True),
                "fandisk_ao_rays": agreement(two, 1, n_pts // 2, 16, 4, vote=True),
                "bunny_uniform_rays": agreement(two, 0, n_pts // 2, 16, 5, uniform=True, vote=True),
                "fandisk_uniform_rays": agreement(two, 1, n_pts // 2, 16, 6, uniform=True, vote=True)}
    two_scene = {k: v[0] for k, v in two_both.items()}

    # 3. per-vertex AO, 256 samples
    solo = pyshadow.Scene(ground=0.0)
    solo.add(csm_64x128, Tb, mesh=bunny)
    pts, nrm = solo.vertex_points(0)
    ours = solo.vertex_ao(0, sampling=Sampling(256))
    truth = embree.ambient_occlusion(solo, pts, nrm, sampling=Sampling(256))
    err = np.abs(ours - truth)
    vertex = {"vertices": int(len(pts)), "samples": 256, "mean_abs": float(err.mean()),
              "p99_abs": float(np.quantile(err, 0.99)), "max_abs": float(err.max()),
              "mean_signed": float((ours - truth).mean())}

    # 4. strategies at 36 samples against a 4096-sample reference
    sel = np.random.default_rng(7).choice(len(pts), 2000, replace=False)
    conv = embree.ambient_occlusion(solo, pts[sel], nrm[sel], sampling=Sampling(4096, "hammersley", 16, 99))
    strategies = {}
    for strategy in pyshadow.STRATEGIES:
        s36 = Sampling(36, strategy, seed=3)
        ao = solo.ambient_occlusion(pts[sel], nrm[sel], sampling=s36, surface_ids=0)
        ref36 = embree.ambient_occlusion(solo, pts[sel], nrm[sel], sampling=s36)
        strategies[strategy] = {"rmse": float(np.sqrt(np.mean((ao - conv) ** 2))),
                                "rmse_embree_same_directions": float(np.sqrt(np.mean((ref36 - conv) ** 2)))}

    # 5. the other meshes, default settings; 7. each with footprint intervals on the same rays
    others, footprint, filtered = {}, {}, {}
    views = pyshadow.ViewSet.zigzag(64, 128)
    for fp in (False, True):
        csm = pyshadow.CoherentShadowMap.build(bunny, views, resolution=128, progress=False, footprint=fp)
        scene = pyshadow.Scene(ground=0.0)
        scene.add(csm, Tb, mesh=bunny)
        # 8. the same rays, also asked by the vote lookup
        ao_rays = agreement(scene, 0, n_pts, 16, 1, vote=True)
        uniform_rays = agreement(scene, 0, n_pts // 2, 16, 2, uniform=True, vote=True)
        footprint.setdefault("stanford-bunny.obj", {})[fp] = {
            "ratio": csm.stats["ratio"], "build_seconds": csm.stats["build_seconds"],
            "agreement_ao_rays": ao_rays[0], "agreement_uniform_rays": uniform_rays[0]}
        filtered["footprint" if fp else "centre"] = {"ao_rays": ao_rays[1], "uniform_rays": uniform_rays[1]}
    filtered["two_objects"] = {k: v[1] for k, v in two_both.items()}
    for name in pyshadow.data.MESHES:
        if name == "stanford-bunny.obj":
            continue
        mesh = load_mesh(name)
        for fp in (False, True):
            csm = pyshadow.CoherentShadowMap.build(mesh, views, resolution=128, progress=False, footprint=fp)
            scene = pyshadow.Scene(ground=0.0)
            scene.add(csm, pyshadow.stand_on_ground(mesh), mesh=mesh)
            row = {"ratio": csm.stats["ratio"], "build_seconds": csm.stats["build_seconds"],
                   "agreement_ao_rays": agreement(scene, 0, n_pts // 4, 16, 8),
                   "agreement_uniform_rays": agreement(scene, 0, n_pts // 4, 16, 9, uniform=True)}
            footprint.setdefault(name, {})[fp] = row
            if not fp:
                others[name] = {"faces": int(len(mesh.faces)), "watertight": bool(mesh.is_watertight),
                                "agreement_ao_rays": row["agreement_ao_rays"],
                                "agreement_uniform_rays": row["agreement_uniform_rays"]}
    # 6. error budget: the CSM against an exact map along every ray
    budget = {R: error_budget(sc, 0, 64 if args.quick else 256, n_pts // 5, 10) for R, sc in budget_scenes.items()}

    result = {"benchmark": "accuracy", **environment(), "agreement_table": table, "two_objects": two_scene,
              "vertex_ao": vertex, "strategies_36_samples": strategies, "other_meshes": others,
              "error_budget": {str(R): b for R, b in budget.items()},
              "footprint": {name: {"centre" if not fp else "footprint": v for fp, v in rows.items()}
                            for name, rows in footprint.items()},
              "filtered_lookup": filtered,
              "seconds": time.perf_counter() - t_start}
    if args.json:
        emit(result, True)
        return
    print(f"device: {result['device']}")
    print("\n1. visibility agreement with Embree, Stanford bunny on the ground (rays from its surface)")
    print(f"{'maps':>9} {'R':>5} {'ratio':>7} {'AO rays':>9} {'uniform':>9}")
    for r in table:
        print(f"{r['grid']:>9} {r['resolution']:>5} {r['ratio']:>6.1f}: {r['agreement_ao_rays']:>8.3%} "
              f"{r['agreement_uniform_rays']:>8.3%}")
    print("\n2. two-object scene (64x128 maps @128^2): " + ", ".join(f"{k} {v:.3%}" for k, v in two_scene.items()))
    print(f"\n3. per-vertex AO, 256 samples, {vertex['vertices']} vertices: mean |dAO| {vertex['mean_abs']:.4f}, "
          f"p99 {vertex['p99_abs']:.4f}, max {vertex['max_abs']:.3f}, mean signed {vertex['mean_signed']:+.4f}")
    print("\n4. AO RMSE at 36 samples vs 4096-sample Embree, 2000 bunny vertices")
    for k, v in sorted(strategies.items(), key=lambda kv: kv[1]["rmse"]):
        print(f"   {k:16} pyshadow {v['rmse']:.4f}   (Embree, same directions {v['rmse_embree_same_directions']:.4f})")
    print(f"\n5. agreement on the other meshes, alone on the ground (64x128 maps @128^2, {n_pts // 4} points)")
    print(f"   {'mesh':18} {'faces':>6} {'closed':>6} {'AO rays':>9} {'uniform':>9}")
    for name, r in others.items():
        print(f"   {name:18} {r['faces']:>6} {'yes' if r['watertight'] else 'no':>6} "
              f"{r['agreement_ao_rays']:>8.3%} {r['agreement_uniform_rays']:>8.3%}")
    print("\n6. error budget, bunny on the ground, identical rays: the 64x128 CSM against one exact map "
          "along each ray's direction")
    print(f"   {'R':>5} {'CSM uniform':>12} {'exact uniform':>14} {'footprint':>10} {'CSM cosine':>11} "
          f"{'exact cosine':>13} {'footprint':>10}")
    for R, b in budget.items():
        print(f"   {R:>5} {b['csm'][0]:>11.3%} {b['exact_map'][0]:>13.3%} {b['exact_map_footprint'][0]:>9.3%} "
              f"{b['csm'][1]:>10.3%} {b['exact_map'][1]:>12.3%} {b['exact_map_footprint'][1]:>9.3%}")
    for R, b in budget.items():
        print(f"   R={R}, four-texel vote (PCF) on the exact maps, self-bias in texels, uniform / cosine: "
              + "; ".join(f"{bias}: {u:.3%} / {c:.3%} (footprint {fu:.3%} / {fc:.3%})"
                          for (bias, (u, c)), (fu, fc) in zip(b["pcf"].items(), b["pcf_footprint"].values())))
    for R, b in budget.items():
        print(f"   R={R}: the exact map lights {b['wrongly_lit']:.3%} of the rays Embree finds blocked, "
              f"their blockers at {' / '.join(f'{x:.1f}' for x in b['blocker_texels'])} texels "
              f"(10/25/50/75/90 %); {b['grazing']:.0%} of its wrong answers are rays within 6 deg of the surface")
    print("\n7. footprint intervals (build(..., footprint=True)) against the default, 64x128 maps @128^2, "
          "the rays of sections 1 and 5")
    print(f"   {'mesh':18} {'ratio':>13} {'build s':>11} {'AO rays':>19} {'uniform rays':>19}")
    for name, rows in footprint.items():
        a, b = rows[False], rows[True]
        print(f"   {name:18} {a['ratio']:>5.1f} -> {b['ratio']:>4.1f} {a['build_seconds']:>4.1f} -> "
              f"{b['build_seconds']:>4.1f} {a['agreement_ao_rays']:>7.3%} -> {b['agreement_ao_rays']:>7.3%} "
              f"{a['agreement_uniform_rays']:>7.3%} -> {b['agreement_uniform_rays']:>7.3%}")
    print("\n8. vote lookup (Scene.visible(..., lookup=\"vote\"): 4 maps x 4 texels, up to 16 searches a "
          "query), 64x128 maps @128^2")
    for name in ("centre", "footprint"):
        r, base = filtered[name], footprint["stanford-bunny.obj"][name == "footprint"]
        print(f"   bunny, {name:9} intervals, rays of section 1: AO rays {base['agreement_ao_rays']:.3%} -> "
              f"{r['ao_rays']:.3%}, uniform rays {base['agreement_uniform_rays']:.3%} -> {r['uniform_rays']:.3%}")
    print("   two-object scene, rays of section 2: " + ", ".join(
        f"{k} {two_scene[k]:.3%} -> {v:.3%}" for k, v in filtered["two_objects"].items()))
    print(f"\n({result['seconds']:.0f} s)")


if __name__ == "__main__":
    main()

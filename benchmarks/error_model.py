"""The error model against measured CSMs: every shared mesh, the two-object scene, a mixed scene.

1. For every mesh of ``pyshadow.data.MESHES`` and each target (2 %, 1 %,
   0.5 % disagreement with Embree): ``CoherentShadowMap.build(mesh,
   max_error=target)`` (verification on). Its choice, the model's
   prediction (on the model's rays) and the built CSM's measured
   disagreement (on independent rays, through the visibility kernel), for
   the body's own AO rays and for rays of bodies around it; measured over
   predicted; whether the target was met.
2. The two-object scene of ``accuracy.py`` (bunny and fandisk, rotated,
   scaled and moved, on the ground) with each body's CSM chosen at each
   target: predicted (traced taps of both bodies' layouts) against measured
   (the kernel) disagreement on identical AO rays from both bodies.
3. A detailed and a smooth body (the bundled scene's bunny and torus) at
   ``max_error=0.01``: agreement on each body's AO rays in the scene, and
   the bytes of the chosen CSMs against both at the bunny's parameters.
4. With ``--shapes``: part 1's rows for shapes made here (:data:`SHAPES`),
   meshes the model was not calibrated on -- a thin plate, a capsule, a
   rough sphere, a comb of thin fins, an open tube, a thin ring. With
   ``--files``: the same for mesh files (held out: meshes from elsewhere
   that no rule or constant of the model was fitted on).

    python benchmarks/error_model.py [--quick] [--meshes NAME ...] [--targets E ...] [--meshes-only]
                                     [--shapes [NAME ...] | --files PATH ...] [--lookup auto|nearest|vote]
                                     [--json]

``--quick``: 2 % and 1 % only, four meshes. ``--meshes`` and ``--targets``
choose the rows of part 1 (and the targets of part 2), each over what
``--quick`` would choose (so not all three together); ``--meshes-only``
skips parts 2 and 3. ``--shapes`` alone runs part 4 only (every shape, or
those named), at ``--targets``; ``--files`` likewise (a row whose
choice finds no candidate in the memory free records the MemoryError). ``--lookup`` (``auto``, the default;
``nearest``, ``vote``): the lookup the rows of parts 1 and 4 choose for
(with ``--meshes-only`` or ``--shapes``).
"""
from __future__ import annotations

import argparse
import time
import warnings
from functools import partial
from pathlib import Path

import numpy as np
import trimesh

import pyshadow
from pyshadow import embree
from pyshadow.csm.error_model import MODEL_RATIO, Body, Layout, ao_rays, model_visible, truth_visible, wilson
from _common import check_file, check_meshes, emit, environment

TARGETS = (0.02, 0.01, 0.005)


def _comb():
    """Eight fins 0.05 thick, 0.6 tall, 0.14 apart, on a base plate: thin parts and narrow gaps."""
    box = trimesh.creation.box
    move = trimesh.transformations.translation_matrix
    fins = [box((0.05, 1.0, 0.6), move((x, 0.0, 0.0))) for x in np.linspace(-0.5, 0.5, 8)]
    return trimesh.util.concatenate(fins + [box((1.1, 1.0, 0.05), move((0.0, 0.0, -0.3)))])


def _rough():
    """An icosphere (2,562 vertices) with each vertex moved along its radius by 8 % noise: detail at the
    scale of a face, everywhere."""
    m = trimesh.creation.icosphere(4)
    v = m.vertices * (1 + 0.08 * np.random.default_rng(3).standard_normal(len(m.vertices)))[:, None]
    return trimesh.Trimesh(v, m.faces)


def _tube():
    """A cylinder's side without its caps (radius 0.3, length 1.5): open, its inside as much surface as its
    outside, with walls of no thickness at the rims."""
    m = trimesh.creation.cylinder(0.3, 1.5, sections=48)
    return trimesh.Trimesh(m.vertices, m.faces[np.abs(m.face_normals[:, 2]) < 0.5])


#: part 4's shapes: meshes none of the model's rules or constants were fitted on (name -> a function making it)
SHAPES = {
    "plate": partial(trimesh.creation.box, (1.0, 1.0, 0.01)),
    "capsule": partial(trimesh.creation.capsule, 1.0, 0.25),
    "rough": _rough,
    "comb": _comb,
    "tube": _tube,
    "ring": partial(trimesh.creation.torus, 0.6, 0.08, major_sections=64, minor_sections=16),
}


def choose(mesh, target, layers="auto", lookup="auto"):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)         # a miss is reported in the row
        return pyshadow.CoherentShadowMap.build(mesh, max_error=target, layers=layers, lookup=lookup,
                                                progress=False)


def mesh_row(name, mesh, target, lookup="auto"):
    csm = choose(mesh, target, lookup=lookup)
    c = csm.stats["choice"]
    p, m = c["predicted"], c["measured"]
    built = [t for t in c["tried"] if "build_seconds" in t]
    row = {"mesh": name, "target": target, "choice": p["layout"], "lookup": c["lookup"],
           "bytes": csm.stats["bytes"], "met": c["met"],
           "candidates_predicted": len(c["tried"]), "builds": len(built),
           "model_seconds": sum(t["predicted"]["seconds"] for t in c["tried"]),
           "build_seconds": sum(t["build_seconds"] for t in built), "choice_seconds": c["seconds"]}
    for k in ("own", "near"):
        row[f"predicted_{k}"] = p[k]["disagreement"]
        row[f"measured_{k}"] = m[k]["disagreement"]
    row["predicted"], row["measured"] = p["disagreement"], m["disagreement"]
    row["ratio"] = m["disagreement"] / p["disagreement"] if p["disagreement"] > 0 else None
    row["within_1_5"] = row["ratio"] is not None and 1 / 1.5 <= row["ratio"] <= 1.5
    return csm, row


def scene_rays(scene, mesh_of, seed):
    """AO rays from every caster's surface in world space: (p, d, n, owner)."""
    P, D, N, O = [], [], [], []
    for i in scene.casters:
        inst = scene.instances[i]
        p, d, n = ao_rays(mesh_of[i], 2000, 16, seed + i)
        T = inst.transform
        P.append(p @ T[:3, :3].T + T[:3, 3])
        D.append(d @ inst.rotation.T)
        N.append(n @ inst.rotation.T)
        O.append(np.full(len(p), i))
    return np.concatenate(P), np.concatenate(D), np.concatenate(N), np.concatenate(O)


def scene_study(scene, mesh_of, seed=21, lookup="nearest"):
    """Per body and overall: predicted and measured disagreement on identical AO rays."""
    bodies = [Body(mesh_of[i], inst.transform, Layout(inst.csm.views, inst.csm.resolution, inst.csm.depth_bits,
                                                      inst.csm.centre, inst.csm.radius))
              for i, inst in enumerate(scene.instances)]
    p, d, n, owner = scene_rays(scene, mesh_of, seed)
    truth_m = truth_visible(bodies, p, d, ground=scene.ground)
    model = model_visible(bodies, p, d, n, owner, lookup=lookup, ground=scene.ground)
    truth = embree.visible(scene, p, d)
    ours = scene.visible(p, d, surface_ids=owner, normals=n, lookup=lookup)
    out = {"truth_agreement_model_vs_kernel_reference": float(np.mean(truth_m == truth))}
    for name, rows in [("all", np.ones(len(p), bool))] + [(f"body{i}", owner == i) for i in scene.casters]:
        pr, me = float(np.mean(model[rows] != truth_m[rows])), float(np.mean(ours[rows] != truth[rows]))
        k = int(np.count_nonzero(ours[rows] != truth[rows]))
        out[name] = {"predicted": pr, "measured": me, "measured_interval": wilson(k, int(rows.sum())),
                     "ratio": me / pr if pr > 0 else None, "agreement": 1 - me, "rays": int(rows.sum())}
    return out


def _mesh_name(name):
    """The entry of ``pyshadow.data.MESHES`` that ``name`` means (file name or stem)."""
    for full in pyshadow.data.MESHES:
        if name.lower() in (full.lower(), full.rsplit(".", 1)[0].lower()):
            return full
    raise SystemExit(f"no bundled mesh {name!r}; available: {', '.join(pyshadow.data.MESHES)}")


def scenes(meshes, chosen, targets, quiet):
    """Parts 2 and 3: the two-object scene at each target, the mixed scene at 1 %."""
    bunny, fandisk, torus = (meshes[n] for n in ("stanford-bunny.obj", "fandisk.obj", "torus.STL"))
    rot = trimesh.transformations.rotation_matrix(0.9, [0.3, 1.0, 0.2])[:3, :3]
    two = {}
    for target in targets:
        for n, m in (("stanford-bunny.obj", bunny), ("fandisk.obj", fandisk)):
            if (n, target) not in chosen:
                chosen[n, target] = choose(m, target)
        s = pyshadow.Scene(ground=0.0)
        s.add(chosen["stanford-bunny.obj", target], pyshadow.stand_on_ground(bunny), mesh=bunny)
        s.add(chosen["fandisk.obj", target], pyshadow.stand_on_ground(fandisk, radius=0.8, position=(1.7, 0.4),
                                                                      rotation=rot), mesh=fandisk)
        lk = "vote" if any(chosen[n, target].stats["choice"]["lookup"] == "vote"
                           for n in ("stanford-bunny.obj", "fandisk.obj")) else "nearest"
        two[target] = scene_study(s, {0: bunny, 1: fandisk}, lookup=lk)
        two[target]["lookup"] = lk
        if not quiet:
            a = two[target]["all"]
            print(f"two-object scene {target:.3f}: predicted {a['predicted']:.4f} measured {a['measured']:.4f} "
                  f"ratio {a['ratio']:.2f}", flush=True)

    # 3. detailed and smooth at 1 %
    parts = {name: (m, T) for name, m, T, casts in pyshadow.data.default_parts() if casts}
    mixed = pyshadow.Scene(ground=0.0)
    for name, (m, T) in parts.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            mixed.add(m, T, max_error=0.01, lookup="auto")
    lk = "vote" if any(inst.csm.stats["choice"]["lookup"] == "vote" for inst in mixed.instances) else "nearest"
    study = scene_study(mixed, {i: parts[n][0] for i, n in enumerate(parts)}, lookup=lk)
    csms = [inst.csm for inst in mixed.instances]
    detailed = max(csms, key=lambda c: c.maps * c.resolution ** 2)
    same = [detailed.stats["bytes"] if c is detailed else
            pyshadow.CoherentShadowMap.build(parts[n][0], detailed.views, resolution=detailed.resolution,
                                             progress=False).stats["bytes"] for n, c in zip(parts, csms)]
    mixed_out = {"lookup": lk,
                 "bodies": {n: {"choice": c.stats["choice"]["predicted"]["layout"], "bytes": c.stats["bytes"],
                                "lookup": c.stats["choice"]["lookup"],
                                "agreement": study[f"body{i}"]["agreement"]}
                            for i, (n, c) in enumerate(zip(parts, csms))},
                 "bytes_chosen": sum(c.stats["bytes"] for c in csms), "bytes_at_detailed_parameters": sum(same),
                 "study": study}
    return two, mixed_out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--meshes", nargs="+", metavar="NAME", help="bundled meshes (file name or stem)")
    ap.add_argument("--targets", nargs="+", type=float, metavar="E")
    ap.add_argument("--meshes-only", action="store_true", help="part 1 only")
    ap.add_argument("--shapes", nargs="*", metavar="NAME", choices=tuple(SHAPES),
                    help=f"part 4 only: shapes made here ({', '.join(SHAPES)}; all where none is named)")
    ap.add_argument("--files", nargs="+", metavar="PATH",
                    help="part 4 only: mesh files (any format load_mesh reads) in place of the shapes")
    ap.add_argument("--lookup", choices=("auto", "nearest", "vote"), default="auto",
                    help="the lookup part 1 and part 4 choose for (default: auto)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.targets and not all(0 < t < 1 for t in args.targets):
        ap.error(f"--targets must lie in (0, 1) (a disagreement, 0.01 = 1 %), got {args.targets}")
    if args.quick and args.meshes and args.targets:
        ap.error("--quick chooses meshes and targets; with both --meshes and --targets given it has no effect")
    check_meshes(ap, "--meshes", args.meshes or (), files=False)
    for f in args.files or ():
        check_file(ap, "--files", f)
    part4 = args.shapes is not None or args.files is not None
    if part4 and (args.meshes or args.quick or args.meshes_only or (args.shapes is not None and args.files)):
        ap.error("--shapes and --files run part 4 alone: give one of them without --meshes, --quick and "
                 "--meshes-only")
    if args.lookup != "auto" and not (args.meshes_only or part4):
        ap.error("--lookup applies to the rows of parts 1 and 4: give it with --meshes-only or --shapes "
                 "(parts 2 and 3 reuse part 1's choices)")
    t0 = time.perf_counter()
    targets = args.targets or (TARGETS[:2] if args.quick else TARGETS)
    if args.files is not None:
        meshes = {Path(f).name: pyshadow.load_mesh(f) for f in args.files}
        names = tuple(meshes)
    elif args.shapes is not None:
        names = tuple(args.shapes) or tuple(SHAPES)
        meshes = {n: SHAPES[n]() for n in names}
    else:
        names = (("stanford-bunny.obj", "fandisk.obj", "torus.STL", "homer.obj") if args.quick
                 else pyshadow.data.MESHES)
        if args.meshes:
            names = tuple(_mesh_name(n) for n in args.meshes)
        meshes = {n: pyshadow.data.mesh(n) for n in set(names) | {"stanford-bunny.obj", "fandisk.obj", "torus.STL"}}

    rows, chosen = [], {}
    for name in names:
        for target in targets:
            try:
                csm, row = mesh_row(name, meshes[name], target, args.lookup)
            except MemoryError as e:
                if args.files is None:
                    raise
                rows.append({"mesh": name, "target": target, "memory_error": str(e), "within_1_5": False,
                             "met": False, "ratio": None})
                print(f"{name:20s} {target:.3f} {e}", flush=True)
                continue
            chosen[name, target] = csm
            rows.append(row)
            if not args.json:
                print(f"{name:20s} {target:.3f} {row['choice']:16s} {row['lookup']:7s} own {row['predicted_own']:.4f}/"
                      f"{row['measured_own']:.4f} near {row['predicted_near']:.4f}/{row['measured_near']:.4f} "
                      f"ratio {row['ratio'] if row['ratio'] is None else round(row['ratio'], 2)} met {row['met']} "
                      f"{row['bytes'] / 1e6:.2f} MB  model {row['model_seconds']:.1f} s build "
                      f"{row['build_seconds']:.1f} s", flush=True)

    two, mixed_out = {}, None
    if not args.meshes_only and not part4:
        two, mixed_out = scenes(meshes, chosen, targets, args.json)
    res = {"benchmark": "error_model", **environment(), "model_ratio": MODEL_RATIO, "targets": targets,
           "rows_are": ("mesh files" if args.files is not None else "shapes made here" if args.shapes is not None
                        else "bundled meshes"), "lookup": args.lookup,
           "meshes": rows, "two_objects": {str(k): v for k, v in two.items()}, "mixed": mixed_out,
           "all_within_1_5": all(r["within_1_5"] for r in rows) and all(
               v["all"]["ratio"] is not None and 1 / 1.5 <= v["all"]["ratio"] <= 1.5 for v in two.values()),
           "all_met": all(r["met"] for r in rows), "seconds": time.perf_counter() - t0}
    if not args.json:
        ratios = [r["ratio"] for r in rows if r["ratio"] is not None]
        print(f"measured / predicted over {len(ratios)} mesh rows: {min(ratios):.2f} .. {max(ratios):.2f} "
              f"(median {np.median(ratios):.2f}); all within 1.5x: {res['all_within_1_5']}; all met: {res['all_met']}")
        for n, b in (mixed_out or {"bodies": {}})["bodies"].items():
            print(f"mixed scene at 1 %: {n} {b['choice']} {b['lookup']} {b['bytes'] / 1e6:.2f} MB, agreement {b['agreement']:.4%}")
        if mixed_out:
            print(f"mixed scene bytes {mixed_out['bytes_chosen'] / 1e6:.2f} MB against "
                  f"{mixed_out['bytes_at_detailed_parameters'] / 1e6:.2f} MB at the detailed body's parameters")
        print(f"total {res['seconds']:.0f} s")
    emit(res, args.json)


if __name__ == "__main__":
    main()

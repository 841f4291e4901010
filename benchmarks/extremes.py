"""Numerical stability at the extremes: one row per extreme, measured against Embree.

Each row builds what it needs, asks pyshadow and Embree the identical rays,
and prints its figure, the bound it is held to and pass/fail (``--json``
too; "info" for baselines and documented behaviour). The row groups of this
file:

- ``grazing``: rays exactly 0.01 degrees, 0.01-0.5, 0.5-3 and 3-6 degrees
  above the flat top face of a thin plate (3 mm on a 1 m part), from points
  on that face: the fraction the CSM reports shadowed, where Embree sees the
  sky on every one (the plate cannot shadow its own top face). Both
  lookups, with the face's normal (the surface rule, what AO always does)
  and, informational, without it.
- ``sun-sphere``: a tessellated sphere under three directional lights:
  points with n.l > 0.05 shadowed by the sphere itself (bound 0).
- ``translation``: the bundled scene moved 1e5 and 1e7 from the origin:
  visibility agreement with Embree on AO rays, and AO, against the scene at
  the origin (bounds: 0.1 points of agreement, 0.005 mean absolute AO).
- ``scale``: the bundled scene scaled by 1e-3, 1e4, 1e-20 and 1e20 (the last
  two beyond float32's products of three coordinates): agreement against the
  scene at scale 1 (bound: 0.1 points).

and those of ``extremes_geometry.py`` (size, position, thin plate, 4 cm
beside 4 m, contact, ground contact, points on faces / edges / vertices,
invariants), ``extremes_meshes.py`` (broken meshes) and ``extremes_params.py`` (directions at the
poles, on the seam and between maps; samples 1 and 4096; map counts 2x4 to
256x512; resolutions 8 to 1024; 16- and 32-bit depth; 1 and 10,000
instances; receivers only; no ground), whose docstrings give their bounds.

    python benchmarks/extremes.py [--rows grazing,translation,...] [--maps 64x128] [--json]
"""
from __future__ import annotations

import argparse
import sys

import numpy as np
import trimesh

from _common import check_counts, emit, environment, parse_grid

#: the bound a false-shadow fraction is held to: the visibility disagreement of
#: the CSM on AO rays of the bunny (0.5 %, benchmarks/README.md)
FALSE_SHADOW_BOUND = 0.005
AGREEMENT_POINTS = 0.1          # translation and scale invariance (issue's bound)
AO_MEAN_ABS = 0.005


def _row(name, figure, bound, ok, **extra):
    """One row of the table; ``bound`` and ``ok`` None for an informational row."""
    return {"row": name, "figure": figure, "bound": bound, "pass": None if ok is None else bool(ok), **extra}


def grazing_rows(resolution: int, views, n: int = 20000, seed: int = 3) -> list[dict]:
    """Points on the top face of a 1 m x 1 m x 3 mm plate, rays at low elevation above it.

    With the face's normal (``normals=``, what AO always passes) the surface
    rule applies and the row is held to the bound; without it the figure is
    the documented limit of a lookup that does not know the surface
    (informational: bound None).
    """
    import pyshadow
    from pyshadow import embree, visibility

    plate = trimesh.creation.box((1.0, 0.003, 1.0))
    csm = pyshadow.CoherentShadowMap.build(plate, views, resolution=resolution, progress=False)
    scene = pyshadow.Scene()                      # no ground: only the plate can shadow
    scene.add(csm, mesh=plate)
    rng = np.random.default_rng(seed)
    top = 0.0015
    rows = []
    for lo, hi in ((0.01, 0.01), (0.01, 0.5), (0.5, 3.0), (3.0, 6.0)):
        p = np.column_stack([rng.uniform(-0.45, 0.45, n), np.full(n, top), rng.uniform(-0.45, 0.45, n)])
        elev = np.radians(rng.uniform(lo, hi, n))
        az = rng.uniform(0.0, 2.0 * np.pi, n)
        d = np.column_stack([np.cos(elev) * np.cos(az), np.sin(elev), np.cos(elev) * np.sin(az)])
        normals = np.tile([0.0, 1.0, 0.0], (n, 1))
        truth = embree.visible(scene, p, d)
        band = f"{lo:g} deg" if lo == hi else f"{lo:g}-{hi:g} deg"
        for backend in ("csm", "csm-vote"):
            for given in (True, False):
                vis = visibility.visible(scene, p, d, backend=backend, surface_ids=0,
                                         normals=normals if given else None)
                false_shadow = float(np.mean(truth & ~vis))
                label = f"grazing {band}, {backend}" + ("" if given else ", no normals")
                bound = FALSE_SHADOW_BOUND if given else None
                rows.append(_row(label, false_shadow, bound, false_shadow <= FALSE_SHADOW_BOUND if given else None,
                                 unit="fraction of rays wrongly shadowed", embree_open=float(truth.mean())))
    return rows


def sun_sphere_rows(resolution: int, views, n: int = 100000, lights: int = 3, seed: int = 2) -> list[dict]:
    """A tessellated sphere under a directional light: points with n.l > 0.05 shadowed by the sphere itself."""
    import pyshadow
    from pyshadow import embree, visibility

    sphere = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
    csm = pyshadow.CoherentShadowMap.build(sphere, views, resolution=resolution, progress=False)
    scene = pyshadow.Scene()
    scene.add(csm, mesh=sphere)
    pts, face = trimesh.sample.sample_surface(sphere, n, seed=seed)
    normals = sphere.face_normals[face]
    rng = np.random.default_rng(seed)
    rows = []
    for backend in ("csm", "csm-vote"):
        bad = lit = 0
        for _ in range(lights):
            sun = rng.normal(size=3)
            sun /= np.linalg.norm(sun)
            ndl = normals @ sun
            sel = ndl > 0.05
            d = np.tile(sun, (int(sel.sum()), 1))
            truth = embree.visible(scene, pts[sel], d)
            vis = visibility.visible(scene, pts[sel], d, backend=backend, surface_ids=0, normals=normals[sel])
            bad += int((truth & ~vis).sum())
            lit += int(truth.sum())
        rows.append(_row(f"sphere under the sun, n.l > 0.05, {backend}", bad, 0, bad == 0,
                         unit="points shadowed by the sphere itself", points=lit))
    return rows


def _moved_scene(scene, camera, shift, scale):
    """The same scene with every transform, the ground and the camera scaled, then shifted."""
    import pyshadow

    S = np.diag([scale, scale, scale, 1.0])
    S[:3, 3] = shift
    out = pyshadow.Scene(ground=scene.ground * scale + shift[1])
    for inst in scene.instances:
        T = S @ inst.transform
        if inst.casts:
            out.add(inst.csm, T, mesh=inst.mesh)
        else:
            out.add(inst.mesh, T, casts=False)
    cam = pyshadow.Camera(camera.eye * scale + shift, camera.target * scale + shift, fov_y=camera.fov_y,
                          width=camera.width, height=camera.height)
    return out, cam


def _ao_rays(scene, camera, samples: int = 16):
    """Surface points of the camera's covered pixels and their AO rays (identical in every frame)."""
    import pyshadow
    from pyshadow.render import surface_points

    sp = surface_points(scene, camera)
    n = np.asarray(sp.normals, np.float64)
    d = pyshadow.sample_directions(n, sampling=pyshadow.Sampling(samples), indices=sp.index)
    return sp, np.repeat(sp.points, samples, axis=0), d.reshape(-1, 3).astype(np.float64), samples


def invariance_rows(kind: str, views, resolution: int) -> list[dict]:
    """Agreement with Embree of the bundled scene moved (or scaled), against it at the origin."""
    import pyshadow
    from pyshadow import embree
    from pyshadow.data import default_scene

    base, camera = default_scene(views=views, resolution=resolution, width=160, height=120)
    cases = ((1e5, 1.0), (1e7, 1.0)) if kind == "translation" else ((0.0, 1e-3), (0.0, 1e4), (0.0, 1e-20), (0.0, 1e20))
    results = {}
    for offset, scale in ((0.0, 1.0),) + cases:
        shift = np.array([offset, 0.5 * offset, -offset])
        scene, cam = _moved_scene(base, camera, shift, scale)
        sp, P, D, S = _ao_rays(scene, cam)
        vis = scene.visible(P, D, surface_ids=np.repeat(sp.surface_ids, S),
                            normals=np.repeat(np.asarray(sp.normals, np.float64), S, axis=0))
        truth = embree.visible(scene, P, D)
        ao = scene.ambient_occlusion(sp.points, sp.normals, indices=sp.index, surface_ids=sp.surface_ids,
                                     sampling=pyshadow.Sampling(S))
        results[(offset, scale)] = {"agreement": float((vis == truth).mean()), "ao": ao, "pixels": sp.index}
    ref = results[(0.0, 1.0)]
    rows = []
    for key in cases:
        r = results[key]
        same_pixels = np.array_equal(r["pixels"], ref["pixels"])
        d_agree = 100.0 * abs(r["agreement"] - ref["agreement"])
        label = f"offset {key[0]:g}" if kind == "translation" else f"scale {key[1]:g}"
        rows.append(_row(f"{label}: agreement", d_agree, AGREEMENT_POINTS, d_agree <= AGREEMENT_POINTS,
                         unit="points of agreement from the scene at the origin",
                         agreement=r["agreement"], agreement_origin=ref["agreement"]))
        if kind == "translation":
            mad = float(np.abs(r["ao"] - ref["ao"]).mean()) if same_pixels else float("inf")
            rows.append(_row(f"{label}: AO", mad, AO_MEAN_ABS, mad <= AO_MEAN_ABS,
                             unit="mean absolute AO difference from the scene at the origin",
                             same_pixels=same_pixels))
    return rows


ROWS = {"grazing": lambda a: grazing_rows(a.resolution, a.views),
        "sun-sphere": lambda a: sun_sphere_rows(a.resolution, a.views),
        "translation": lambda a: invariance_rows("translation", a.views, a.resolution),
        "scale": lambda a: invariance_rows("scale", a.views, a.resolution)}


def _all_rows() -> dict:
    """This module's row groups, then those of extremes_geometry.py and extremes_params.py."""
    import extremes_geometry
    import extremes_meshes
    import extremes_params

    out = dict(ROWS)
    for module in (extremes_geometry, extremes_meshes, extremes_params):
        clash = set(out) & set(module.ROWS)
        if clash:
            raise RuntimeError(f"row groups {sorted(clash)} defined twice")
        out.update(module.ROWS)
    return out


def main(argv=None, groups=None, benchmark: str = "extremes", detail=None) -> int:
    """The table of ``groups`` (default: every group), or ``--json``; exit 1 if a row fails.

    ``extremes_geometry.py``, ``extremes_meshes.py`` and ``extremes_params.py``
    call it with their own groups; ``detail(row)`` adds text after a row. A
    group that raises becomes a failing row and the other groups still run.
    """
    import time

    import pyshadow

    groups = _all_rows() if groups is None else groups
    ap = argparse.ArgumentParser(description=(__doc__ if benchmark == "extremes" else
                                              sys.modules["__main__"].__doc__ or __doc__).split("\n\n")[0])
    ap.add_argument("--rows", default=",".join(groups), help=f"comma-separated, of {', '.join(groups)}")
    ap.add_argument("--maps", default="64x128", help="zigzag map grid THETAxPHI (default %(default)s)")
    ap.add_argument("--resolution", type=int, default=128)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    check_counts(ap, args, "resolution", most=4096)
    names = [r for r in args.rows.split(",") if r]
    unknown = [r for r in names if r not in groups]
    if unknown:
        ap.error(f"unknown rows {unknown}; choose from {', '.join(groups)}")
    t, p = parse_grid(ap, args.maps)
    args.views = pyshadow.ViewSet.zigzag(t, p)
    rows = []
    for name in names:
        t0 = time.perf_counter()
        try:
            group = groups[name](args)
        except Exception as exc:        # a crash is a row that fails; the other groups still run
            group = [_row(f"{name}: crashed", float("nan"), None, False, error=f"{type(exc).__name__}: {exc}")]
        for r in group:
            r["group"] = name
        rows += group
        if not args.json:
            print(f"[{name}: {len(group)} rows, {time.perf_counter() - t0:.0f} s]", file=sys.stderr, flush=True)
    if args.json:
        emit({"benchmark": benchmark, **environment(), "maps": args.maps, "resolution": args.resolution,
              "rows": rows}, True)
        return 0
    print(f"{'row':58s} {'figure':>10s} {'bound':>8s}  pass")
    for r in rows:
        bound = "-" if r["bound"] is None or r["bound"] != r["bound"] else f"{r['bound']:8.4g}"
        verdict = "info" if r["pass"] is None else ("yes" if r["pass"] else "NO")
        extra = f"  {detail(r)}" if detail is not None else ""
        print(f"{r['row']:58s} {r['figure']:10.4g} {bound:>8s}  {verdict:4s}{extra}")
        if "error" in r:
            print(f"    {r['error'][:300]}")
    return 0 if all(r["pass"] is not False for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())

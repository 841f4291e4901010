"""Thesis 000 Fig. 6.5's setting on the bundled scene: a red point light from the left, a blue ambient.

The bundled scene (``pyshadow.data.default_scene``: bunny and torus on the
ground between two walls, CSMs of 64x128 maps @ 128^2 from the CSM cache),
its camera, and ``pyshadow.lighting.phong.PhongLighting`` (eq. 3.2) in three
settings, each rendered with the CSM (``--backend``, default one-texel) and
with Embree answering the same rays (AO directions, the light's shadow rays,
the normal samples):

``fig65a``  eq. 2.2: constant ambient (``ao="off"``), Fig. 6.5(a);
``fig65b``  eq. 3.2: the ambient weighted by the frame's AO, Fig. 6.5(b);
``no_ao``   the thesis's "No Ambient Occlusion" viewer setting: one shadow
            sample along the normal in AO's place, the light per vertex and
            unshadowed (``PhongLighting.no_ao``); the walls and the ground are
            two triangles each, so their Gouraud light is the classic
            artefact of per-vertex lighting on coarse meshes;
``no_ao_pixel`` the same with the light per pixel.

The light's shadow is on in (a) and (b). Each image is written as a PNG of the
thesis's frame buffer (``phong.display``: ``c`` clipped to [0, 1], 8 bits, no
tone mapping: the model's colours are display values) under ``--out``
(default benchmarks/out/fig65/), or tone-mapped as linear values with
``--curve srgb`` (``pyshadow.lighting.tonemap``). Printed: the RMSE (over the
covered pixels, per channel, in display units 0..1) of each CSM image against
its Embree image, the fraction of pixels whose light visibility or normal
sample differ, and the RMSE of fig65a and of no_ao against fig65b.

    python benchmarks/fig65.py [--width 640 --height 480] [--samples 64] [--normals smooth]
                               [--backend csm] [--curve display] [--out DIR] [--json]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from _common import REPO, check_counts, check_out_folder, emit, environment

#: Fig. 6.5's light and colours (the thesis gives only "red light from the left, blue ambient").
LIGHT = (-1.25, 2.3, 1.4)
AMBIENT = (0.45, 0.6, 1.0)          # with the default albedo 0.8: the light blue of Fig. 6.5(a)
LIGHT_COLOUR = (1.0, 0.12, 0.08)
SPECULAR = (0.4, 0.4, 0.4)
EXPONENT = 24.0


def settings():
    from pyshadow.lighting.phong import PhongLighting

    kw = dict(ambient=AMBIENT, light_colour=LIGHT_COLOUR, specular=SPECULAR, exponent=EXPONENT)
    return {"fig65a": PhongLighting(LIGHT, ao="off", **kw),
            "fig65b": PhongLighting(LIGHT, ao="ao", **kw),
            "no_ao": PhongLighting.no_ao(LIGHT, **kw),
            "no_ao_pixel": PhongLighting(LIGHT, ao="normal", shadows=False, **kw)}


def rmse(a, b, mask):
    d = (np.asarray(a, np.float64) - np.asarray(b, np.float64))[mask]
    return float(np.sqrt(np.mean(d ** 2))) if d.size else 0.0


def main(argv=None) -> int:
    import pyshadow
    from pyshadow.cache import CSMCache, default_cache_dir
    from pyshadow.io import write_image
    from pyshadow.lighting.phong import display, phong_shade
    from pyshadow.lighting.tonemap import tonemap

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--samples", type=int, default=64, help="AO directions per pixel (default %(default)s)")
    ap.add_argument("--normals", choices=("flat", "smooth"), default="smooth",
                    help="shading normals of render() (default %(default)s)")
    ap.add_argument("--backend", default="csm", help="CSM backend: csm or csm-vote (default %(default)s)")
    ap.add_argument("--curve", choices=("display", "srgb"), default="display",
                    help="PNG encoding: the thesis's frame buffer or sRGB tone mapping (default %(default)s)")
    ap.add_argument("--out", type=Path, default=REPO / "benchmarks" / "out" / "fig65")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    check_counts(ap, args, "width", "height", "samples")
    if args.backend not in ("csm", "csm-vote"):
        ap.error(f"--backend must be csm or csm-vote, got {args.backend!r}")
    check_out_folder(ap, "--out", args.out)

    cache = CSMCache(default_cache_dir())
    views = pyshadow.ViewSet.zigzag(64, 128)
    scene, cam = pyshadow.data.default_scene(width=args.width, height=args.height,
                                             csm_for=lambda name, mesh: cache.csm(name, mesh, views, 128, 16)[0])
    for i in scene.casters:
        c, r = scene.instances[i].world_sphere()
        if np.linalg.norm(np.asarray(LIGHT) - c) <= r:
            raise SystemExit(f"the light lies inside caster {i}'s bounding sphere")
    sampling = pyshadow.Sampling(samples=args.samples)
    args.out.mkdir(parents=True, exist_ok=True)
    images, frames, times = {}, {}, {}
    for backend in (args.backend, "embree"):
        for name, lighting in settings().items():
            t0 = time.perf_counter()
            f = pyshadow.render.render(scene, cam, visibility=backend, sampling=sampling, lighting=lighting,
                                     normals=args.normals)
            times[f"{name}/{backend}"] = time.perf_counter() - t0
            images[name, backend] = f.radiance
            frames[name, backend] = f
            png = display(f.radiance) if args.curve == "display" else tonemap(f.radiance)
            tag = "csm" if backend != "embree" else "embree"
            write_image(args.out / f"{name}_{tag}.png", png)
    for backend in (args.backend, "embree"):        # (a) | (b) | no AO side by side, as Fig. 6.5
        row = np.concatenate([images[n, backend] for n in ("fig65a", "fig65b", "no_ao")], axis=1)
        write_image(args.out / f"strip_{'embree' if backend == 'embree' else 'csm'}.png",
                    display(row) if args.curve == "display" else tonemap(row))
    mask = frames["fig65b", "embree"].object_id != -1
    # the pixels' visibilities: light shadow ray and normal sample, CSM against Embree on identical rays
    sp = pyshadow.render.surface_points(scene, cam)
    fe = frames["fig65b", "embree"]
    nrm = fe.normal.reshape(-1, 3)[sp.index]
    geo = None if fe.geometric_normal is None else fe.geometric_normal.reshape(-1, 3)[sp.index]
    vis, agree_rmse = {}, {}
    for name, key, j in (("fig65b", "light_visibility", 2), ("no_ao_pixel", "normal_sample", 1)):
        got = [phong_shade(scene, sp.points, nrm, cam.eye, settings()[name],
                           frames[name, b].ao.reshape(-1)[sp.index], backend=b, surface_ids=sp.surface_ids,
                           geometric_normals=geo)[j] for b in (args.backend, "embree")]
        vis[key] = float(np.mean(got[0] != got[1]))
        same = np.zeros(mask.size, bool)
        same[sp.index[got[0] == got[1]]] = True         # pixels whose visibility sample agrees
        agree_rmse[name] = rmse(images[name, args.backend], images[name, "embree"], same.reshape(mask.shape))
    ao_rmse = rmse(frames["fig65b", args.backend].ao, frames["fig65b", "embree"].ao, mask)
    res = {"benchmark": "fig65", **environment(), "width": args.width, "height": args.height,
           "samples": args.samples, "backend": args.backend, "normals": args.normals, "pixels": int(mask.sum()),
           "light": list(LIGHT), "ambient": list(AMBIENT), "light_colour": list(LIGHT_COLOUR),
           "specular": list(SPECULAR), "exponent": EXPONENT,
           "rmse_csm_vs_embree": {n: rmse(images[n, args.backend], images[n, "embree"], mask) for n in settings()},
           "ao_rmse_csm_vs_embree": ao_rmse,
           "rmse_csm_vs_embree_where_the_sample_agrees": agree_rmse,
           "disagreement_csm_vs_embree": vis,
           "rmse_vs_fig65b": {n: rmse(images[n, args.backend], images["fig65b", args.backend], mask)
                              for n in ("fig65a", "no_ao", "no_ao_pixel")},
           "mean_colour": {n: np.asarray(images[n, args.backend])[mask].mean(axis=0).round(4).tolist()
                           for n in settings()},
           "seconds": {k: round(v, 2) for k, v in times.items()},
           "out": str(args.out)}
    if args.json:
        emit(res, True)
    else:
        print(f"{res['pixels']} covered pixels, {args.samples} AO samples, CSM backend {args.backend}; "
              f"PNGs in {args.out}")
        for n, v in res["rmse_csm_vs_embree"].items():
            print(f"  {n:7s} RMSE CSM vs Embree {v:.5f}  (mean colour {res['mean_colour'][n]})")
        print(f"  AO RMSE CSM vs Embree {ao_rmse:.5f}; pixels whose light shadow differs "
              f"{100 * vis['light_visibility']:.3f} %, whose normal sample differs {100 * vis['normal_sample']:.3f} %")
        print("  RMSE where the light's shadow (fig65b) / the normal sample (no_ao_pixel) agrees: "
              + ", ".join(f"{n} {v:.5f}" for n, v in agree_rmse.items()))
        for n, v in res["rmse_vs_fig65b"].items():
            print(f"  {n:7s} RMSE against fig65b (AO) {v:.5f}")
        print("  seconds: " + ", ".join(f"{k} {v}" for k, v in res["seconds"].items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())

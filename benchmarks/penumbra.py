"""Soft shadows of sphere (and disc) lights: penumbra error against converged Embree, and the curve
of error against the light's angular size (issue 20's soft-shadow acceptance).

Scene: the bundled scene (``pyshadow.data.default_scene``, CSMs of 64x128 maps @ 128^2), its
camera at ``--width`` x ``--height``; every covered pixel is a surface point (normal, surface id,
pattern index = its flat pixel index, seed 0). Light: a sphere light (``PointLight(radius=R)``)
at distance ``D`` from the scene centre ``C`` (the mean of the casters' bounding-sphere centres)
in the direction of benchmarks/direct_light.py's first light, ``R = D sin(alpha)`` for the
angular radius ``alpha`` seen from ``C``; the disc light (``DiscLight``) facing ``C`` at the same
place, ``R = D tan(alpha)``. Both outside every caster's bounding sphere.

Metrics, over the penumbra pixels: the RMSE of the irradiance ``E`` against the reference's,
divided by the mean unshadowed reference irradiance there ("relative radiance RMSE": the
albedo cancels), the primary figure; and the RMSE of the lit share ``s = E / E_free`` (``E_free``
the same estimator on the same samples without the shadow, so the unshadowed estimator's own
noise does not count -- for the disc light the exact unshadowed irradiance its ratio estimator
scales, ``pyshadow.lighting.area_exact``; 0..1), over the penumbra pixels whose light lies wholly above the
surface's plane (where a few samples would leave ``s`` undefined). The reference is Embree with
``--k-ref`` samples ("converged"). Penumbra pixels: those where the reference's ``s`` lies
strictly inside (0, 1) (beyond 1e-9), dilated by one pixel (3x3) within the pixels the light can
reach (some of the light above the surface's plane) -- so a CSM that moves a narrow penumbra by
a pixel is charged. The reference is traced only where needed: seeds are the pixels whose
Embree ``s`` at 16 samples is fractional or whose hard shadow (one ray to the centre) differs
from a 4-neighbour's; the set grows by 2 pixels around every fractional reference pixel until
closed, so every penumbra pixel of a connected penumbra touching a seed is found.

Per light: both RMSEs for Embree, the one-texel CSM lookup ("csm") and the vote ("csm-vote")
at 16 and 64 samples (identical sample rays per K on every backend), and the CSM's share RMSE
against Embree at equal K (the lookup's own error, without sampling noise). The curve: the
relative radiance RMSEs against ``alpha`` (``--alphas``, degrees) and the CSM / Embree ratio at
equal K, plotted with the CSMs' map spacing marked (``--plot``, a PNG).

    python benchmarks/penumbra.py [--width 320 --height 240] [--json] [--plot benchmarks/out/penumbra.png]
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

from _common import REPO, check_counts, check_out_file, emit, environment

TABLE_ALPHAS = (1.0, 2.8, 8.0)
CURVE_ALPHAS = (0.1, 0.2, 0.4, 0.7, 1.0, 1.6, 2.8, 4.5, 8.0, 15.0)
KS = (16, 64)
BACKENDS = ("embree", "csm", "csm-vote")
DIRECTION = np.array([0.8, 3.2, 1.6])          # direct_light.py's first light
CHUNK_RAYS = 1 << 21


def map_spacing(scene) -> float:
    """Angular spacing of the casters' CSM view directions, rad (zigzag: pi / theta rows)."""
    sp = []
    for i in scene.casters:
        v = scene.instances[i].csm.views
        if v.layout == "zigzag":
            sp.append(max(math.pi / v.params["theta"], 2 * math.pi / v.params["phi"]))
        else:
            sp.append(math.sqrt(4 * math.pi / len(v)))
    return max(sp)


class Setup:
    """The scene, its surface points and the geometry of the lights."""

    def __init__(self, width, height):
        import pyshadow
        from pyshadow import render

        self.scene, self.cam = pyshadow.data.default_scene(width=width, height=height)
        sp = render.surface_points(self.scene, self.cam)
        self.shape = (height, width)
        self.P = np.asarray(sp.points, np.float64)
        n = np.asarray(sp.normals, np.float64)
        self.N = n / np.linalg.norm(n, axis=1, keepdims=True)
        self.ids, self.idx = sp.surface_ids, np.asarray(sp.index, np.int64)
        spheres = [self.scene.instances[i].world_sphere() for i in self.scene.casters]
        self.centre = np.mean([c for c, _ in spheres], axis=0)
        to = DIRECTION - self.centre
        self.D = float(np.linalg.norm(to))
        self.dir = to / self.D
        self.spheres = spheres
        self.spacing = map_spacing(self.scene)

    def light(self, kind, alpha):
        from pyshadow.lighting import PointLight
        from pyshadow.lighting.area import DiscLight

        pos = self.centre + self.D * self.dir
        if kind == "sphere":
            r = self.D * math.sin(alpha)
            light = PointLight(pos, 1.0, radius=r)
        else:
            r = self.D * math.tan(alpha)
            light = DiscLight(pos, -self.dir, r, intensity=1.0)
        for c, rad in self.spheres:
            if np.linalg.norm(pos - c) - r <= rad * (1 + 1e-6) + 1e-9:
                raise SystemExit(f"the {kind} light at {alpha} rad reaches into a caster's bounding sphere")
        return light, r

    def above(self, light, r, rows):
        """Points ``rows`` whose light lies wholly above their tangent plane, (M,) bool."""
        n, h = self.N[rows], np.einsum("ij,ij->i", self.N[rows], light.position - self.P[rows])
        if hasattr(light, "normal"):
            return h > r * np.linalg.norm(np.cross(n, light.normal), axis=1)
        return h > r

    def reachable(self, light, r):
        """Pixels some of whose light lies above their tangent plane (and, for a disc, in front of it)."""
        ok = np.einsum("ij,ij->i", self.N, light.position - self.P) > -r
        if hasattr(light, "normal"):
            ok &= (self.P - light.position) @ light.normal > 0
        return ok


def estimate(setup, light, rows, k, backends):
    """({backend: E}, E_free) at the points ``rows`` with K samples, float64 (N,) each."""
    from pyshadow.lighting.area import AreaLight, area_light_radiance
    from pyshadow.lighting.area_exact import unshadowed_factor
    from pyshadow.lighting.local import light_directions, point_light_radiance

    E, F = {b: np.zeros(len(rows)) for b in backends}, np.zeros(len(rows))
    step = max(1, CHUNK_RAYS // k)
    for lo in range(0, len(rows), step):
        r = rows[lo:lo + step]
        p, n, idx = setup.P[r], setup.N[r], setup.idx[r]
        fn = area_light_radiance if isinstance(light, AreaLight) else point_light_radiance
        for b in backends:
            rad, _ = fn(setup.scene, p, n, light, 1.0, backend=b, samples=k, surface_ids=setup.ids[r], indices=idx)
            E[b][lo:lo + len(r)] = rad[:, 0] * math.pi
        if isinstance(light, AreaLight):            # the same estimator with V = 1: the exact unshadowed E_0
            F[lo:lo + len(r)] = light.radiance[0] * unshadowed_factor(light, p, n / np.linalg.norm(n, axis=1)[:, None])
        else:
            to = light.position - p
            d = np.linalg.norm(to, axis=1)
            half = np.arcsin(np.minimum(light.radius / d, 1.0))
            cs = np.maximum(np.einsum("nkj,nj->nk", light_directions(to / d[:, None], half, k, idx), n), 0)
            omega = 2 * math.pi * (1 - np.cos(half))
            F[lo:lo + len(r)] = light.intensity[0] * omega / (math.pi * light.radius ** 2) * cs.mean(1)
    return E, F


def share(E, F):
    return np.divide(E, F, out=np.zeros_like(E), where=F > 0)


def dilate(mask, r):
    from scipy.ndimage import binary_dilation

    return binary_dilation(mask, structure=np.ones((2 * r + 1, 2 * r + 1), bool))


def fractional(s):
    return (s > 1e-9) & (s < 1 - 1e-9)


def measure(setup, kind, alpha, k_ref, check_ref=False):
    t0 = time.perf_counter()
    light, r = setup.light(kind, alpha)
    H, W = setup.shape
    img = np.full(H * W, -1, np.int64)
    img[setup.idx] = np.arange(len(setup.P))
    reach = np.zeros(H * W, bool)
    reach[setup.idx] = setup.reachable(light, r)
    reach = reach.reshape(H, W)
    live = np.flatnonzero(reach.ravel()[setup.idx])                       # point rows the light can reach
    # Embree at 16 samples everywhere (seeds, and its figure), one ray to the centre (hard-shadow edges)
    e16, f16 = np.zeros(len(setup.P)), np.zeros(len(setup.P))
    e, f = estimate(setup, light, live, 16, ["embree"])
    e16[live], f16[live] = e["embree"], f
    s16 = np.zeros(H * W)
    s16[setup.idx] = share(e16, f16)
    e, f = estimate(setup, light, live, 1, ["embree"])
    hard = np.zeros(H * W)
    hard[setup.idx[live]] = share(e["embree"], f)
    hard = hard.reshape(H, W) > 0.5
    edge = np.zeros((H, W), bool)
    edge[1:] |= hard[1:] != hard[:-1]
    edge[:-1] |= hard[1:] != hard[:-1]
    edge[:, 1:] |= hard[:, 1:] != hard[:, :-1]
    edge[:, :-1] |= hard[:, 1:] != hard[:, :-1]
    cand = dilate(fractional(s16.reshape(H, W)) | (edge & reach), 2) & reach
    ref, free = np.full(H * W, np.nan), np.full(H * W, np.nan)
    while True:
        todo = np.flatnonzero((cand & np.isnan(ref.reshape(H, W))).ravel())
        if not len(todo):
            break
        e, f = estimate(setup, light, img[todo], k_ref, ["embree"])
        ref[todo], free[todo] = share(e["embree"], f), f
        cand |= dilate(fractional(np.nan_to_num(ref, nan=0.0)).reshape(H, W), 2) & reach
    frac = fractional(np.nan_to_num(ref, nan=0.0)).reshape(H, W)
    pen = np.flatnonzero((dilate(frac, 1) & reach).ravel())
    rows = img[pen]
    s_ref, e_ref = ref[pen], ref[pen] * free[pen]
    scale = float(free[pen].mean()) if len(pen) else 1.0
    above = setup.above(light, r, rows)
    row = {"light": kind, "alpha_deg": math.degrees(alpha), "radius": r, "distance": setup.D,
           "reference_samples": k_ref, "penumbra_pixels": int(len(pen)), "fractional_pixels": int(frac.sum()),
           "share_pixels": int(above.sum()),
           "reference_pixels": int(np.isfinite(ref).sum()), "rmse_share": {}, "rmse_radiance_rel": {},
           "rmse_vs_embree_same_k": {}}
    if not len(pen):
        row["seconds"] = time.perf_counter() - t0
        return row
    for k in KS:
        if k == 16:
            E, F = estimate(setup, light, rows, k, BACKENDS[1:])
            E["embree"] = e16[rows]
            np.testing.assert_allclose(F, f16[rows], rtol=1e-12)
        else:
            E, F = estimate(setup, light, rows, k, BACKENDS)
        got = {b: share(E[b], F) for b in BACKENDS}
        for b in BACKENDS:
            row["rmse_share"][f"{b}@{k}"] = float(np.sqrt(np.mean((got[b] - s_ref)[above] ** 2)))
            row["rmse_radiance_rel"][f"{b}@{k}"] = float(np.sqrt(np.mean((E[b] - e_ref) ** 2)) / scale)
        for b in BACKENDS[1:]:
            row["rmse_vs_embree_same_k"][f"{b}@{k}"] = float(np.sqrt(np.mean((got[b] - got["embree"])[above] ** 2)))
    if check_ref:                 # the reference's own error: against 4x its samples on up to 1500 pixels
        sub = np.sort(np.random.default_rng(0).permutation(len(pen))[:1500])
        E, F = estimate(setup, light, rows[sub], 4 * k_ref, ["embree"])
        row["reference_check"] = {"samples": 4 * k_ref, "pixels": int(len(sub)), "rmse_radiance_rel":
                                  float(np.sqrt(np.mean((e_ref[sub] - E["embree"]) ** 2)) / F.mean())}
    row["seconds"] = time.perf_counter() - t0
    return row


def plot(rows, spacing, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in rows if r["light"] == "sphere" and r["penumbra_pixels"]]
    a = np.array([r["alpha_deg"] for r in rows])
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 4.8))
    style = {"embree": ("k", "Embree"), "csm": ("tab:red", "CSM one-texel"), "csm-vote": ("tab:blue", "CSM vote")}
    for b, (c, name) in style.items():
        for k, ls in zip(KS, ("--", "-")):
            ax.plot(a, [r["rmse_radiance_rel"][f"{b}@{k}"] for r in rows], ls, color=c, marker="o", ms=3,
                    label=f"{name}, K={k}")
    for b in BACKENDS[1:]:
        for k, ls in zip(KS, ("--", "-")):
            m = "rmse_radiance_rel"
            bx.plot(a, [r[m][f"{b}@{k}"] / r[m][f"embree@{k}"] for r in rows], ls,
                    color=style[b][0], marker="o", ms=3, label=f"{style[b][1]} / Embree, K={k}")
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    for axis in (ax, bx):
        axis.axvline(math.degrees(spacing), color="gray", ls=":", label=f"CSM map spacing {math.degrees(spacing):.2f} deg")
        axis.set_xscale("log")
        axis.set_xlabel("angular radius of the sphere light seen from the scene centre (deg)")
        axis.grid(True, which="both", alpha=0.3)
        axis.set_xticks([t for t in (0.1, 0.2, 0.5, 1, 2, 5, 10, 20) if a.min() / 1.5 <= t <= a.max() * 1.5])
        for fmt_axis in (axis.xaxis, axis.yaxis):
            fmt_axis.set_major_formatter(ScalarFormatter())
            fmt_axis.set_minor_formatter(NullFormatter())
    ax.set_yscale("log")
    ax.set_ylabel(f"penumbra radiance RMSE (rel.) vs Embree K={rows[0]['reference_samples']}")
    bx.set_yscale("log")
    bx.set_ylabel("RMSE ratio CSM / Embree at equal K")
    ax.legend(fontsize=7)
    bx.legend(fontsize=7)
    fig.suptitle("Soft shadows on the bundled scene: where the CSM's map spacing stops resolving the penumbra")
    fig.tight_layout()
    from pyshadow._files import atomic_path

    Path(path).parent.mkdir(parents=True, exist_ok=True)
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=110)
    finally:
        plt.close(fig)


def ratio(a, b):
    return a / b if b > 0 else float("nan")


def fmt(row):
    if not row["rmse_share"]:
        return f"{row['light']:6s} {row['alpha_deg']:5.2f} deg: no penumbra pixels"
    out = []
    for name, key, n in (("radiance rel.", "rmse_radiance_rel", row["penumbra_pixels"]),
                         ("lit share", "rmse_share", row["share_pixels"])):
        k = row[key]
        cells = "  ".join(f"{b}@{kk} {k[f'{b}@{kk}']:.4f}" for kk in KS for b in BACKENDS)
        out.append(f"    {name:13s} RMSE over {n:5d} px | {cells} | CSM/Embree@64 {ratio(k['csm@64'], k['embree@64']):.2f}, "
                   f"vote {ratio(k['csm-vote@64'], k['embree@64']):.2f}")
    v = row["rmse_vs_embree_same_k"]
    return (f"{row['light']:6s} {row['alpha_deg']:5.2f} deg (R {row['radius']:.4f}), {row['fractional_pixels']} "
            f"fractional pixels, {row['reference_pixels']} traced at K={row['reference_samples']}, "
            f"{row['seconds']:.0f} s\n" + "\n".join(out) + "\n    CSM share vs Embree at equal K: "
            + "  ".join(f"{b} {v[b]:.4f}" for b in v)
            + ("" if "reference_check" not in row else
               f"\n    reference vs Embree K={row['reference_check']['samples']} on {row['reference_check']['pixels']}"
               f" px: radiance rel. RMSE {row['reference_check']['rmse_radiance_rel']:.4f}"))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--k-ref", type=int, default=1024, help="samples of the converged Embree reference")
    ap.add_argument("--alphas", type=float, nargs="+", default=list(CURVE_ALPHAS),
                    help="angular radii of the curve, degrees")
    ap.add_argument("--table", type=float, nargs="+", default=list(TABLE_ALPHAS),
                    help="angular radii of the table (sphere and disc), degrees")
    ap.add_argument("--no-disc", action="store_true", help="skip the disc light")
    ap.add_argument("--plot", default=str(REPO / "benchmarks" / "out" / "penumbra.png"))
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.k_ref <= max(KS):
        ap.error(f"--k-ref must exceed the measured sample counts {KS} (got {args.k_ref})")
    check_counts(ap, args, "width", "height")
    for option, values in (("--alphas", args.alphas), ("--table", args.table)):
        if not all(0 < a < 90 for a in values):
            ap.error(f"{option} must each be an angular radius in (0, 90) degrees, got {values}")
    check_out_file(ap, "--plot", args.plot, make=True)
    t0 = time.perf_counter()
    setup = Setup(args.width, args.height)
    if not args.json:
        print(f"bundled scene {args.width}x{args.height}, {len(setup.P)} covered pixels, light at distance "
              f"{setup.D:.3f} from the scene centre {np.round(setup.centre, 3).tolist()}, CSM map spacing "
              f"{math.degrees(setup.spacing):.3f} deg, reference Embree K={args.k_ref} ({time.perf_counter() - t0:.0f} s)",
              flush=True)
    rows = []
    todo = [("sphere", a) for a in sorted(set(args.alphas) | set(args.table))]
    if not args.no_disc:
        todo += [("disc", a) for a in args.table]
    for kind, a in todo:
        row = measure(setup, kind, math.radians(a), args.k_ref, check_ref=kind == "sphere" and a in args.table)
        row["table"] = a in args.table
        rows.append(row)
        if not args.json:
            print(fmt(row), flush=True)
    plot(rows, setup.spacing, args.plot)
    result = {"benchmark": "penumbra", **environment(), "width": args.width, "height": args.height,
              "map_spacing_deg": math.degrees(setup.spacing), "distance": setup.D,
              "scene_centre": setup.centre.tolist(), "rows": rows, "plot": args.plot,
              "seconds": time.perf_counter() - t0}
    if args.json:
        emit(result, True)
    else:
        print(f"plot: {args.plot}; total {result['seconds']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

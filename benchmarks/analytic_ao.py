"""AO of two analytic cases against their closed forms: every backend, every estimator (issue 23).

Cases (ground plane y = 0, the point on it, normal +y):

* ``wall``: a box wall (width 2b along x, height h, thickness 0.5) standing
  on the ground, its front face at distance x from the point.
  Unoccluded AO, cosine-weighted: 1 - F, F the form factor of the front
  rectangle, exact by Lambert's polygon formula (:func:`lambert_polygon`);
  for an infinite wall F = 1/2 (every direction towards the wall meets it).
  Distance-limited (D < min(b, h), so the finite wall acts as an infinite
  one): cosine-weighted directions are uniform on the unit disk of their
  (w_x, w_z); a ray towards the wall meets it at L = x / w_z, within D iff
  w_z > a = x / D, so AO_D = 1 - (acos a - a sqrt(1 - a^2)) / pi (1 for
  x >= D). Distance-weighted (rho(L) = 1 - exp(-tau L), seed 002 eq. 3.3):
  AO = 1 - (2 / pi) int_a^1 sqrt(1 - z^2) exp(-tau x / z) dz (a = x / D,
  0 for D = inf), by quadrature; the finite wall changes it by at most
  exp(-tau min(b, h)) (rays that pass it would meet the infinite wall
  only beyond min(b, h)).
* ``sphere``: a sphere of radius r resting on the ground, the point at
  distance s from the contact point: centre at height c = r, distance
  d = sqrt(s^2 + c^2), angle alpha from the normal to the centre (cos alpha
  = c / d), angular radius beta (sin beta = r / d). The cap touches the
  horizon (alpha + beta = pi / 2 exactly) and lies above it, so the
  occluded fraction is the cap's form factor cos(alpha) sin^2(beta) =
  (r / d)^3. Distance-limited: the rays that meet the sphere within D form
  the cone of half-angle g about the centre direction, cos g = (D^2 + d^2
  - r^2) / (2 D d) (law of cosines; none for D <= d - r, the whole cap for D
  >= sqrt(d^2 - r^2)): occlusion cos(alpha) sin^2(g). Weighted: integrating
  cos(theta) over the azimuth about the centre direction leaves
  2 pi cos(alpha) cos(g) (the cone stays above the horizon), so occlusion =
  2 cos(alpha) int_0^g exp(-tau L(g')) cos g' sin g' dg' with the first hit
  L(g') = d cos g' - sqrt(r^2 - d^2 sin^2 g'). The icosphere lies between
  the balls of its inscribed and circumscribed radii; occlusion grows with
  the body, so the closed forms at both radii bracket the mesh's value.

Estimators: ``unlimited``, ``limited`` (max_distance D), ``weighted``
(obscurance tau, D = inf). Methods: ``embree`` (exact per ray), ``csm``,
``csm-vote`` (the CSM: distance AO with straddle='embree' and
straddle='infinite' both shown; weighted by the quadrature of Q = 16
lengths, error <= 1/32 per ray), ``numpy`` (the float64 mirror of ``csm``),
``ssao`` (pyshadow.ssao on a G-buffer of the scene, radius = D: limited
only; ``ssao-norange`` without its range check), ``cubemap-raymarch`` and
``cubemap-horizon`` (seed 002: one probe at the camera's eye, R = 128, the
per-texel AO of either estimator projected onto the patch; limited only),
``vtk-ssao`` (pyvista's SSAO render pass on the same camera, the
ratio of the ambient-only images with and without it; blur off). Each
point is asked ``copies`` times with different sample patterns
(``copies x samples`` rays); SSAO averages a 5x5 pixel patch around the
point and compares with the closed form at each pixel's own position.

    python benchmarks/analytic_ao.py [--samples 64] [--copies 64] [--no-vtk] [--json]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from _common import check_counts, emit, environment

WALL = {"b": 4.0, "h": 4.0, "thickness": 0.5, "x": (0.5, 1.0, 2.0), "D": 1.5}
SPHERE = {"r": 1.0, "subdivisions": 4, "s": (0.5, 1.0, 1.5), "D": 0.9}
TAU = 2.0
QUADRATURE = 16


# ---------------------------------------------------------------------------
# closed forms
# ---------------------------------------------------------------------------
def lambert_polygon(p, n, verts) -> float:
    """Form factor from a differential area at ``p`` (unit normal ``n``) to a planar polygon
    wholly above its tangent plane: |sum over edges of angle_k n . unit(R_k x R_k+1)| / (2 pi)."""
    R = np.asarray(verts, np.float64) - np.asarray(p, np.float64)
    R /= np.linalg.norm(R, axis=1, keepdims=True)
    total = 0.0
    for k in range(len(R)):
        a, b = R[k], R[(k + 1) % len(R)]
        c = np.cross(a, b)
        total += np.arctan2(np.linalg.norm(c), a @ b) * (np.asarray(n) @ c) / np.linalg.norm(c)
    return abs(total) / (2 * np.pi)


def wall_ao(x, *, D=np.inf, tau=None, b=np.inf, h=np.inf) -> float:
    """Closed-form AO of a ground point at distance ``x`` in front of a wall (see the module docstring).

    Unlimited: the finite rectangle (2b wide, h high) by :func:`lambert_polygon`.
    Limited and weighted: the infinite wall (the caller keeps D < min(b, h);
    weighted differs from a finite wall by at most exp(-tau min(b, h))).
    """
    if not x > 0:                       # on or behind the wall's plane: no closed form here
        return float("nan")
    a = min(1.0, x / D)
    if tau is None and np.isinf(D):
        if np.isinf(b) and np.isinf(h):
            return 0.5
        verts = [(-b, 0, x), (b, 0, x), (b, h, x), (-b, h, x)]
        return 1.0 - lambert_polygon((0, 0, 0), (0, 1, 0), verts)
    if tau is None:
        return 1.0 - (np.arccos(a) - a * np.sqrt(1 - a * a)) / np.pi
    # z = cos(phi): int_0^acos(a) sin^2(phi) exp(-tau x / cos phi) dphi, smooth: Gauss-Legendre
    u, wts = np.polynomial.legendre.leggauss(200)
    top = np.arccos(a)
    phi = 0.5 * top * (u + 1.0)
    with np.errstate(divide="ignore", over="ignore"):
        occ = 0.5 * top * np.sum(wts * np.sin(phi) ** 2 * np.exp(-tau * x / np.cos(phi)))
    return 1.0 - 2.0 / np.pi * occ


def sphere_ao(s, r, *, centre_height=None, D=np.inf, tau=None) -> float:
    """Closed-form AO of a ground point at horizontal distance ``s`` from the foot of a sphere of
    radius ``r`` whose centre is at ``centre_height`` >= r (default r: resting on the ground)."""
    from scipy.integrate import quad

    c = r if centre_height is None else centre_height
    d = np.hypot(s, c)
    cos_a = c / d
    if D <= d - r:
        return 1.0
    sin_b2 = (r / d) ** 2
    if D >= np.sqrt(d * d - r * r):
        sin_g2 = sin_b2
    else:
        cg = (D * D + d * d - r * r) / (2 * D * d)
        sin_g2 = 1.0 - cg * cg
    if tau is None:
        return 1.0 - cos_a * sin_g2
    g = np.arcsin(np.sqrt(sin_g2))

    def f(x):
        L = d * np.cos(x) - np.sqrt(max(r * r - (d * np.sin(x)) ** 2, 0.0))
        return np.exp(-tau * L) * np.cos(x) * np.sin(x)

    return 1.0 - 2.0 * cos_a * quad(f, 0.0, g, epsabs=1e-12, epsrel=1e-10)[0]


# ---------------------------------------------------------------------------
# scenes
# ---------------------------------------------------------------------------
def wall_scene(maps=32, resolution=128, b=WALL["b"], h=WALL["h"], thickness=WALL["thickness"]):
    """Ground y = 0 and the wall box (front face z = 0, spanning x in [-b, b], y in [0, h])."""
    import trimesh

    import pyshadow

    box = trimesh.creation.box((2 * b, h, thickness))
    T = np.eye(4)
    T[:3, 3] = (0.0, h / 2, thickness / 2)
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(maps // 2, maps), resolution=resolution)
    scene.add(box, T)
    return scene


def sphere_scene(maps=32, resolution=128, r=SPHERE["r"], subdivisions=SPHERE["subdivisions"]):
    """Ground y = 0 and an icosphere of (circumscribed) radius r resting on it at the origin's foot.

    Returns the scene and the icosphere's inscribed radius (its faces' smallest distance to the centre).
    """
    import trimesh

    import pyshadow

    sph = trimesh.creation.icosphere(subdivisions=subdivisions, radius=r)
    r_in = float(np.min(np.einsum("ij,ij->i", sph.face_normals, sph.triangles_center)))
    T = np.eye(4)
    T[1, 3] = r
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(maps // 2, maps), resolution=resolution)
    scene.add(sph, T)
    return scene, r_in


def estimators(D):
    """The keyword arguments of each estimator, for distance limit ``D``."""
    return {"unlimited": {}, "limited": {"max_distance": D}, "weighted": {"obscurance": TAU}}


def wall_truth(x, estimator):
    """(closed form, its geometric error bound) for the wall case."""
    b, h = WALL["b"], WALL["h"]
    if estimator == "unlimited":
        return wall_ao(x, b=b, h=h), 0.0
    if estimator == "limited":
        return wall_ao(x, D=WALL["D"]), 0.0
    return wall_ao(x, tau=TAU), float(np.exp(-TAU * min(b, h)))


def sphere_truth(s, estimator, r_in, r=SPHERE["r"]):
    """(closed form at the mid radius, half the bracket of the inscribed/circumscribed balls)."""
    kw = {"unlimited": {}, "limited": {"D": SPHERE["D"]}, "weighted": {"tau": TAU}}[estimator]
    lo = sphere_ao(s, r_in, centre_height=r, **kw)
    hi = sphere_ao(s, r, **kw)
    return 0.5 * (lo + hi), 0.5 * abs(lo - hi)


def estimate(scene, point, backend, sampling, copies, **distance):
    """Mean AO of ``copies`` copies of a ground point (normal +y), each with its own pattern."""
    from pyshadow import visibility

    p = np.tile(np.asarray(point, np.float64), (copies, 1))
    n = np.tile([0.0, 1.0, 0.0], (copies, 1))
    ao = visibility.ambient_occlusion(scene, p, n, backend=backend, sampling=sampling, surface_ids=-2,
                                      indices=np.arange(copies), **distance)
    return float(np.mean(ao))


def noise_bound(value, rays) -> float:
    """4 sigma of a mean of ``rays`` Bernoulli(value) samples (the stratified patterns do better)."""
    return 4.0 * np.sqrt(max(value * (1 - value), 1.0 / rays) / rays)


# ---------------------------------------------------------------------------
# screen space
# ---------------------------------------------------------------------------
CAMERAS = {"wall": dict(eye=(1.5, 2.5, -5.0), target=(0.0, 0.5, -1.0)),
           "sphere": dict(eye=(5.0, 3.0, 3.0), target=(1.0, 0.3, 0.0))}


def patch(camera, sp, point, half=2):
    """Pixel rows and columns of the ground pixels of the (2 half + 1)^2 patch around the ground
    pixel nearest ``point`` (``sp``: :func:`pyshadow.render.surface_points`)."""
    pos = np.asarray(sp.gbuffer["position"], np.float64)
    dist = np.linalg.norm(pos - np.asarray(point), axis=2)
    dist[~np.isfinite(dist) | (sp.object_id != -2)] = np.inf
    r, c = np.unravel_index(np.argmin(dist), dist.shape)
    rows, cols = np.meshgrid(np.arange(r - half, r + half + 1), np.arange(c - half, c + half + 1), indexing="ij")
    keep = sp.object_id[rows, cols] == -2
    return rows[keep], cols[keep]


def ssao_case(scene, camera, points, truth_at, radius, samples, range_check=True):
    """SSAO on the patch of each point against the closed form at each pixel's position, and against
    Embree's distance-limited AO on the identical rays (same directions, same patterns)."""
    from pyshadow import Sampling, ssao
    from pyshadow.render import surface_points

    sp = surface_points(scene, camera)
    g = sp.gbuffer
    t0 = time.perf_counter()
    ao = ssao.screen_space_ao(g, camera, radius, samples=samples, range_check=range_check)
    seconds = time.perf_counter() - t0
    W = camera.width
    out = []
    for point in points:
        rows, cols = patch(camera, sp, point)
        pos = np.asarray(g["position"], np.float64)[rows, cols]
        truth = float(np.mean([truth_at(q) for q in pos]))
        from pyshadow import visibility

        emb = visibility.ambient_occlusion(scene, pos, np.tile([0.0, 1.0, 0.0], (len(pos), 1)), backend="embree",
                                           sampling=Sampling(samples), indices=rows * W + cols, surface_ids=-2,
                                           max_distance=radius)
        out.append({"value": float(ao[rows, cols].mean()), "closed_form": truth,
                    "embree_same_rays": float(emb.mean())})
    return out, seconds


def cubemap_case(scene, camera, points, truth_at, radius, estimator, resolution=128, samples=64):
    """Cube-map AO (one probe at the camera's eye, seed 002) projected onto the patch of each point,
    against the closed form at each pixel's position. Returns (rows, seconds of probe + texel AO)."""
    from pyshadow import Sampling
    from pyshadow.cubemap import CubeMapAO
    from pyshadow.render import surface_points

    maps = CubeMapAO(scene, radius, resolution=resolution, estimator=estimator, sampling=Sampling(samples))
    maps.place(camera)
    seconds = sum(t["render_s"] + t["ao_s"] for t in maps.timings)
    sp = surface_points(scene, camera)
    pr = maps.project(camera, gbuffer=sp.gbuffer)
    ao = pr.ao.reshape(camera.height, camera.width)
    out = []
    for point in points:
        rows, cols = patch(camera, sp, point)
        pos = np.asarray(sp.gbuffer["position"], np.float64)[rows, cols]
        v = ao[rows, cols]
        out.append({"value": float(np.nanmean(v)) if np.isfinite(v).any() else float("nan"),
                    "covered": float(np.isfinite(v).mean()),
                    "closed_form": float(np.mean([truth_at(q) for q in pos]))})
    return out, seconds


def vtk_ssao(scene, camera, points, truth_at, radius):
    """pyvista's SSAO pass (blur off) on the same camera: the ratio of ambient-only renders with and
    without it, on the patch of each point. Returns the rows, or the error text."""
    try:
        from pyshadow.viz.ssao_pass import vtk_ssao as ssao_pass

        ratio = ssao_pass(scene, camera, radius, kernel_size=256, bias=0.02 * radius, blur=False).ao
        from pyshadow.render import surface_points

        sp = surface_points(scene, camera)
        g = sp.gbuffer
        floor = np.flatnonzero((sp.object_id == -2).reshape(-1))[::7]
        pos = np.asarray(g["position"], np.float64).reshape(-1, 3)
        open_ = [i for i in floor if truth_at(pos[i]) == 1.0]
        control = float(ratio.reshape(-1)[open_].mean())       # ground where nothing is within D
        out = []
        for point in points:
            rows, cols = patch(camera, sp, point)
            pos = np.asarray(g["position"], np.float64)[rows, cols]
            out.append({"value": float(ratio[rows, cols].mean()), "open_floor_ratio": control,
                        "closed_form": float(np.mean([truth_at(q) for q in pos]))})
        return out
    except Exception as exc:          # report the failure in the table, do not hide it
        return f"{type(exc).__name__}: {exc}"


# ---------------------------------------------------------------------------
def run(samples=64, copies=64, ssao_samples=256, width=320, height=240, vtk=True, maps=32, resolution=128,
        cube_resolution=128):
    import pyshadow

    sampling = pyshadow.Sampling(samples)
    rows = []
    wall = wall_scene(maps, resolution)
    sphere, r_in = sphere_scene(maps, resolution)
    cases = [("wall", wall, WALL, [(0.0, 0.0, -x) for x in WALL["x"]], WALL["x"], lambda v, e: wall_truth(v, e)),
             ("sphere", sphere, SPHERE, [(s, 0.0, 0.0) for s in SPHERE["s"]], SPHERE["s"],
              lambda v, e: sphere_truth(v, e, r_in))]
    for case, scene, spec, points, params, truth in cases:
        D = spec["D"]
        for est, kw in estimators(D).items():
            variants = [("embree", {}), ("csm", {}), ("csm-vote", {}), ("numpy", {})]
            if kw:
                variants = [("embree", {})] + [(m, {"straddle": st}) for m in ("csm", "csm-vote", "numpy")
                                                for st in ("embree", "infinite")]
            for method, extra in variants:
                if "obscurance" in kw and method != "embree":
                    extra = dict(extra, quadrature=QUADRATURE)
                for point, v in zip(points, params):
                    value, geo = truth(v, est)
                    t0 = time.perf_counter()
                    got = estimate(scene, point, method, sampling, copies, **kw, **extra)
                    rows.append({"case": case, "param": v, "estimator": est, "method": method, "D": D,
                                 "straddle": extra.get("straddle"), "value": got, "closed_form": value,
                                 "error": got - value, "geometric_bound": geo,
                                 "noise_bound": noise_bound(value, samples * copies),
                                 "quadrature_bound": 0.5 / QUADRATURE if "obscurance" in kw and method != "embree"
                                 else 0.0,
                                 "seconds": time.perf_counter() - t0})
        cam = pyshadow.Camera(**CAMERAS[case], width=width, height=height)
        if case == "wall":
            def at(q, D=D):
                return wall_ao(-q[2], D=D)
        else:
            def at(q, D=D):
                return sphere_ao(np.hypot(q[0], q[2]), SPHERE["r"], D=D)
        for rc in (True, False):
            got, secs = ssao_case(scene, cam, points, at, D, ssao_samples, rc)
            for v, g in zip(params, got):
                rows.append({"case": case, "param": v, "estimator": "limited", "D": D,
                             "method": "ssao" if rc else "ssao-norange", "straddle": None,
                             **g, "error": g["value"] - g["closed_form"], "seconds": secs})
        for est in ("raymarch", "horizon"):
            got, secs = cubemap_case(scene, cam, points, at, D, est, cube_resolution, samples)
            for v, g in zip(params, got):
                rows.append({"case": case, "param": v, "estimator": "limited", "D": D,
                             "method": f"cubemap-{est}", "straddle": None, "probe_resolution": cube_resolution,
                             **g, "error": g["value"] - g["closed_form"], "seconds": secs})
        if vtk:
            got = vtk_ssao(scene, cam, points, at, D)
            if isinstance(got, str):
                rows.append({"case": case, "method": "vtk-ssao", "estimator": "limited", "error_text": got})
            else:
                for v, g in zip(params, got):
                    rows.append({"case": case, "param": v, "estimator": "limited", "method": "vtk-ssao",
                                 "straddle": None, "D": D, **g, "error": g["value"] - g["closed_form"]})
    return rows


def timing(points=20000, samples=36):
    """Seconds of AO on ``points`` ground points around the sphere (s in [0.2, 3]): the default query,
    distance-limited with every point's shell clear of the sphere (the AO kernel, FINITE_RAYS=1), with
    most rays straddling (ray by ray), weighted (Q = 16), by the CSM, Embree and SSAO at 640x480."""
    import pyshadow
    from pyshadow import ssao, visibility
    from pyshadow.render import surface_points

    from _common import median_time

    scene, _ = sphere_scene(32, 128)
    rng = np.random.default_rng(0)
    s, phi = rng.uniform(0.2, 3.0, points), rng.uniform(0, 2 * np.pi, points)
    p = np.column_stack([s * np.cos(phi), np.zeros(points), s * np.sin(phi)])
    n = np.tile([0.0, 1.0, 0.0], (points, 1))
    d = np.hypot(s, 1.0)
    sm = pyshadow.Sampling(samples)
    runs = {"default": {}, "limited-clear": {"max_distance": 0.9 * (d - 1.0)},
            "limited-straddling": {"max_distance": 0.9, "straddle": "infinite"},
            "weighted-Q16": {"obscurance": TAU, "quadrature": 16, "straddle": "infinite"}}
    out = {}
    for backend in ("csm", "embree"):
        for name, kw in runs.items():
            out[f"{backend} {name}"] = median_time(lambda: visibility.ambient_occlusion(
                scene, p, n, backend=backend, sampling=sm, surface_ids=-2, **kw), repeats=3)[0]
    cam = pyshadow.Camera(**CAMERAS["sphere"], width=640, height=480)
    g = surface_points(scene, cam).gbuffer
    out["ssao 640x480 16 samples"] = median_time(lambda: ssao.screen_space_ao(g, cam, 0.9, samples=16))[0]
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--samples", type=int, default=64, help="directions per point (default %(default)s)")
    ap.add_argument("--copies", type=int, default=64, help="copies of each point, own patterns (default %(default)s)")
    ap.add_argument("--ssao-samples", type=int, default=256, help="SSAO samples per pixel (default %(default)s)")
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--no-vtk", action="store_true", help="skip pyvista's SSAO pass")
    ap.add_argument("--probe-resolution", type=int, default=128, help="cube-map face resolution (default 128)")
    ap.add_argument("--timing", action="store_true", help="only time the AO queries (20000 points, 36 samples)")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    check_counts(ap, a, "samples", "copies", "ssao_samples", "width", "height")
    if not 16 <= a.probe_resolution <= 2048:
        ap.error(f"--probe-resolution must be in 16..2048 (pyshadow.CubeProbe), got {a.probe_resolution}")
    if a.timing:        # its own workload: the other settings would be accepted and ignored
        given = [f"--{d.replace('_', '-')}" for d in ("samples", "copies", "ssao_samples", "width", "height",
                                                      "no_vtk", "probe_resolution")
                 if getattr(a, d) != ap.get_default(d)]
        if given:
            ap.error(f"{', '.join(given)}: --timing times its own workload (20000 points, 36 samples) "
                     "and takes none of them")
        t = timing()
        if a.json:
            emit({"environment": environment(), "seconds": t}, True)
        else:
            for k, v in t.items():
                print(f"{k:28s} {v:8.3f} s")
        return
    rows = run(a.samples, a.copies, a.ssao_samples, a.width, a.height, not a.no_vtk,
               cube_resolution=a.probe_resolution)
    result = {"environment": environment(), "D": {"wall": WALL["D"], "sphere": SPHERE["D"]}, "tau": TAU,
              "quadrature": QUADRATURE, "samples": a.samples, "copies": a.copies, "ssao_samples": a.ssao_samples,
              "rows": rows}
    if a.json:
        emit(result, True)
        return
    print(f"D = {WALL['D']} (wall), {SPHERE['D']} (sphere); tau = {TAU}, Q = {QUADRATURE}; "
          f"{a.copies} x {a.samples} rays per point; "
          f"SSAO {a.ssao_samples} samples, 5x5 pixels at {a.width}x{a.height}")
    print(f"{'case':7s} {'param':>5s} {'estimator':9s} {'method':12s} {'straddle':8s} {'value':>7s} "
          f"{'closed':>7s} {'error':>8s} {'bound':>6s}")
    for r in rows:
        if "error_text" in r:
            print(f"{r['case']:7s} {'':5s} {r['estimator']:9s} {r['method']:12s} failed: {r['error_text']}")
            continue
        bound = r.get("noise_bound", float("nan")) + r.get("geometric_bound", 0.0) + r.get("quadrature_bound", 0.0)
        print(f"{r['case']:7s} {r['param']:5.2f} {r['estimator']:9s} {r['method']:12s} {str(r['straddle'] or ''):8s} "
              f"{r['value']:7.4f} {r['closed_form']:7.4f} {r['error']:+8.4f} {bound:6.4f}"
              + (f"  (Embree, same rays: {r['embree_same_rays']:.4f})" if "embree_same_rays" in r else "")
              + (f"  (open floor: {r['open_floor_ratio']:.4f})" if "open_floor_ratio" in r else "")
              + (f"  (probe sees {100 * r['covered']:.0f} % of the patch)" if "covered" in r else ""))


if __name__ == "__main__":
    main()

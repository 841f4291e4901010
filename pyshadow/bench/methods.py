"""The methods table of ``pyshadow-bench --method``: CSM, CSM vote, cube-map AO, SSAO and Embree side by side.

Every method shades the covered pixels of the benchmark's camera (the same
:class:`~pyshadow.bench.measure.GBuffer`) and is measured the same way:

* **precompute** -- what must exist before a frame: the CSMs (built or
  loaded from the cache), the cube-map probe (render and per-texel AO),
  Embree's BVH (built from the casters' triangles); nothing for SSAO.
* **memory** -- bytes of that precomputed data (the CSMs' stored bytes, the
  probes' maps and AO; for Embree the casters' float32 vertices and int32
  triangle indices handed to it, its own BVH not counted; 0 for SSAO).
* **frame time** -- the G-buffer raster (timed once a round, shared) plus the
  method's AO of every covered pixel, medians over ``--repeats`` rounds in
  which the methods run interleaved.
* **agreement** -- the fraction of the identical rays (pyshadow's sample
  directions of every pixel) on which the method's visibility equals
  Embree's: unbounded rays for the unlimited definition, rays ending at
  ``D`` for the distance-limited one (a CSM's as its AO asks them:
  :func:`~pyshadow.bench.measure.ao_rays_visible`). SSAO answers no rays ("n/a").
* **AO RMSE** against both converged Embree references: the unlimited one
  of the single benchmark and the distance-limited one (same ``D``, same
  reference sample count, cached like the other).

Definitions
-----------
``csm``, ``csm-vote`` and ``embree`` give two rows each: the unlimited AO
(every occluder counts) and the distance-limited AO (occluders within ``D``;
:func:`pyshadow.visibility.ambient_occlusion` with ``max_distance=D``; the
CSM rows use ``straddle='embree'``: the rays a CSM cannot decide are traced
by Embree). ``cubemap`` (seed 002, raymarch estimator), ``cubemap-horizon``
(the thesis's horizon estimator, eq. 4.4), ``ssao`` (:mod:`pyshadow.ssao`) and
``vtk-ssao`` (pyvista's own SSAO render pass on the same camera,
:func:`pyshadow.viz.ssao_pass.vtk_ssao`, radius ``D``, kernel size = the
samples) estimate the distance-limited AO only. ``vtk-ssao`` renders its own
frame: its frame time is that render, with no G-buffer raster added.

The distance ``D``
------------------
``--ao-distance D`` or, by default, :func:`default_distance`: the mean
world bounding-sphere radius of the casting bodies, the scale on which a body
shades its own surroundings.

Uncovered cube-map pixels
-------------------------
One probe is placed at the camera's eye (:meth:`pyshadow.cubemap.CubeMapAO.place`);
pixels no probe sees get :data:`CUBEMAP_FALLBACK` (1: open -- what the probe
does not see adds no occlusion, as off-screen geometry for SSAO). The row
reports the covered fraction.
"""
from __future__ import annotations

import argparse
import hashlib
import statistics
import time

import numpy as np

from .._validate import FLOAT32_MAX, check_int, nonzero, rows3
from ..lighting._checks import positive
from .common import _fig, _num, cached_ao
from .config import positive_number
from .measure import GBuffer, _errors, _ray_chunks, _reference_key, ao_rays_visible

#: Method names of ``--method``.
METHODS = ("csm", "csm-vote", "cubemap", "cubemap-horizon", "ssao", "vtk-ssao", "embree")
#: AO of pixels no cube-map probe sees.
CUBEMAP_FALLBACK = 1.0


def parse_methods(text: str) -> list:
    """``--method`` value: comma-separated names of :data:`METHODS` (argparse type)."""
    names = [t.strip() for t in str(text).split(",") if t.strip()]
    bad = [t for t in names if t not in METHODS]
    if not names or bad:
        raise argparse.ArgumentTypeError(f"unknown method {', '.join(bad) or repr(text)}: "
                                         f"choose from {', '.join(METHODS)}")
    return names


#: ``--ao-distance`` value: a number > 0 and at most float32's largest (the kernels read it as
#: float32), world units (argparse type).
positive_distance = positive_number("not a number: {text!r}", "must be finite and > 0 (world units), got {text}",
                                    hi=(FLOAT32_MAX, "must be at most {hi:.3g} (float32's range; world units), "
                                                     "got {text}"))


def selected_methods(values) -> list:
    """The distinct methods of repeated ``--method`` values, in :data:`METHODS` order."""
    chosen = {m for v in values for m in v}
    return [m for m in METHODS if m in chosen]


def default_distance(scene) -> float:
    """The default ``D``: mean world bounding-sphere radius of the scene's casters (world units).

    Raises
    ------
    ValueError
        When the scene has no caster.
    """
    radii = [scene.instances[i].world_sphere()[1] for i in scene.casters]
    if not radii:
        raise ValueError("the scene has no caster: give --ao-distance")
    return float(np.mean(radii))


def embree_limited(tracer, points, directions, max_distance) -> np.ndarray:
    """Embree occlusion of rays ending at ``max_distance``, on the tracer's thread pool.

    The rays of :func:`pyshadow.embree.visible` (start moved by the surface
    epsilon along the direction, analytic ground plane, a ray grazing its own
    surface traced again off it), traced with the tracer's BVH.

    Parameters
    ----------
    tracer : pyshadow.embree.EmbreeTracer
    points, directions : ndarray, shape (n, 3), float
        World ray origins on surfaces and directions (normalised here).
    max_distance : float
        Ray length ``D``, world units (> 0).

    Returns
    -------
    ndarray, shape (n,), bool
        True where an occluder lies within ``D``.

    Raises
    ------
    ValueError
        Points or directions not (n, 3) finite rows of one count, a zero
        direction, or ``max_distance`` not a finite number > 0.
    """
    from pyshadow.embree import end_epsilon, ground_occludes, off_own_surface, surface_epsilon

    p = rows3(points, "points")
    w = nonzero(rows3(directions, "directions", len(p)), "directions")
    w = w / np.linalg.norm(w, axis=1, keepdims=True)
    D = positive(max_distance, "max_distance")
    rel = p - tracer.anchor
    occ = ground_occludes(tracer.scene, rel, w, tracer.anchor, np.full(len(p), D))
    todo = np.flatnonzero(~occ)
    if len(todo) == 0:
        return occ
    eps = surface_epsilon(tracer.scene, p[todo])
    # the end moved back as embree.visible's (float64: EmbreeScene.occluded converts, copies, it)
    back = end_epsilon(tracer.scene, p[todo], w[todo], np.full(len(todo), D), tracer.anchor)
    tfar = np.maximum(D - eps - back, 0.0)
    rt, wt = rel[todo], w[todo]
    o32, d32 = (rt + eps[:, None] * wt).astype(np.float32), wt.astype(np.float32)
    res = np.empty(len(todo), bool)
    step = max(4096, -(-len(todo) // (4 * tracer.threads)))

    def work(s):        # as embree.visible: a ray stopped by the surface its point or end lies on, again off it
        q = slice(s, s + step)
        hit = tracer.rays.occluded(o32[q], d32[q], tfar[q])
        res[q] = off_own_surface(tracer.rays, rt[q], wt[q], eps[q], tfar[q], hit, (rt[q] + D * wt[q], back[q]))

    list(tracer.pool.map(work, range(0, len(todo), step)))
    occ[todo] = res
    return occ


def limited_pass(tracer, gb: GBuffer, samples, strategy, seed, patterns, D, keep=True):
    """Distance-limited Embree AO of the G-buffer pixels on the kernels' directions.

    Returns ``(ao (N,) float32, occluded (N*S,) bool or None)``.
    """
    S = int(samples)
    ao = np.empty(gb.n, np.float32)
    occ_all = np.empty(gb.n * S, bool) if keep else None
    for s, e, d32 in _ray_chunks(gb, S, strategy, seed, patterns):
        occ = embree_limited(tracer, np.repeat(gb.points[s:e], S, axis=0), d32, D)
        ao[s:e] = (~occ.reshape(e - s, S)).mean(axis=1)
        if keep:
            occ_all[s * S:e * S] = occ
    return ao, occ_all


def limited_reference(cache, tracer, scene, gb, D, samples, strategy, seed, patterns, log):
    """The converged distance-limited Embree AO: from ``cache``, or traced and stored.

    Keyed like :func:`pyshadow.bench.measure.converged_reference`, plus ``D``
    (and checked like it: an impossible cached array is traced again).
    Returns ``(ao (N,) float32, seconds or None, 'cached' | 'computed')``.
    """
    key = hashlib.sha256((_reference_key(scene, gb, samples, strategy, seed, patterns)
                          + f" limited {float(D)!r}").encode()).hexdigest()
    ao = cached_ao(cache, key, gb.n, log)
    if ao is not None:
        return ao, None, "cached"
    log(f"tracing the distance-limited Embree reference (D = {D:.3g}): {samples} samples x {gb.n} pixels")
    t0 = time.perf_counter()
    ao, _ = limited_pass(tracer, gb, samples, strategy, seed, patterns, D, keep=False)
    seconds = time.perf_counter() - t0
    cache.put_array(key, ao)
    return ao, seconds, "computed"


def _agreement(mine_visible, embree_occluded, samples):
    """Agreement, false-visible and false-occluded fractions, and disagreeing rays per pixel ((N,) int).

    Both answers are (N * samples,) bool; with no rays the fractions are NaN (null in the records).
    """
    mine_visible, embree_occluded = np.asarray(mine_visible), np.asarray(embree_occluded)
    S = check_int(samples, "samples", 1)
    if mine_visible.shape != embree_occluded.shape or embree_occluded.ndim != 1 or len(embree_occluded) % S:
        raise ValueError(f"the method's and Embree's answers must both be (N * {S},) rays, got shapes "
                         f"{mine_visible.shape} and {embree_occluded.shape}")
    ref = ~embree_occluded
    n = len(ref) or float("nan")        # no rays: no fraction agrees (not 100 %)
    dis = mine_visible != ref
    return {"agreement": 1.0 - np.count_nonzero(dis) / n,
            "false_visible": np.count_nonzero(mine_visible & ~ref) / n,
            "false_occluded": np.count_nonzero(~mine_visible & ref) / n,
            "disagree": dis.reshape(-1, S).sum(axis=1)}


class Context:
    """What every method run of one camera shares: scene, pixels, sampling, tracer, references.

    Parameters
    ----------
    scene : pyshadow.Scene
    camera : pyshadow.Camera
    gb : GBuffer
        The covered pixels.
    gbuffer : dict
        :func:`pyshadow.render_gbuffer` of ``scene.draw_items()`` (item ids), for SSAO and projection.
    D : float
        Distance limit, world units.
    strategy, seed, patterns :
        The sampling of every method.
    tracer : pyshadow.embree.EmbreeTracer
    conv, conv_d : ndarray, shape (N,)
        Converged Embree AO, unlimited and distance-limited.
    """

    def __init__(self, scene, camera, gb, gbuffer, D, strategy, seed, patterns, tracer, conv, conv_d):
        self.scene, self.camera, self.gb, self.gbuffer, self.D = scene, camera, gb, gbuffer, float(D)
        self.strategy, self.seed, self.patterns, self.tracer = strategy, seed, patterns, tracer
        self.conv, self.conv_d = conv, conv_d
        self.gbuffer_time = None      # set by run_methods
        self._embree = {}

    def sampling(self, samples):
        from pyshadow.sampling import Sampling

        return Sampling(int(samples), self.strategy, self.patterns, self.seed)

    def embree_rays(self, samples, limited):
        """Embree's per-ray occlusion (N*S,) bool on the identical rays (cached per setting)."""
        key = (int(samples), bool(limited))
        if key not in self._embree:
            self._embree[key] = self._trace(samples, limited)[1]
        return self._embree[key]

    def _trace(self, samples, limited):
        gb, S = self.gb, int(samples)
        if limited:
            return limited_pass(self.tracer, gb, S, self.strategy, self.seed, self.patterns, self.D)
        from .measure import embree_pass

        r = embree_pass(self.tracer, gb, S, self.strategy, self.seed, self.patterns, desc=f"Embree {S} spp")
        return r["ao"], r["occluded"]

    def rays(self, samples):
        """Yield (start, end, origins (n*S, 3) float64, dirs (n*S, 3) float32) of the identical rays."""
        S = int(samples)
        for s, e, d32 in _ray_chunks(self.gb, S, self.strategy, self.seed, self.patterns):
            yield s, e, np.repeat(self.gb.points[s:e], S, axis=0), d32


def _embree_share(ctx: Context, backend: str, samples: int) -> float:
    """Fraction of the identical rays of length D that a CSM backend hands to Embree.

    The rule of :func:`pyshadow.visibility.finite.answer_finite_ao`: a ray
    ending inside a caster's bounding sphere (``straddling``) is asked
    unbounded first; only where that ray is occluded is it traced. With no
    rays the fraction is NaN (null in the records), as :func:`_agreement`'s.
    """
    from pyshadow import visibility
    from pyshadow.visibility.finite import straddling, unit_directions

    S, n = int(samples), 0
    for s, e, p, d in ctx.rays(S):
        w = unit_directions(np.asarray(d, np.float64))
        rows, _ = straddling(ctx.scene, p, w, np.full(len(p), ctx.D))
        if len(rows):
            ids = np.repeat(ctx.gb.ids[s:e], S)[rows]
            nrm = np.repeat(ctx.gb.normals[s:e], S, axis=0)[rows]
            free = visibility.visible(ctx.scene, p[rows], w[rows], backend=backend, surface_ids=ids, normals=nrm)
            n += int(np.count_nonzero(~free))
    return n / (ctx.gb.n * S or float("nan"))       # no rays: no fraction (not 0 %)


def method_runs(ctx: Context, method: str, samples: int, *, probe_resolution: int = 128, csm=None):
    """The rows of one method at one setting, ready to time and measure.

    Parameters
    ----------
    ctx : Context
    method : str
        One of :data:`METHODS`.
    samples : int
        Sample directions per pixel (per texel for the cube map).
    probe_resolution : int, optional
        Cube-map face resolution.
    csm : dict, optional
        :func:`pyshadow.bench.scenes._csm_summary` of the scene's CSMs
        (precompute time and bytes of the CSM rows).

    Returns
    -------
    list of dict
        Each: ``method``, ``definition`` ('unlimited' | 'limited'),
        ``setting``, ``precompute_s``, ``bytes``, ``ao()`` (returns (N,)
        AO), ``visible()`` (returns (N*S,) bool or None: per-ray answers),
        ``coverage`` (fraction of pixels the method shades).
    """
    from pyshadow import visibility

    gb, S, D, scene = ctx.gb, int(samples), ctx.D, ctx.scene
    smp = ctx.sampling(S)
    setting = {"samples": S}
    rows = []
    if method in ("csm", "csm-vote"):
        pre = None if csm is None else csm["seconds"]
        nbytes = None if csm is None else csm["bytes"]
        for definition, md, st in (("unlimited", None, "error"), ("limited", D, "embree")):
            def ao(md=md, st=st):
                return visibility.ambient_occlusion(scene, gb.points, gb.normals, backend=method, sampling=smp,
                                                    indices=gb.sel, surface_ids=gb.ids, max_distance=md,
                                                    straddle=st)

            def vis(md=md):       # the rays as the AO asks them (straddling: Embree only where occluded)
                out = np.empty(gb.n * S, bool)
                for s, e, p, d in ctx.rays(S):
                    out[s * S:e * S] = ao_rays_visible(scene, method, p, d, np.repeat(gb.ids[s:e], S),
                                                       np.repeat(gb.normals[s:e], S, axis=0), md)
                return out

            row = {"method": method, "definition": definition, "setting": setting, "precompute_s": pre,
                   "bytes": nbytes, "ao": ao, "visible": vis, "coverage": 1.0}
            if md is not None:
                row["embree_share"] = lambda: _embree_share(ctx, method, S)
            rows.append(row)
    elif method == "embree":
        from pyshadow.embree import caster_scene

        t0 = time.perf_counter()
        rays, _ = caster_scene(scene)       # Embree builds the BVH at the first ray: part of the precompute
        rays.occluded(np.zeros((1, 3), np.float32), np.array([[0.0, 1.0, 0.0]], np.float32))
        pre = time.perf_counter() - t0
        nbytes = 0
        for i in scene.casters:
            m = scene.instances[i].mesh
            nbytes += 12 * len(m.vertices) + 12 * len(m.faces)
        for definition in ("unlimited", "limited"):
            lim = definition == "limited"
            rows.append({"method": "embree", "definition": definition, "setting": setting, "precompute_s": pre,
                         "bytes": nbytes, "ao": lambda lim=lim: ctx._trace(S, lim)[0],
                         "visible": lambda lim=lim: ~ctx._trace(S, lim)[1], "coverage": 1.0})
    elif method in ("cubemap", "cubemap-horizon"):
        from pyshadow.cubemap import CubeMapAO, CubeMapVisibility

        estimator = "raymarch" if method == "cubemap" else "horizon"
        maps = CubeMapAO(scene, D, resolution=probe_resolution, estimator=estimator, sampling=smp)
        maps.place(ctx.camera)
        pre = sum(t["render_s"] + t["ao_s"] for t in maps.timings)
        state = {}

        def ao():
            pr = maps.project(ctx.camera, gbuffer=ctx.gbuffer, fallback=CUBEMAP_FALLBACK, on_empty="fallback")
            state["coverage"] = pr.coverage
            return pr.ao.reshape(-1)[gb.sel]

        backend = CubeMapVisibility(maps, unseen="open")

        def vis():
            out = np.empty(gb.n * S, bool)
            for s, e, p, d in ctx.rays(S):
                out[s * S:e * S] = backend.visible(scene, p, d, surface_ids=np.repeat(gb.ids[s:e], S),
                                                   normals=np.repeat(gb.normals[s:e], S, axis=0))
            return out

        rows.append({"method": method, "definition": "limited",
                     "setting": {**setting, "probe_resolution": int(probe_resolution), "probes": len(maps.probes)},
                     "precompute_s": pre, "bytes": maps.nbytes, "ao": ao, "coverage": state, "maps": maps,
                     "visible": vis if estimator == "raymarch" else None})      # the horizon answers no rays
    elif method == "ssao":
        from pyshadow.ssao import screen_space_ao

        def ao():
            return screen_space_ao(ctx.gbuffer, ctx.camera, D, samples=S, seed=ctx.seed).reshape(-1)[gb.sel]

        rows.append({"method": "ssao", "definition": "limited", "setting": setting, "precompute_s": 0.0,
                     "bytes": 0, "ao": ao, "visible": None, "coverage": 1.0})
    elif method == "vtk-ssao":
        from pyshadow.viz.ssao_pass import vtk_ssao

        renders = []

        def ao():
            r = vtk_ssao(scene, ctx.camera, D, kernel_size=S)
            renders.append(r.render_s)
            return r.ao.reshape(-1)[gb.sel]

        rows.append({"method": "vtk-ssao", "definition": "limited", "setting": setting, "precompute_s": 0.0,
                     "bytes": 0, "ao": ao, "visible": None, "coverage": 1.0, "own_frame": renders})
    else:
        raise ValueError(f"unknown method {method!r}: choose from {', '.join(METHODS)}")
    return rows


def time_rows(ctx: Context, rows, repeats: int) -> float:
    """Run every row's ``ao()`` once untimed and ``repeats`` times interleaved with the G-buffer raster.

    Sets ``row['ao_s']`` (median seconds) and ``row['values']`` (the AO);
    returns the median G-buffer raster time, seconds.
    """
    from pyshadow.gbuffer import render_gbuffer

    repeats = check_int(repeats, "repeats", 1, why="the times are medians of the timed rounds")
    items, _ = ctx.scene.draw_items()
    for r in rows:
        r["values"] = np.asarray(r["ao"](), np.float32)
        r["times"] = []
    graster = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        render_gbuffer(items, ctx.camera)
        graster.append(time.perf_counter() - t0)
        for r in rows:
            t0 = time.perf_counter()
            r["ao"]()
            r["times"].append(time.perf_counter() - t0)
    for r in rows:       # a method rendering its own frame: its render, not the whole call
        r["ao_s"] = statistics.median(r["own_frame"][1:] if "own_frame" in r else r["times"])
    return statistics.median(graster)


def measure_row(ctx: Context, row, names=None, agreement=None) -> dict:
    """The record of one timed row (:func:`time_rows`): figures, per-surface errors, agreement.

    ``agreement``: a precomputed :func:`_agreement`-like dict to use instead
    of asking ``row['visible']`` (the single benchmark's own CSM pass).
    """
    from pyshadow.scene import GROUND_ID

    gb, S = ctx.gb, row["setting"]["samples"]
    a = row["values"]
    if agreement is None and row["visible"] is not None:
        agreement = _agreement(row["visible"](), ctx.embree_rays(S, row["definition"] == "limited"), S)
    cov = row["coverage"]
    cov = cov.get("coverage") if isinstance(cov, dict) else cov
    cov = cov if gb.n else float("nan")       # no pixels: no fraction shaded (not all of them)
    rmse_u, mae_u = _errors(a, ctx.conv)
    rmse_d, mae_d = _errors(a, ctx.conv_d)
    na = "n/a (answers no rays)"
    rec = {
        "method": row["method"], "definition": row["definition"], "setting": row["setting"],
        "precompute_time": _fig(row["precompute_s"], "s", "precomputation (CSM build or load; probe render + "
                                                          "texel AO; BVH build; none)"),
        "memory": _fig(row["bytes"], "B", "precomputed data kept for frames"),
        "ao_time": _fig(row["ao_s"], "s", "AO of the covered pixels from the G-buffer (median)"),
        "frame_time": _fig(row["ao_s"] + (0.0 if "own_frame" in row else ctx.gbuffer_time), "s",
                           "G-buffer raster + AO (medians); its own render for vtk-ssao"),
        "coverage": _fig(cov, "fraction", "pixels the method shades (cube map: probes see them)"),
        "visibility_agreement": na if agreement is None else _fig(
            agreement["agreement"], "fraction", f"rays agreeing with Embree ({row['definition']}), identical rays"),
        "false_visible": na if agreement is None else _fig(agreement["false_visible"], "fraction",
                                                           "rays called open that Embree finds occluded"),
        "false_occluded": na if agreement is None else _fig(agreement["false_occluded"], "fraction",
                                                            "rays called occluded that Embree finds open"),
        "ao_rmse_unlimited": _fig(rmse_u, "AO", "AO RMSE vs converged unlimited Embree"),
        "ao_mae_unlimited": _fig(mae_u, "AO", "AO MAE vs converged unlimited Embree"),
        "ao_rmse_limited": _fig(rmse_d, "AO", "AO RMSE vs converged distance-limited Embree"),
        "ao_mae_limited": _fig(mae_d, "AO", "AO MAE vs converged distance-limited Embree"),
    }
    surfaces = []
    dis = None if agreement is None else agreement["disagree"]
    for sid in np.unique(gb.ids):
        m = gb.ids == sid
        name = (names or {}).get(int(sid), "ground" if sid == GROUND_ID else f"instance {int(sid)}")
        surfaces.append({
            "surface": name, "id": int(sid), "pixels": _fig(int(m.sum()), "px", "covered pixels"),
            "visibility_agreement": na if dis is None else _fig(1.0 - dis[m].sum() / (m.sum() * S), "fraction",
                                                                "rays agreeing with Embree"),
            "ao_rmse_unlimited": _fig(_errors(a[m], ctx.conv[m])[0], "AO", "AO RMSE vs unlimited reference"),
            "ao_rmse_limited": _fig(_errors(a[m], ctx.conv_d[m])[0], "AO", "AO RMSE vs limited reference"),
        })
    if "embree_share" in row and row["visible"] is not None:
        rec["embree_share"] = _fig(row["embree_share"](), "fraction",
                                   "rays the CSM cannot decide within D, traced by Embree (straddle='embree')")
    rec["surfaces"] = surfaces
    return rec


def run_methods(ctx: Context, methods, samples, repeats, *, probe_resolution=128, csm=None, names=None,
                own_csm=None) -> list:
    """Build, time (interleaved) and measure the rows of ``methods``; returns their records."""
    rows = [r for m in methods for r in method_runs(ctx, m, samples, probe_resolution=probe_resolution, csm=csm)]
    ctx.gbuffer_time = time_rows(ctx, rows, repeats)
    recs = []
    for r in rows:
        agree = own_csm if (own_csm is not None and r["method"] == own_csm["method"]
                            and r["definition"] == "unlimited") else None
        recs.append(measure_row(ctx, r, names, agree))
    return recs


def method_context(args, scene, camera, gb: GBuffer, tracer, cache, conv, log):
    """The :class:`Context` of a benchmark's pixels: ``D`` (``args.ao_distance`` or the default rule),
    the limited reference (cached) and the G-buffer of ``scene.draw_items()``.

    Returns ``(ctx, rule, limited reference seconds, its source)``.
    """
    from pyshadow.gbuffer import render_gbuffer

    D = args.ao_distance if args.ao_distance is not None else default_distance(scene)
    rule = "--ao-distance" if args.ao_distance is not None else "mean bounding radius of the casters"
    conv_d, conv_d_s, conv_d_src = limited_reference(cache, tracer, scene, gb, D, args.reference_samples,
                                                     args.strategy, args.seed, args.patterns, log)
    g = render_gbuffer(scene.draw_items()[0], camera)
    if not np.array_equal(np.flatnonzero(np.asarray(g["object_id"]).reshape(-1) >= 0), gb.sel):
        raise RuntimeError("the G-buffer raster does not cover the benchmark's pixels")
    ctx = Context(scene, camera, gb, g, D, args.strategy, args.seed, args.patterns, tracer, conv, conv_d)
    return ctx, rule, conv_d_s, conv_d_src


def methods_pass(args, scene, camera, gb: GBuffer, tracer, cache, csm, conv, vis, lookup, names, log) -> dict:
    """The ``"methods"`` entry of results.json (module docstring): every ``--method`` on the benchmark's pixels.

    Parameters
    ----------
    args : argparse.Namespace
        ``method`` (list of lists of names), ``ao_distance`` (float or
        None), ``probe_resolution``, ``samples``, ``strategy``, ``seed``,
        ``patterns``, ``reference_samples``, ``repeats``.
    scene, camera, gb, tracer, cache :
        The single benchmark's (tracer still open).
    csm : dict
        :func:`pyshadow.bench.scenes._csm_summary` of the scene.
    conv : ndarray, shape (N,)
        The converged unlimited reference.
    vis : dict
        :func:`pyshadow.bench.measure.visibility_pass` of the benchmark's
        CSM lookup: reused for that CSM row's agreement.
    lookup : {'nearest', 'vote'}
        The benchmark's CSM lookup.
    names : dict
        Surface id -> name.
    log : callable

    Returns
    -------
    dict
    """
    from .method_sweep import check_camera

    methods = selected_methods(args.method)
    check_camera(methods, camera, (args.samples,))      # vtk-ssao: a UsageError before any work or output
    ctx, rule, conv_d_s, conv_d_src = method_context(args, scene, camera, gb, tracer, cache, conv, log)
    D, conv_d = ctx.D, ctx.conv_d
    log(f"methods: {', '.join(methods)} at D = {D:.4g} ({rule}), {args.samples} samples")
    own = {"method": "csm" if lookup == "nearest" else "csm-vote", **vis}
    rows = run_methods(ctx, methods, args.samples, args.repeats, probe_resolution=args.probe_resolution,
                       csm=csm, names=names, own_csm=own)
    return {
        "distance": _fig(D, "world", f"D of the distance-limited definition ({rule})"),
        "limited_reference_source": conv_d_src,
        "limited_reference_time": _fig(conv_d_s, "s", "time of the limited reference (null when cached)"),
        "limit_effect_rmse": _fig(_errors(conv, conv_d)[0], "AO",
                                  "RMSE between the unlimited and the limited converged references"),
        "gbuffer_time": _fig(ctx.gbuffer_time, "s", "G-buffer raster (median), part of every frame time"),
        "cubemap_fallback": CUBEMAP_FALLBACK,
        "rows": rows,
    }


def methods_table(m: dict) -> str:
    """The methods entry as a markdown table (no final newline); a missing figure prints as "n/a"."""
    def v(f, fmt, scale=1.0):
        return _num(f["value"] if isinstance(f, dict) else None, fmt, scale)

    lines = [f"methods (D = {v(m['distance'], '.3g')}; limit moves the reference by RMSE "
             f"{v(m['limit_effect_rmse'], '.3f')})",
             "| method | definition | setting | precompute s | memory MB | frame ms | agreement % | coverage "
             "| RMSE vs limited | RMSE vs unlimited | rays by Embree % |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in m["rows"]:
        st = r["setting"]
        setting = f"{st['samples']} spp" + (f", R {st['probe_resolution']}" if "probe_resolution" in st else "")
        lines.append(f"| {r['method']} | {r['definition']} | {setting} | {v(r['precompute_time'], '.2f')} | "
                     f"{v(r['memory'], '.2f', 1e-6)} | {v(r['frame_time'], '.0f', 1e3)} | "
                     f"{v(r['visibility_agreement'], '.2f', 100)} | {v(r['coverage'], '.3f')} | "
                     f"{v(r['ao_rmse_limited'], '.4f')} | {v(r['ao_rmse_unlimited'], '.4f')} | "
                     f"{v(r.get('embree_share'), '.1f', 100) if r['method'] != 'embree' else '100'} |")
    return "\n".join(lines)

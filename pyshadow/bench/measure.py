"""Measurements on the covered pixels of a render: the G-buffer, Embree and pyshadow passes
on identical rays, errors, and the converged Embree reference."""
from __future__ import annotations

import dataclasses
import hashlib
import json
import time

import numpy as np

from ..cache import CSMCache
from ..embree import EmbreeTracer
from ..render import covered_pixels, surface_points
from .common import _bar, _fig, cached_ao


@dataclasses.dataclass
class GBuffer:
    """The covered pixels of a render, exactly as :meth:`pyshadow.Scene.render` queries them.

    Attributes
    ----------
    height, width : int
        Image size in pixels.
    sel : ndarray, shape (N,), int64
        Flat indices ``r * width + c`` of the covered pixels (also their
        sample-pattern indices), ascending.
    points : ndarray, shape (N, 3), float64
        World positions, computed as ``Scene.render`` computes them.
    normals : ndarray, shape (N, 3), float64
        Unit normals (world frame).
    ids : ndarray, shape (N,), int32
        Surface ids: instance id, or ``pyshadow.scene.GROUND_ID``.
    object_id : ndarray, shape (height, width), int32
        The render's object ids, -1 where no surface is seen.
    """

    height: int
    width: int
    sel: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    ids: np.ndarray
    object_id: np.ndarray

    @classmethod
    def from_render(cls, out, camera, scene=None):
        """The G-buffer of ``out = scene.render(camera, ...)`` (its depth, normal and object_id).

        ``out``'s depth is float32: from a far camera its points lie off their faces by a float32
        spacing of the depth, where ``Scene.render`` shades points on the faces' planes in float64
        (:func:`pyshadow.render.surface_points`); given ``scene`` (the rendered one), the points are those.
        """
        sp = covered_pixels(camera, out, out["object_id"])      # the points Scene.render shades
        points = sp.points
        if scene is not None:
            on = surface_points(scene, camera)
            if not np.array_equal(on.index, sp.index):
                raise ValueError("scene does not draw the covered pixels of out as seen by camera")
            points = on.points
        n = np.asarray(sp.normals, np.float64)
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
        return cls(camera.height, camera.width, sp.index.astype(np.int64), points, n,
                   sp.surface_ids.astype(np.int32), out["object_id"])

    @property
    def n(self) -> int:
        """Number of covered pixels N."""
        return len(self.sel)

    def image(self, values, background=1.0) -> np.ndarray:
        """Per-pixel ``values`` (N,) as a float32 (height, width) image; ``background`` elsewhere."""
        img = np.full(self.height * self.width, background, np.float32)
        img[self.sel] = values
        return img.reshape(self.height, self.width)

    def digest(self) -> str:
        """SHA-256 hex digest of ``sel``, ``points``, ``normals`` and ``ids``."""
        h = hashlib.sha256()
        for a in (self.sel, self.points, self.normals, self.ids):
            h.update(np.ascontiguousarray(a).tobytes())
        return h.hexdigest()


def _ray_chunks(gb: GBuffer, samples, strategy, seed, patterns, max_rays=1 << 22):
    """Yield (start, end, dirs float32 (n*S, 3)): the kernels' sample directions of pixel runs."""
    from pyshadow.sampling import Sampling, sample_directions

    step = max(1, max_rays // samples)
    for s in range(0, gb.n, step):
        e = min(gb.n, s + step)
        d = sample_directions(gb.normals[s:e], sampling=Sampling(samples, strategy, patterns, seed),
                              indices=gb.sel[s:e])
        yield s, e, np.ascontiguousarray(d.reshape(-1, 3), dtype=np.float32)


def embree_pass(tracer: EmbreeTracer, gb: GBuffer, samples, strategy, seed, patterns, *,
                keep: bool = True, keep_rays: int = 0, desc: str | None = None):
    """Embree AO on the G-buffer points along the kernels' directions.

    Parameters
    ----------
    tracer : pyshadow.embree.EmbreeTracer
    gb : GBuffer
    samples, strategy, seed, patterns :
        The sampling of :func:`pyshadow.sample_directions`.
    keep : bool
        Return every ray's occlusion (``occluded``).
    keep_rays : int
        Also keep the prepared rays of the first pixel chunks, up to about
        this many samples, for timing (``rays``; ``rays_pixels`` of them).

    Returns
    -------
    dict
        ``ao`` (N,) float32, ``occluded`` (N*S,) bool or None, ``seconds``
        (time of this pass's Embree calls), ``traced`` (rays given to
        Embree), ``rays`` and ``rays_pixels`` (see ``keep_rays``),
        ``rays_traced`` (traced rays among them), ``samples`` (N*S).
    """
    S = int(samples)
    ao = np.empty(gb.n, np.float32)
    occ_all = np.empty(gb.n * S, bool) if keep else None
    seconds, traced = 0.0, 0
    rays, rays_pixels, rays_traced = [], 0, 0
    bar = _bar(gb.n, desc or f"Embree {S} spp", "px")
    try:
        for s, e, d32 in _ray_chunks(gb, S, strategy, seed, patterns):
            occ, todo, o32, dd = tracer.prepare(gb.points[s:e], gb.normals[s:e], d32, S)
            t0 = time.perf_counter()
            occ[todo] = tracer.occluded(o32, dd)
            seconds += time.perf_counter() - t0
            ao[s:e] = (~occ.reshape(e - s, S)).mean(axis=1)
            if keep:
                occ_all[s * S:e * S] = occ
            if rays_pixels * S < keep_rays and rays_pixels == s:
                rays.append((o32, dd))
                rays_pixels, rays_traced = e, rays_traced + len(todo)
            traced += len(todo)
            bar.update(e - s)
    finally:
        bar.close()
    return {"ao": ao, "occluded": occ_all, "seconds": seconds, "traced": traced, "samples": gb.n * S,
            "rays": rays, "rays_pixels": rays_pixels, "rays_traced": rays_traced}


def time_rays(tracer: EmbreeTracer, rays) -> float:
    """Seconds to trace the stored rays once.

    Parameters
    ----------
    tracer : pyshadow.embree.EmbreeTracer
    rays : list of (origins, dirs)
        ``embree_pass(..., keep_rays=...)["rays"]``: float32 (n, 3) pairs.

    Returns
    -------
    float
        Wall time of :meth:`EmbreeTracer.occluded` over all pairs, seconds.
    """
    t0 = time.perf_counter()
    for o32, d32 in rays:
        tracer.occluded(o32, d32)
    return time.perf_counter() - t0


def visibility_pass(scene, gb: GBuffer, samples, strategy, seed, patterns, embree_occluded,
                    lookup="nearest"):
    """pyshadow's :meth:`pyshadow.Scene.visible` on the identical rays, compared with Embree's.

    Parameters
    ----------
    scene : pyshadow.Scene
    gb : GBuffer
    samples, strategy, seed, patterns :
        The sampling of :func:`pyshadow.sample_directions`.
    embree_occluded : ndarray, shape (N * samples,), bool
        ``embree_pass(...)["occluded"]`` for the same sampling.
    lookup : {'nearest', 'vote'}
        The CSM lookup (:meth:`pyshadow.Scene.visible`).

    Returns
    -------
    dict
        ``agreement``: fraction of rays on which both agree;
        ``false_visible``: fraction pyshadow calls visible where Embree
        hits; ``false_occluded``: fraction pyshadow calls occluded where
        Embree sees the sky; ``ao`` (N,) float32: the AO the per-ray
        results give (a consistency check against the AO kernel);
        ``disagree`` (N,) int32: disagreeing rays of every pixel. With no
        pixels the fractions are NaN (null in the records).
    """
    S = int(samples)
    agree = fv = fo = 0
    ao = np.empty(gb.n, np.float32)
    disagree = np.empty(gb.n, np.int32)
    for s, e, d32 in _ray_chunks(gb, S, strategy, seed, patterns):
        # with the pixels' normals: the rays as the AO kernel asks them (the surface rule)
        vis = scene.visible(np.repeat(gb.points[s:e], S, axis=0), d32,
                            surface_ids=np.repeat(gb.ids[s:e], S), lookup=lookup,
                            normals=np.repeat(gb.normals[s:e], S, axis=0))
        ref = ~embree_occluded[s * S:e * S]
        agree += int(np.count_nonzero(vis == ref))
        fv += int(np.count_nonzero(vis & ~ref))
        fo += int(np.count_nonzero(~vis & ref))
        ao[s:e] = vis.reshape(e - s, S).mean(axis=1)
        disagree[s:e] = (vis != ref).reshape(e - s, S).sum(axis=1)
    total = gb.n * S or float("nan")       # no rays: no fraction agrees (not 0 %)
    return {"agreement": agree / total, "false_visible": fv / total, "false_occluded": fo / total,
            "ao": ao, "disagree": disagree}


def ao_rays_visible(scene, backend, points, directions, surface_ids, normals, max_distance=None) -> np.ndarray:
    """A CSM backend's answer for each ray, as its AO (:func:`pyshadow.visibility.ambient_occlusion`) asks it.

    Unbounded rays: :func:`pyshadow.visibility.visible`. Rays of length ``max_distance``: the rule of
    :func:`pyshadow.visibility.finite.answer_finite_ao` with ``straddle='embree'``: a ray ending inside a
    caster's bounding sphere is asked unbounded first and traced by Embree only where the CSM finds it
    occluded. (:func:`~pyshadow.visibility.visible` traces every such ray: its answers leave out the CSM's
    own errors on them, and averaged per pixel they are not the AO.)

    Parameters
    ----------
    scene : pyshadow.Scene
    backend : {'csm', 'csm-vote'}
    points : ndarray, shape (n, 3), float64
        World ray origins on the surfaces.
    directions : ndarray, shape (n, 3)
        Unit directions.
    surface_ids : ndarray, shape (n,), int
    normals : ndarray, shape (n, 3)
        The points' unit normals.
    max_distance : float, optional
        Ray length ``D``, world units (None: unbounded).

    Returns
    -------
    ndarray, shape (n,), bool
        True where the ray is free (up to ``max_distance``).
    """
    from pyshadow import visibility
    from pyshadow.visibility.finite import answer_finite_ao, unit_directions

    def answer(rows, lengths):        # lengths: all D, or all inf (the straddling rays asked unbounded)
        return visibility.visible(scene, points[rows], w[rows], backend=backend, surface_ids=surface_ids[rows],
                                  normals=normals[rows], max_distance=None if np.isinf(lengths).all() else lengths,
                                  straddle="embree")

    if max_distance is None:
        return visibility.visible(scene, points, directions, backend=backend, surface_ids=surface_ids,
                                  normals=normals)
    w = unit_directions(directions)
    return answer_finite_ao(scene, points, w, np.full(len(w), float(max_distance)), "embree", answer)


def by_surface(gb: GBuffer, names: dict, samples: int, disagree, ao, ref_ao, conv_ao) -> list:
    """Per surface (instance or ground): pixels, ray agreement, AO bias and errors.

    Parameters
    ----------
    gb : GBuffer
    names : dict
        Surface id -> name (:attr:`SceneFactory.names`).
    samples : int
        Rays per pixel.
    disagree : ndarray, shape (N,), int
        ``visibility_pass(...)["disagree"]``.
    ao, ref_ao, conv_ao : ndarray, shape (N,)
        pyshadow's unfiltered AO, Embree's on the identical rays, the
        converged reference.

    Returns
    -------
    list of dict
        One row per surface id present, ascending: ``surface`` (name),
        ``id`` and figure records (``pixels``, ``visibility_agreement``,
        ``ao_bias_identical``, ``ao_rmse_identical``, ``ao_rmse_converged``).
    """
    from pyshadow.scene import GROUND_ID

    rows = []
    for sid in np.unique(gb.ids):
        m = gb.ids == sid
        d = ao[m].astype(np.float64) - ref_ao[m]
        rows.append({
            "surface": names.get(int(sid), "ground" if sid == GROUND_ID else f"instance {int(sid)}"),
            "id": int(sid),
            "pixels": _fig(int(m.sum()), "px", "covered pixels of this surface"),
            "visibility_agreement": _fig(1.0 - disagree[m].sum() / (m.sum() * samples), "fraction",
                                         "rays on which pyshadow and Embree agree"),
            "ao_bias_identical": _fig(float(d.mean()), "AO", "mean pyshadow - Embree, identical rays"),
            "ao_rmse_identical": _fig(_errors(ao[m], ref_ao[m])[0], "AO", "AO RMSE, identical rays"),
            "ao_rmse_converged": _fig(_errors(ao[m], conv_ao[m])[0], "AO",
                                      "unfiltered AO RMSE vs converged"),
        })
    return rows


def _errors(a, b):
    """(RMSE, MAE) of ``a - b`` in float64, arrays of one shape; (nan, nan) when empty."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    if a.shape != b.shape:          # broadcasting (N, 1) against (N,) compared every pixel with every other
        raise ValueError(f"AO errors of arrays of different shapes: {a.shape} and {b.shape}")
    d = a - b
    if d.size == 0:
        return float("nan"), float("nan")
    return float(np.sqrt(np.mean(d * d))), float(np.mean(np.abs(d)))


#: The package's modules whose code decides a converged reference (unlimited and distance-limited): the
#: functions its tracing runs (found by tests/test_benchcli_reference_key.py; besides them only the device
#: and launch choice of ``_cl``, argument checks and the cache's file store run), with
#: :data:`REFERENCE_KERNELS`. Their text is part of the cache key: a cached reference of other code is
#: traced again (30f924a changed the limited pass's answers on rays grazing their surface, not the key).
REFERENCE_SOURCES = ("_embree_checks.py", "_embree_lift.py", "anchor_reach.py", "bench/measure.py",
                     "bench/methods.py", "contact.py", "contact_bodies.py", "contact_parts.py", "embree.py",
                     "mesh.py", "sampling.py", "scene.py", "scene_arrays.py", "visibility/finite.py")
#: The kernels of the reference's sample directions (:func:`pyshadow.sample_directions`).
REFERENCE_KERNELS = ("sampling.cl",)


def _reference_key(scene, gb: GBuffer, samples, strategy, seed, patterns) -> str:
    """Everything a converged reference depends on: the pixels, the sampling, the casters and
    the code (:data:`REFERENCE_SOURCES`)."""
    import pyshadow
    from pyshadow.cache import source_digest
    from pyshadow.embree import surface_epsilon

    h = hashlib.sha256(b"pyshadow-bench converged reference v2")     # v2: each point lifted by its own body
    h.update(gb.digest().encode())
    h.update(json.dumps([int(samples), strategy, int(seed), int(patterns), scene.ground,
                         surface_epsilon(scene), pyshadow.__version__]).encode())
    h.update(source_digest(REFERENCE_SOURCES, REFERENCE_KERNELS).encode())
    for inst in scene.instances:
        if inst.casts:
            from pyshadow.mesh import mesh_hash

            h.update(mesh_hash(inst.mesh).encode())
            h.update(np.ascontiguousarray(inst.transform, "<f8").tobytes())
    return h.hexdigest()


def converged_reference(cache: CSMCache, tracer, scene, gb, samples, strategy, seed, patterns, log):
    """The converged Embree AO of the G-buffer pixels: from ``cache``, or traced and stored.

    The cache key (:func:`_reference_key`) hashes the G-buffer, the
    sampling, the ground, the surface epsilon, pyshadow's version, every
    caster's mesh hash and transform, and the text of the code that traces
    it (:data:`REFERENCE_SOURCES`, :data:`REFERENCE_KERNELS`).

    A cached array that is not a possible AO of the pixels
    (:func:`pyshadow.bench.common.cached_ao`) is traced again and replaced,
    with a note through ``log``.

    Returns
    -------
    ao : ndarray, shape (N,), float32
    seconds : float or None
        Time of the trace, seconds; None when cached.
    source : str
        'cached' or 'computed'.
    """
    key = _reference_key(scene, gb, samples, strategy, seed, patterns)
    ao = cached_ao(cache, key, gb.n, log)
    if ao is not None:
        return ao, None, "cached"
    log(f"tracing the converged Embree reference: {samples} samples x {gb.n} pixels "
        f"({gb.n * samples / 1e6:.0f} M rays, {tracer.threads} threads)")
    t0 = time.perf_counter()
    r = embree_pass(tracer, gb, samples, strategy, seed, patterns, keep=False,
                    desc=f"reference {samples} spp")
    seconds = time.perf_counter() - t0
    cache.put_array(key, r["ao"])
    return r["ao"], seconds, "computed"

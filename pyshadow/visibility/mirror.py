"""The ``"numpy"`` backend: the float64 NumPy mirror of the CSM lookup (small inputs).

:func:`visible_reference` applies the visibility kernel's rules in float64
(bounding-sphere cull, nearest map or the vote, texel, ``searchsorted`` on
the segment lists, bias, ground plane); AO traces the directions of
:func:`pyshadow.sampling.sample_directions_reference` through it. Its answers
differ from the kernel's only where float32 rounding decides (a direction
almost exactly between two maps, a vote of almost exactly one half).
"""
from __future__ import annotations

import numpy as np

from .._validate import check_indices, check_lookup, flag, rows3, unit_normals
from ..contact import ground_tolerance, occlude_contacts
from ..csm.core import DEFAULT_BIAS_TEXELS, DEPTH_Q, VOTE_BIAS_TEXELS, lookup_box
from ..csm.reference import shadow_vote
from ..csm.surface_rule import surface_horizon
from ..sampling import ao_from_samples, sample_directions_reference
from ..scene_arrays import check_meshes, scene_arrays
from .base import check_bias, check_sampling, register
from .finite import (answer_finite, ao_nodes, check_ao_options, check_max_distance, check_straddle, ground_blocks,
                     ground_offsets, rays_ao)

__all__ = ["NumPyVisibility", "visible_reference", "ambient_occlusion_reference", "caster_occludes"]


def visible_reference(scene, points, directions, *, bias: float | None = None,
                      surface_ids=None, lookup: str = "nearest", normals=None, max_distance=None,
                      straddle: str = "error") -> np.ndarray:
    """NumPy version of :meth:`Scene.visible` (the same rules in float64).

    For each caster: bounding-sphere cull, the point and direction in the
    instance's normalised frame, the nearest map (:meth:`ViewSet.nearest`),
    the texel, the stored depth of that (map, texel) found with
    ``searchsorted`` on the segment lists, and the comparison with the bias;
    then the analytic ground plane. With ``lookup="vote"``, the weighted vote of
    the four maps of :meth:`ViewSet.filter_window` times the four texels
    around the point. Differences to the kernel come only from float32
    rounding (e.g. a direction almost exactly between two maps, a vote of
    almost exactly one half). With ``normals``, the surface rule of
    :mod:`pyshadow.csm.surface_rule` for the rays leaving a caster's own
    surface. With ``max_distance``, finite rays by the rules of
    :mod:`pyshadow.visibility.finite` (``straddle`` as there).
    """
    check_lookup(lookup)
    check_bias(bias)                    # as the kernels: a NaN bias answered every ray open here
    check_straddle(straddle)            # as visibility.visible: also where unused (no max_distance, no rays)
    p = rows3(points, "points")
    w = unit_normals(directions, len(p), "directions")     # any length: huge or tiny rows scaled first
    own = scene.caster_slots(surface_ids, len(p), p)
    m = None if normals is None else unit_normals(normals, len(p))
    tmax = check_max_distance(max_distance, len(p))
    if tmax is None or not len(p):
        return _visible_reference(scene, p, w, own, m, lookup, bias, None)
    return answer_finite(scene, p, w, tmax, straddle,
                         lambda: _visible_reference(scene, p, w, own, m, lookup, bias, tmax))


def _visible_reference(scene, p, w, own, m, lookup, bias, tmax, ground=True):
    """:func:`visible_reference` of validated rows (``tmax``: (N,) lengths or None; ``ground`` False: the
    casters alone, as the kernel compiled with ``GROUND=0``)."""
    check_meshes(scene)                 # a caster's mesh changed in place: refused, as on the other backends
    occ = np.zeros(len(p), bool)
    if ground and scene.ground is not None:
        occ |= ground_blocks(p[:, 1] - scene.ground, w[:, 1], tmax, ground_tolerance(scene),
                             0.0 if tmax is None else ground_offsets(scene, p))
    types, _ = scene.caster_types()
    bits = 16 if all(c.depth_bits == 16 for c in types) else 32
    quantum = (1.0 / DEPTH_Q if bits == 16 else 0.0) + 1e-7
    arr = scene_arrays(scene)           # the casters and their instances of one state (not a placeholder removed since)
    for slot, i in enumerate(np.flatnonzero(arr["casts"]).tolist()):
        inst = arr["placed"][i]
        own_rows = (own == -1) | (own == slot)
        occ |= caster_occludes(inst.csm, inst.world_sphere(), inst.rotation, inst.scale,
                               inst.transform[:3, 3], p, w, m, own_rows, ~occ, lookup=lookup, bias=bias,
                               quantum=quantum, vote=shadow_vote, tmax=tmax)
    return occlude_contacts(scene, p, w, ~occ)


def caster_occludes(csm, sphere, rotation, scale, translation, p, w, m, own_rows, ask, *, lookup, bias,
                    quantum, vote, tmax=None) -> np.ndarray:
    """Rows ``ask`` of world rays ``(p, w)`` that one caster shadows, by the kernel's rules (float64).

    Bounding-sphere cull, the point and direction in the caster's normalised
    frame, points before their ray's chord through the sphere and the mesh's
    box asked at it (:func:`_to_chord`; rays whose chord is empty or behind
    them missed), the surface rule where normals ``m`` are given (for the rows
    ``own_rows`` that may lie on this caster), the nearest map or the vote's
    window, then ``vote`` (:func:`shadow_vote`, or the traced taps of
    :mod:`pyshadow.csm.error_model`) over the taps.

    Parameters
    ----------
    csm : CoherentShadowMap or anything with ``views``, ``resolution``, ``centre``, ``radius``
    sphere : (centre (3,), radius)
        The caster's bounding sphere in world space.
    rotation : ndarray, shape (3, 3)
    scale : float
    translation : ndarray, shape (3,)
    p, w : ndarray, shape (N, 3)
        World points and unit directions.
    m : ndarray, shape (N, 3), or None
        Unit surface normals.
    own_rows, ask : ndarray of bool, shape (N,)
    tmax : ndarray, shape (N,), optional
        Ray lengths, world units: the caster counts only where the ray
        passes the midpoint of its chord through the sphere (``tca < tmax``,
        :mod:`pyshadow.visibility.finite`). Default: unbounded rays.

    Returns
    -------
    ndarray of bool, shape (N,)
    """
    wc, wr = sphere
    oc = wc - p
    tca = np.einsum("ij,ij->i", oc, w)
    oc2 = np.einsum("ij,ij->i", oc, oc)
    r2 = (wr * (1 + 1e-6)) ** 2
    perp = oc - tca[:, None] * w                     # as sphere_v: no difference of squares
    act = ask & ~((oc2 > r2) & ((tca < 0) | (np.einsum("ij,ij->i", perp, perp) > r2)))
    if tmax is not None:
        act &= tca < tmax
    out = np.zeros(len(p), bool)
    if not act.any():
        return out
    pn = ((p[act] - translation) @ rotation) / (scale * csm.radius) - csm.centre / csm.radius
    wn = w[act] @ rotation
    pn, pt, miss, beyond = _to_chord(pn, wn, lookup_box(csm), own_rows[act], csm.resolution)
    mine = own_rows[act] & ~beyond      # a point beyond the sphere is on none of this caster's surfaces
    mn, up = None, None
    if m is not None:
        mn = m[act] @ rotation
        wn, up = _raise_directions(csm, lookup, wn, mn, mine)
    if lookup == "vote":
        maps, map_w = csm.views.filter_window(wn)
    else:
        maps, map_w = csm.views.nearest(wn)[:, None].astype(np.int64), np.ones((len(wn), 1))
    taps = dict(quantum=quantum, texels=4 if lookup == "vote" else 1, self_=mine, bias=bias,
                bias_texels=VOTE_BIAS_TEXELS if lookup == "vote" else DEFAULT_BIAS_TEXELS, normals=mn, lift=up,
                beyond=beyond)
    hit = ~miss                         # missed rows keep far points: their texels overflowed int64
    if not hit.any():
        return out
    if not hit.all():
        pn, wn, maps, map_w, pt = pn[hit], wn[hit], maps[hit], map_w[hit], pt[hit]
        taps.update(self_=mine[hit], normals=None if mn is None else mn[hit], lift=None if up is None else up[hit],
                    beyond=beyond[hit])
    v = vote(csm, pn, wn, maps, map_w, texel_points=pt, **taps)
    out[np.flatnonzero(act)[hit][v > 0.5]] = True
    return out


def _to_chord(q, v, box, own, resolution):
    """Where points are asked on their ray's chord through a caster (kernels/csm_lookup.h, instance_v), float64.

    The chord is the part of the ray inside both the unit sphere and
    ``box`` (``(lo, hi)``, :func:`pyshadow.csm.core.lookup_box`): ``u`` in
    ``[u0, u1]`` along ``v`` from ``perp = q - (q.v) v``. Returns
    ``(depth_points, texel_points, miss, beyond)``: a point before its chord takes
    its texel at the chord's midpoint and,
    from outside the sphere, its depth where the ray enters the sphere; other
    points are unchanged in both; ``miss`` where the chord is empty or behind
    the point (the caster cannot shadow the ray); ``beyond`` where a point
    outside the sphere is not ``own`` (may lie on this caster) or lies more
    than two texels (``4 / resolution``) outside it: it is on none of the
    caster's surfaces and asks with a depth behind every stored one
    (:func:`pyshadow.csm.reference.shadow_taps`).
    """
    b = np.einsum("ij,ij->i", q, v)
    perp = q - b[:, None] * v
    h2 = 1.0 - np.einsum("ij,ij->i", perp, perp)
    e = np.sqrt(np.maximum(h2, 0.0))
    lo, hi = (np.asarray(x, np.float64) for x in box)
    r = 1.0 / np.where(np.abs(v) < 1e-30, 1e-30, v)
    ua, ub = (lo - perp) * r, (hi - perp) * r
    u0 = np.maximum(-e, np.minimum(ua, ub).max(axis=1))
    u1 = np.minimum(e, np.maximum(ua, ub).min(axis=1))
    miss = (h2 < 0) | (u0 > u1) | (u1 < b)
    far = (b < u0) & ~miss
    out = far & (b < -e)
    beyond = out & (~np.asarray(own, bool) | (b * b - h2 > (8.0 + 16.0 / resolution) / resolution))
    return (np.where(out[:, None], perp - e[:, None] * v, q),
            np.where(far[:, None], perp + (0.5 * (u0 + u1))[:, None] * v, q), miss, beyond)


def _raise_directions(csm, lookup, wn, mn, mine):
    """The surface rule's raised lookup directions (kernels/csm_lookup.h, surface_rule_v), float64.

    Returns the directions and the rows the rule applies to (``up``).
    """
    hs = surface_horizon(csm, lookup)
    s = np.einsum("ij,ij->i", wn, mn)
    up = mine & (s > 0)
    low = up & (s < hs)
    t = wn - s[:, None] * mn
    tl = np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-30)
    raised = t * (np.sqrt(1.0 - hs * hs) / tl) + hs * mn
    return np.where(low[:, None], raised, wn), up


def ambient_occlusion_reference(scene, points, normals, *, sampling, return_bent_normals=False, bias=None,
                                indices=None, surface_ids=None, lookup: str = "nearest", max_distance=None,
                                obscurance=None, quadrature=16, straddle="error"):
    """NumPy version of :meth:`Scene.ambient_occlusion`: :func:`visible_reference` on every sample.

    AO is the fraction of the sample directions that reach the sky; the bent
    normal is the normalised sum of those directions (the normal where none
    does), float64 until the float32 result. With ``max_distance`` or
    ``obscurance``: distance AO by the same finite queries and quadrature as
    the CSM backends (:mod:`pyshadow.visibility.finite`), ray by ray.
    """
    check_sampling(sampling)            # (None or 8: AttributeError 'samples')
    return_bent_normals = flag(return_bent_normals, "return_bent_normals")     # "no" returned (ao, bent)
    check_lookup(lookup)               # (distance AO read any other value as 'nearest')
    check_bias(bias)
    tau, Q, straddle = check_ao_options(obscurance, quadrature, straddle)     # as visibility.ambient_occlusion
    p = rows3(points, "points")
    n = unit_normals(normals, len(p))
    idx = check_indices(indices, len(p))
    S = sampling.samples
    if max_distance is not None or obscurance is not None:
        tmax = check_max_distance(np.inf if max_distance is None else max_distance, len(p))
        own = np.repeat(scene.caster_slots(surface_ids, len(p), p), S)
        dirs = sample_directions_reference(n, sampling=sampling, indices=idx)
        P, W, M = np.repeat(p, S, axis=0), dirs.reshape(-1, 3), np.repeat(n, S, axis=0)

        def answer(k, t):
            return _visible_reference(scene, P[k], W[k], own[k], M[k], lookup, bias, t)

        def casters(k):                 # unbounded, without the plane (finite.answer_finite_ao)
            return _visible_reference(scene, P[k], W[k], own[k], M[k], lookup, bias, None, ground=False)

        weights = rays_ao(scene, p, n, dirs, ao_nodes(tmax, tau, Q), straddle, answer, None, casters)
        return ao_from_samples(dirs, weights, n, return_bent_normals)
    dirs = sample_directions_reference(n, sampling=sampling, indices=idx)
    scene.caster_slots(surface_ids, len(p))     # checked before the broadcast below (numpy's message)
    ids = None if surface_ids is None else np.repeat(np.broadcast_to(np.asarray(surface_ids), (len(p),)), S)
    vis = visible_reference(scene, np.repeat(p, S, axis=0), dirs.reshape(-1, 3), bias=bias,
                            surface_ids=ids, lookup=lookup, normals=np.repeat(n, S, axis=0)).reshape(len(p), S)
    return ao_from_samples(dirs, vis, n, return_bent_normals)


class NumPyVisibility:
    """The float64 NumPy mirror of the CSM backends, as a backend (``lookup`` as theirs)."""

    def __init__(self, lookup: str = "nearest"):
        # checked here, as CSMVisibility does: any other value was named "numpy-vote", refused only when asked
        self.lookup = check_lookup(lookup)
        self.name = "numpy" if lookup == "nearest" else "numpy-vote"

    def __repr__(self) -> str:
        return f"<NumPyVisibility {self.name!r}>"

    def visible(self, scene, points, directions, *, bias=None, surface_ids=None, normals=None,
                max_distance=None, straddle="error"):
        return visible_reference(scene, points, directions, bias=bias, surface_ids=surface_ids,
                                 lookup=self.lookup, normals=normals, max_distance=max_distance,
                                 straddle=straddle)

    def ambient_occlusion(self, scene, points, normals, *, sampling, return_bent_normals=False, bias=None,
                          indices=None, surface_ids=None, **distance):
        return ambient_occlusion_reference(scene, points, normals, sampling=sampling,
                                           return_bent_normals=return_bent_normals, bias=bias,
                                           indices=indices, surface_ids=surface_ids, lookup=self.lookup, **distance)


register("numpy", NumPyVisibility("nearest"))
register("numpy-vote", NumPyVisibility("vote"))

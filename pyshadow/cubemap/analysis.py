"""Which rays a probe can answer at all: the part of the space it does not see, by Embree.

A probe knows the surfaces it sees, not what lies behind them. A ray that
passes behind a surface seen by the probe (as seen from its centre) before
the ray's first hit may meet geometry the probe never saw, or miss geometry
the march takes as thick: no resolution decides such rays. These helpers
split a comparison with Embree into such *unseen* rays and the rest, whose
disagreements only the probe's resolution can explain.
"""
from __future__ import annotations

import numpy as np

from .._validate import check_int, rows3, unit_normals
from ..lighting._checks import _number
from .estimators import march_defaults

__all__ = ["unseen_rays", "ambiguous_rays"]


def _rays(points, directions, normals, max_distance):
    """Validated rays: points (N, 3) float64, unit directions, normals (or None) and the length ``D``.

    (Rows of another count were broadcast, a zero direction became NaN with a RuntimeWarning, one of
    length 1e-200 too, and a negative, zero or NaN ``D`` tested no point: every ray "seen".)"""
    p = rows3(points, "points")
    w = unit_normals(directions, len(p), "directions")
    n = None if normals is None else rows3(normals, "normals", len(p))
    return p, w, n, march_defaults(max_distance)["max_distance"]


def unseen_rays(scene, probe, points, directions, max_distance, *, samples: int = 32, margin: float = 0.0,
                normals=None) -> np.ndarray:
    """Rays that pass through space hidden from the probe before their first hit (or ``max_distance``).

    Parameters
    ----------
    scene : pyshadow.Scene
        Its casters (with meshes) are traced by Embree.
    probe : CubeProbe
    points, directions : ndarray, shape (N, 3), float
        World ray origins and directions (normalised here).
    max_distance : float
        Ray length ``D``, world units.
    samples : int, optional
        Points tested per ray, evenly spaced over ``(0, min(t_hit, D))``.
    margin : float, optional
        In texels: also test the four points ``margin * 2 r / R`` beside each
        tested point ``q`` (perpendicular to the probe's sight line, ``r`` its
        distance from the centre) -- space within ``margin`` texels of hidden
        space. Points nearer their own surface's plane than that offset
        (``normals`` needed) are not moved.
    normals : ndarray, shape (N, 3), optional
        Unit normals of the points' surfaces (with ``margin > 0``).

    Returns
    -------
    ndarray, shape (N,), bool
        True where some tested point, in front of the ray's first caster
        hit, is not visible from the probe's centre: the segment from the
        centre to it meets a mesh the probe draws -- a caster, or a receiver
        (``casts=False``: it blocks no ray but hides what lies behind it) --
        more than 1e-3 of its length before it.
    """
    from ..embree import caster_scene, surface_epsilon
    from ..sampling import hemisphere_frame

    p, w, _, max_distance = _rays(points, directions, None, max_distance)
    samples = check_int(samples, "samples", 1)
    margin = _number(margin, "margin")
    if not (np.isfinite(margin) and margin >= 0):
        raise ValueError(f"margin must be a finite number of texels >= 0, got {margin!r}")
    if margin > 0:
        if normals is None:
            raise ValueError("unseen_rays: margin > 0 needs the points' normals (normals=)")
        normals = rows3(normals, "normals", len(p))
    rays, anchor = caster_scene(scene)
    hiders = _sight_scene(scene, rays, anchor)
    eps = surface_epsilon(scene, p)
    t_hit, _prim, _ng = rays.intersect(p - anchor + eps[:, None] * w, w)
    end = np.minimum(t_hit + eps, float(max_distance))
    t = end[:, None] * (np.arange(samples) + 0.5) / samples                 # (N, samples)
    q = (p[:, None] + t[..., None] * w[:, None]).reshape(-1, 3)
    sight = q - probe.centre
    length = np.linalg.norm(sight, axis=1)
    offsets = [np.zeros_like(q)]
    if margin > 0:
        height = (t * np.einsum("ij,ij->i", w, np.asarray(normals, np.float64).reshape(-1, 3))[:, None]).reshape(-1)
        step = margin * 2.0 * length / probe.resolution
        step = np.where(height > step, step, 0.0)
        e1, e2 = hemisphere_frame(sight / length[:, None])
        offsets += [step[:, None] * e for e in (e1, -e1, e2, -e2)]
    hidden = np.zeros(len(q), bool)
    for off in offsets:
        v = q + off - probe.centre
        ln = np.linalg.norm(v, axis=1)
        hidden |= hiders.occluded(np.broadcast_to(probe.centre - anchor, v.shape), v / ln[:, None], ln * (1 - 1e-3))
    return hidden.reshape(len(p), samples).any(axis=1)


def _sight_scene(scene, rays, anchor):
    """Embree scene of the meshes that hide space from a probe: ``rays`` (the casters, relative to ``anchor``)
    when the scene has no receiver with a mesh, else every instance with a mesh, as the probe draws them.

    (Receivers were left out: the space behind a receiver plate counted as seen, 19 of 1,888 floor rays
    flagged where 1,181 pass behind it; the march reads the plate there and answers open.)"""
    from ..embree import EmbreeScene

    drawn = [inst for inst in scene.instances if inst.mesh is not None]
    if all(inst.casts for inst in drawn):
        return rays
    tris = []
    for inst in drawn:
        T = np.asarray(inst.transform, dtype=np.float64)
        w = np.asarray(inst.mesh.vertices, dtype=np.float64) @ T[:3, :3].T + T[:3, 3] - anchor
        tris.append(w[np.asarray(inst.mesh.faces)])
    return EmbreeScene(np.concatenate(tris))


def ambiguous_rays(scene, probe, points, normals, directions, max_distance, answer=None) -> np.ndarray:
    """Rays that pass within the probe's resolution of an occluder edge: either answer is defensible.

    The march reads positions to the nearest texel -- ``2 r / R`` world
    units wide at distance ``r`` from the probe's centre (a face centre's;
    texels shrink towards the corners) -- and advances up to a texel per
    step, so it cannot tell apart rays less than about one texel apart at
    their farthest point, ``delta = 2 (|p - c| + D) / R``. A ray is
    ambiguous when Embree's answer changes for the ray moved sideways by
    ``delta`` (six directions perpendicular to it; a moved origin below the
    point's tangent plane first advances along the ray to that plane) or
    lengthened or shortened by ``delta``, or when it stays within ``delta``
    of its own surface's tangent plane over its whole length
    (``w . n D < delta``: a grazing ray, whose own surface's edges and
    curvature lie within a texel of it), or when it passes within a texel of
    space hidden from the probe (:func:`unseen_rays` with ``margin=1``, but
    not with ``margin=0``): the probe's sight line to a march point then
    passes within a texel of a silhouette, and the march may read either
    surface.

    Parameters
    ----------
    scene : pyshadow.Scene
    probe : CubeProbe
    points, normals, directions : ndarray, shape (N, 3), float
        Ray origins on surfaces, their unit normals, ray directions (in the
        normals' hemisphere).
    max_distance : float
        Ray length ``D``, world units.
    answer : ndarray, shape (N,), bool, optional
        Embree's answer for the rays themselves (computed when None).

    Returns
    -------
    ndarray, shape (N,), bool
    """
    from ..embree import visible
    from ..sampling import hemisphere_frame

    p, w, n, D = _rays(points, directions, normals, max_distance)
    if answer is not None and np.shape(answer) != (len(p),):
        raise ValueError(f"answer must have shape ({len(p)},) (one per ray), got {np.shape(answer)}")
    ref = visible(scene, p, w, max_distance=D) if answer is None else np.asarray(answer, bool)
    delta = 2.0 * (np.linalg.norm(p - probe.centre, axis=1) + D) / probe.resolution
    e1, e2 = hemisphere_frame(w)
    amb = np.zeros(len(p), bool)
    wn = np.maximum(np.einsum("ij,ij->i", w, n), 1e-6)
    for ang in np.arange(6) * np.pi / 3:
        e = np.cos(ang) * e1 + np.sin(ang) * e2
        o = p + delta[:, None] * e
        below = np.maximum(-np.einsum("ij,ij->i", o - p, n), 0.0)
        t0 = below / wn
        live = t0 < D
        o = o + t0[:, None] * w
        moved = visible(scene, o[live], w[live], max_distance=D - t0[live])
        amb[np.flatnonzero(live)[moved != ref[live]]] = True
    amb |= wn * D < delta
    amb |= unseen_rays(scene, probe, p, w, D, margin=1.0, normals=n) & ~unseen_rays(scene, probe, p, w, D)
    for dd in (-delta, delta):
        amb |= visible(scene, p, w, max_distance=np.maximum(D + dd, 1e-9)) != ref
    return amb

"""Finite shadow rays: ``visible(..., max_distance=...)`` and what a CSM can answer of them.

A shadow ray towards a light at distance ``t`` from the point is the segment
``p + s w``, ``0 <= s <= t`` (``w`` unit): occluders beyond ``t`` do not
count, nor does a surface through the end itself (the tie ``s = t``): a light
on a wall or in the ground plane is not hidden by it (Embree stops the ray
:func:`pyshadow._embree_lift.end_epsilon` short of its end; the plane's rule
is below; a CSM refuses or reroutes such a ray, whose end lies in the
caster's sphere). Per caster, with its world bounding sphere (the kernels' radius,
grown by 1e-6) met by the ray over ``[t0, t1]``:

* ``t0 >= t`` (the sphere lies wholly beyond the end): the caster is culled;
* ``t1 <= t`` (it ends before the end): it is answered as for an infinite ray
  -- the segment then holds every point of the caster the ray can meet, so
  the two answers agree;
* ``t0 < t < t1``, i.e. the end ``p + t w`` lies inside (or on) the sphere:
  a CSM cannot answer. Its maps store each occluder's depth only up to its
  compression interval (any depth in ``[z1, z2)``), not where along the ray
  the occluder lies, so whether it is before or beyond the end is unknown.
  Such rays ("straddling" rays) are refused with a ``ValueError`` naming the
  instance (``straddle="error"``, the default), or answered -- those rays
  only -- by Embree on the casters' meshes (``straddle="embree"``; every
  caster needs its mesh, else the same error). Nothing is launched before
  the check.

The kernel tells the first two cases apart by the midpoint of the chord:
the caster counts where ``(c - p).w < t``. For a ray that does not end inside
the sphere this is exactly the case split above, and it stays far from its
float32 rounding boundary except for rays that only graze the sphere.

The ground plane ``y = ground`` blocks a finite ray only where the segment
crosses it: from a point on or above it (within the kernels' tolerance,
:func:`pyshadow.contact.ground_tolerance`) going down to an end below it,
or from a point below it going up to an end above it; a point on the plane
(within that tolerance) going down enters the ground at once, whatever the
ray's length. The end counts as on the plane within that tolerance plus
``END_ROUNDING`` (2^-20) of the start's height and of the plane's distance
from the anchor the kernels read the point relative to: an end computed
from the start (a light in the plane, ``p + t w`` with ``t`` and ``w``
rounded, the anchored height in float32) lies off the plane by the rounding
of those, about 1e-7 of them in float32. A light exactly in the plane is
therefore not hidden by the plane (before, about a third of the rays from
points above the ground to lights in it were hidden, at random, differently
by each backend).

Every backend applies these rules (the kernel under ``FINITE_RAYS=1``, the
NumPy mirror in float64, Embree with ``tfar``); ``max_distance=None`` (or
``+inf`` for a ray) is the unbounded ray of before, bit-identical and as
fast: the kernel is compiled without the length test then.

Distance AO (``ambient_occlusion(..., max_distance=, obscurance=)``, seed 002
eq. 3.2-3.4) asks the same finite rays: see the section below
(:func:`ao_nodes`, :func:`answer_finite_ao`, :func:`rays_ao`). Its straddle
rule differs from that of :func:`answer_finite` in one respect: a
straddling ray is first asked unbounded, and only if that ray is occluded is
it undecided (``straddle='error'``, ``'embree'`` or ``'infinite'``). For a
convex caster that fills its bounding sphere (a sphere) ``'infinite'`` is
then wrong only for rays that end between the body and its sphere, or that
another caster occludes beyond the end: a ray that ends inside such a body
has met it.
"""
from __future__ import annotations

import numpy as np

from .._validate import squared_lengths
from ..scene_arrays import scene_arrays

__all__ = ["END_ROUNDING", "STRADDLE", "AO_STRADDLE", "check_max_distance", "check_straddle", "unit_directions",
           "straddling", "ground_blocks", "ground_offsets", "answer_finite", "check_ao_options", "ao_nodes",
           "obscurance_weight", "shell_clear", "answer_finite_ao", "rays_ao"]

#: The rounding a finite ray's end may carry off the ground plane, as a fraction of its start's height and of
#: the plane's distance from the anchor (:func:`ground_blocks`; the kernels' ``ground_v`` writes the same number).
END_ROUNDING = 2.0 ** -20
#: What to do with rays that end inside a caster's bounding sphere.
STRADDLE = ("error", "embree")
#: The same for the rays of distance-limited AO (:func:`answer_finite_ao`).
AO_STRADDLE = ("error", "embree", "infinite")


def check_max_distance(max_distance, n: int):
    """Validate ``max_distance`` for ``n`` rays.

    Parameters
    ----------
    max_distance : None, float or array_like, shape (N,)
        Length of each ray, world units: > 0 and not NaN; ``inf`` is the
        unbounded ray.
    n : int

    Returns
    -------
    ndarray, shape (N,), float64, or None
        A new array (None passes through).
    """
    if max_distance is None:
        return None
    try:
        t = np.asarray(max_distance)
        if t.dtype.kind in "bcmMSUV":       # True (1.0), "2.5", 1+0j, dates: not lengths
            raise TypeError
        t = np.asarray(t, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"max_distance must be a number or an array of N numbers, got {max_distance!r}") from None
    except OverflowError:       # an int beyond float64 (10**400): not a bare "int too large to convert to float"
        raise ValueError("max_distance must be within float64's range (inf: unbounded), got an int beyond it") from None
    if t.ndim > 1 or (t.ndim == 1 and len(t) != n):
        raise ValueError(f"max_distance must be a number or have shape ({n},), got shape {t.shape}")
    t = np.array(np.broadcast_to(t, (n,)))
    bad = np.isnan(t) | ~(t > 0)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"max_distance must be > 0 (inf: unbounded), got {t[i]} for ray {i} "
                         f"({int(bad.sum())} bad)")
    return t


def check_straddle(straddle) -> str:
    """Validate ``straddle`` (one of :data:`STRADDLE`)."""
    if not isinstance(straddle, str) or straddle not in STRADDLE:     # (an array's ``in``: "truth value ambiguous")
        raise ValueError(f"straddle must be one of {STRADDLE}, got {straddle!r}")
    return straddle


def unit_directions(w) -> np.ndarray:
    """Non-zero (N, 3) directions -> float64 unit rows (scaled by a power of two first, as the kernel)."""
    w = np.asarray(w, dtype=np.float64).reshape(-1, 3)
    if len(w) == 0:
        return w.copy()
    sq = np.einsum("ij,ij->i", w, w)
    if not ((sq > 1e-30) & (sq < 1e30)).all():      # squares would lose digits: rescale first (exact)
        w = np.ldexp(w, -np.frexp(np.abs(w).max(axis=1, keepdims=True))[1])
        sq = np.einsum("ij,ij->i", w, w)
    return w / np.sqrt(sq)[:, None]


def straddling(scene, points, directions, tmax):
    """Rays that end inside (or on) a caster's bounding sphere: those a CSM cannot answer.

    Parameters
    ----------
    scene : pyshadow.Scene
    points : ndarray, shape (N, 3)
        World ray origins.
    directions : ndarray, shape (N, 3)
        World unit directions (:func:`unit_directions`).
    tmax : ndarray, shape (N,)
        Ray lengths, world units (``inf`` never straddles).

    Returns
    -------
    rows : ndarray of int, shape (K,)
        The straddling rays, ascending.
    instances : ndarray of int, shape (K,)
        For each, the id of a caster instance whose sphere holds its end
        (the lowest such id).
    """
    arr = scene_arrays(scene)
    casters = np.flatnonzero(arr["casts"])
    fin = np.flatnonzero(np.isfinite(tmax))
    centres = arr["world_centre"][casters]
    radii = arr["world_radius"][casters] * (1 + 1e-6)      # the kernels' radius
    if len(casters) and len(fin):
        # a ray longer than twice the distance to the far corner of the spheres' box ends beyond them all
        # (and ends beyond 1e154 overflowed the k-d tree's squared distances: SciPy's "value of p too large")
        q = np.asarray(points, np.float64)[fin]
        lo, hi = (centres - radii[:, None]).min(axis=0), (centres + radii[:, None]).max(axis=0)
        reach = np.sqrt(squared_lengths(np.maximum(np.abs(q - lo), np.abs(q - hi))))
        fin = fin[~(tmax[fin] > 2.0 * reach)]
    if not len(casters) or not len(fin):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    ends = np.asarray(points, np.float64)[fin] + tmax[fin, None] * directions[fin]
    owner = np.full(len(fin), -1, np.int64)
    if len(casters) <= 32:
        for k in range(len(casters) - 1, -1, -1):          # lowest id wins
            d = ends - centres[k]
            owner[np.einsum("ij,ij->i", d, d) <= radii[k] ** 2] = casters[k]
    else:
        from scipy.spatial import cKDTree

        hits = cKDTree(ends).query_ball_point(centres, radii)
        for k in range(len(casters) - 1, -1, -1):
            owner[np.asarray(hits[k], np.int64)] = casters[k]
    inside = owner >= 0
    return fin[inside], owner[inside]


def ground_blocks(h, wy, tmax, eps, offset=0.0) -> np.ndarray:
    """The ground rule of a ray (float64): ``h`` the height above the plane, ``wy`` the
    unit direction's y, ``tmax`` the lengths (None: unbounded), ``eps`` the plane's tolerance,
    ``offset`` (float or (N,)) the plane's distance from the anchor the kernels read the ray's
    point relative to (:func:`ground_offsets`).

    A finite ray's end counts as on the plane within ``eps + END_ROUNDING * (|h| + offset)``
    (see the module)."""
    if tmax is None:
        return ((h >= -eps) & (wy < 0)) | ((h < -eps) & (wy > 0))
    with np.errstate(invalid="ignore"):
        e = h + tmax * wy
    te = eps + END_ROUNDING * (np.abs(h) + offset)
    return ((h >= -eps) & (wy < 0) & ((e < -te) | (h <= eps))) | ((h < -eps) & (wy > 0) & (e > te))


def ground_offsets(scene, points) -> np.ndarray:
    """(N,) the ground plane's distance from the anchor each of ``points`` (world (N, 3)) is asked relative to
    (:func:`pyshadow.scene_arrays.anchor_groups`): the kernels' ``|ground_y|``, whose float32 rounding and that
    of the point's anchored height a finite ray's end may carry off the plane (:func:`ground_blocks`)."""
    from ..scene_arrays import anchor_groups

    out = np.empty(len(points))
    for rows, anchor in anchor_groups(scene, np.asarray(points, np.float64)):
        out[slice(None) if rows is None else rows] = abs(scene.ground - anchor[1])
    return out


def answer_finite(scene, points, directions, tmax, straddle, answer) -> np.ndarray:
    """Finite rays by a CSM backend: refuse or reroute the straddling ones, ``answer()`` the rest.

    Parameters
    ----------
    scene : pyshadow.Scene
    points, directions : ndarray, shape (N, 3)
        World origins and unit directions (float64).
    tmax : ndarray, shape (N,)
        Validated lengths (:func:`check_max_distance`).
    straddle : {'error', 'embree'}
    answer : callable
        ``answer()`` -> (N,) bool, the backend's answer for every ray (its
        rows for the straddling rays are replaced).

    Returns
    -------
    ndarray, shape (N,), bool
    """
    check_straddle(straddle)
    rows, inst = straddling(scene, points, directions, tmax)
    if len(rows):
        meshes = all(scene.instances[i].mesh is not None for i in np.flatnonzero(scene_arrays(scene)["casts"]))
        if straddle == "error" or not meshes:
            i, j = int(rows[0]), int(inst[0])
            c, r = scene.instances[j].world_sphere()
            why = ("pass straddle='embree' to answer those rays by ray tracing" if straddle == "error" else
                   "straddle='embree' needs every caster's mesh (Scene.add(csm, mesh=...))")
            raise ValueError(f"ray {i} (and {len(rows) - 1} more) ends inside the bounding sphere of caster "
                             f"instance {j} (centre {np.round(np.asarray(c), 6).tolist()}, radius {float(r):.6g}): "
                             f"a CSM stores occluder depths only up to its compression intervals, so it cannot "
                             f"tell whether that caster lies before or beyond the ray's end; move the light "
                             f"outside the sphere, or {why}")
    vis = answer()
    if len(rows):
        from .. import embree

        vis[rows] = embree.visible(scene, points[rows], directions[rows], max_distance=tmax[rows])
    return vis


# ---------------------------------------------------------------------------
# distance-limited and distance-weighted AO (seed 002, eq. 3.2-3.4)
# ---------------------------------------------------------------------------
# Distance-limited AO counts an occluder only when a sample ray meets it
# within ``D = max_distance``: each ray contributes rho(L) = [L > D], L its
# first-hit distance (inf: a miss). Distance-weighted AO ("obscurance",
# [IKSZ03] as in seed 002 eq. 3.3) contributes rho(L) = 1 - exp(-tau L) for
# L <= D and 1 beyond D (D = inf by default); AO is the mean of rho over the
# cosine-weighted samples, 1 = open.
#
# A CSM answers "is the ray free up to t" (V_t = [L > t]), not L. Since
# rho_D(L) = P(min(t(U), D) < L) for U uniform on [0, 1) and
# t(u) = -log(1 - u) / tau (the inverse of rho), the midpoint rule with Q
# nodes u_j = (j - 1/2) / Q gives, per ray,
#     rho_Q(L) = (1/Q) sum_j V_{t_j},   t_j = min(t(u_j), D),
# i.e. (1/Q) #{j : u_j < rho(L)} for L <= D and exactly 1 for L > D (a miss
# included): |rho_Q(L) - rho_D(L)| <= 1 / (2Q) for every ray, hence for
# every point's AO (before the backend's own errors on the V_t).
def check_ao_options(obscurance, quadrature, straddle):
    """Validate the options of distance AO; returns ``(tau or None, Q, straddle)``.

    Parameters
    ----------
    obscurance : None or float
        ``tau`` of rho(L) = 1 - exp(-tau L), 1 / world units, finite and > 0.
    quadrature : int
        Nodes Q of the CSM's quadrature, 1 .. 256.
    straddle : {'error', 'embree', 'infinite'}
    """
    tau = None
    if obscurance is not None:
        try:
            if isinstance(obscurance, (bool, np.bool_, str, bytes)) or np.iscomplexobj(obscurance):
                raise TypeError         # True (tau 1), "2", 2+1j (tau 2, its imaginary part dropped): not rates
            tau = float(obscurance)
        except (TypeError, ValueError):
            raise TypeError(f"obscurance must be a number (tau, 1 / world units), got {obscurance!r}") from None
        except OverflowError:   # an int beyond float64 (10**400)
            raise ValueError("obscurance (tau) must be finite and > 0, got an int beyond float64's range") from None
        if not (np.isfinite(tau) and tau > 0):
            raise ValueError(f"obscurance (tau) must be finite and > 0, got {tau}")
    if isinstance(quadrature, bool) or not isinstance(quadrature, (int, np.integer)) or not 1 <= quadrature <= 256:
        raise ValueError(f"quadrature must be an int in 1..256, got {quadrature!r}")
    if not isinstance(straddle, str) or straddle not in AO_STRADDLE:
        raise ValueError(f"straddle must be one of {AO_STRADDLE}, got {straddle!r}")
    return tau, int(quadrature), straddle


def ao_nodes(tmax, tau, quadrature: int) -> np.ndarray:
    """The lengths ``t_j`` at which each point's rays are asked, (N, Q) float64 ascending.

    ``tau`` None (distance-limited): one node, ``tmax``. Else the Q nodes
    ``min(-log(1 - u_j) / tau, tmax)``, ``u_j = (j - 1/2) / Q``.
    """
    tmax = np.asarray(tmax, np.float64)
    if tau is None:
        return tmax[:, None].copy()
    u = (np.arange(quadrature) + 0.5) / quadrature
    with np.errstate(over="ignore"):        # tau below ~1e-308: nodes beyond float64 are unbounded (inf)
        return np.minimum(-np.log1p(-u)[None, :] / tau, tmax[:, None])


def obscurance_weight(L, tmax, tau) -> np.ndarray:
    """rho_D of first-hit distances ``L`` (inf: miss), float64: exact, for ray tracers."""
    L = np.asarray(L, np.float64)
    tmax = np.broadcast_to(np.asarray(tmax, np.float64), L.shape)
    beyond = (L > tmax) | np.isposinf(L)           # a miss counts as beyond
    if tau is None:
        return beyond.astype(np.float64)
    with np.errstate(over="ignore", invalid="ignore"):
        w = -np.expm1(-tau * np.where(np.isfinite(L), L, 0.0))
    return np.where(beyond, 1.0, w)


def shell_clear(scene, points, tmax) -> np.ndarray:
    """Points none of whose rays of length ``tmax`` can end inside a caster's bounding sphere.

    The ends ``p + t w`` lie on the sphere of radius ``t`` about ``p``; it
    meets the bounding sphere ``(c, r)`` only where ``| |p - c| - t | <= r``.
    (N,) bool; O(N x casters).
    """
    arr = scene_arrays(scene)
    casters = np.flatnonzero(arr["casts"])
    p = np.asarray(points, np.float64)
    t = np.asarray(tmax, np.float64)
    ok = np.ones(len(p), bool)
    fin = np.isfinite(t)
    for k in casters:
        r = arr["world_radius"][k] * (1 + 1e-6)
        d = np.linalg.norm(p - arr["world_centre"][k], axis=1)
        with np.errstate(invalid="ignore"):
            ok &= ~fin | (np.abs(d - t) > r * (1 + 1e-9) + 1e-12)
    return ok


def answer_finite_ao(scene, points, directions, tmax, straddle, answer, name=None, casters=None) -> np.ndarray:
    """Finite AO rays by a CSM backend: ``answer(rows, lengths)`` -> (K,) bool for the rows it is given.

    Rays that do not straddle (:func:`straddling`) are answered at their
    length. A straddling ray is first asked unbounded: where that ray is
    free, so is every part of it (exact). Only a straddling ray the CSM finds
    occluded unbounded is undecided -- the occluder may lie beyond the end;
    ``straddle`` then says: ``'error'`` raise a ``ValueError`` naming the
    instance, ``'embree'`` trace those rays with Embree (exact; needs the
    meshes), ``'infinite'`` keep the unbounded answer (occluded: AO too dark
    by the occluders met beyond the end, never too bright). The ground plane
    is decided exactly (:func:`ground_blocks`): a straddling ray it blocks
    within its length is occluded; one it blocks only beyond its end (one
    that ends short of the plane it heads for) is asked ``casters``, but
    with ``'embree'``, which traces it as before. (Before, the plane left
    such a ray undecided: a box resting on the ground read AO 0.5 on its
    sides with ``'infinite'``, where 1.0 is right, and ``'error'`` refused.)

    Parameters
    ----------
    scene : pyshadow.Scene
    points, directions : ndarray, shape (N, 3), float64
        World origins and unit directions.
    tmax : ndarray, shape (N,)
        Validated lengths.
    straddle : {'error', 'embree', 'infinite'}
    answer : callable
    name : callable, optional
        ``name(i)``: how the ``'error'`` message names ray ``i`` to the
        caller (default ``"AO ray i"``).
    casters : callable, optional
        ``casters(rows)`` -> (K,) bool, the backend's unbounded answer for
        the rays ``rows`` without the ground plane (default: none, such rays
        stay undecided).

    Returns
    -------
    ndarray, shape (N,), bool
        True where the ray is free up to its length.
    """
    n = len(points)
    vis = np.empty(n, bool)
    rows, inst = straddling(scene, points, directions, tmax)
    clean = np.ones(n, bool)
    clean[rows] = False
    sel = np.flatnonzero(clean)
    if len(sel):
        vis[sel] = answer(sel, tmax[sel])
    if not len(rows):
        return vis
    vis[rows] = answer(rows, np.full(len(rows), np.inf))
    if scene.ground is not None:
        from ..contact import ground_tolerance

        h, wy = points[rows, 1] - scene.ground, directions[rows, 1]
        eps, off = ground_tolerance(scene), ground_offsets(scene, points[rows])
        hit = ground_blocks(h, wy, tmax[rows], eps, off)      # within the length: occluded, exactly
        beyond = ground_blocks(h, wy, None, eps) & ~hit       # only beyond the end: the casters decide
        vis[rows[hit]] = False
        if casters is not None and straddle != "embree" and beyond.any():     # ('embree': traced, exact)
            vis[rows[beyond]] = casters(rows[beyond])
        done = vis[rows] | hit
    else:
        done = vis[rows]
    amb, owner = rows[~done], inst[~done]
    if not len(amb) or straddle == "infinite":
        return vis
    meshes = all(scene.instances[i].mesh is not None for i in np.flatnonzero(scene_arrays(scene)["casts"]))
    if straddle == "error" or not meshes:
        i, j = int(amb[0]), int(owner[0])
        c, r = scene.instances[j].world_sphere()
        why = ("pass straddle='embree' (ray tracing) or 'infinite' (the unbounded answer)"
               if straddle == "error" else "straddle='embree' needs every caster's mesh (Scene.add(csm, mesh=...))")
        raise ValueError(f"{name(i) if name else f'AO ray {i}'} (and {len(amb) - 1} more) of length "
                         f"{float(tmax[i]):.6g} ends inside the bounding sphere of caster instance {j} "
                         f"(centre {np.round(np.asarray(c), 6).tolist()}, "
                         f"radius {float(r):.6g}) and is occluded unbounded: a CSM cannot tell whether the "
                         f"occluder lies before or beyond the end; {why}")
    from .. import embree

    vis[amb] = embree.visible(scene, points[amb], directions[amb], max_distance=tmax[amb])
    return vis


def rays_ao(scene, points, normals, directions, nodes, straddle, answer, point_ids=None, casters=None):
    """Per-sample weights rho_Q of distance AO from finite visibility queries.

    Parameters
    ----------
    scene : pyshadow.Scene
    points, normals : ndarray, shape (N, 3), float64
    directions : ndarray, shape (N, S, 3)
        The sample directions of each point.
    nodes : ndarray, shape (N, Q)
        :func:`ao_nodes`.
    straddle : {'error', 'embree', 'infinite'}
    answer : callable
        ``answer(rows, lengths)``: the backend's finite visibility of the
        flattened rays ``rows`` (point-major, ``i * S + s``), (K,) bool.
    point_ids : ndarray, shape (N,), optional
        The caller's index of each point, for the ``'error'`` message
        (default ``0 .. N-1``).
    casters : callable, optional
        ``casters(rows)``: the unbounded visibility of the flattened rays
        ``rows`` without the ground plane (:func:`answer_finite_ao`).

    Returns
    -------
    ndarray, shape (N, S), float64
        ``(1/Q) sum_j V_{t_j}`` per sample.
    """
    N, S = directions.shape[:2]
    Q = nodes.shape[1]
    P = np.repeat(np.asarray(points, np.float64), S, axis=0)
    W = unit_directions(directions.reshape(-1, 3))
    weight = np.zeros(N * S)
    vis = prev = None

    def name(i):
        return f"AO sample {i % S} of point {i // S if point_ids is None else int(point_ids[i // S])}"

    for j in range(Q):
        t = np.repeat(nodes[:, j], S)
        if vis is None or not np.array_equal(t, prev):      # equal lengths: the same answers
            vis, prev = answer_finite_ao(scene, P, W, t, straddle, answer, name, casters), t
        weight += vis
    return (weight / Q).reshape(N, S)

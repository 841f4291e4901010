"""AO at the concave corners and edges of a mesh, for :meth:`pyshadow.Scene.vertex_ao`.

A vertex where faces meet in a concave corner or edge (the inside of an L,
the corner of a room) lies on several of its own faces at once. A sample
direction that enters one of them at the vertex is blocked at distance 0,
but the CSM does not see it: the point lies on that face's far side (where
the ray leaves the solid), where the stored depth of a CSM segment may lie
anywhere between the layer's entry and exit, and the own-surface bias of a
texel or two covers the rest (:mod:`pyshadow.csm.surface_rule`). A corner
looks the same at every scale, so the error does not shrink with the
resolution: a cube with one octant removed read 0.77-0.81 at its concave
corner from 32^2 to 256^2 maps, against Embree's 0.42; the inside of a closed
box 0.34-0.47 where Embree reads 0.

The star of such a vertex settles those directions exactly. Where every
neighbour of the vertex lies on or in front of every face plane of its
closed fan (a concave corner or edge; not flat, convex or a saddle), the
open side of the fan is the convex cone ``C = {x : f_i . (x - o) >= 0}``
(``f_i`` the unit normals of the fan's faces, ``o`` the vertex), and a ray
from ``o`` in direction ``w`` enters the solid at once exactly when
``f_i . w < 0`` for some ``i``. Those samples are blocked; the others (which
leave ``o`` into ``C``, where every face of the fan faces them) keep the
CSM's answer, asked per sample with :meth:`pyshadow.Scene.visible` and the
same directions as the AO kernels (:func:`pyshadow.sampling.sample_directions`).
"""
from __future__ import annotations

import numpy as np

from ._validate import check_values, squared_lengths
from .mesh_kept import MeshKept

__all__ = ["concave_vertices", "corner_ao"]

#: a neighbour behind a face plane by more than this fraction of its
#: distance makes the vertex convex or a saddle; one above it by more makes
#: it not flat
FLAT_TOL = 1e-6

#: neighbours x faces held at once while the stars are tested
_BLOCK_ELEMENTS = 2_000_000

# mesh -> its concave vertices and their faces (_mesh_stars); a mesh changed in place misses (and is replaced)
_STARS = MeshKept()


def concave_vertices(points, faces):
    """The concave vertices of a mesh and the unit normals of the faces around each.

    Parameters
    ----------
    points : array_like, shape (V, 3), float64
        Vertex positions (any frame).
    faces : array_like, shape (F, 3), int
        Triangles, counter-clockwise seen from the front (outward normals).

    Returns
    -------
    index : ndarray, shape (n,), int64
        The concave vertices: those whose faces (every face at the same
        position: vertices split at creases share one star) form a closed
        fan (each edge at the vertex shared by exactly two faces) with every
        neighbour on or in front of every face plane (within
        :data:`FLAT_TOL` of its distance), and not all flat. Zero-area faces
        (a corner within :data:`FLAT_TOL` of the longest edge from the line
        of the other two) have no plane: with three distinct positions (a
        sliver closing a T-junction) they still close the fan, else they are
        left out.
    normals : ndarray, shape (n, M, 3), float64
        Unit normals of the faces around each, padded with zero rows.

    Raises
    ------
    ValueError
        Arrays not of shape (n, 3), points not finite, or a vertex index
        outside ``[0, V)``.
    TypeError
        Points that are not real numbers, or faces that are not integers.
    """
    P = _rows(points, "points", "fiu").astype(np.float64)
    check_values(P, "points")                   # a NaN corner's faces were left out: 2 of a room's 8 corners found
    F = _rows(faces, "faces", "iu").astype(np.int64)
    if F.size and (F.min() < 0 or F.max() >= len(P)):         # a negative index read a vertex from the end
        raise ValueError(f"faces: vertex indices must be in [0, {len(P)}) (got {F.min()} to {F.max()})")
    index, ids = _concave_stars(P, F)
    return index, _star_normals(P, F, ids)


def _rows(a, name: str, kinds: str) -> np.ndarray:
    """``a`` as an (n, 3) array of a dtype kind in ``kinds`` (any when empty), or a ValueError/TypeError
    naming it: a reshape to (n, 3) read quads (F, 4) as other triangles (a room's corners: none found) and
    (V, 2) points as other points, silently, and truncated float indices."""
    a = np.asarray(a)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name} must have shape (n, 3), got {a.shape}")
    if a.size and a.dtype.kind not in kinds:
        raise TypeError(f"{name} must be {'integers' if kinds == 'iu' else 'real numbers'}, got dtype {a.dtype}")
    return a


def _star_normals(P, F, ids):
    """Unit normals (n, M, 3) of the faces ``ids`` (n, M) of ``F`` (-1: padding, a zero row), from ``P``."""
    out = np.zeros(ids.shape + (3,))
    used = ids >= 0
    u = ids[used]
    c = np.cross(P[F[u, 1]] - P[F[u, 0]], P[F[u, 2]] - P[F[u, 0]])
    out[used] = c / np.linalg.norm(c, axis=1)[:, None]
    return out


def _concave_stars(P, F):
    """:func:`concave_vertices`' vertices (n,) and the faces of ``F`` around each (n, M), padded with -1."""
    none = (np.zeros(0, np.int64), np.full((0, 1), -1, np.int64))
    if not len(P) or not len(F):
        return none
    _, key = np.unique(P, axis=0, return_inverse=True)
    key = key.reshape(-1)
    K = int(key.max()) + 1
    fn = np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]])
    area = np.linalg.norm(fn, axis=1)
    # a face with a corner within FLAT_TOL of its longest edge from the line of the other two has no plane
    # (a zero area rounds to any normal); with three distinct positions (a sliver closing a T-junction) it
    # still closes the fans of its corners (left out, a notch's corner there read 0.81 for Embree's 0.42)
    flat = ~(area > FLAT_TOL * squared_lengths(P[F] - P[F[:, [1, 2, 0]]]).max(axis=1))
    kf = key[F]
    sliver = flat & (kf[:, 0] != kf[:, 1]) & (kf[:, 1] != kf[:, 2]) & (kf[:, 2] != kf[:, 0])
    kept = np.flatnonzero(~flat)                            # the faces with a plane, by their index in F
    closing = np.vstack([F[kept], F[sliver]])               # the faces that close fans: row i < len(kept) is kept[i]
    F, fn, kf = F[kept], fn[kept] / area[kept, None], kf[kept]
    if not len(F):
        return none
    cand = _candidates(P, closing, key[closing], np.vstack([fn, np.zeros((len(closing) - len(F), 3))]), K)
    if not len(cand):
        return none
    # the star of each candidate: its faces, padded with -1
    corner = np.unique(kf.reshape(-1) * len(F) + np.repeat(np.arange(len(F)), 3))   # a face once per position
    ck, fi = corner // len(F), corner % len(F)
    at = np.full(K, -1)
    at[cand] = np.arange(len(cand))
    keep = at[ck] >= 0
    ck, fi = at[ck[keep]], fi[keep]
    sizes = np.bincount(ck, minlength=len(cand))
    star = np.full((len(cand), int(sizes.max())), -1, np.int64)
    star[ck, np.arange(len(ck)) - np.r_[0, np.cumsum(sizes)[:-1]][ck]] = fi
    fn = np.vstack([fn, np.zeros(3)])                   # row -1: the padding of a star, no face
    origin = np.zeros((K, 3))
    origin[key] = P
    origin = origin[cand]
    concave = np.zeros(len(cand), bool)
    block = max(1, _BLOCK_ELEMENTS // (3 * star.shape[1] ** 2))
    for a in range(0, len(cand), block):
        s = star[a:a + block]
        nb = F[s].reshape(len(s), -1)                   # the star's corners (the padding's: masked below)
        rel = np.where(np.repeat(s >= 0, 3, axis=1)[:, :, None], P[nb] - origin[a:a + block, None], 0.0)
        h = np.einsum("bmd,bqd->bmq", fn[s], rel)       # height of each corner over each face plane
        tol = FLAT_TOL * np.linalg.norm(rel, axis=2)[:, None, :]
        concave[a:a + block] = (h >= -tol).all(axis=(1, 2))
    at[cand[~concave]] = -1
    index = np.flatnonzero(at[key] >= 0)
    star = star[at[key[index]]]
    return index, np.where(star >= 0, kept[star], -1)


def _mesh_stars(mesh):
    """:func:`_concave_stars` of ``mesh`` in its own frame, kept with it (a rigid placement with a uniform
    scale keeps which vertices are concave and their faces; :meth:`pyshadow.Scene.vertex_ao` asks it of
    every instance every call, where the search cost about 3 times the AO of the bunny's vertices)."""
    held = _STARS.get(mesh)
    if held is None:
        held = _STARS[mesh] = _concave_stars(np.asarray(mesh.vertices, np.float64).reshape(-1, 3),
                                             np.asarray(mesh.faces, np.int64).reshape(-1, 3))
    return held


def _candidates(P, F, kf, fn, K):
    """Positions (of ``K``) whose fan is closed, with no convex edge and a concave one: (n,) int64, sorted.

    ``F`` (F, 3) are the faces that close fans, ``kf`` their corners' position keys, ``fn`` (F, 3) their
    unit normals (zero rows: slivers, without a plane, neither convex nor concave). An edge is convex
    (concave) where the far corner of one of its two faces lies behind (in front of) the other's plane by
    more than :data:`FLAT_TOL` of its distance.
    """
    ends = np.concatenate([kf[:, [0, 1]], kf[:, [1, 2]], kf[:, [2, 0]]])
    far = np.concatenate([F[:, 2], F[:, 0], F[:, 1]])           # the corner opposite each edge
    face = np.tile(np.arange(len(F)), 3)
    ends = np.sort(ends, axis=1)
    real = ends[:, 0] != ends[:, 1]
    ends, far, face = ends[real], far[real], face[real]
    pid = ends[:, 0] * K + ends[:, 1]
    order = np.argsort(pid, kind="stable")
    pid, ends, far, face = pid[order], ends[order], far[order], face[order]
    pair, first, count = np.unique(pid, return_index=True, return_counts=True)
    ok = np.ones(K, bool)
    ok[pair[count != 2] // K] = False                            # an open or non-manifold fan
    ok[pair[count != 2] % K] = False
    a = first[count == 2]
    b = a + 1
    rel = np.stack([P[far[b]] - P[F[face[a], 0]], P[far[a]] - P[F[face[b], 0]]])      # (2, E, 3)
    h = np.stack([np.einsum("id,id->i", fn[face[a]], rel[0]), np.einsum("id,id->i", fn[face[b]], rel[1])])
    tol = FLAT_TOL * np.linalg.norm(rel, axis=2)
    ok[ends[a][(h < -tol).any(axis=0)].reshape(-1)] = False
    bent = np.zeros(K, bool)
    bent[ends[a][(h > tol).any(axis=0)].reshape(-1)] = True
    return np.flatnonzero(ok & bent)


def corner_ao(scene, instance_id, points, normals, sampling, result, backend, bias=None):
    """:meth:`pyshadow.Scene.vertex_ao` with the samples that enter a concave vertex's own faces blocked.

    Parameters
    ----------
    scene : pyshadow.Scene
    instance_id : int
    points, normals : ndarray, shape (V, 3), float64
        World vertex positions and the unit normals AO was asked with.
    sampling : pyshadow.Sampling
        The sampling AO was asked with (pattern index = vertex index).
    result : ndarray or tuple
        What ``Scene.ambient_occlusion`` answered: AO ``(V,)`` float32, or
        ``(ao, bent)`` with bent normals ``(V, 3)``.
    backend : str or object
        The backend asked: only the CSM backends (``"csm"``, ``"csm-vote"``)
        are corrected, and only for an instance that casts.
    bias : float, optional
        As in :meth:`pyshadow.Scene.visible`.

    Returns
    -------
    ndarray or tuple
        ``result`` with the rows of concave vertices (:func:`concave_vertices`)
        where any sample enters one of their faces recomputed.
    """
    from .sampling import ao_from_samples, sample_directions

    inst = scene.instances[int(instance_id)]
    if inst.csm is None or not inst.casts or not (isinstance(backend, str) and backend in ("csm", "csm-vote")):
        return result
    sel, ids = _mesh_stars(inst.mesh)
    if not len(sel):
        return result
    fs = _star_normals(points, np.asarray(inst.mesh.faces, np.int64).reshape(-1, 3), ids)   # world frame
    d = sample_directions(normals[sel], sampling=sampling, indices=sel).astype(np.float64)    # (n, S, 3)
    into = (np.einsum("nsd,nmd->nsm", d, fs) < 0).any(axis=2)          # enters a face of the vertex at once
    hit = into.any(axis=1)
    sel, d, into = sel[hit], d[hit], into[hit]
    if not len(sel):
        return result
    S = d.shape[1]
    seen = scene.visible(np.repeat(points[sel], S, axis=0), d.reshape(-1, 3), surface_ids=int(instance_id),
                         lookup="vote" if backend == "csm-vote" else "nearest", bias=bias,
                         normals=np.repeat(normals[sel], S, axis=0))
    bent = isinstance(result, tuple)
    out = ao_from_samples(d, seen.reshape(len(sel), S) & ~into, normals[sel], return_bent_normals=bent)
    if not bent:
        ao = result.copy()
        ao[sel] = out
        return ao
    ao, b = result[0].copy(), result[1].copy()
    ao[sel], b[sel] = out
    return ao, b

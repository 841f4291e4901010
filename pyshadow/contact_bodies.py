"""Bodies resting on bodies (:mod:`pyshadow.contact`): a point on a closed caster's face that touches another body's
face, away from the touching region's outline, is closed in: occluded on every ray into the body, AO 0 where its
normal faces into it (a lower box's lid under an upper box). The touching faces are found once per scene change
(:func:`body_patches`: faces of two bodies making more than ``_PAIRS`` pairs pass through each other, not
searched; each closed part's winding turned by its volume's sign: inverted meshes, cavities), the points on them
per query (:func:`body_hits`).
"""
from __future__ import annotations

import weakref

import numpy as np

from ._validate import float32_exact
from .contact import _CHUNK, _SURFACES, _closed_surface, _edges, _face_tolerances, _far_from, _in_chunks
from .scene_arrays import scene_arrays

__all__ = ["FACING", "body_patches", "body_hits"]

FACING = 1.0 - 1e-6        # a normal (or ray) this close (cosine) to a contact face's inward normal faces into it
_ORIENTED = weakref.WeakKeyDictionary()         # mesh -> _outward(mesh)
_PAIRS = 1 << 18            # face pairs of two bodies compared at most (about 10 ms; two boxes: 144)


def _cross(a, b):
    """``np.cross`` along the last axis, without its per-call cost (small arrays, many calls)."""
    return a[..., [1, 2, 0]] * b[..., [2, 0, 1]] - a[..., [2, 0, 1]] * b[..., [1, 2, 0]]


def _outward(mesh):
    """The closed surface's distinct vertices (U, 3) and its faces (F, 3) wound so that their normals point
    out of the part they bound (each part, faces joined by edges, turned by its volume's sign: a ray into
    a part meets it again, in a cavity too), or None: the surface is open, or its winding inconsistent
    (an edge run the same way by both its faces). Found once per mesh (:data:`_ORIENTED`)."""
    if mesh in _ORIENTED or _closed_surface(mesh) is None:
        return _ORIENTED.get(mesh)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    u, _, wf = _SURFACES[mesh]
    got = None
    d = np.concatenate([wf[:, [0, 1]], wf[:, [1, 2]], wf[:, [2, 0]]])
    if len(np.unique(d, axis=0)) == len(d):
        _, edge = np.unique(np.sort(d, axis=1), axis=0, return_inverse=True)       # each edge: two faces
        pair = np.tile(np.arange(len(wf)), 3)[np.argsort(edge.ravel(), kind="stable")].reshape(-1, 2)
        k, label = connected_components(coo_matrix((np.ones(len(pair)), tuple(pair.T)), shape=(len(wf),) * 2))
        c = u - u.mean(axis=0)
        vol = np.bincount(label, np.einsum("ij,ij->i", c[wf[:, 0]], _cross(c[wf[:, 1]], c[wf[:, 2]])), k)
        if (np.abs(vol) > 1e-12 * np.ptp(c, axis=0).max() ** 3).all():        # else a part encloses nothing
            got = u, np.where((vol[label] > 0)[:, None], wf, wf[:, ::-1])
    _ORIENTED[mesh] = got
    return got


def _unit_normals(tri):
    """(K, 3) unit normals of triangles (K, 3, 3) by their winding (0 for a degenerate one)."""
    n = _cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)


def _touching(b, a, tol):
    """(K,) bool: which of body B's outward faces lie within ``tol`` of the plane of one of body A's faces
    facing them (opposite normals; either way where A's are not known outwards) and overlap it in that
    plane by more than ``tol`` (the lids of two boxes side by side do not touch). ``b``, ``a``: world faces
    (K, 3, 3), their unit normals (K, 3) and whether they are wound outwards (:func:`body_patches`)."""
    (tri_b, n_b, _, b_lo, b_hi), (tri_a, n_a, oriented, a_lo, a_hi) = b, a     # with each face's box
    out = np.zeros(len(tri_b), bool)
    near = np.flatnonzero(((b_hi >= a_lo.min(axis=0) - tol) & (b_lo <= a_hi.max(axis=0) + tol)).all(axis=1))
    if not len(near):
        return out
    keep = ((a_hi >= b_lo[near].min(axis=0) - tol) & (a_lo <= b_hi[near].max(axis=0) + tol)).all(axis=1)
    tri_a, n_a = tri_a[keep], n_a[keep]
    if len(near) * len(tri_a) > _PAIRS:
        return out                  # faces deep in each other's box: bodies that pass through, not resting
    step = max(1, _CHUNK // max(3 * len(tri_a), 1))
    for s in range(0, len(near), step):
        k = near[s:s + step]
        off = np.einsum("kvj,mj->kmv", tri_b[k], n_a) - np.einsum("mj,mj->m", tri_a[:, 0], n_a)[None, :, None]
        cos = n_b[k] @ n_a.T
        ok = (np.abs(off) <= tol).all(axis=2) & ((-cos if oriented else np.abs(cos)) >= FACING)
        e1 = tri_b[k, 1] - tri_b[k, 0]
        e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
        for e in (e1, _cross(n_b[k], e1)):              # the faces' extents along two axes of B's face
            pb, pa = np.einsum("kvj,kj->kv", tri_b[k], e), np.einsum("mvj,kj->kmv", tri_a, e)
            ok &= np.minimum(pb.max(axis=1)[:, None], pa.max(axis=2)) - np.maximum(pb.min(axis=1)[:, None],
                                                                                    pa.min(axis=2)) > tol
        out[k] = ok.any(axis=1)
    return out


def body_patches(scene):
    """Per plane of a closed caster's faces touching another body (both with meshes; a receiver too): (inward unit
    normal (3,), offset ``n . x``, tolerance, 3D box (2, 3), plane basis (2, 3), faces in it (K, 3, 2) and the
    outline of their union (E, 2, 2)); kept with the scene's arrays. Ground contacts: :func:`footprints`."""
    held = scene_arrays(scene)
    if "bodies" in held:
        return held["bodies"]
    out = []                    # stored when complete: another thread's query reads all of it or none
    ids = [i for i, s in enumerate(scene.instances) if s.mesh is not None and len(s.mesh.faces)]
    if len(ids) < 2:
        held["bodies"] = out
        return out
    from scipy.spatial import cKDTree

    c, r, tol = held["world_centre"][ids], held["world_radius"][ids], _face_tolerances(held)[ids]
    # each pair from its larger sphere, within twice its radius (the largest's radius for all: N^2 pairs by a floor)
    near = cKDTree(c).query_ball_point(c, 2 * (r + tol.max()), return_sorted=False)
    i = np.repeat(np.arange(len(ids)), [len(x) for x in near])
    j = np.concatenate(near).astype(np.intp) if len(i) else i
    keep = (r[j] < r[i]) | ((r[j] == r[i]) & (j < i))
    pairs = np.stack([i[keep], j[keep]], axis=1)
    pairs = pairs[np.linalg.norm(c[pairs[:, 0]] - c[pairs[:, 1]], axis=1) <= (r + tol)[pairs].sum(axis=1)]
    world = {}

    def body(i):
        """Instance ``ids[i]``'s world vertices (U, 3) and faces (F, 3) (wound outwards where closed), its
        faces (F, 3, 3), their unit normals and whether they are outwards, and its world box (2, 3)."""
        if i not in world:
            inst = scene.instances[ids[i]]
            got = _outward(inst.mesh)
            v, f = got if got is not None else (np.asarray(inst.mesh.vertices, np.float64), np.asarray(inst.mesh.faces))
            v = v @ inst.transform[:3, :3].T + inst.transform[:3, 3]
            world[i] = v, f, (v[f], _unit_normals(v[f]), got is not None, v[f].min(axis=1), v[f].max(axis=1)), \
                np.array([v.min(axis=0), v.max(axis=0)])
        return world[i]

    touched = {}
    for b, a in np.concatenate([pairs, pairs[:, ::-1]]):
        if not scene.instances[ids[b]].casts:
            continue                                    # a receiver closes nothing in
        (B, A), t = (body(b), body(a)), tol[a] + tol[b]
        if B[2][2] and (B[3][0] <= A[3][1] + t).all() and (A[3][0] <= B[3][1] + t).all():      # boxes meet
            touched[b] = touched.get(b, np.zeros(len(B[1]), bool)) | _touching(B[2], A[2], tol[b])
    for b, hit in touched.items():
        v, wf, (tri_b, n_b, *_), _ = body(b)
        while hit.any():                                # one plane at a time
            n = -n_b[np.flatnonzero(hit)[0]]
            d = float(tri_b[hit][0, 0] @ n)
            same = hit & (-n_b @ n >= FACING) & (np.abs(tri_b @ n - d) <= tol[b]).all(axis=1)
            hit &= ~same
            e1 = _cross(n, np.eye(3)[np.argmin(np.abs(n))])
            basis = np.array([e1 / np.linalg.norm(e1), _cross(n, e1 / np.linalg.norm(e1))])
            edges, count = _edges(np.sort(wf[same], axis=1))
            flat, box = v @ basis.T, np.array([tri_b[same].min(axis=(0, 1)), tri_b[same].max(axis=(0, 1))])
            out.append((n, d, float(tol[b]), box, basis, flat[wf[same]], flat[edges[count == 1]]))
    held["bodies"] = out
    return out


def body_hits(scene, points):
    """``[(rows, inward unit normal (3,))]``: per contact patch (:func:`body_patches`), the points lying on it
    farther than its tolerance from its outline (a point between two bodies lies on a patch of each)."""
    patches = body_patches(scene) if len(points) and scene.instances else []
    if not patches:
        return []
    p = np.asarray(points, np.float64)
    big = np.abs(p).max(axis=1)
    # float32 points of a plane far from the origin lie off it by up to their rounding
    rounding = np.where(float32_exact(p).all(axis=1), np.spacing(big.astype(np.float32)).astype(np.float64),
                        np.spacing(big))
    normal, offset, tol, lo, hi = _patch_arrays(patches)
    # the candidates of each patch by sorting, along the axis whose slab of its grown box holds the fewest points
    # (not its thin axis: a floor's points lie in its plane)
    order, grow = np.argsort(p, axis=0, kind="stable"), tol + rounding.max()
    ends = np.stack([[np.searchsorted(p[order[:, j], j], lo[:, j] - grow),
                      np.searchsorted(p[order[:, j], j], hi[:, j] + grow, side="right")] for j in range(3)], axis=2)
    slab = np.argmin(ends[1] - ends[0], axis=1)
    a, b = ends[:, np.arange(len(patches)), slab]
    pid = np.repeat(np.arange(len(patches)), b - a)             # (patch, point) candidate pairs, by patch
    rows = order[np.arange(len(pid)) + np.repeat(a - (np.cumsum(b - a) - (b - a)), b - a), slab[pid]]
    g = (tol[pid] + rounding[rows])[:, None]                     # within the patch's box and its plane
    ok = np.all((p[rows] >= lo[pid] - g) & (p[rows] <= hi[pid] + g), axis=1)
    ok[ok] = np.abs(np.einsum("ij,ij->i", p[rows[ok]], normal[pid[ok]]) - offset[pid[ok]]) <= \
        np.maximum(tol[pid[ok]], rounding[rows[ok]])
    pid, rows = pid[ok], rows[ok]
    out = []
    for i, k in zip(*_groups(pid, rows)):                      # the patches with points on them
        n, _, t, _, basis, flat, seg = patches[i]
        q = p[k] @ basis.T
        for j, hit in _in_chunks(q, flat, len(seg)):
            if hit.any():
                hit[hit] = _far_from(q[j][hit], seg, t)
            out.append((k[j[hit]], n))
    return out


def _patch_arrays(patches):
    """The patches' inward normals (P, 3), plane offsets (P,), tolerances (P,) and boxes' corners (P, 3) x 2."""
    box = np.array([x[3] for x in patches])
    return (np.array([x[0] for x in patches]), np.array([x[1] for x in patches]), np.array([x[2] for x in patches]),
            box[:, 0], box[:, 1])


def _groups(pid, rows):
    """(patch numbers, [rows of each]) of the pairs ``pid``, ``rows`` sorted by patch."""
    cut = np.flatnonzero(np.diff(pid)) + 1
    return pid[np.r_[0, cut]] if len(pid) else pid, np.split(rows, cut) if len(pid) else []

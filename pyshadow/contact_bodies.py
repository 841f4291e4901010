"""Bodies resting on bodies (:mod:`pyshadow.contact`): a point on a closed caster's face that touches another body's
face, away from the touching region's outline, is closed in: occluded on every ray into the body, AO 0 where its
normal faces into it (a lower box's lid under an upper box). The touching faces are found once per scene change,
for the bodies that moved and their neighbours (:func:`body_patches`: the faces of two bodies near each other
compared pair by pair, or where they make more
than ``_PAIRS`` pairs, those whose boxes meet, found among at most ``_PAIRS`` candidates; beyond, as bodies passing
through each other, not searched (nor is a column of 3,000 sides standing on a terrain of 0.1 m cells); each closed
part's winding turned by its volume's sign: inverted meshes, cavities), the points on them per query
(:func:`body_hits`).
"""
from __future__ import annotations

import weakref
from collections import namedtuple

import numpy as np

from ._validate import float32_exact
from .contact import _SURFACES, _closed_surface, _face_tolerances
from .contact_parts import _expanded, _in_parts, _kept_parts, _outlines, _ragged, _slab_pairs
from .mesh_kept import MeshKept
from .scene_arrays import mesh_groups, scene_arrays

__all__ = ["FACING", "body_patches", "body_hits"]

FACING = 1.0 - 1e-6        # a normal (or ray) this close (cosine) to a contact face's inward normal faces into it
_ORIENTED = MeshKept()         # mesh -> _outward(mesh)
_PAIRS = 1 << 18            # face pairs of two bodies compared at most (about 10 ms; two boxes: 144)


def _cross(a, b):
    """``np.cross`` along the last axis, without its per-call cost (small arrays, many calls)."""
    return a[..., [1, 2, 0]] * b[..., [2, 0, 1]] - a[..., [2, 0, 1]] * b[..., [1, 2, 0]]


def _outward(mesh):
    """The closed surface's distinct vertices (U, 3) and its faces (F, 3) wound so that their normals point
    out of the part they bound (each part, faces joined by edges, wound as one (:func:`_consistent`) and
    turned by its volume's sign: a ray into a part meets it again, in a cavity too), or None: the surface is
    open, or no winding is consistent. Found once per mesh (:data:`_ORIENTED`)."""
    if mesh in _ORIENTED or _closed_surface(mesh) is None:
        return _ORIENTED.get(mesh)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    u, _, wf, _ = _SURFACES[mesh]
    got = None
    d = np.concatenate([wf[:, [0, 1]], wf[:, [1, 2]], wf[:, [2, 0]]])
    if len(np.unique(d, axis=0)) != len(d):             # an edge run the same way by both its faces
        wf = _consistent(wf, d)
    if wf is not None:
        _, edge = np.unique(np.sort(d, axis=1), axis=0, return_inverse=True)       # each edge: two faces
        pair = np.tile(np.arange(len(wf)), 3)[np.argsort(edge.ravel(), kind="stable")].reshape(-1, 2)
        k, label = connected_components(coo_matrix((np.ones(len(pair)), tuple(pair.T)), shape=(len(wf),) * 2))
        c = u - u.mean(axis=0)
        vol = np.bincount(label, np.einsum("ij,ij->i", c[wf[:, 0]], _cross(c[wf[:, 1]], c[wf[:, 2]])), k)
        if (np.abs(vol) > 1e-12 * np.ptp(c, axis=0).max() ** 3).all():        # else a part encloses nothing
            got = u, np.where((vol[label] > 0)[:, None], wf, wf[:, ::-1])
    _ORIENTED[mesh] = got
    return got


def _consistent(wf, d):
    """The faces ``wf`` (F, 3) of a closed surface (each edge shared by two; ``d``: their directed edges, the
    first of every face, then the second, then the third) with faces turned so that the two faces of each
    edge run it in opposite directions, or None where no turning does (a surface without sides). A closed
    box with one face turned (an asset's flipped triangle) had no winding out of it: a box resting on
    another, so wound, left the top under it open (AO up to 0.59 at its edge, Embree 0)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    _, edge = np.unique(np.sort(d, axis=1), axis=0, return_inverse=True)
    o = np.argsort(edge.ravel(), kind="stable")
    f = np.tile(np.arange(len(wf)), 3)[o].reshape(-1, 2)                   # each edge's two faces
    turn = (d[o, 0].reshape(-1, 2)[:, 0] == d[o, 0].reshape(-1, 2)[:, 1]).astype(np.intp)  # the same way
    # face i as wound: state 2i, turned: 2i + 1; an edge joins its faces' states that agree on it
    a = np.concatenate([2 * f[:, 0], 2 * f[:, 0] + 1])
    b = np.concatenate([2 * f[:, 1] + turn, 2 * f[:, 1] + 1 - turn])
    state = connected_components(coo_matrix((np.ones(len(a)), (a, b)), shape=(2 * len(wf),) * 2),
                                 directed=False)[1]
    kept, turned = state[0::2], state[1::2]
    if (kept == turned).any():
        return None
    return np.where((kept < turned)[:, None], wf, wf[:, ::-1])


def _unit_normals(tri):
    """(K, 3) unit normals of triangles (K, 3, 3) by their winding (0 for a degenerate one)."""
    n = _cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)


def _touching(faces, pairs, tol, either):
    """(sum F,) bool over the faces of every body (``faces``: their arrays, :func:`body_patches`'s ``body``,
    concatenated in body order, with each body's first face ``first``): which of body B's outward faces lie
    within ``tol[B]`` of the plane of one of body A's faces facing them (opposite normals; either way where
    A's are not known outwards or ``either`` (P,) holds for the pair: B may lie in A's closed part) and overlap
    it in that plane by more than ``tol[B]`` (the lids of two boxes side by side do not touch), for every pair
    ``(B, A)`` of ``pairs`` (P, 2), all pairs at once."""
    lo, hi, first, count, blo, bhi = faces[3:9]
    out = np.zeros(len(lo), bool)
    b, a = pairs.T
    t = tol[b]
    # B's faces within A's faces' box (grown by tol), then A's faces within those faces' box
    p, k = _ragged(count[b])
    fb = first[b][p] + k
    ok = _all3((hi[fb] >= blo[a][p] - t[p, None]) & (lo[fb] <= bhi[a][p] + t[p, None]))
    p, fb = p[ok], fb[ok]
    nb = np.bincount(p, minlength=len(b))
    has = np.flatnonzero(nb)
    if not len(has):
        return out
    start = np.cumsum(nb) - nb
    near_lo, near_hi = np.minimum.reduceat(lo[fb], start[has]), np.maximum.reduceat(hi[fb], start[has])
    q, k = _ragged(count[a][has])
    fa = first[a][has][q] + k
    ok = _all3((hi[fa] >= near_lo[q] - t[has][q, None]) & (lo[fa] <= near_hi[q] + t[has][q, None]))
    na = np.zeros(len(b), np.intp)
    na[has] = np.bincount(q[ok], minlength=len(has))
    fa, a_start = fa[ok], np.zeros(len(b), np.intp)
    a_start[has] = np.cumsum(na[has]) - na[has]
    # B's near faces against every near face of A; where that makes too many pairs (detailed bodies: a
    # 600-sided column on a floor of 20,000 faces, 2,400 x 240), B's faces meeting the box of A's against those
    # whose boxes meet theirs, up to _PAIRS << 8 pairs (beyond, as where the candidates of the boxes that meet
    # are too many: bodies that pass through each other, not searched)
    use = (na[p] > 0) & (nb[p] * na[p] <= _PAIRS)
    pu, fu = p[use], fb[use]
    # of those, only the A faces whose normal's axis (_axes) can face the B face's: A's near faces of each pair
    # by axis, each B face against the runs of the opposite axis, the same axis (``either``) and of no axis
    axis, plane = _axes(faces[1]), _plane_offsets(faces)
    key = np.repeat(np.arange(len(b)), na) * 7 + axis[fa]
    fs, count = fa[np.argsort(key, kind="stable")], np.bincount(key, minlength=7 * len(b))
    run, ab, free = np.cumsum(count) - count, axis[fu], axis[fu] == 6
    opp = 7 * pu + np.where(free, 6, ab ^ 1)
    at = np.stack([np.where(free, a_start[pu], run[opp]), run[7 * pu + 6], run[7 * pu + ab]], axis=1)
    size = np.stack([np.where(free, na[pu], count[opp]), np.where(free, 0, count[7 * pu + 6]),
                     np.where(free | ~either[pu], 0, count[7 * pu + ab])], axis=1).ravel()
    e = np.flatnonzero(size)
    for s, _, i, j in _expanded(size[e]):               # run e[s + i] (of B's near face e // 3), its j-th face
        i = e[i + s]
        _mark(out, faces, plane, either, t, pu[i // 3], fu[i // 3], fs[at.ravel()[i] + j])
    for g in np.unique(p[(na[p] > 0) & ~use & (nb[p] * na[p] <= _PAIRS << 8)]):
        ib, ia = fb[p == g], fa[a_start[g]:a_start[g] + na[g]]
        ib = ib[((hi[ib] >= lo[ia].min(axis=0) - t[g]) & (lo[ib] <= hi[ia].max(axis=0) + t[g])).all(axis=1)]
        k, m = _meeting(lo[ib], hi[ib], lo[ia], hi[ia], t[g])
        if k is not None:
            _mark(out, faces, plane, either, t, np.full(len(k), g), ib[k], ia[m])
    return out


_CLEAR = 4e-3               # an axis of a normal this much larger than its others (_axes)


def _axes(n):
    """(F,) the axis of unit normals ``n`` (F, 3) that they are nearest: 2 x its number, + 1 for a negative one;
    6 where that is not ``_CLEAR``er than the next (or a zero normal). Normals facing each other (cosine of
    ``FACING`` or nearer to -1) differ by ``sqrt(2e-6)`` = 1.42e-3 at most in each coordinate: where one is clear
    (by more than twice that), the other is nearest the same axis, of the opposite sign (its axis ``^ 1``), or
    is not clear."""
    a = np.abs(n)
    big = np.argmax(a, axis=1)
    s = np.sort(a, axis=1)
    return np.where(s[:, 2] - s[:, 1] > _CLEAR, 2 * big + (n[np.arange(len(n)), big] < 0), 6)


def _plane_offsets(faces):
    """Each face's plane offset ``s = n . (x0 - c)`` (its normal ``n``, first corner ``x0``, ``c`` the faces'
    middle) and how far (``bound``) it may be from minus another's that faces it (cosine ``FACING`` or nearer
    -1) and lies within ``t`` of its plane, less ``t``: the two normals differ by 1.42e-3 at most
    (:func:`_axes`), ``2e-3`` of the first corners' distances from ``c``, and rounding (``1e-12`` of their
    coordinates). The rows of :func:`_mark` whose ``s`` do not meet so (nor, where ``either``, ``s`` and
    another's that faces the same way) do not face each other, or are not in the plane."""
    tri, n, lo, hi = faces[0], faces[1], faces[3], faces[4]
    c = 0.5 * (lo.min(axis=0) + hi.max(axis=0)) if len(lo) else np.zeros(3)
    c = c if np.isfinite(c).all() else np.zeros(3)
    x = tri[:, 0] - c
    big = np.abs(tri[:, 0]).max(axis=1) + np.abs(c).max()
    return np.einsum("kj,kj->k", n, x), 2e-3 * np.sqrt(np.einsum("kj,kj->k", x, x)) + 1e-12 * big


def _meeting(blo, bhi, alo, ahi, t):
    """(B's box, A's box) pairs of the boxes (corners (NB, 3), (NA, 3)) that meet, grown by ``t``: the A boxes
    whose centre lies in a B box grown by A's widest half (along the axis whose slab holds the fewest), then
    the boxes; (None, None) where those candidates exceed ``_PAIRS`` (bodies that pass through each other: two
    spheres of 5,120 faces, 0.3 radii apart, make 1.2 million, 0.27 s)."""
    half = 0.5 * (ahi - alo).max(axis=0) + 2.0 * t
    k, m = _slab_pairs(0.5 * (alo + ahi), blo - half, bhi + half, _PAIRS)
    if k is None:
        return None, None
    ok = ((ahi[m] >= blo[k] - t) & (alo[m] <= bhi[k] + t)).all(axis=1)
    return k[ok], m[ok]


def _mark(out, faces, plane, either, t, pi, bi, m):
    """``out[bi] = True`` for B's faces ``bi`` (of the body pairs ``pi``) lying on A's faces ``m`` facing them
    (:func:`_touching`), one (B face, A face) pair a row; each test on the rows that passed the one before
    (each row's values its own: the same on fewer rows)."""
    tri, n = faces[:2]
    s, bound = plane                                    # near A's plane (_plane_offsets) first, facing, in it
    near = np.abs(s[m] + s[bi])
    near = np.where(either[pi], np.minimum(near, np.abs(s[m] - s[bi])), near) if either.any() else near
    pi, bi, m = (x[near <= t[pi] + bound[bi] + bound[m]] for x in (pi, bi, m))
    cos = np.einsum("kj,kj->k", n[bi], n[m])
    pi, bi, m = (x[np.where(either[pi], np.abs(cos), -cos) >= FACING] for x in (pi, bi, m))
    nm = n[m]
    off = np.einsum("kvj,kj->kv", tri[bi], nm) - np.einsum("kj,kj->k", tri[m, 0], nm)[:, None]
    pi, bi, m = (x[_all3(np.abs(off) <= t[pi, None])] for x in (pi, bi, m))
    e1 = tri[bi, 1] - tri[bi, 0]
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    hit = np.ones(len(bi), bool)
    for ax in (e1, _cross(n[bi], e1)):                  # the faces' extents along two axes of B's face
        pb, pa = np.einsum("kvj,kj->kv", tri[bi], ax), np.einsum("kvj,kj->kv", tri[m], ax)
        hit &= np.minimum(_max3(pb), _max3(pa)) - np.maximum(_min3(pb), _min3(pa)) > t[pi]
    out[bi[hit]] = True


def _all3(x):
    """``x.all(axis=1)`` of (K, 3) bools, column by column (a reduction over 3 per row is 10x slower)."""
    return x[:, 0] & x[:, 1] & x[:, 2]


def _max3(x):
    """``x.max(axis=1)`` of (K, 3) values for comparisons (the sign of a zero may differ)."""
    return np.maximum(np.maximum(x[:, 0], x[:, 1]), x[:, 2])


def _min3(x):
    """``x.min(axis=1)`` of (K, 3) values for comparisons (the sign of a zero may differ)."""
    return np.minimum(np.minimum(x[:, 0], x[:, 1]), x[:, 2])


def _world_bodies(instances):
    """Per instance (each with a mesh): its world vertices (U, 3) and faces (F, 3) (wound outwards where
    closed), and for all of them, in order: the world faces (sum F, 3, 3), their unit normals, whether each
    instance's faces are wound outwards (n,), the faces' boxes' corners (sum F, 3) x 2, each instance's first
    face and face count (n,), its faces' box (n, 3) x 2 and its world box (n, 2, 3). Instances sharing a mesh
    are moved together (the same values as one at a time)."""
    groups = {}
    for i, inst in enumerate(instances):
        groups.setdefault(id(inst.mesh), []).append(i)
    world, parts = [None] * len(instances), [None] * len(instances)
    for rows in groups.values():
        mesh = instances[rows[0]].mesh
        got = _outward(mesh)
        v, f = got if got is not None else (np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces))
        T = np.array([instances[i].transform for i in rows])
        vs = np.matmul(v[None], T[:, :3, :3].transpose(0, 2, 1)) + T[:, None, :3, 3]
        tri = vs[:, f]
        n = _unit_normals(tri.reshape(-1, 3, 3)).reshape(tri.shape[:3])
        lo, hi = tri.min(axis=2), tri.max(axis=2)
        vlo, vhi = vs.min(axis=1), vs.max(axis=1)          # each instance's vertices' box, all at once
        for k, i in enumerate(rows):
            world[i] = vs[k], f
            parts[i] = tri[k], n[k], got is not None, lo[k], hi[k], vlo[k], vhi[k]
    nface = np.array([len(w[1]) for w in world], np.intp)
    tri, n, oriented, lo, hi, vlo, vhi = zip(*parts)
    lo, hi = np.concatenate(lo), np.concatenate(hi)
    first = np.cumsum(nface) - nface
    return world, (np.concatenate(tri), np.concatenate(n), np.array(oriented, bool), lo, hi, first, nface,
                   np.minimum.reduceat(lo, first), np.maximum.reduceat(hi, first),
                   np.stack([np.array(vlo), np.array(vhi)], axis=1))


def body_patches(scene):
    """Per plane of a closed caster's faces touching another body (both with meshes; a receiver too): (inward unit
    normal (3,), offset ``n . x``, tolerance, 3D box (2, 3), plane basis (2, 3), faces in it (K, 3, 2) and the
    outline of their union (E, 2, 2)); kept with the scene's arrays. Ground contacts: :func:`footprints`.

    After moves only (the same instances and meshes), a body whose pose and whose neighbours' poses (before and
    after) are unchanged keeps the patches found for it last time (:data:`_SEARCHED`): each body's patches are
    found from its own face pairs alone, so they are the same values; one box moved among 3,600 touching ones
    is searched with its neighbours, not all of them."""
    return _patches(scene, scene_arrays(scene))


def _patches(scene, held):
    """:func:`body_patches` of ``scene`` at the poses of its arrays ``held`` (kept there)."""
    if "bodies" in held:
        return held["bodies"]
    out = []                    # stored when complete: another thread's query reads all of it or none
    faced = np.zeros(held["n"], bool)   # the instances (of the arrays) with a mesh of faces, each mesh asked once
    for first, rows in mesh_groups(held, np.arange(held["n"]), casters=False):
        mesh = held["placed"][first].mesh
        faced[rows] = mesh is not None and len(mesh.faces) > 0
    ids = np.flatnonzero(faced)
    both = _body_pairs(held, ids) if len(ids) >= 2 else np.zeros((0, 2), np.intp)
    if not len(both):
        held["bodies"] = out
        return out
    tol, T = _face_tolerances(held)[ids], held["transform"][ids]
    last = _grown(_SEARCHED.get(scene), held, ids)      # None: other instances or meshes, everything searched anew
    # moved: any bit of the pose (-0.0 is not 0.0: the patches' bits follow the pose's)
    moved = np.ones(len(ids), bool) if last is None else \
        (T.view(np.uint64) != last["T"].view(np.uint64)).any(axis=(1, 2))
    used = np.unique(both)
    if last is None:
        box, oriented, searched = np.zeros((len(ids), 2, 3)), np.zeros(len(ids), bool), np.zeros(len(ids), bool)
        posed = used
    else:
        box, oriented, searched = last["box"].copy(), last["oriented"].copy(), last["searched"].copy()
        posed = used[moved[used] | ~last["posed"][used]]
    world, faces = _world_bodies(_posed(scene, held, ids[posed])) if len(posed) else (None, None)
    if len(posed):
        box[posed], oriented[posed] = faces[9], faces[2]
    was_posed = np.zeros(len(ids), bool) if last is None else last["posed"] & ~moved    # boxes of the poses in T
    was_posed[posed] = True
    b, a = both.T
    t = (tol[b] + tol[a])[:, None]
    meet = oriented[b] & ((box[b, 0] <= box[a, 1] + t) & (box[a, 0] <= box[b, 1] + t)).all(axis=1)    # boxes meet
    b, a, t = b[meet], a[meet], t[meet]
    # B within A's box may rest inside A's closed part, its face on A's with the same outward normal: a box on
    # the floor of a room (a closed box wound inwards, turned outwards by _outward) read no contact, its floor
    # under the box's edge AO up to 0.59 (Embree 0). Where A lies in B's part instead (B the room), B's box is not
    # within A's: B's face (the room's floor) is not closed in by A
    inner = ((box[b, 0] >= box[a, 0] - t) & (box[b, 1] <= box[a, 1] + t)).all(axis=1)
    found = {} if last is None else last["found"]
    if last is not None:                                # a body whose pose or a neighbour's (before, after) moved
        for pb, pa in ((b, a), last["pairs"]):
            searched[pb[moved[pb] | moved[pa]]] = False
        found = {k: v for k, v in found.items() if searched[k]}
    sel = ~searched[b]
    if sel.any():
        found.update(_searched(scene, held, ids, b[sel], a[sel], ~oriented[a[sel]] | inner[sel], tol, world, faces,
                               posed))
        searched[b[sel]] = True
    for i in b[np.sort(np.unique(b, return_index=True)[1])]:      # in the order the bodies were first met
        out.extend(found[int(i)])
    _SEARCHED[scene] = {"mesh_id": held["mesh_id"], "ids": ids, "T": T, "box": box, "oriented": oriented,
                        "posed": was_posed, "searched": searched, "pairs": (b, a), "found": found,
                        "receivers": _receiver_hashes(held)}
    held["bodies"] = out
    return out


#: scene -> its last :func:`body_patches` search: the poses (``T``) and world boxes it read, the touching pairs
#: ``(B, A)`` it tested (positions into ``ids``) and the patches it found for each body B (``found``)
_SEARCHED = weakref.WeakKeyDictionary()


def _grown(last, held, ids):
    """The last search ``last`` (:data:`_SEARCHED`) where it holds for the bodies ``ids`` of the scene's arrays
    ``held``: as it is after moves only; after ``Scene.add`` (the instances only grow, the earlier ones keep their
    meshes; no receiver's mesh changed in place since) with the new bodies as moved ones, so that they and their
    neighbours are searched, not every body (a simulation spawning bodies searched every body at each add); else
    None."""
    if last is None or (last["mesh_id"] is held["mesh_id"] and np.array_equal(last["ids"], ids)):
        return last
    k, m = len(last["ids"]), len(last["mesh_id"])
    if not (m <= len(held["mesh_id"]) and k <= len(ids) and np.array_equal(ids[:k], last["ids"])
            and (k == len(ids) or ids[k] >= m) and np.array_equal(held["mesh_id"][:m], last["mesh_id"])
            and _receivers_kept(last["receivers"], held)):
        return None
    new = len(ids) - k

    def grow(a, fill):
        return np.concatenate([a, np.full((new,) + a.shape[1:], fill, a.dtype)])

    return dict(last, mesh_id=held["mesh_id"], ids=ids, T=grow(last["T"], np.nan), box=grow(last["box"], 0.0),
                oriented=grow(last["oriented"], False), posed=grow(last["posed"], False),
                searched=grow(last["searched"], False))


def _receiver_hashes(held):
    """``{id(mesh): trimesh's hash}`` of the receivers' meshes as the scene's arrays ``held`` were made with."""
    return {id(mesh): h for mesh, h in held["receivers"]}


def _receivers_kept(hashes, held):
    """Whether every receiver's mesh of ``hashes`` (:func:`_receiver_hashes`) has the same hash in ``held``."""
    now = _receiver_hashes(held)
    return all(now.get(i) == h for i, h in hashes.items())


_Posed = namedtuple("_Posed", "mesh transform")


def _posed(scene, held, rows):
    """The instances ``rows`` (ids) as ``(mesh, transform)`` at the poses of the scene's arrays ``held``, those the
    search is kept for (:data:`_SEARCHED`), not the instances' own: a move from another thread during a query
    gave the faces of its pose to the patches kept for the pose asked, found again only after another move
    (a box lifted onto another, moved away during the query and back: no patch, AO 1 on the lid under it)."""
    T = held["transform"]
    return [_Posed(held["placed"][i].mesh, T[i]) for i in rows]


def _body_pairs(held, ids):
    """(P, 2) pairs (B, A) of positions into ``ids`` of bodies whose spheres (grown by their face tolerances)
    meet, each both ways, B a caster (a receiver closes nothing in)."""
    from scipy.spatial import cKDTree

    c, r, tol = held["world_centre"][ids], held["world_radius"][ids], _face_tolerances(held)[ids]
    # each pair from its larger sphere, within twice its radius (the largest's radius for all: N^2 pairs by a floor)
    near = cKDTree(c).query_ball_point(c, 2 * (r + tol.max()), return_sorted=False)
    i = np.repeat(np.arange(len(ids)), [len(x) for x in near])
    j = np.concatenate(near).astype(np.intp) if len(i) else i
    keep = (r[j] < r[i]) | ((r[j] == r[i]) & (j < i))
    pairs = np.stack([i[keep], j[keep]], axis=1)
    pairs = pairs[np.linalg.norm(c[pairs[:, 0]] - c[pairs[:, 1]], axis=1) <= (r + tol)[pairs].sum(axis=1)]
    both = np.concatenate([pairs, pairs[:, ::-1]])
    return both[held["casts"][np.asarray(ids)[both[:, 0]]]] if len(both) else both


def _searched(scene, held, ids, b, a, either, tol, world, faces, posed):
    """``{B: [patch]}``: the patches of every body B of the pairs ``(b, a)`` (positions into ``ids``; ``either``:
    :func:`_touching`'s), from :func:`_world_bodies`' ``world, faces`` of the bodies ``posed`` where those hold
    all of ``b`` and ``a`` (else found here, at the poses of ``held``: :func:`_posed`)."""
    used = np.unique(np.concatenate([b, a]))
    if world is None or not np.isin(used, posed).all():
        posed = used
        world, faces = _world_bodies(_posed(scene, held, ids[posed]))
    row = np.full(len(ids), -1)
    row[posed] = np.arange(len(posed))
    hit = _touching(faces, np.stack([row[b], row[a]], axis=1), tol[posed], either)
    planes = _plane_faces(hit, faces, row[b][np.sort(np.unique(b, return_index=True)[1])], tol[posed])
    found = {int(k): [] for k in np.unique(b)}
    for i, patch in zip(planes[0], _planes(planes, world, faces[0], faces[5], tol[posed]) if len(planes[0])
                        else ()):
        found[int(posed[i])].append(patch)
    return found


_ROUND = 1 << 17            # faces of bodies split into planes together (:func:`_plane_faces`)


def _plane_faces(hit, faces, bodies, tol):
    """The touching faces ``hit`` (:func:`_touching`) of the bodies ``bodies`` (rows of :func:`_world_bodies`'
    ``faces``) split into planes, one at a time per body: its first face in no plane yet gives the inward normal
    ``n`` (minus the face's normal) and offset ``d`` (its first corner's ``n . x``), the plane's faces are the
    body's touching faces facing along ``n`` (cosine ``FACING``) within ``tol`` of it. Every body's next plane
    is found in one round, its faces tested by the same numpy calls on the same shapes as that body alone (the
    same values to the bit). Returns, by body (in the order of ``bodies``), then plane: each plane's body (P,),
    ``n`` (P, 3), ``d`` (P,), its faces' numbers in its body (sum K,) and their count (P,)."""
    count = faces[6][bodies]
    part = (np.cumsum(count) - count) // _ROUND         # runs of about _ROUND faces
    cut = np.r_[0, np.flatnonzero(np.diff(part)) + 1, len(bodies)]
    got = [x for s, e in zip(cut[:-1], cut[1:]) for x in _plane_rounds(hit, faces, bodies[s:e], tol, s)]
    if not got:
        return np.zeros(0, np.intp), np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.intp), np.zeros(0, np.intp)
    key, n, d, k, size = (np.concatenate(x) for x in zip(*got))
    o = np.argsort(key, kind="stable")                  # by body, each body's planes in the order found
    g, j = _ragged(size[o])
    return bodies[key[o]], n[o], d[o], k[(np.cumsum(size) - size)[o][g] + j], size[o]


def _plane_rounds(hit, faces, bodies, tol, base):
    """:func:`_plane_faces` of ``bodies`` (at ``base`` on there), a round a list item: the planes' bodies'
    positions, ``n``, ``d``, faces and their counts, as one body's ``while`` loop over its planes would find
    them (``d``: ``tri_b[j, 0] @ n``, the faces ``-n_b @ n`` and ``tri_b @ n`` of each body's arrays)."""
    tri, nrm, first, count = faces[0], faces[1], faces[5][bodies], faces[6][bodies]
    g, k = _ragged(count)                               # the bodies' faces: body (position), face in body
    f = first[g] + k
    h, start = hit[f], np.cumsum(count) - count
    rounds = []
    while h.any():
        at = np.flatnonzero(h)
        q, i = np.unique(g[at], return_index=True)     # the bodies with faces left, the first of each
        n = -nrm[f[at[i]]]
        d = (tri[f[at[i]], 0][:, None, :] @ n[:, :, None])[:, 0, 0]
        r, kk = _ragged(count[q])                       # their faces
        loc = start[q][r] + kk
        near = np.abs((tri[f[loc]] @ n[r][:, :, None])[..., 0] - d[r][:, None]) <= tol[bodies[q]][r][:, None]
        cos, at_q = np.empty(len(loc)), np.cumsum(count[q]) - count[q]
        for c in np.unique(count[q]):                   # each body's faces as one (F, 3) array
            w = np.flatnonzero(count[q] == c)
            cos[(at_q[w][:, None] + np.arange(c)).ravel()] = \
                (-nrm[first[q[w]][:, None] + np.arange(c)] @ n[w][:, :, None]).ravel()
        same = h[loc] & (cos >= FACING) & _all3(near)
        h[loc[same]] = False
        h[at[i]] = False                                # (in its plane: n . n)
        rounds.append((q + base, n, d, kk[same], np.bincount(r[same], minlength=len(q))))
    return rounds


def _planes(planes, world, tri, first, tol):
    """:func:`body_patches`'s patches of the planes ``planes`` (:func:`_plane_faces`; ``world``, ``tri``,
    ``first``: :func:`_world_bodies`'s), all planes at once but each one's plane basis and flattening by the same
    numpy calls on the same shapes as one plane alone (the same values)."""
    body, n, d, k, size = planes
    start = np.cumsum(size) - size
    # the planes' faces: numbers into ``tri`` and the faces' vertex numbers (sorted rows)
    plane = np.repeat(np.arange(len(body)), size)
    fv = np.concatenate([w[1] for w in world])
    nface = np.array([len(w[1]) for w in world], np.intp)
    wf = fv[k + (np.cumsum(nface) - nface)[body][plane]].astype(np.int64)
    k = k + first[body][plane]
    lo, hi = np.minimum.reduceat(tri[k].min(axis=1), start), np.maximum.reduceat(tri[k].max(axis=1), start)
    edge, ecut = _outlines(np.sort(wf, axis=1), plane, len(body))   # the outlines
    e1 = _cross(n, np.eye(3)[np.argmin(np.abs(n), axis=1)])
    unit = e1 / np.sqrt((e1[:, None, :] @ e1[:, :, None])[:, 0, 0])[:, None]      # np.linalg.norm of each
    basis = np.stack([unit, _cross(n, unit)], axis=1)
    # each plane's body's vertices flattened (world[i][0] @ basis.T), planes of bodies of as many vertices at
    # once (about _ROUND vertices a run), and its faces' and outline's corners taken from them
    v = np.concatenate([w[0] for w in world])
    nv = np.array([len(w[0]) for w in world], np.intp)
    vfirst, count = np.cumsum(nv) - nv, nv[body]
    on, out_edge = np.empty((len(wf), 3, 2)), np.empty((len(edge), 2, 2))
    for c in np.unique(count):
        for w in np.array_split(np.flatnonzero(count == c), -(-int((count == c).sum()) * int(c) // _ROUND)):
            flat = (v[vfirst[body[w]][:, None] + np.arange(c)] @ basis[w].transpose(0, 2, 1)).reshape(-1, 2)
            for got, first_at, num, rows in ((on, start, size, wf), (out_edge, ecut[:-1], np.diff(ecut), edge)):
                g, j = _ragged(num[w])
                got[first_at[w][g] + j] = flat[rows[first_at[w][g] + j] + c * g[:, None]]
    box = np.stack([lo, hi], axis=1)
    return [(n[j], float(d[j]), float(tol[body[j]]), box[j], basis[j], on[start[j]:start[j] + size[j]],
             out_edge[ecut[j]:ecut[j + 1]]) for j in range(len(body))]


def body_hits(scene, points):
    """``[(rows, inward unit normal (3,))]``: per contact patch (:func:`body_patches`), the points lying on it
    farther than its tolerance from its outline (a point between two bodies lies on a patch of each)."""
    held = scene_arrays(scene) if len(points) and scene.instances else None
    patches = _patches(scene, held) if held is not None else []     # the patches and their parts of one pose
    if not patches:
        return []
    p = np.asarray(points, np.float64)
    big = np.abs(p).max(axis=1)
    # float32 points of a plane far from the origin lie off it by up to their rounding
    rounding = np.where(float32_exact(p).all(axis=1), np.spacing(big.astype(np.float32)).astype(np.float64),
                        np.spacing(big))
    normal, offset, tol, lo, hi = _patch_arrays(patches)
    # the candidates of each patch along the axis whose slab of its grown box holds the fewest points (not its
    # thin axis: a floor's points lie in its plane)
    grow = (tol + rounding.max())[:, None]
    pid, rows = _slab_pairs(p, lo - grow, hi + grow)
    g = (tol[pid] + rounding[rows])[:, None]                     # within the patch's box and its plane
    ok = np.all((p[rows] >= lo[pid] - g) & (p[rows] <= hi[pid] + g), axis=1)
    ok[ok] = np.abs(np.einsum("ij,ij->i", p[rows[ok]], normal[pid[ok]]) - offset[pid[ok]]) <= \
        np.maximum(tol[pid[ok]], rounding[rows[ok]])
    pid, rows = pid[ok], rows[ok]
    if not len(pid):
        return []
    # in the patch's plane (each patch's points flattened as that patch's alone), inside one of its faces and
    # farther than its tolerance from its outline
    q = np.concatenate([p[k] @ patches[i][4].T for i, k in zip(*_groups(pid, rows))])
    ok = _in_parts(q, pid, _kept_parts(held, "body parts",
                                       lambda: ([x[5] for x in patches], [x[6] for x in patches], None)), tol)
    pid, rows = pid[ok], rows[ok]
    return [(k, patches[i][0]) for i, k in zip(*_groups(pid, rows))]


def _patch_arrays(patches):
    """The patches' inward normals (P, 3), plane offsets (P,), tolerances (P,) and boxes' corners (P, 3) x 2."""
    box = np.array([x[3] for x in patches])
    return (np.array([x[0] for x in patches]), np.array([x[1] for x in patches]), np.array([x[2] for x in patches]),
            box[:, 0], box[:, 1])


def _groups(pid, rows):
    """(patch numbers, [rows of each]) of the pairs ``pid``, ``rows`` sorted by patch."""
    cut = np.flatnonzero(np.diff(pid)) + 1
    return pid[np.r_[0, cut]] if len(pid) else pid, np.split(rows, cut) if len(pid) else []

"""A scene's instances as stacked arrays, kept until the scene changes.

Every query needs each instance's transform and world bounding sphere; with
10,000 instances, gathering them one Python object at a time costs more
than the query. :func:`scene_arrays` stacks them once per change of the
scene (``Scene.add``, ``Scene.set_transform`` and ``Scene.remove`` advance its version) and
computes the world spheres for all instances at once, with the same
operations, in the same order, as :meth:`pyshadow.scene.Instance.world_sphere`
(so the results are bit-identical to it). :func:`anchor_groups` gives the
anchors query points are asked relative to (one, the scene's, but where they
lie far from it).
"""
from __future__ import annotations

import threading
import weakref

import numpy as np

from ._validate import FLOAT32_MAX, check_float32_points, uniform_scale
from .anchor_reach import caster_buckets, reach_bound, run_starts

__all__ = ["scene_arrays", "ANCHOR_REACH_RADII", "anchor_groups", "cube_groups", "points_bound", "check_meshes"]

_HELD = weakref.WeakKeyDictionary()
#: Held while arrays just made are kept for their scene (:func:`_kept_for`).
_KEEP_LOCK = threading.Lock()


def scene_arrays(scene) -> dict:
    """Stacked per-instance data of ``scene`` (read-only arrays; do not modify).

    Returns
    -------
    dict
        ``transform`` (n, 4, 4) float64; ``scale`` (n,) (cube root of the
        3x3 part's determinant); ``object_centre`` (n, 3), ``object_radius``
        (n,) (the CSM's bounding sphere, or the mesh's for a receiver);
        ``world_centre`` (n, 3), ``world_radius`` (n,); ``casts`` (n,) bool;
        ``types`` (the distinct CSMs of the casters, in first-use order),
        ``type_index`` (``{id(csm): index}``), ``itype`` (n,) int32 (each
        instance's type, -1 for a receiver); ``live`` (n,) bool (False where
        ``Scene.remove`` left a placeholder: no CSM, no mesh, ``casts``
        False; its sphere a point at its last place). Callers may keep derived data
        of their own in the dict (it is dropped with it when the scene changes).
        ``meshes``: ``(instance id, mesh)`` of each distinct caster mesh (:func:`check_meshes`);
        ``receivers``: ``(mesh, trimesh's hash)`` of each distinct receiver mesh: one changed in place
        (a receiver's may be) makes the arrays anew, with its sphere. ``mesh_id`` (n,) int64: ``id`` of
        each instance's mesh, 0 without one. ``placed``: the instances these rows describe (a tuple of
        ``Scene.instances`` as it was; a query reads an instance there, not in the list, which another
        thread's ``Scene.remove`` may have given a placeholder since). After moves only (the same
        instances), the arrays the transforms do not change are kept.
    """
    version, removals = getattr(scene, "_version", None), getattr(scene, "_removals", 0)    # (Scene.remove's count)
    held = _HELD.get(scene)
    n = len(scene.instances)
    if held is not None and version is not None and held["n"] == n and held["removals"] == removals \
            and all(hash(m) == h for m, h in held["receivers"]):
        if held["version"] == version:
            return held
        # the same instances (the list only grows, none removed): only transforms moved; what they do not change is kept
        out = {k: held[k] for k in _STATIC}
        return _kept_for(scene, _posed(out, np.stack([inst.transform for inst in out["placed"]]) if n
                                       else held["transform"], version))
    insts = tuple(scene.instances)      # one list of them (another thread may add or remove meanwhile)
    n = len(insts)
    receivers = {id(i.mesh): (i.mesh, hash(i.mesh)) for i in insts if not i.casts and not i.removed}
    T = np.stack([inst.transform for inst in insts]) if n else np.zeros((0, 4, 4))
    spheres = [(np.zeros(3), 0.0) if inst.removed else inst.object_sphere() for inst in insts]
    c = np.array([np.asarray(s[0], np.float64) for s in spheres]).reshape(n, 3)
    r = np.array([float(s[1]) for s in spheres], np.float64)
    types, index = [], {}
    for inst in insts:                  # the distinct CSMs of the casters, in first-use order
        if inst.casts and id(inst.csm) not in index:
            index[id(inst.csm)] = len(types)
            types.append(inst.csm)
    itype = np.array([index[id(i.csm)] if i.casts else -1 for i in insts], np.int32)
    meshes = {}
    for k, inst in enumerate(insts):    # the casters' distinct meshes, each with an instance placing it
        if inst.casts and inst.mesh is not None and id(inst.mesh) not in meshes:
            meshes[id(inst.mesh)] = (k, inst.mesh)
    out = {"types": tuple(types), "type_index": index, "itype": itype, "n": n, "removals": removals,
           "object_centre": c, "object_radius": r,
           "casts": np.array([i.casts for i in insts], bool), "meshes": tuple(meshes.values()),
           "receivers": tuple(receivers.values()), "live": np.array([not i.removed for i in insts], bool),
           "mesh_id": np.array([0 if i.mesh is None else id(i.mesh) for i in insts], np.int64), "placed": insts}
    for v in out.values():
        if isinstance(v, np.ndarray):
            v.flags.writeable = False
    return _kept_for(scene, _posed(out, T, version))


def _kept_for(scene, out) -> dict:
    """``out``, kept as ``scene``'s arrays; or the arrays of the same state another thread kept meanwhile (the
    first queries of threads at once each made them: the tables one thread then kept with its own dict were
    lost to the others, made again by each)."""
    with _KEEP_LOCK:
        cur = _HELD.get(scene)
        if cur is not None and out["version"] is not None \
                and all(cur[k] == out[k] for k in ("version", "n", "removals")) \
                and all(hash(m) == h for m, h in cur["receivers"]):
            return cur
        _HELD[scene] = out
        return out


def mesh_groups(held, ids, casters: bool = True) -> list:
    """The instances ``ids`` (positions into it) grouped by mesh object, in the order each mesh first
    appears: ``[(first position, positions (ascending))]``. The instances without a mesh (and with
    ``casters``, the receivers) form one group of their own, the key 0 (``held``: :func:`scene_arrays`)."""
    ids = np.asarray(ids, np.intp)
    key = held["mesh_id"][ids]
    if casters:
        key = np.where(held["casts"][ids], key, 0)
    _, first, back, count = np.unique(key, return_index=True, return_inverse=True, return_counts=True)
    rows = np.split(np.argsort(back.ravel(), kind="stable"), np.cumsum(count)[:-1])
    return [(int(first[g]), rows[g]) for g in np.argsort(first, kind="stable")]


# what a move leaves as it was (the instances, their CSMs, meshes and object spheres)
_STATIC = ("types", "type_index", "itype", "n", "object_centre", "object_radius", "casts", "meshes", "receivers",
           "mesh_id", "live", "removals", "placed")


def _posed(out, T, version):
    """``out`` with the arrays of the transforms ``T`` (n, 4, 4): the world spheres, for all at once."""
    n, c, r = out["n"], out["object_centre"], out["object_radius"]
    A = T[:, :3, :3]
    scale = uniform_scale(A) if n else np.zeros(0)
    wc = np.matmul(A, c[:, :, None])[:, :, 0] + T[:, :3, 3] if n else np.zeros((0, 3))
    out.update(version=version, transform=T, scale=scale, world_centre=wc, world_radius=r * scale)
    for v in (T, scale, wc, out["world_radius"]):
        v.flags.writeable = False
    return out


def check_meshes(scene) -> None:
    """Raise ValueError where a caster's mesh was changed in place after ``Scene.add``.

    Its CSM was built from (or checked against) the mesh as it was placed: Embree and the drawn image
    followed the changed mesh while the CSM backends answered for the old one. trimesh's hash of the
    mesh (cheap while it is unchanged: trimesh tracks writes through its arrays) is compared with the
    one it was placed with; where they differ, the mesh's SHA-256 with its CSM's decides (a hash
    computed by another trimesh build, after pickling, is not a change).
    """
    if not scene.instances:
        return
    from .mesh import mesh_hash

    for k, mesh in scene_arrays(scene)["meshes"]:
        inst = scene.instances[k]
        if inst._stamp is not None and hash(mesh) != inst._stamp:
            if mesh_hash(mesh) != inst.csm.mesh_hash:
                raise ValueError(f"the mesh of instance {k} was changed in place after Scene.add: its CSM holds "
                                 "the mesh as it was placed (build a new scene with the changed mesh)")
            object.__setattr__(inst, "_stamp", hash(mesh))     # the same mesh, hashed differently


#: How far from its anchor a query point may always lie, in radii of the scene's smallest caster, before
#: it may need an anchor of its own: float32 rounds a coordinate at distance d by up to d 2**-24, which
#: stays below the 16-bit depth quantum of that caster (2 r / 65534) up to d = 512 r. Beyond, a point's
#: reach is set by the casters near it (:mod:`pyshadow.anchor_reach`): max(512 r_c, its distance to c).
ANCHOR_REACH_RADII = 512.0


def points_bound(points) -> float:
    """The largest |coordinate| of ``points`` (two passes, no temporaries); 0 for no points."""
    if not points.size:
        return 0.0
    return max(abs(float(points.max())), abs(float(points.min())))


def anchor_groups(scene, points, bound=None):
    """The anchors the queries of ``points`` are asked relative to, and the rows of each.

    The device reads points relative to an anchor in float32. The scene's
    anchor (:meth:`pyshadow.Scene.anchor`) serves every point within its
    reach (:mod:`pyshadow.anchor_reach`): within :data:`ANCHOR_REACH_RADII`
    radii of every caster nearer to it than the anchor (so always within
    512 radii of the smallest caster, the common case: one group, decided
    by a bound on the points' coordinates). The points beyond (near a caster
    tiny beside their distance from the anchor; a scene whose bodies lie
    far apart, asked near one of them) are grouped by cubes of a
    power-of-two side at most twice their reach, each asked relative to its
    cube's centre (within half the side of each point in every coordinate),
    so that no point loses more precision than within its reach.

    Parameters
    ----------
    scene : pyshadow.Scene
    points : ndarray, shape (N, 3), float64
        World points.
    bound : float, optional
        :func:`points_bound` of ``points``, where the caller has it.

    Returns
    -------
    list of (ndarray or None, ndarray)
        ``(rows, anchor)``: the row indices (int64) of each group, or None
        for all rows (the common case, one group: the scene's anchor), and
        its world anchor (3,) float64.

    Raises
    ------
    ValueError
        A caster's mesh was changed in place after it was placed (:func:`check_meshes`).
    """
    check_meshes(scene)                 # (once a query of the kernels and Embree)
    anchor = scene.anchor(points)
    arr = scene_arrays(scene) if scene.instances else None
    if arr is None or not arr["casts"].any() or not len(points):
        return [(None, anchor)]
    return cube_groups(points, anchor, ANCHOR_REACH_RADII * float(arr["world_radius"][arr["casts"]].min()), bound,
                       lambda: _buckets(arr))


def _buckets(arr) -> list:
    """:func:`pyshadow.anchor_reach.caster_buckets` of the casters of ``arr``, kept with it."""
    if "reach_buckets" not in arr:
        arr["reach_buckets"] = caster_buckets(arr["world_centre"][arr["casts"]], arr["world_radius"][arr["casts"]])
    return arr["reach_buckets"]


def cube_groups(points, anchor, reach: float, bound=None, casters=None):
    """:func:`anchor_groups` of ``points`` (N, 3) float64 around the world ``anchor`` (3,): the points
    within ``reach`` (world units: 512 radii of the smallest caster) of it are asked relative to it. With
    ``casters`` (a callable returning :func:`pyshadow.anchor_reach.caster_buckets`), so are the others
    within their own reach (:func:`pyshadow.anchor_reach.reach_bound`); the rest relative to the centre of
    their cube of a power-of-two side at most twice their reach (``reach`` without ``casters``): no coordinate
    farther than their reach from its centre."""
    bound = (points_bound(points) if bound is None else bound) + float(np.abs(anchor).max())
    if bound <= reach:
        return [(None, anchor)]                 # the cheap bound: every point within reach
    if bound > FLOAT32_MAX:                     # points float32 cannot place from the scene: refused, named
        check_float32_points(points, anchor)
    d = np.asarray(points, np.float64) - anchor
    np.abs(d, out=d)
    extent = np.maximum(np.maximum(d[:, 0], d[:, 1]), d[:, 2])     # (max(axis=1) over 3 columns: 4x the time)
    rows = np.flatnonzero(extent > reach)
    own = np.full(len(rows), reach)             # each far point's reach
    if casters is not None and len(rows):       # beyond 512 r_min: within the reach of the casters near them?
        own = np.maximum(reach_bound(points[rows], extent[rows], casters(), ANCHOR_REACH_RADII), reach)
        keep = extent[rows] > own
        rows, own = rows[keep], own[keep]
    if not len(rows):
        return [(None, anchor)]
    far = np.zeros(len(points), bool)
    far[rows] = True
    # each point's cube: with own = m 2**e (m in [0.5, 1)), side = 2**e, the largest power of two at most 2 own.
    # Its centre lies within side / 2 <= own of the point in each coordinate: the point is in [cell side,
    # (cell + 1) side) (side a power of two: points / side and the floor are exact), the centre is (cell + 1/2)
    # side (exact while |cell| < 2**52), and the roundings of p - a to float64 and float32 keep |p - a| <= side / 2
    # (a power of two, representable; rounding is monotonic). The rule is on the largest coordinate
    # (pyshadow.anchor_reach), as for the points kept at the scene's anchor (extent <= own), and own <= reach(p)
    # here (reach_bound). (Sides of at most own, whose half diagonal 0.87 side kept the Euclidean distance within
    # it, made 1.2 to 3.7 times the groups, each a kernel launch with its instance tables.)
    # The cubes (side, cell) in lexicographic order, each one's points in their order (np.unique(axis=0)'s groups,
    # by a stable lexsort). Equal points have equal cubes: the runs of equal rows (a point's AO directions come
    # as one) are sorted, stably, and each run's rows follow its start, as a sort of every row would place them.
    pr = points[rows]
    starts = np.flatnonzero(run_starts(pr))
    side = np.ldexp(1.0, np.frexp(own[starts])[1])
    k = np.column_stack([side, np.floor(pr[starts] / side[:, None])])
    ro = np.lexsort(k.T[::-1])
    k, length = k[ro], np.diff(np.r_[starts, len(pr)])[ro]
    at = np.cumsum(length) - length             # each sorted run's first place
    order = np.repeat(starts[ro] - at, length) + np.arange(len(pr))
    first = np.flatnonzero(run_starts(k))
    keys, bounds = k[first], np.r_[at[first], len(pr)]
    anchors = (keys[:, 1:] + 0.5) * keys[:, :1]
    groups = [(np.flatnonzero(~far), anchor)] if (~far).any() else []
    groups += [(rows[order[bounds[k]:bounds[k + 1]]], anchors[k]) for k in range(len(keys))]
    return groups

"""Bodies sunk partly into the ground plane: the ground's points inside them.

The ground is a plane, not a solid. A closed body whose surface crosses it
(part of it below the plane by more than its tolerance, part above) cuts it
in a section: the points of the plane inside the body. A ray leaving such a
point upwards runs inside the body until it leaves through the body's
surface above the plane, and downwards the ground occludes it: every ray is
occluded, AO 0, as Embree's (with the ground as the plane or as a large
quad). The CSM cannot answer a point inside a solid (its interval may store
any depth there: such points read mean AO 0.17-0.50 under a box sunk 10-50 %
into the ground), so the CSM backends answer these points from the
section, as the footprint of a resting body (:func:`pyshadow.contact.contact_mask`).

An open body (the bunny, with holes in its base) has a section where
each of its open or non-manifold edges lies below the plane (or within its
tolerance above it): its
surface above the plane closes the section in, so a ray leaving the section
upwards meets it (Embree's do); where an opening reaches above the plane,
rays may leave through it and the CSM answers alone.

The section is the cut of the body's distinct surface (that of
:func:`pyshadow.contact.kept_surface`, as placed) by the plane: one
segment per face with corners on both sides of it, taken at the body's
tolerance above the plane (a corner within it counts as below: a face flush
with the ground is the ground there), whose ends are the crossing points of
the face's edges, the same for both faces of an edge, so the segments close
into loops. A
point of the plane is in the section where a half-line from it along +x
crosses an odd number of them, and farther than the body's tolerance
(``1e-5`` of its radius) from every one: the points of the body's sides just
at the ground line stay the CSM's. A body resting on the plane (nothing of
it below by more than its tolerance) has its footprint instead; a body
wholly below it, or with nothing above it by more than its tolerance (a
buried box whose lid lies flush with the ground: the ground there is its
lid, open to the sky), has no section.
"""
from __future__ import annotations

import numpy as np

from .contact_parts import _expanded, _grid_pairs, _ragged_parts, _square_distance
from .scene_arrays import mesh_groups, scene_arrays

__all__ = ["sections", "section_mask"]

def _cut(u, f, h):
    """Segments (E, 2, 2) in (x, z) where the plane ``h = 0`` cuts the closed surfaces of vertices ``u`` (B, V, 3),
    faces ``f`` (F, 3) sorted rows, heights ``h`` (B, V) above the plane, body by body, and where each body's
    start (B + 1,); each edge's crossing from its corners in index order (the same point for both its faces)."""
    above = h > 0
    side = above[:, f]                                          # (B, F, 3)
    body, face = np.nonzero(side.any(axis=2) & ~side.all(axis=2))
    ends = []
    for a, b in ((0, 1), (1, 2), (0, 2)):           # the face's edges, corners in index order (rows sorted)
        i, j = f[face, a], f[face, b]
        hi, hj = h[body, i], h[body, j]
        cross = above[body, i] != above[body, j]
        t = hi / np.where(cross, hi - hj, 1.0)
        ui, uj = u[body, i][:, [0, 2]], u[body, j][:, [0, 2]]
        ends.append((cross, ui + t[:, None] * (uj - ui)))
    crosses = np.stack([c for c, _ in ends], axis=1)          # (E, 3): exactly two per face
    pts = np.stack([x for _, x in ends], axis=1)              # (E, 3, 2)
    first = np.argmax(crosses, axis=1)
    last = 2 - np.argmax(crosses[:, ::-1], axis=1)
    k = np.arange(len(face))
    return np.stack([pts[k, first], pts[k, last]], axis=1), np.searchsorted(body, np.arange(len(h) + 1))


def _sections(scene, ids, ground, tols):
    """Per instance ``ids[k]``: the outline segments (E, 2, 2) of its section by the plane, in the ground's
    (x, z), or None (open, resting within ``tols[k]``, wholly below or above). Instances sharing a mesh are
    cut together (the same values as one at a time)."""
    from .contact import kept_surface

    out, held = [None] * len(ids), scene_arrays(scene)
    ids = np.asarray(ids, np.intp)
    for first, rows in mesh_groups(held, ids):
        inst = scene.instances[ids[first]]
        if inst.mesh is None or not inst.casts or not len(inst.mesh.faces):
            continue
        u, f, _, edge = kept_surface(inst.mesh)
        if not len(f):
            continue
        rows = np.asarray(rows)
        T = held["transform"][ids[rows]]
        y = np.matmul(u, T[:, 1, :3].T).T + T[:, 1, 3:] - ground      # (bodies, V) heights, all at once
        # below the plane by more than its tolerance (else it rests: its footprint), above it by more (else its
        # lid lies flush with the ground: the ground there is its lid, open), and its surface above the plane
        # closed (no open or non-manifold edge reaching above it)
        tol = np.asarray(tols)[rows]
        cut_by = (y.min(axis=1) < -tol) & (y.max(axis=1) > tol)
        if len(edge):
            cut_by &= y[:, edge].max(axis=1) <= tol
        rows, T = rows[cut_by], T[cut_by]
        if not len(rows):
            continue
        w = np.matmul(u[None], T[:, :3, :3].transpose(0, 2, 1)) + T[:, None, :3, 3]
        # cut where the body rises above the plane by more than its tolerance: a face of it flush with the
        # ground, within that above it (a step's tread, a lid), is the ground there, open, not a section
        seg, cut = _cut(w, f, w[:, :, 1] - ground - tol[cut_by, None])
        for k, r in enumerate(rows.tolist()):
            out[r] = seg[cut[k]:cut[k + 1]] if cut[k + 1] > cut[k] else None
    return out


def sections(scene) -> list:
    """The sections of ``scene``'s casters sunk partly into its ground (closed, or closed above it), in the
    ground's (x, z).

    Returns
    -------
    list of ndarray
        Per instance crossing the plane: float64 outline segments (E, 2, 2)
        of its section (world x, z). Empty without a ground plane. Kept with
        the scene's arrays until the scene changes.
    """
    from .contact import _on_ground

    return [x for _, x, _ in _on_ground(scene, "sections", _sections)]


def section_mask(scene, p, held):
    """(N,) bool: which points ``p`` (N, 3) lie on the ground (:func:`pyshadow.contact._on_plane`) inside a sunk
    closed body's section, farther than its tolerance from the section's outline; None where the scene has no
    section (``held``: the scene's arrays)."""
    from .contact import _ground_key, _on_ground, _on_plane, _plane_offsets

    found = _on_ground(scene, "sections", _sections, held)
    if not found:
        return None
    key = _ground_key(held, "section parts", scene.ground)
    parts = held.get(key)
    if parts is None:
        segs = [s for _, s, _ in found]
        seg = _ragged_parts(segs)
        lo = np.array([s.min(axis=(0, 1)) for s in segs])
        hi = np.array([s.max(axis=(0, 1)) for s in segs])
        parts = held[key] = (seg, lo, hi, np.array([t for _, _, t in found], np.float64))
    (seg, seg_first, seg_count), lo, hi, tol = parts
    mask = np.zeros(len(p), bool)
    off = _plane_offsets(scene, p)
    cand = np.flatnonzero(_on_plane(off, tol.max()))
    if not len(cand):
        return mask
    q_all = p[cand][:, [0, 2]].astype(np.float64)
    pid, rows = _grid_pairs(q_all, lo, hi)
    ok = _on_plane((off[0][cand][rows], off[1][cand][rows]), tol[pid])
    ok &= np.all((q_all[rows] >= lo[pid]) & (q_all[rows] <= hi[pid]), axis=1)
    pid, rows = pid[ok], rows[ok]
    q = q_all[rows]
    odd = np.zeros(len(q), bool)
    far = np.ones(len(q), bool)
    for s, e, c, j in _expanded(seg_count[pid]):
        k = c + s
        ends = seg[seg_first[pid[k]] + j]
        a, b, x = ends[:, 0], ends[:, 1], q[k]
        span = (a[:, 1] > x[:, 1]) != (b[:, 1] > x[:, 1])         # the segment spans the point's z
        with np.errstate(divide="ignore", invalid="ignore"):
            at = a[:, 0] + (x[:, 1] - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
        hits = span & (at > x[:, 0])                               # crossed by the half-line along +x
        odd[s:e] ^= (np.bincount(c, hits, minlength=e - s) % 2).astype(bool)
        t = tol[pid[k]]
        far[s:e] &= np.bincount(c, _square_distance(x, a, b) <= t * t, minlength=e - s) == 0
    inside = odd & far
    mask[cand[rows[inside]]] = True
    return mask

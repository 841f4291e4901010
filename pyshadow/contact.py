"""Closed bodies resting on the ground plane: the footprint whose rays enter the body.

A point of the ground under a closed body that lies on it (the faces of its
underside within the ground's tolerance of the plane) is inside the body's
footprint: every ray leaving it upwards enters the body at once and must
leave it through its surface, so it is occluded; downwards the ground
occludes it. The CSM cannot answer this near the footprint's edge: a ray
leaving such a point outwards at a low elevation crosses a sliver of the body
thinner than a texel (the silhouette's limit; ``benchmarks/README.md``, "The
extremes"). The footprint is known exactly from the mesh and its pose, so
the CSM backends answer those points from it (:func:`contact_mask`).

A face lies on the ground within ``1e-5`` of its own body's world bounding
radius (:func:`_face_tolerances`) of the plane. A point lies on a body's
footprint within the same, or within the rounding its height may carry
where that is larger (far from ``y = 0`` the float32 points of the plane
lie off it by more; :func:`_on_plane`). A point counts as inside the
footprint when it lies in one of the contact faces (seen from above) and
farther than ``1e-5`` of the body's radius from the footprint's outline, so
the points of the body's sides just above the ground stay the CSM's. Each
body's own size, not the scene's: beside a caster 200x larger, the lid of a
resting 1 mm box lay within the scene's band (2 mm) and counted as ground
under the box, its rays all occluded.

Only casters added with their mesh (:meth:`pyshadow.Scene.add` from a mesh,
or a CSM with ``mesh=``) whose surface is closed have a footprint (every edge
of its distinct faces shared by two, vertices of equal coordinates merged,
whatever the faces' winding: duplicate, reversed and zero-area faces do not
open it); an open mesh lying on the ground encloses nothing, and a body sunk
below the plane does not rest on it: the ground's points inside a body sunk
partly into it are those of its section (:mod:`pyshadow.contact_sunk`).

An open caster's faces that lie on the ground (the floor of a box without a
lid, a sheet) coincide with the ground under them instead: a point of the
ground there is a point of the caster's surface, asked as one
(:func:`ground_sheet_slots`, through :meth:`pyshadow.Scene.caster_slots`).

A body resting on another body closes in the face under it the same way (:mod:`pyshadow.contact_bodies`): a
point on a closed caster's face (within ``1e-5`` of its radius, or its float32 rounding) that touches another
body's face (a receiver's too), farther than that from the touching region's outline, is occluded on every ray
into the body, and its AO is 0 where its normal faces into the body (a lower box's lid under an upper box; a
point of the body's own face, its normal out of it, keeps the CSM's answer). The CSM alone let light through
within a texel of the upper body's edge (AO up to 0.56 at 32 samples; Embree: 0).
"""
from __future__ import annotations

import numpy as np

from ._validate import check_rows, float32_exact
from .contact_parts import _CHUNK, _grid_pairs, _in_parts, _in_triangles_of, _inside, _kept_parts, _outlines
from .contact_sunk import section_mask
from .mesh_kept import MeshKept
from .scene_arrays import mesh_groups, scene_arrays

__all__ = ["ground_tolerance", "footprints", "contact_mask", "occlude_contacts", "close_contacts", "sheets",
           "ground_sheet_slots"]

# mesh -> its distinct vertices, faces, faces in their first winding and the vertices of its edges not shared by
# exactly two faces (:func:`kept_surface`; a mesh changed in place misses, and is replaced)
_SURFACES = MeshKept()


def ground_tolerance(scene) -> float:
    """Distance to the ground plane within which a point lies on it (world units): :func:`plane_tolerance`
    of the scene's scale and ground height.

    The one definition of the ground test of a ray: the kernels' (``ground_eps``), the float64 mirror's,
    Embree's and the shadow maps' all read it. It differs from ``1e-5 * scene.scale()`` only for points
    below the plane (a point above it is above it either way). A body's face lies on the plane within
    ``1e-5`` of the body's radius (:func:`_face_tolerances`); the footprints' and sheets' points within
    that or the rounding their heights may carry (:func:`_on_plane`).
    """
    return plane_tolerance(scene.scale(), scene.ground)


def _face_tolerances(held) -> np.ndarray:
    """(n,) distance to the ground plane within which each instance's face lies on it, and its
    footprint's outline margin: ``1e-5`` of its world bounding radius (``held``: the scene's arrays).
    The mesh and its pose are float64; a float32 spacing at a far plane's height, a metre at y = 1e7,
    would rest a lifted body on it."""
    return 1e-5 * held["world_radius"]


def _plane_offsets(scene, p):
    """(distance to the ground plane, the rounding the height may carry), (N,) float64 each, of points
    ``p`` (N, 3): half a float32 spacing at the plane's height for a height float32 holds exactly (a
    float32 point of a plane far from ``y = 0`` lies up to that far off it; float64 arrays of such points
    too), one float64 spacing for any other."""
    y = p[:, 1].astype(np.float64)
    g = abs(scene.ground)
    rounding = np.where(float32_exact(y), 0.5 * float(np.spacing(np.float32(g))), float(np.spacing(g)))
    return np.abs(y - scene.ground), rounding


def _on_plane(offsets, tol) -> np.ndarray:
    """(N,) bool: which points lie on the ground plane for a body's footprint or sheet of tolerance
    ``tol`` (float or (N,)), given their :func:`_plane_offsets`: within ``tol`` of it, or within the
    rounding their heights may carry where that is larger. Not one float32 spacing for every point: a
    float64 point 0.5 above a plane at y = 1e7 (float32 spacing 1), on a resting slab's lid, counted as
    under the slab and its rays upwards as occluded."""
    dist, rounding = offsets
    return dist <= np.maximum(tol, rounding)


def plane_tolerance(scale, ground) -> float:
    """``1e-5 * scale``, or one float32 spacing at the plane's height ``ground`` where that is larger.

    Points come as float32 (a G-buffer's, a user's array), the nearest of which lies up to half a
    spacing off the plane: at y = 1000.1 up to 2.4e-5 below it beside ``1e-5 * scale`` = 8.7e-6 for unit
    bodies, so every ray of such a point upwards crossed the plane and was occluded (AO 0 where the
    float64 points read 1). The spacing exceeds ``1e-5 * scale`` only where ``|ground|`` exceeds about
    ``84 * scale``; nearer planes keep ``1e-5 * scale`` exactly. ``ground`` None: no plane, the first term.
    """
    tol = 1e-5 * float(scale)
    if ground is None:
        return tol
    return max(tol, float(np.spacing(np.float32(abs(ground)))))


def _closed_surface(mesh):
    """The mesh's distinct vertices (U, 3) (equal coordinates merged) and its distinct faces over them
    (F, 3), each once whatever its winding (sorted indices), zero-area faces dropped; None where the
    surface is open (an edge not shared by exactly two of them). Object frame, found once per mesh
    (:data:`_SURFACES`)."""
    u, f, _, open_ends = kept_surface(mesh)
    return (u, f) if len(f) and not len(open_ends) else None


def kept_surface(mesh):
    """:func:`_distinct_surface` of ``mesh`` (distinct vertices, faces, each face in its first winding) and the
    vertices of its edges not shared by exactly two faces (none: closed), found once per mesh (:data:`_SURFACES`;
    the footprints, the touching bodies and the sections of sunk bodies share it)."""
    got = _SURFACES.get(mesh)
    if got is None:
        u, f, wound = _distinct_surface(mesh)
        e, count = _edges(f)
        got = _SURFACES[mesh] = (u, f, wound, np.unique(e[count != 2]))
    return got


def _distinct_surface(mesh):
    """:func:`_closed_surface`'s distinct vertices (U, 3), distinct faces (F, 3) (sorted rows) and each face in
    its first winding, of any mesh, open or closed (not kept)."""
    v, faces = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces)
    u, merged = np.unique(v, axis=0, return_inverse=True)
    f = np.sort(merged.reshape(-1)[faces], axis=1)
    scale = max(float(np.ptp(v, axis=0).max()), 1e-300)
    if not 1e-100 < scale < 1e100 and np.isfinite(scale):
        # areas of sizes beyond about 1e-154 or 1e154 under- or overflow: every face was dropped as
        # zero-area; measured on the mesh moved to the origin and scaled by a power of two to size ~1
        unit = 2.0 ** -int(np.frexp(scale)[1])
        v, scale = (v - v.min(axis=0)) * unit, scale * unit
    a, b, c = v[faces[:, 0]], v[faces[:, 1]], v[faces[:, 2]]
    area2 = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    keep = (area2 > 1e-12 * scale * scale) & (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2])
    f, first = np.unique(f[keep], axis=0, return_index=True)
    wound = merged.reshape(-1)[faces][keep][first]      # each distinct face in its first winding
    return u, f, wound


def _edges(f):
    """Edges (sorted index pairs, in order) of faces with sorted rows, and how many faces share each."""
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [0, 2]]]).astype(np.int64)
    m = int(e.max()) + 1 if len(e) else 1          # an edge's key: its pair's place in that order
    key, count = np.unique(e[:, 0] * m + e[:, 1], return_counts=True)
    return np.stack([key // m, key % m], axis=1).astype(f.dtype, copy=False), count


def _footprints(scene, ids, ground, tols):
    """Per instance ``ids[k]``: (triangles (K, 3, 2), outline segments (E, 2, 2)) in the ground's (x, z), or None.

    The body must rest on the ground (no vertex of its faces below it by more than its ``tols[k]``: the side
    above its faces on the plane is its inside) and its surface must be closed (every edge of its distinct
    faces shared by two), whatever its winding: every ray leaving such a face upwards meets the surface
    again. Instances sharing a mesh are moved together (the same values as one at a time)."""
    out, found, held = [None] * len(ids), [], scene_arrays(scene)
    ids = np.asarray(ids, np.intp)
    for first, rows in mesh_groups(held, ids):          # by mesh, in the order of the bodies first placing it
        inst = scene.instances[ids[first]]
        if inst.mesh is None or not inst.casts or not len(inst.mesh.faces):
            continue
        mesh = inst.mesh
        surface = _closed_surface(mesh)
        if surface is None:
            continue                                    # open: it encloses nothing
        u, f = surface
        T = held["transform"][ids[rows]]
        u = np.matmul(u[None], T[:, :3, :3].transpose(0, 2, 1)) + T[:, None, :3, 3]
        h, t = u[:, :, 1] - ground, np.asarray(tols)[rows]
        # the surface's vertices: a stray vertex below the plane lost the footprint (sunk: not resting on it)
        on = (h <= t[:, None])[:, f].all(axis=2) & (h[:, f].min(axis=(1, 2)) >= -t)[:, None]
        hit = np.flatnonzero(on.any(axis=1))
        body, face = np.nonzero(on[hit])                # body by body, its faces in order
        found.append((np.asarray(rows)[hit], u[hit][:, :, [0, 2]], body, f[face]))
    nb = np.cumsum([0] + [len(g[0]) for g in found])
    if nb[-1]:
        edge, cut = _outlines(np.concatenate([g[3] for g in found]),
                              np.concatenate([g[2] + b for g, b in zip(found, nb)]), int(nb[-1]))
        for (ks, xz, body, fk), b in zip(found, nb):    # each group's bodies' triangles and outlines at once
            tri = xz[body[:, None], fk]                 # (faces, 3, 2)
            tcut = np.searchsorted(body, np.arange(len(ks) + 1))
            ecut = cut[b:b + len(ks) + 1]
            seg = xz[np.repeat(np.arange(len(ks)), np.diff(ecut))[:, None], edge[ecut[0]:ecut[-1]]]
            ecut = ecut - ecut[0]
            for j, k in enumerate(ks.tolist()):         # edges of one contact face: the outline
                out[k] = tri[tcut[j]:tcut[j + 1]], seg[ecut[j]:ecut[j + 1]]
    return out


def footprints(scene) -> list:
    """The contact footprints of ``scene``'s closed casters on its ground, in the ground's (x, z).

    Returns
    -------
    list of (ndarray, ndarray)
        Per instance in contact: float64 triangles (K, 3, 2) of its faces
        lying on the ground (world x, z), and the footprint's outline
        segments (E, 2, 2). Empty without a ground plane. Kept with the
        scene's arrays until the scene changes.
    """
    return [x for _, x, _ in _on_ground(scene, "contact", _footprints)]


def _ground_key(held, name, ground):
    """``(name, ground)``: the key of a table kept in ``held`` (a scene's arrays) for this ground height. The
    tables of ``name`` at other heights go: they were kept until the scene changed, which setting
    ``Scene.ground`` is not (a ground moved every frame under unmoved bodies kept four more tables a frame)."""
    key = (name, float(ground))
    if key not in held:
        for old in [k for k in list(held) if type(k) is tuple and len(k) == 2 and k[0] == name]:
            held.pop(old, None)
    return key


def _on_ground(scene, name, make, held=None):
    """``[(caster slot, x, tol)]`` over the casters whose mesh's box reaches down to the ground plane (within
    their own tolerance ``tol``, :func:`_face_tolerances`), ``x`` of ``make(scene, instance numbers, ground,
    tolerances)``'s list where not None; kept with the scene's arrays (``held``, or fetched here) as ``name``."""
    ground = scene.ground               # (read once: another thread may set it meanwhile)
    if ground is None or not scene.instances:
        return []
    held = scene_arrays(scene) if held is None else held
    key = _ground_key(held, name, ground)
    got = held.get(key)                 # (what is stored is returned: another height's store may drop the key)
    if got is None:
        tol = _face_tolerances(held)
        near_key = _ground_key(held, "near ground", ground)
        near = held.get(near_key)       # found once for every table (its boxes were read per table)
        if near is None:
            lowest = held["world_centre"][:, 1] - held["world_radius"]
            near = np.flatnonzero(held["casts"] & (lowest <= ground + tol))
            near = held[near_key] = near[_box_bottom(scene, held, near) <= ground + tol[near]]
        slot = np.cumsum(held["casts"]) - 1            # a caster's position in Scene.casters
        found = make(scene, near, ground, tol[near])
        got = held[key] = [(int(slot[i]), x, float(tol[i])) for i, x in zip(near, found) if x is not None]
    return got


def _sheets(scene, ids, ground, tols):
    """:func:`_sheet` of each instance ``ids[k]`` with its tolerance ``tols[k]``: asked only of the instances
    whose mesh may have sheets (a caster's open mesh of faces, decided once per mesh)."""
    ids, out = np.asarray(ids, np.intp), [None] * len(ids)
    for first, rows in mesh_groups(scene_arrays(scene), ids):
        inst = scene.instances[ids[first]]
        if inst.mesh is None or not inst.casts or not len(inst.mesh.faces) or _closed_surface(inst.mesh) is not None:
            continue
        for k in rows.tolist():
            out[k] = _sheet(scene.instances[ids[k]], ground, float(tols[k]))
    return out


def _sheet(inst, ground, tol):
    """Triangles (K, 3, 2) in the ground's (x, z) of an open caster's faces lying on the ground whose
    upper side is open to the sky (the vertical ray from the face's centroid meets no other face of the
    body above it), or None. A closed caster's are its footprint; an open one that still covers the
    face (a box whose edges are not all shared, say) encloses the ground there: not a sheet."""
    mesh = inst.mesh
    if mesh is None or not inst.casts or len(mesh.faces) == 0 or _closed_surface(mesh) is not None:
        return None
    T = inst.transform
    v = np.asarray(mesh.vertices, np.float64) @ T[:3, :3].T + T[:3, 3]
    faces = np.asarray(mesh.faces)
    f = faces[(np.abs(v[:, 1] - ground) <= tol)[faces].all(axis=1)]
    if len(f):
        f = f[~_covered(v[f].mean(axis=1), v[faces], ground + tol)]
    return v[:, [0, 2]][f] if len(f) else None


def _covered(c, tri, above):
    """(n,) bool: whether the vertical line through each point ``c`` (n, 3) crosses one of the triangles
    ``tri`` (F, 3, 3) higher than ``above`` (world y)."""
    out = np.zeros(len(c), bool)
    a, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    det = e1[:, 0] * e2[:, 2] - e1[:, 2] * e2[:, 0]             # the triangle's signed area in (x, z), x2
    ok = np.abs(det) > 1e-300
    a, e1, e2, det = a[ok], e1[ok], e2[ok], det[ok]
    step = max(1, _CHUNK // max(len(a), 1))
    for s in range(0, len(c), step):
        d = c[s:s + step, None, :] - a[None]
        u = (d[..., 0] * e2[:, 2] - d[..., 2] * e2[:, 0]) / det
        w = (e1[:, 0] * d[..., 2] - e1[:, 2] * d[..., 0]) / det
        y = a[:, 1] + u * e1[:, 1] + w * e2[:, 1]
        out[s:s + step] = ((u >= 0) & (w >= 0) & (u + w <= 1) & (y > above)).any(axis=1)
    return out


def sheets(scene) -> list:
    """The faces of ``scene``'s open casters that lie on its ground, in the ground's (x, z).

    Returns
    -------
    list of (int, ndarray)
        Per open caster with such faces: its caster slot (position in
        :attr:`pyshadow.Scene.casters`) and float64 triangles (K, 3, 2) of
        those faces (world x, z). Empty without a ground plane. Kept with
        the scene's arrays until the scene changes.
    """
    return [(k, x) for k, x, _ in _on_ground(scene, "sheets", _sheets)]


def ground_sheet_slots(scene, points, own):
    """Caster slots ``own`` (N,) with the ground's points on an open caster's face on the ground made its.

    A face of an open body lying on the ground (the floor of a box without
    a lid, a sheet) coincides with the ground under it: a point there is a
    point of that body's surface, and its rays leave through the face as
    from the body's own side (Embree's do). Asked as the ground, with no
    self-bias against the body, the coincident face shadowed about half of
    them. A point whose slot is the ground's or a receiver's (-2), within
    ``1e-5`` of that body's radius of the plane (or the rounding its height may
    carry, where larger: :func:`_on_plane`) and inside (or on) such a face seen from above takes
    that caster's slot.

    Returns
    -------
    ndarray of int32, shape (N,)
        ``own`` itself where no point changes, else a changed copy.
    """
    p = check_rows(points, "points")
    if np.shape(own) != (len(p),):
        raise ValueError(f"own must have shape ({len(p)},) (one caster slot per point), got {np.shape(own)}")
    if not isinstance(own, np.ndarray):             # a list: indexed and copied as an array below
        own = np.asarray(own)
        own = own.astype(np.int32) if own.dtype.kind in "iu" or not len(own) else own
    if own.dtype.kind not in "iu":
        raise TypeError(f"own must hold integer caster slots, got dtype {own.dtype}")
    # the arrays first: another thread's move landing before the sheets are found keeps no parts of the old poses
    held = scene_arrays(scene)
    found = _on_ground(scene, "sheets", _sheets, held) if len(own) else []
    if not found:
        return own
    tris, _, lo, hi, tol = _kept_parts(held, _ground_key(held, "sheet parts", scene.ground),
                                       lambda: ([tri for _, tri, _ in found], None, [t for _, _, t in found]))
    off = _plane_offsets(scene, p)
    cand = np.flatnonzero((np.asarray(own) == -2) & _on_plane(off, tol.max()))
    off = (off[0][cand], off[1][cand])
    q_all = p[cand][:, [0, 2]].astype(np.float64)
    # (sheet, point) candidates from a grid over the points (each point against every sheet's box was
    # O(sheets x points): 100,000 leaves on the ground); a point on several sheets takes the last one's slot
    pid, rows = _grid_pairs(q_all, lo, hi)
    ok = np.all((q_all[rows] >= lo[pid]) & (q_all[rows] <= hi[pid]), axis=1)
    pid, rows = pid[ok], rows[ok]
    ok = _on_plane((off[0][rows], off[1][rows]), tol[pid])
    pid, rows = pid[ok], rows[ok]
    hit = _in_triangles_of(q_all[rows], pid, tris)                   # inside or on one of its triangles
    pid, rows = pid[hit], rows[hit]
    if not len(pid):
        return own
    last = np.full(len(cand), -1)
    np.maximum.at(last, rows, pid)
    out = own.copy()
    on = np.flatnonzero(last >= 0)
    out[cand[on]] = np.array([slot for slot, _, _ in found])[last[on]]
    return out


def _box_bottom(scene, held, ids):
    """(n,) lowest world height of the instances' meshes' object-frame boxes (-inf without a mesh): the
    exact test, which moves every vertex, runs only where the box reaches the ground."""
    meshes = [scene.instances[i].mesh for i in ids]
    # instances share meshes: each mesh's box read once
    _, first, back = np.unique(np.array([id(m) for m in meshes], np.int64), return_index=True, return_inverse=True)
    none = np.array([[-np.inf] * 3, [np.inf] * 3])
    boxes = np.array([none if meshes[j] is None or not len(meshes[j].vertices) else meshes[j].bounds
                      for j in first]).reshape(-1, 2, 3)
    lo, hi = boxes[back.ravel(), 0], boxes[back.ravel(), 1]
    T = held["transform"][ids]
    row = T[:, 1, :3]                                   # world y = row . v + t_y (scale included)
    with np.errstate(invalid="ignore"):
        low = np.nan_to_num(np.minimum(row * lo, row * hi), nan=0.0, neginf=-np.inf).sum(axis=1)  # -inf: no mesh
    return low + T[:, 1, 3]


def _in_triangles(q, tri):
    """(n,) bool: points ``q`` (n, 2) inside or on one of the triangles ``tri`` (K, 3, 2)."""
    return _inside(tri[None, :, 0], tri[None, :, 1], tri[None, :, 2], q[:, None, :]).any(axis=1)


def contact_mask(scene, points):
    """Which points lie on the ground inside a closed body's footprint (all their rays are occluded).

    Parameters
    ----------
    scene : pyshadow.Scene
    points : ndarray, shape (N, 3)
        World points (float32 or float64).

    Returns
    -------
    ndarray of bool, shape (N,), or None
        True where the point lies on the ground plane (within ``1e-5`` of the
        resting body's radius, or the rounding its height may carry where
        larger: :func:`_on_plane`), inside one of that body's contact faces
        seen from above and farther than ``1e-5`` of its radius from the
        footprint's outline, or inside the section of a body sunk partly
        into the ground (:mod:`pyshadow.contact_sunk`). None when the
        scene has no footprint or section (nothing to test).
    """
    p = check_rows(points, "points")
    # the arrays first: another thread's move landing before the footprints are found keeps no parts of the old poses
    held = scene_arrays(scene)
    fps = _on_ground(scene, "contact", _footprints, held)     # footprints(scene), with the casters' slots
    sunk = section_mask(scene, p, held)         # the ground inside bodies sunk partly into it
    if not fps:
        return sunk
    mask = np.zeros(len(p), bool) if sunk is None else sunk
    parts = _kept_parts(held, _ground_key(held, "contact parts", scene.ground), lambda: (
        [tri for _, (tri, _), _ in fps], [seg for _, (_, seg), _ in fps], [t for _, _, t in fps]))
    tol = parts[4]
    off = _plane_offsets(scene, p)
    cand = np.flatnonzero(_on_plane(off, tol.max()))
    if not len(cand):
        return mask
    off = (off[0][cand], off[1][cand])
    q_all = p[cand][:, [0, 2]].astype(np.float64)
    pid, rows = _grid_pairs(q_all, *parts[2:4])                 # in a footprint's box
    ok = _on_plane((off[0][rows], off[1][rows]), tol[pid])
    pid, rows = pid[ok], rows[ok]
    mask[cand[rows[_in_parts(q_all[rows], pid, parts, tol)]]] = True
    return mask


def _in_place(a, name):
    """TypeError naming ``name`` where ``a``, an output changed in place, is no NumPy array (a list failed
    in indexing with a message naming nothing)."""
    if not isinstance(a, np.ndarray):
        raise TypeError(f"{name} must be a NumPy array (it is changed in place), got {type(a).__name__}")


def occlude_contacts(scene, points, directions, visible):
    """``visible`` (N,) bool with the rays that leave a footprint's point upwards or along the ground, and a
    body's contact face into the body (:func:`pyshadow.contact_bodies.body_hits`), set occluded (in place).

    The points of :func:`contact_mask`; a ray downwards keeps its answer (the
    ground plane's). A ray along the ground (``w_y = 0``) runs inside the
    body: it kept the CSM's answer, which is undefined inside a solid (84 of
    1000 such rays from under a resting box read open).
    """
    _in_place(visible, "visible")
    mask = contact_mask(scene, points)
    if mask is not None and (np.shape(directions) != (len(mask), 3) or np.shape(visible) != (len(mask),)):
        raise ValueError(f"directions (N, 3) and visible (N,) must match points' {len(mask)} rows, got "
                         f"{np.shape(directions)} and {np.shape(visible)}")
    if mask is not None:
        visible[mask & (np.asarray(directions)[:, 1] >= 0)] = False
    from .contact_bodies import body_hits

    for k, n in body_hits(scene, points):            # on a body's contact face, going into it
        visible[k[np.asarray(directions, np.float64)[k] @ n > 0]] = False
    return visible


def close_contacts(scene, points, normals, ao, bent, *zero):
    """The AO kernel's outputs of the footprint's points, and of the points on a body's contact face whose
    normal faces into the body (:func:`pyshadow.contact_bodies.body_hits`), set to "no open sample" (in place).

    ``ao`` (N,) 0, ``bent`` (N, 3) the ``normals`` (what the kernel gives
    a point with no open sample), every array of ``zero`` (None: skipped)
    0 on those rows (the shadowed SH transfer, the sampled sky).
    """
    for name, out in (("ao", ao), ("bent", bent), *((f"zero[{k}]", z) for k, z in enumerate(zero) if z is not None)):
        _in_place(out, name)
    mask = contact_mask(scene, points) if len(points) else None
    from .contact_bodies import FACING, body_hits

    for k, n in body_hits(scene, points):            # on a body's contact face, facing into it
        mask = np.zeros(len(points), bool) if mask is None else mask
        mask[k[np.asarray(normals, np.float64)[k] @ n >= FACING]] = True
    if mask is None or not mask.any():
        return
    ao[mask], bent[mask] = 0.0, normals[mask]
    for out in zero:
        if out is not None:
            out[mask] = 0.0

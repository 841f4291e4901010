"""Mesh loading, validation, hole filling and the normalised frame.

Every per-object structure of pyshadow (depth maps, CSMs) lives in the
object's *normalised frame*: ``p_norm = (p - centre) / radius`` with the
object's bounding sphere (:func:`bounding_sphere`). See the conventions
in :mod:`pyshadow`.
"""
from __future__ import annotations

import hashlib
import os
import warnings
from itertools import combinations
from pathlib import Path

import numpy as np
import trimesh

from ._validate import check_transform, flag
from .materials import GLTF_SUFFIXES, VISUAL_KEY, _mesh_visual, join_visuals, visual_of
from .mesh_files import read_mesh_file
from .mesh_sphere import kept_per_mesh, minimum_nsphere

__all__ = ["MeshCleanupWarning", "load_mesh", "bounding_sphere", "close_holes", "mesh_hash", "normalised_vertices",
           "normalised_bounds", "float32_unit"]

#: Coordinates whose largest magnitude lies in [2**-UNIT_BAND, 2**UNIT_BAND] are used as they are by
#: the float32 ray tracer and the sphere fit; outside, they are scaled by :func:`float32_unit`.
UNIT_BAND = 20


class MeshCleanupWarning(UserWarning):
    """Faces were removed from a mesh while loading it (degenerate or duplicate)."""


def _as_trimesh(source, label: str, gltf: bool | None = None):
    """Turn what trimesh gives back for ``source`` into one Trimesh (no processing) and its visual.

    Returns the new mesh (geometry only) and its :class:`pyshadow.materials.MeshVisual` (or None),
    aligned with the new mesh's faces. A scene's meshes are placed and concatenated exactly as
    ``Scene.to_geometry`` does (the same vertices and faces: :func:`mesh_hash` does not depend on
    the visuals), but each mesh's visual is read from the scene's own geometry (trimesh's copies
    lose glTF's ``COLOR_0``), reversed where the node's transform reverses the faces' winding, and
    joined per face corner (:func:`pyshadow.materials.join_visuals`). ``gltf``: as
    :func:`pyshadow.materials.mesh_visual`.
    """
    if isinstance(source, trimesh.Trimesh):
        return trimesh.Trimesh(vertices=np.array(source.vertices, dtype=np.float64),
                               faces=np.array(source.faces, dtype=np.int64), process=False), \
            _mesh_visual(source, label, gltf, None)
    if isinstance(source, trimesh.Scene):
        if not any(isinstance(g, trimesh.Trimesh) for g in source.geometry.values()):
            raise ValueError(f"{label}: the scene holds no triangle meshes")
        # every node's geometry moved by its transform, as to_geometry concatenates it (which keeps the
        # meshes, unless paths outnumber them)
        parts = source.dump()
        meshes = [g for g in parts if isinstance(g, trimesh.Trimesh)]
        if sum(trimesh.util.is_instance_named(g, "Path") for g in parts) > len(meshes):
            raise ValueError(f"{label}: the scene could not be concatenated into one mesh")
        if not meshes:
            return trimesh.Trimesh(process=False), None
        vertices, faces = trimesh.util.append_faces([m.vertices.copy() for m in meshes],
                                                    [m.faces.copy() for m in meshes])
        geom = trimesh.Trimesh(vertices=np.array(vertices, dtype=np.float64),
                               faces=np.array(faces, dtype=np.int64).reshape(-1, 3), process=False)
        cache = ({}, {})
        return geom, join_visuals([(_part_visual(source, m, label, gltf, cache), len(m.faces)) for m in meshes],
                                  label)
    raise ValueError(f"{label}: not a triangle mesh (trimesh returned {type(source).__name__}" + (
        f": {len(source.vertices)} points and no faces)" if isinstance(source, trimesh.PointCloud) else ")"))


def _part_visual(scene, part, label, gltf, cache):
    """The visual of ``part`` (a mesh of ``scene.dump()``) read from the scene geometry it copies.

    ``cache``: (visual by geometry name, decoded images) shared by the parts of one scene.
    """
    visuals, images = cache
    name = part.metadata.get("name")
    orig = scene.geometry.get(name) if isinstance(name, str) else None
    if not isinstance(orig, trimesh.Trimesh) or orig.faces.shape != part.faces.shape:
        return _mesh_visual(part, label, gltf, images)
    if name not in visuals:
        visuals[name] = _mesh_visual(orig, label, gltf, images)
    visual = visuals[name]
    if visual is None or np.array_equal(part.faces, orig.faces):
        return visual
    if np.array_equal(part.faces, orig.faces[:, ::-1]):          # a mirroring node: trimesh's fliplr
        return visual.reversed()
    return _mesh_visual(part, label, gltf, images)


def check_mesh(mesh: trimesh.Trimesh, label: str = "mesh") -> None:
    """Raise ValueError unless ``mesh`` has triangles, finite vertices and faces that index them.

    What every mesh pyshadow is given must hold, cleaned or not (:func:`load_mesh` cleans and checks;
    a mesh object handed to :meth:`pyshadow.Scene.add` or :meth:`pyshadow.CoherentShadowMap.build`
    is used as it is, and checked here).
    """
    if not isinstance(mesh, trimesh.Trimesh):
        raise TypeError(f"{label}: expected a trimesh.Trimesh, got {type(mesh).__name__}")
    if len(mesh.faces) == 0 or len(mesh.vertices) == 0:
        raise ValueError(f"{label}: the mesh has no triangles (empty mesh)")
    if mesh.faces.min() < 0 or mesh.faces.max() >= len(mesh.vertices):
        raise ValueError(f"{label}: a face refers to a vertex that does not exist")
    bad = ~np.isfinite(mesh.vertices).all(axis=1)
    if bad.any():       # (every vertex: vertex_ao answers one per vertex)
        i, unused = int(np.argmax(bad)), not bad[np.asarray(mesh.faces).reshape(-1)].any()
        raise ValueError(f"{label}: {int(bad.sum())} of {len(bad)} vertices are not finite (NaN or inf), e.g. vertex "
                         f"{i} = {mesh.vertices[i]}" + (" (no face uses them: pyshadow.load_mesh(mesh) drops them)"
                                                      if unused else ""))


def load_mesh(path_or_trimesh, fill_holes: bool = False) -> trimesh.Trimesh:
    """Load and validate a triangle mesh.

    Parameters
    ----------
    path_or_trimesh : str, os.PathLike, trimesh.Trimesh, trimesh.Scene or pyvista.DataSet
        A file trimesh can read (OBJ, PLY, STL, OFF, GLB/GLTF, ...) or a mesh
        object (pyvista's: :func:`pyshadow.viz.polydata_to_mesh`). OBJ's relative (negative)
        indices count back from the line that holds them, concave faces of 5 or more corners
        (OBJ, PLY, OFF) are tiled, and a binary PLY may mix triangles and larger polygons
        (:mod:`pyshadow.mesh_files`). A scene (GLB/GLTF, an OBJ with several materials) is
        flattened: every node's transform is applied and the meshes are
        concatenated (as ``Scene.to_geometry``), each keeping its own colours,
        material colour and texture.
    fill_holes : bool, optional
        Close every boundary loop with a fan of triangles around the loop's
        centroid (see :func:`close_holes`). Closed meshes compress much better:
        thesis 000, section 5.2.1 reports 30.5:1 instead of 17.5:1 for the
        hole-filled Stanford bunny at 64x128 maps.

    Returns
    -------
    mesh : trimesh.Trimesh
        Vertices float64 (V, 3), faces int64 (T, 3); vertices no face uses
        dropped, coincident ones merged; degenerate faces (repeated vertices or zero area) and
        duplicate faces (the same three vertices in any order or winding)
        removed. Visual attributes (vertex or face colours, UVs and a base
        colour texture) take no part in merging: they are kept per face
        corner, aligned with the cleaned faces, as a
        :class:`pyshadow.materials.MeshVisual` in
        ``mesh.metadata["pyshadow_visual"]`` (linear RGB; absent when the
        source has none). Vertex and face colours are decoded from sRGB,
        except glTF's linear ``COLOR_0`` (a path ending in ``.glb`` or
        ``.gltf``, or a mesh object from trimesh's glTF reader:
        :func:`pyshadow.materials.is_gltf`; the rule is in
        :mod:`pyshadow.materials`). A scene's meshes each keep their own
        colours, material colour and texture
        (:func:`pyshadow.materials.join_visuals`; a mesh without colours is
        white). Vertices, faces and :func:`mesh_hash` are the same
        with or without them. UVs that are not finite are kept: only a
        texture lookup needs them, and it refuses them
        (:func:`pyshadow.materials.point_colours`).

    Raises
    ------
    FileNotFoundError
        If ``path_or_trimesh`` is a path that does not exist.
    ValueError
        If the format is unknown, the file is empty or has no triangles, a vertex a face uses is NaN or
        infinite, an OBJ counts from 0, an ASCII STL is cut short, or a glTF stores its geometry in a way
        trimesh reads wrongly (:func:`pyshadow.mesh_files.check_gltf`: Draco without DracoPy, meshopt,
        normalised or sparse positions, triangle fans), names a buffer file not in its folder or holds
        fewer bytes than it says (:func:`pyshadow.gltf_files.check_gltf_buffers`); the message names
        the path and the reason.

    Warns
    -----
    MeshCleanupWarning
        When faces were removed, with their counts.
    UserWarning
        A glTF's image file not in its folder (read without it).

    Examples
    --------
    >>> import trimesh
    >>> m = load_mesh(trimesh.creation.box())
    >>> m.faces.shape
    (12, 3)
    """
    fill_holes = flag(fill_holes, "fill_holes")     # "no" closed the holes
    gltf = None             # a mesh object: pyshadow.materials.is_gltf tells
    if isinstance(path_or_trimesh, (trimesh.Trimesh, trimesh.Scene)):
        label = f"<{type(path_or_trimesh).__name__}>"
        raw = path_or_trimesh
    elif isinstance(path_or_trimesh, (str, os.PathLike)):
        path = Path(path_or_trimesh)
        label = str(path)
        if not path.exists():
            raise FileNotFoundError(f"mesh file not found: {path}")
        if not path.is_file():
            raise ValueError(f"{path}: not a regular file")
        gltf = True if path.suffix.lower() in GLTF_SUFFIXES else None
        raw = read_mesh_file(path, label)       # OBJ's relative indices as OBJ means them
    elif type(path_or_trimesh).__module__.split(".")[0] == "pyvista":      # its surface's triangles as a Trimesh
        from .viz.meshes import polydata_to_mesh
        label, raw = f"<{type(path_or_trimesh).__name__}>", polydata_to_mesh(path_or_trimesh)
    else:
        raise TypeError(f"load_mesh expects a path, a trimesh.Trimesh/Scene or a pyvista mesh, "
                        f"got {type(path_or_trimesh).__name__}")

    if isinstance(raw, trimesh.Scene) and len(raw.geometry) == 0:
        raise ValueError(f"{label}: the file holds no geometry (empty mesh)")
    mesh, visual = _as_trimesh(raw, label, gltf)      # the visual per corner of its faces, which merging keeps
    mesh = referenced_mesh(mesh)     # first: a far vertex no face used coarsened the merge, a NaN one was refused
    check_mesh(mesh, label)

    mesh.merge_vertices(merge_tex=True, merge_norm=True, digits_vertex=_merge_digits(mesh.vertices))
    faces = np.asarray(mesh.faces)
    verts = np.asarray(mesh.vertices)

    # degenerate: repeated indices or zero area (relative to the mesh size)
    repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
    tri = verts[faces]
    with np.errstate(over="ignore"):           # an area beyond float64 is not zero: kept
        cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        area2 = np.linalg.norm(cross, axis=1)
    extent = float(np.ptp(verts, axis=0).max()) or 1.0
    thr = 1e-12 * extent
    flat = area2 <= thr * thr if thr < 1e150 else area2 / thr <= thr     # (thr**2 would overflow)
    degenerate = repeated | flat
    # duplicates: the same vertex set, whatever the order or winding
    key = np.sort(faces, axis=1)
    keep = ~degenerate
    idx = np.flatnonzero(keep)
    _, first = np.unique(key[idx], axis=0, return_index=True)
    unique_mask = np.zeros(len(faces), dtype=bool)
    unique_mask[idx[first]] = True
    n_degenerate = int(degenerate.sum())
    n_duplicate = int(keep.sum() - unique_mask.sum())
    if n_degenerate or n_duplicate:
        warnings.warn(
            f"{label}: removed {n_degenerate} degenerate and {n_duplicate} duplicate faces "
            f"of {len(faces)}",
            MeshCleanupWarning,
            stacklevel=2,
        )
    kept = np.sort(np.flatnonzero(unique_mask))
    faces = faces[kept]
    if len(faces) == 0:
        raise ValueError(f"{label}: every face is degenerate (empty mesh after cleaning)")
    mesh = trimesh.Trimesh(vertices=verts, faces=faces, process=False)
    mesh.remove_unreferenced_vertices()
    if visual is not None:
        mesh.metadata[VISUAL_KEY] = visual.take(kept).attached_to(mesh.faces)
    if fill_holes:
        mesh = close_holes(mesh)
    return mesh


def _merge_digits(verts) -> int | None:
    """Decimal digits to which :func:`load_mesh` rounds vertices to merge them (None: trimesh's 8).

    trimesh merges vertices closer than 1e-8 (absolute), rounding ``v * 1e8``
    to int64: a mesh smaller than a millimetre loses its detail (a bunny of
    1.6 micrometres kept 1,600 of its 69,451 faces) and coordinates beyond
    about 9e10 overflow int64. Below an extent of 1e-3 the tolerance is
    therefore 1e-5 of the extent (as at 1e-3), and it is never finer than
    int64 holds; meshes between those bounds merge as before.
    """
    v = np.asarray(verts, dtype=np.float64)
    if not len(v):
        return None
    extent, big = float(np.ptp(v, axis=0).max()), float(np.abs(v).max())
    digits = 8
    if 0.0 < extent < 1e-3:
        digits += int(np.ceil(-3.0 - np.log10(extent)))
    if big > 0.0:                                   # |v| 10**digits below 4e18 (int64), 10**digits a float64
        digits = min(digits, int(np.floor(np.log10(4e18) - np.log10(big))), 300)
    return None if digits == 8 else digits


def _boundary_loops(faces: np.ndarray) -> list[list[tuple[int, int]]]:
    """Directed boundary edges (a, b) of ``faces`` chained head to tail into closed loops; a chain that
    breaks where the winding changes (a face flipped beside a hole: its pieces got fans of their own and
    the hole stayed open) is chained again whatever the edges' directions (:func:`_undirected_loops`)."""
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    und = np.sort(directed, axis=1)
    _, inverse, counts = np.unique(und, axis=0, return_inverse=True, return_counts=True)
    boundary = directed[counts[inverse.ravel()] == 1]
    outgoing: dict[int, list[int]] = {}
    for a, b in boundary.tolist():
        outgoing.setdefault(a, []).append(b)
    loops, broken = [], []
    for start in sorted(outgoing):
        while outgoing.get(start):
            loop = []
            a = start
            while True:
                nxt = outgoing[a]
                b = nxt.pop()
                loop.append((a, b))
                a = b
                if a == start or not outgoing.get(a):
                    break
            (loops if a == start else broken).append(loop)
    return loops + _undirected_loops([e for chain in broken for e in chain])


def _undirected_loops(edges: list[tuple[int, int]]) -> list[list[tuple[int, int]]]:
    """Boundary edges chained into loops through their shared vertices, whatever their direction; each
    edge is kept as ``(a, b)``, as its face has it (a loop that cannot close ends where it must)."""
    at: dict[int, list[int]] = {}
    for k, (a, b) in enumerate(edges):
        at.setdefault(a, []).append(k)
        at.setdefault(b, []).append(k)
    used, loops = [False] * len(edges), []
    for first in (k for k in range(len(edges)) if not used[k]):
        used[first], (start, v), loop = True, edges[first], [edges[first]]
        while v != start and (k := next((k for k in at[v] if not used[k]), None)) is not None:
            used[k] = True
            loop.append(edges[k])
            v = edges[k][1] if edges[k][0] == v else edges[k][0]
        loops.append(loop)
    return loops


def close_holes(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Close every boundary loop of ``mesh`` with a triangle fan.

    Each loop of boundary edges gets one new vertex at the loop's centroid
    and one triangle per boundary edge, wound against the edge so the new
    faces continue the orientation of their neighbours.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        A mesh from :func:`load_mesh`.

    Returns
    -------
    trimesh.Trimesh
        A new mesh; ``is_watertight`` holds when every boundary was a
        simple closed loop, whatever the winding of the faces along it. A
        :class:`pyshadow.materials.MeshVisual` of ``mesh`` is carried over
        (:meth:`pyshadow.materials.MeshVisual.with_fans`).
    """
    faces = np.asarray(mesh.faces, dtype=np.int64)
    verts = np.asarray(mesh.vertices, dtype=np.float64)
    new_verts = [verts]
    new_faces = [faces]
    n = len(verts)
    loops = _boundary_loops(faces)
    for loop in loops:
        if len(loop) < 3:
            continue
        ring = np.array([a for a, _ in loop])
        if any(b != c for (_, b), (c, _) in zip(loop, loop[1:] + loop[:1])):     # edges of both windings
            ring = np.unique(loop)
        centre = verts[ring].mean(axis=0)
        new_verts.append(centre[None])
        fan = np.array([(b, a, n) for a, b in loop], dtype=np.int64)
        new_faces.append(fan)
        n += 1
    out = trimesh.Trimesh(vertices=np.concatenate(new_verts), faces=np.concatenate(new_faces), process=False)
    visual = visual_of(mesh)
    if visual is not None:
        out.metadata[VISUAL_KEY] = visual.with_fans(faces, loops).attached_to(out.faces)
    return out


def float32_unit(magnitude) -> float:
    """A power of two that brings coordinates of size ``magnitude`` near 1, or 1 where they are already.

    A float32 triangle test multiplies up to three coordinates together: beyond
    about 7e12 (the cube root of float32's largest number) its products
    overflow, below about 2e-13 they leave float32's normal range, and rays
    pass through triangles (Embree, measured: every ray near a unit box scaled
    by 1e13 or 1e-15 answers differently). Scaling by a power of two changes
    no significand, so the answers of coordinates scaled by it are those of
    the scene at size 1, and within ``2**+-UNIT_BAND`` of 1 nothing is scaled:
    the answers there are bit for bit those of the coordinates themselves.

    Parameters
    ----------
    magnitude : float
        The largest absolute coordinate, any unit; 0 or not finite: 1 is returned.

    Returns
    -------
    float
        1.0, or ``2**-round(log2(magnitude))`` where ``magnitude`` lies outside
        ``[2**-UNIT_BAND, 2**UNIT_BAND]``.
    """
    m = float(magnitude)
    if not (np.isfinite(m) and m > 0.0) or 2.0 ** -UNIT_BAND <= m <= 2.0 ** UNIT_BAND:
        return 1.0
    return float(2.0 ** -max(np.round(np.log2(m)), -1023.0))     # subnormal magnitudes: 2**1023 at most


def _ball_through(p: np.ndarray):
    """The smallest sphere through the 1 to 4 points ``p`` (k, 3): (centre, squared radius) or None."""
    a = p[1:] - p[0]
    if len(p) < 3:
        c = p[0] + 0.5 * a.sum(axis=0)
    elif len(p) == 3:
        n = np.cross(a[0], a[1])
        if not n @ n > 1e-24:
            return None
        c = p[0] + np.cross((a[0] @ a[0]) * a[1] - (a[1] @ a[1]) * a[0], n) / (2.0 * (n @ n))
    else:
        if not abs(np.linalg.det(a)) > 1e-18:
            return None
        c = p[0] + np.linalg.solve(2.0 * a, (a * a).sum(axis=1))
    return c, float(((p - c) ** 2).sum(axis=1).max())


def _smallest_ball(points: np.ndarray) -> np.ndarray:
    """Centre of the smallest sphere around ``points`` (n, 3), of extent near 1: the point farthest
    outside the sphere of a support set (at most 4 points) joins it, and the new sphere is the smallest
    through it and 0 to 3 of the set around them all. Each step grows the sphere, ending at the smallest
    around all the points (to a relative 1e-12), or after 40 steps (points on one sphere to round-off)."""
    support = [int(np.argmax(((points - points.mean(axis=0)) ** 2).sum(axis=1)))]
    centre, r2 = points[support[0]], 0.0
    for _ in range(40):
        d2 = ((points - centre) ** 2).sum(axis=1)
        far = int(np.argmax(d2))
        if d2[far] <= r2 * (1.0 + 1e-12) or far in support:
            break
        q, best = points[support + [far]], None
        for k in range(min(len(support), 3) + 1):
            for sub in combinations(range(len(support)), k):
                ball = _ball_through(q[list(sub) + [len(support)]])
                if ball is not None and (best is None or ball[1] < best[1][1]) and \
                        ((q - ball[0]) ** 2).sum(axis=1).max() <= ball[1] * (1.0 + 1e-10) + 1e-30:
                    best = [support[i] for i in sub] + [far], ball
        if best is None:
            break
        support, (centre, r2) = best
    return centre


def referenced_mesh(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """``mesh``, or where a vertex is used by no face, a new mesh (not processed) of the vertices its faces use,
    in their order, and its faces in theirs renumbered; ``mesh`` itself where it has no faces or a face past its
    vertices. The geometry the frame is fitted and checked on: a far vertex no face used widened the sphere."""
    faces, n = np.asarray(mesh.faces), len(mesh.vertices)
    if not faces.size or faces.min() < 0 or faces.max() >= n:
        return mesh
    used = np.zeros(n, bool)
    used[faces.reshape(-1)] = True
    return mesh if used.all() else trimesh.Trimesh(np.asarray(mesh.vertices)[used], (np.cumsum(used) - 1)[faces],
                                                   process=False)


@kept_per_mesh
def bounding_sphere(mesh: trimesh.Trimesh) -> tuple[np.ndarray, float]:
    """Minimal sphere around the vertices the mesh's faces use: the object's normalised frame.

    Parameters
    ----------
    mesh : trimesh.Trimesh

    Returns
    -------
    centre : ndarray, shape (3,), float64
    radius : float
        At least the largest vertex distance from ``centre`` (enlarged by a
        relative 1e-9 so every vertex maps inside the unit sphere after
        ``p_norm = (p - centre) / radius``). Vertices no face uses are left
        out (all vertices of a mesh without faces are taken).

    Notes
    -----
    The minimal enclosing sphere of the convex-hull vertices (trimesh's ``minimum_nsphere``, bit for bit,
    found faster by :mod:`pyshadow.mesh_sphere`; kept per mesh for its content), deterministic and independent
    of vertex order beyond round-off. That fit is the best vertex of a furthest-site Voronoi diagram, or a
    least-squares sphere where the hull's vertices lie on one: where it is over 1 % larger than the smallest
    sphere (a tetrahedron's circumsphere, a dome's whole sphere) or qhull fails (a flat mesh), the smallest
    sphere is taken instead; on the bundled meshes the fit is 0.005-0.45 % larger than the smallest.
    """
    mesh = referenced_mesh(mesh)
    verts = np.asarray(mesh.vertices, dtype=np.float64)
    if len(verts) == 0:
        raise ValueError("bounding_sphere: the mesh has no vertices")
    bad = ~np.isfinite(verts).all(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"bounding_sphere: {int(bad.sum())} of {len(bad)} vertices are not finite (NaN or inf), "
                         f"e.g. vertex {i} = {verts[i]}")
    # the fit (qhull) on a mesh of extent near 1: scaled by an exact power of two (float32_unit) where
    # its extent is not, and below 2**-10 (a mesh in micrometres fell back to the box's centre, 0.8 %
    # wider than the sphere at size 1); a flat or degenerate hull falls back to the smallest sphere below
    extent = float(np.ptp(verts, axis=0).max())
    unit = float32_unit(extent)
    if unit == 1.0 and 0.0 < extent < 2.0 ** -10:     # qhull's absolute tolerances fail it below about 5e-5
        unit = float(2.0 ** -np.round(np.log2(extent)))
    # far from the origin (beyond 2**20 extents) the fit sees the mesh moved to its box's centre, exactly
    # (Sterbenz: each coordinate within a factor 2 of it): qhull on raw coordinates 1e12 extents away fell
    # back to the box's centre, a sphere 5 % wider than the same mesh's at the origin
    shift = 0.5 * (verts.min(axis=0) + verts.max(axis=0))
    if not float(np.abs(shift).max()) > 2.0 ** 20 * extent:
        shift = None
    fit = verts if unit == 1.0 and shift is None else (verts if shift is None else verts - shift) * unit
    try:
        centre, _ = minimum_nsphere(fit)        # trimesh's, bit for bit, faster (mesh_sphere; NumPy errors off)
        centre = np.asarray(centre, dtype=np.float64) / unit
        if shift is not None:
            centre = centre + shift
        if not np.isfinite(centre).all():
            raise ValueError
        slack = 0.01
    except Exception:
        lo, hi = verts.min(axis=0), verts.max(axis=0)
        centre = 0.5 * (lo + hi)
        slack = 1e-9
    # trimesh returns its least-squares sphere wherever the hull's vertices lie on one (a tetrahedron's
    # circumsphere: 13x the smallest for a flat one; a dome's whole sphere: 2x) and qhull fails on a flat
    # hull (the box's centre: a triangle's sphere changed by 14 % under rotation): the smallest sphere
    # is taken where it is smaller than the fit by over 1 % (the fit, one of qhull's vertices, is
    # larger by 0.005-0.45 % on the bundled meshes: kept), than the box's sphere beyond round-off
    mid, size = 0.5 * (verts.min(axis=0) + verts.max(axis=0)), float(np.ptp(verts, axis=0).max())
    if size > 0.0 and np.isfinite(size):
        small = mid + size * _smallest_ball((verts - mid) / size)
        d_small, d_fit = (float((((verts - c) * unit) ** 2).sum(axis=1).max()) for c in (small, centre))
        if d_small < d_fit * (1.0 - slack) ** 2:
            centre = small
    radius = float(np.sqrt((((verts - centre) * unit) ** 2).sum(axis=1).max())) / unit
    if not radius > 0:
        raise ValueError("bounding_sphere: all vertices coincide (radius 0)")
    return centre, radius * (1.0 + 1e-9)


def stand_on_ground(mesh, *, radius: float = 1.0, position=(0.0, 0.0), rotation=None,
                    ground: float = 0.0) -> np.ndarray:
    """A rigid transform that sizes a mesh and stands it on the ground plane.

    Parameters
    ----------
    mesh : trimesh.Trimesh or pyvista.DataSet
        A pyvista mesh as :func:`load_mesh` takes it (its surface's triangles), so ``Scene.add(it, T)`` fits.
    radius : float, optional
        World radius of the mesh's bounding sphere (uniform scale).
    position : (float, float), optional
        World ``(x, z)`` of the bounding sphere's centre.
    rotation : array_like, shape (3, 3) or (4, 4), optional
        Rotation about the bounding sphere's centre, applied before standing (a 4x4 contributes only its 3x3).
    ground : float, optional
        Height of the plane the lowest vertex touches.

    Returns
    -------
    ndarray, shape (4, 4), float64
    """
    try:
        radius = float(radius)
    except (TypeError, ValueError):
        raise TypeError(f"stand_on_ground: radius must be a number, got {radius!r}") from None
    if not (np.isfinite(radius) and radius > 0):
        raise ValueError(f"stand_on_ground: radius must be finite and positive, got {radius}")
    pos = np.asarray(position, dtype=np.float64)
    if pos.shape != (2,) or not np.isfinite(pos).all() or not np.isfinite(ground):
        raise ValueError(f"stand_on_ground: position must be 2 finite numbers (x, z) and ground finite, "
                         f"got {position!r} and {ground!r}")
    if not isinstance(mesh, trimesh.Trimesh):       # a pyvista mesh (or a TypeError, not an AttributeError)
        from .viz.meshes import _surface_mesh
        mesh = _surface_mesh(mesh, "stand_on_ground: mesh")
    c, r = bounding_sphere(mesh)
    Rm = np.eye(3) if rotation is None else np.asarray(rotation, dtype=np.float64)
    if Rm.shape not in ((3, 3), (4, 4)):
        raise ValueError(f"stand_on_ground: rotation must be 3x3 or 4x4, got shape {Rm.shape}")
    Rm = Rm[:3, :3]
    check_transform(np.block([[Rm, np.zeros((3, 1))], [np.zeros((1, 3)), np.ones((1, 1))]]), rigid=True,
                    name="stand_on_ground: rotation")
    T = np.eye(4)
    T[:3, :3] = float(radius) / r * Rm
    T[:3, 3] = np.array([pos[0], 0.0, pos[1]]) - T[:3, :3] @ c
    low = (np.asarray(referenced_mesh(mesh).vertices) @ T[:3, :3].T + T[:3, 3])[:, 1].min()
    T[1, 3] += float(ground) - low
    return T


def normalised_vertices(mesh: trimesh.Trimesh, centre=None, radius=None) -> np.ndarray:
    """Vertices in the normalised frame, float64 (V, 3)."""
    if centre is None or radius is None:
        centre, radius = bounding_sphere(mesh)
    else:
        from ._embree_checks import check_frame

        centre, radius = check_frame((centre, radius), "normalised_vertices")
    return (np.asarray(mesh.vertices, dtype=np.float64) - centre) / radius


def normalised_bounds(mesh: trimesh.Trimesh, centre, radius) -> np.ndarray:
    """The mesh's axis-aligned bounding box ``(lo, hi)`` in the normalised frame, float64 (2, 3)."""
    return (np.asarray(mesh.bounds, dtype=np.float64) - centre) / radius


def mesh_hash(mesh: trimesh.Trimesh) -> str:
    """SHA-256 (hex) of the mesh's vertices (float64) and faces (int64)."""
    if not isinstance(mesh, trimesh.Trimesh):
        raise TypeError(f"mesh_hash: expected a trimesh.Trimesh, got {type(mesh).__name__}")
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(mesh.vertices, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(mesh.faces, dtype="<i8").tobytes())
    return h.hexdigest()

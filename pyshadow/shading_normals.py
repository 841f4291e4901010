"""Smooth shading normals with sharp creases, and the hemisphere rule that goes with them (issue 19).

Stage "render" option ``normals="smooth"`` (:func:`pyshadow.render.render`).
The G-buffer holds each pixel's geometric (face) normal; a tessellated curved
surface then shades as facets (every facet of the bundled torus is a band in
its AO image). With smooth normals each pixel's *shading normal* is
interpolated from its face's corners instead:

Corner normals (:func:`corner_normals`, once per mesh and crease angle,
cached with the mesh)
    The normal of corner ``(f, v)`` is the angle-weighted sum (Thürmer and
    Wüthrich 1998: each face weighted by its angle at ``v``) of the unit
    normals of the faces around vertex ``v`` whose normal lies within the
    *crease angle* of face ``f``'s normal, normalised. Faces meeting at a
    larger dihedral angle keep a sharp crease between them; a face whose
    neighbours are all beyond the crease angle keeps its flat normal
    exactly. Vertices are shared by index (:func:`pyshadow.load_mesh`
    merges coincident ones). A face of no area, or none but for the rounding
    of its corners (:data:`SLIVER_SPACINGS`: the sliver closing a T-junction),
    has no normal: it takes no part, and its corner normals are 0. Computed in the mesh's own frame and carried to
    the world by the inverse transpose of the instance's 3x3 part.
Per pixel (:func:`shading_gbuffer`)
    The barycentric interpolation of the face's corner normals at the
    pixel's surface point (from the G-buffer's ``face`` and ``depth``,
    float64 on the host), normalised and turned to the side of the
    G-buffer's normal (the side facing the camera). Pixels of faces whose
    three corner normals equal the face normal keep the G-buffer's normal
    bit for bit, so a mesh without smooth regions renders exactly as with
    ``normals="flat"``. With the crease angle below 90 degrees every corner
    normal, hence every interpolated one, lies within it of the face normal:
    ``n_s . n_g > 0``.

The hemisphere rule (:func:`below_geometric`)
    AO, the sun and the sky's samples use the hemisphere of the shading
    normal ``n_s``: directions are drawn about it exactly as about a flat
    normal (:func:`pyshadow.sample_directions` of ``n_s``). A direction at or
    below the *geometric* tangent plane (``w . n_g <= 0``) would leave
    through the surface itself; it counts as occluded, decided analytically
    before any ray is traced (the usual guard against light leaking through
    a smoothed surface). Every backend applies the same rule on the same
    directions (:func:`ambient_occlusion`; the "sampled" and "transfer" sky
    and the sun through ``geometric_normals=`` in
    :mod:`pyshadow.lighting`), Embree included, so a backend's agreement
    with Embree is measured on identical rays.
"""
from __future__ import annotations

import math

import numpy as np

from ._validate import check_indices, check_rows, check_values, unit_normals
from .gbuffer import face_corners
from .gbuffer_items import pixels_by_item
from .materials import barycentrics
from .mesh_kept import MeshKept

__all__ = ["NORMAL_MODES", "DEFAULT_CREASE_ANGLE", "corner_normals", "check_crease_angle", "shading_gbuffer",
           "pixel_surface", "below_geometric", "ambient_occlusion"]

#: Accepted values of ``normals=``: the G-buffer's face normals, or interpolated ones with creases.
NORMAL_MODES = ("flat", "smooth")
#: Default crease angle, radians (30 degrees, Blender's default auto-smooth angle): faces meeting at a
#: larger angle keep a sharp edge. The bundled torus's facets meet at 5.6 and 15 degrees.
DEFAULT_CREASE_ANGLE = math.radians(30.0)
#: Relative tolerance of the crease angle: faces meeting at up to ``crease_angle * (1 + CREASE_RTOL)``
#: are smoothed, so that a dihedral angle equal to the crease angle (a 12-sided prism at the default 30
#: degrees) is decided alike at every edge and in every orientation, not by the rounding of the normals.
#: Never up to a right angle (:func:`_cos_crease`).
CREASE_RTOL = 2.0**-20
# pairs of corners at a vertex taken at once by corner_normals (about 150 bytes each)
_PAIRS = 1 << 18
#: A face whose height (twice its area over its longest edge) is at most this many float64 spacings of its
#: largest coordinate has a normal lost in the rounding of its corners (the zero-area sliver closing a
#: T-junction, its third corner the rounded midpoint of an edge): it takes no part in corner normals.
SLIVER_SPACINGS = 2.0**10

# mesh -> {crease angle: (corner normals (T, 3, 3), smooth face mask (T,))}; a mesh changed in place
# misses (and is replaced)
_CORNERS = MeshKept()


def check_crease_angle(angle) -> float:
    """``angle`` as a float in [0, pi/2) radians, or a ValueError naming it."""
    try:
        if isinstance(angle, (str, bytes)):     # float("0.5") read a string as radians
            raise TypeError
        a = float(angle)
    except (TypeError, ValueError):
        raise ValueError(f"crease_angle: expected a number of radians (got {angle!r})") from None
    if isinstance(angle, (bool, np.bool_)) or not (0.0 <= a < math.pi / 2):
        raise ValueError(f"crease_angle: expected radians in [0, pi/2) (got {angle!r}); at pi/2 or more a "
                         f"shading normal could turn away from its face")
    return a


def _cos_crease(crease: float) -> float:
    """The least cosine of smoothed faces' normals: of ``crease * (1 + CREASE_RTOL)``, below a right angle
    (the float below pi/2: cosine 2.8e-16 > 0). Within 8.6e-5 degrees of 90 the tolerance reached 90
    degrees: a cube's faces (normals at 90, cosine 0) were smoothed together at ``radians(89.99995)``
    (corner normals 54.7 degrees off their faces), and the corners of a zero-area face (normal 0) were not 0."""
    return math.cos(min(crease * (1.0 + CREASE_RTOL), math.nextafter(math.pi / 2, 0.0)))


def _vertices(mesh) -> np.ndarray:
    """The mesh's vertices as float64, scaled by a power of two (exactly: no direction or angle changes)
    to a largest |coordinate| in [0.5, 1) where it lies outside [2**-60, 2**60]: the squared lengths of
    the faces' cross products under- or overflowed below about 1e-77 or above 1e77 (corner normals of
    length 1e-206 at 1e-102, NaN ones beyond 1e154). ``np.ldexp``: the factor of a mesh whose coordinates
    are all subnormal (below 2**-1022) is beyond float64 (``2.0 ** 1030`` raised OverflowError)."""
    v = np.asarray(mesh.vertices, dtype=np.float64)
    big = float(np.abs(v).max()) if v.size else 0.0
    if 0.0 < big < 2.0**-60 or 2.0**60 < big < np.inf:
        v = np.ldexp(v, -math.frexp(big)[1])
    return v


def _face_normals(v, faces) -> np.ndarray:
    n = np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return n / np.where(length > 0, length, 1.0)


def _slivers(v, faces) -> np.ndarray:
    """Faces of no area but for the rounding of their corners (:data:`SLIVER_SPACINGS`), (T,) bool: their
    normal is noise, and their angle near pi at the middle corner gave it the most weight there (corner
    normals 15 degrees off around such a sliver in a curved patch)."""
    a, b, c = v[faces[:, 0]], v[faces[:, 1]], v[faces[:, 2]]
    cross = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    edge = np.max([np.linalg.norm(x, axis=1) for x in (b - a, c - a, c - b)], axis=0)
    size = np.abs(np.concatenate([a, b, c], axis=1)).max(axis=1, initial=0.0)
    return cross <= SLIVER_SPACINGS * np.finfo(np.float64).eps * size * edge


def _corner_angles(v, faces) -> np.ndarray:
    """Interior angle of each face at each of its corners, (T, 3) float64 radians."""
    out = np.empty(faces.shape)
    for k in range(3):
        a = v[faces[:, (k + 1) % 3]] - v[faces[:, k]]
        b = v[faces[:, (k + 2) % 3]] - v[faces[:, k]]
        out[:, k] = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))
    return out


def _neighbour_sums(fn, weight, vert, nverts: int, cos_crease: float):
    """Per corner ``c = 3 f + k`` (at vertex ``vert[c]``): the sum of ``weight[c'] fn[f']`` over the corners
    ``c'`` at the same vertex whose face ``f'`` has ``fn[f] . fn[f'] >= cos_crease`` (in the corners' sorted
    order), (3 T, 3), and how many of those ``fn[f']`` differ from ``fn[f]``, (3 T,).

    The pairs of corners in groups of about :data:`_PAIRS`, whole corners each (a corner's sum is added
    up in the same order): a vertex of valence k makes k^2 pairs, all at once 3 GB and 9 s for the apex
    of a cone of 4,000 sections (30 MB and 4 s in groups).
    """
    order = np.argsort(vert, kind="stable")
    counts = np.bincount(vert, minlength=nverts)
    size = counts[vert[order]]                                  # pairs (c, c') of each corner c, in sorted order
    first = np.concatenate([[0], np.cumsum(counts)])[vert[order]]
    end = np.cumsum(size)
    acc, differ = np.zeros((len(vert), 3)), np.zeros(len(vert))
    a = 0
    while a < len(order):
        b = max(a + 1, int(np.searchsorted(end, end[a] - size[a] + _PAIRS, side="right")))
        cs, sz = order[a:b], size[a:b]
        c, local = np.repeat(cs, sz), np.repeat(np.arange(b - a), sz)
        offset = np.arange(len(c)) - np.repeat(np.cumsum(sz) - sz, sz)
        c2 = order[np.repeat(first[a:b], sz) + offset]
        f, f2 = c // 3, c2 // 3
        near = np.einsum("ij,ij->i", fn[f], fn[f2]) >= cos_crease
        f, f2, local, w = f[near], f2[near], local[near], weight[c2[near]]
        acc[cs] = np.column_stack([np.bincount(local, weights=w * fn[f2, j], minlength=b - a) for j in range(3)])
        differ[cs] = np.bincount(local, weights=(np.abs(fn[f2] - fn[f]).max(axis=1) > 0).astype(np.float64),
                                 minlength=b - a)
        a = b
    return acc, differ


def corner_normals(mesh, crease_angle: float = DEFAULT_CREASE_ANGLE, *, return_smooth: bool = False):
    """Unit shading normal of each face corner, in the mesh's own frame (module docstring).

    Parameters
    ----------
    mesh : trimesh.Trimesh
    crease_angle : float, optional
        Radians in [0, pi/2): faces whose normals differ by more (by more than
        ``crease_angle * (1 + CREASE_RTOL)``: ties alike everywhere) keep a crease.
    return_smooth : bool, optional
        Also return which faces have a corner normal other than their face normal.

    Returns
    -------
    normals : ndarray, shape (T, 3, 3), float64
        ``normals[f, k]`` belongs to vertex ``mesh.faces[f, k]`` of face ``f``
        (winding side). Read-only (cached with the mesh).
    smooth : ndarray, shape (T,), bool
        Only with ``return_smooth``.
    """
    crease = check_crease_angle(crease_angle)
    held = _CORNERS.setdefault(mesh, {})
    if crease not in held:
        v = _vertices(mesh)
        faces = np.asarray(mesh.faces, dtype=np.int64)
        fn = _face_normals(v, faces)
        fn[_slivers(v, faces)] = 0.0            # as a face of no area: excluded, its own corners 0
        weight = _corner_angles(v, faces).reshape(-1)
        # a dihedral angle equal to the crease angle but for rounding (a 12-sided prism at 30 degrees) is within it
        acc, differ = _neighbour_sums(fn, weight, faces.reshape(-1), len(v), _cos_crease(crease))
        length = np.linalg.norm(acc, axis=1, keepdims=True)
        own = np.repeat(fn, 3, axis=0)
        out = np.where(length > 0, acc / np.where(length > 0, length, 1.0), own).reshape(-1, 3, 3)
        # a corner whose only contributions are faces parallel to its own keeps the face normal exactly
        alone = differ == 0
        out.reshape(-1, 3)[alone] = own[alone]
        smooth = (out != fn[:, None, :]).any(axis=(1, 2))
        out.setflags(write=False)
        smooth.setflags(write=False)
        held[crease] = (out, smooth)
    out, smooth = held[crease]
    return (out, smooth) if return_smooth else out


def pixel_surface(items, gbuffer, camera):
    """Where each covered pixel lies on its mesh: item, face and barycentric coordinates.

    Parameters
    ----------
    items : sequence of (mesh, transform)
        The drawn items of the G-buffer (its ``object_id`` indexes them).
    gbuffer : dict
        :func:`pyshadow.render_gbuffer`'s form, with ``face``.
    camera : pyshadow.Camera

    Returns
    -------
    index : ndarray, shape (K,), int64
        Flat pixel index of each covered pixel.
    item, face : ndarray, shape (K,), int64
    bary : ndarray, shape (K, 3), float64
        In the face's corner order (:func:`pyshadow.materials.barycentrics`
        of the pixel's point ``eye + depth * ray`` in the world triangle).
    """
    if "face" not in gbuffer:
        raise ValueError("the G-buffer has no 'face' buffer: smooth normals and surface colours need each "
                         "pixel's face (pyshadow.render_gbuffer and pyshadow.embree.gbuffer give it)")
    obj = np.asarray(gbuffer["object_id"]).reshape(-1)
    index = np.flatnonzero(obj >= 0)
    item, face = obj[index].astype(np.int64), np.asarray(gbuffer["face"]).reshape(-1)[index].astype(np.int64)
    if len(item) and item.max() >= len(items):      # else a bare IndexError from items[i]
        raise ValueError(f"gbuffer['object_id'] holds id {int(item.max())} but there are {len(items)} items "
                         f"(the G-buffer was rendered from other items)")
    dirs = camera.ray_directions().reshape(-1, 3)[index]
    p = camera.eye + np.asarray(gbuffer["depth"]).reshape(-1)[index, None].astype(np.float64) * dirs
    bary = np.zeros((len(index), 3))
    for i, sel in pixels_by_item(item):
        bary[sel] = barycentrics(p[sel], face_corners(items, i, face[sel]))
    return index, item, face, bary


def shading_gbuffer(items, gbuffer, camera, crease_angle: float = DEFAULT_CREASE_ANGLE, surface=None) -> dict:
    """A copy of ``gbuffer`` whose ``normal`` is the smooth shading normal (module docstring).

    Parameters
    ----------
    items, gbuffer, camera :
        As in :func:`pixel_surface`.
    crease_angle : float, optional
        Radians, as in :func:`corner_normals`.
    surface : tuple, optional
        :func:`pixel_surface`'s result, if computed already.

    Returns
    -------
    dict
        The G-buffer's arrays, ``normal`` (H, W, 3) float32 replaced by the
        unit world shading normal (facing the camera's side, 0 on the
        background) and ``geometric_normal`` (H, W, 3) float32 the
        G-buffer's own normal.
    """
    crease = check_crease_angle(crease_angle)
    index, item, face, bary = pixel_surface(items, gbuffer, camera) if surface is None else surface
    ng = np.asarray(gbuffer["normal"], dtype=np.float32)
    out_n = ng.copy().reshape(-1, 3)
    for i, sel in pixels_by_item(item):
        mesh, T = items[i]
        corners, smooth = corner_normals(mesh, crease, return_smooth=True)
        sel = sel[smooth[face[sel]]]
        if not len(sel):
            continue
        M = np.linalg.inv(np.asarray(T, dtype=np.float64)[:3, :3])      # n_world ~ n @ M = M^T n
        f = face[sel]
        n = np.einsum("nk,nkj->nj", bary[sel], corners[f]) @ M
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        fn = _face_normals(_vertices(mesh), np.asarray(mesh.faces)[f]) @ M     # the face's normal, same map
        g = ng.reshape(-1, 3)[index[sel]].astype(np.float64)
        flip = np.einsum("ij,ij->i", fn, g) < 0
        out_n[index[sel]] = np.where(flip[:, None], -n, n).astype(np.float32)
    out = dict(gbuffer)
    out["normal"] = out_n.reshape(ng.shape)
    out["geometric_normal"] = ng
    return out


def below_geometric(directions, geometric_normals) -> np.ndarray:
    """Directions at or below the geometric tangent plane, ``w . n_g <= 0``: (N, S) bool.

    ``directions`` (N, S, 3) and ``geometric_normals`` (N, 3), any float
    type (the product is taken in float64).
    """
    d = np.asarray(directions, dtype=np.float64)
    g = np.asarray(geometric_normals, dtype=np.float64)
    return np.einsum("nsj,nj->ns", d, g) <= 0.0


def ambient_occlusion(scene, points, normals, geometric_normals, *, backend="csm", sampling=None, indices=None,
                      surface_ids=None, bias=None):
    """AO and bent normals about shading normals, under the hemisphere rule (module docstring).

    The backend's AO kernel answers every point whose shading normal is its
    geometric normal and every point none of whose directions falls below the
    geometric plane (the rule changes nothing there); the others are asked
    through :func:`pyshadow.visibility.visible` on the same directions
    (:func:`pyshadow.lighting.transfer.sample_visibility`) with the rule applied,
    in chunks of :data:`pyshadow.lighting.shade.SAMPLED_CHUNK_RAYS` rays.

    Parameters
    ----------
    scene : pyshadow.Scene
    points : ndarray, shape (N, 3), float64
        World positions.
    normals, geometric_normals : ndarray, shape (N, 3)
        World shading and geometric normals (``n_s . n_g > 0``; any length, normalised here).
    backend, sampling, indices, surface_ids, bias :
        As in :func:`pyshadow.visibility.ambient_occlusion`.

    Returns
    -------
    ao : ndarray, shape (N,), float32
    bent : ndarray, shape (N, 3), float32
        Unit; the unit shading normal where no direction reaches the sky.
    """
    from . import visibility as vis
    from .lighting.shade import SAMPLED_CHUNK_RAYS
    from .lighting.transfer import sample_visibility
    from .sampling import Sampling, ao_from_samples, sample_directions

    sampling = Sampling() if sampling is None else sampling
    n = check_rows(normals, "normals")
    ng = check_rows(geometric_normals, "geometric_normals")
    if len(ng) != len(n):
        raise ValueError(f"geometric_normals has {len(ng)} rows but normals has {len(n)} (shapes must match)")
    check_values(ng, "geometric_normals", nonzero=True)
    idx = check_indices(indices, len(n))
    ao, bent = vis.ambient_occlusion(scene, points, n, backend=backend, sampling=sampling, return_bent_normals=True,
                                     bias=bias, indices=idx, surface_ids=surface_ids)
    tilted = np.flatnonzero((n != ng).any(axis=1))
    ids = None if surface_ids is None else np.broadcast_to(np.asarray(surface_ids), (len(n),))
    step = max(1, SAMPLED_CHUNK_RAYS // sampling.samples)     # tilted points in chunks of rays, as the "sampled"
    for a in range(0, len(tilted), step):                     # sky: all at once took 0.8 (csm) to 1.4 GB (embree)
        t = tilted[a:a + step]                                # for 1e5 points at 64 samples, growing with N S
        below = below_geometric(sample_directions(n[t], sampling=sampling, indices=idx[t]), ng[t])
        redo = t[below.any(axis=1)]
        if len(redo):
            dirs, lit = sample_visibility(scene, np.asarray(points)[redo], n[redo], backend=backend,
                                          sampling=sampling, indices=idx[redo],
                                          surface_ids=None if ids is None else ids[redo], bias=bias,
                                          geometric_normals=ng[redo])
            # the bent normal of a point none of whose directions is lit is its unit normal, as the backends'
            # (a shading normal of length 1.04 came back as it was: length 1.04, or 1e-3 for one of 1e-3)
            ao[redo], bent[redo] = ao_from_samples(dirs, lit, unit_normals(n[redo], len(redo)),
                                                   return_bent_normals=True)
    return ao, bent

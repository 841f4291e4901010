"""Face corners of a mesh: barycentric weights of points, and corner attributes kept aligned with the faces.

A :class:`pyshadow.materials.MeshVisual` holds colours and UVs per *face
corner*, rows ``(T, 3, ...)`` in the order of ``mesh.faces`` when it was
attached (:func:`pyshadow.load_mesh`, :func:`pyshadow.mesh.close_holes`),
and records those faces (:attr:`~pyshadow.materials.MeshVisual.faces`).
trimesh re-orders the corners of faces in place: ``mesh.invert()`` and a
mirroring ``apply_transform`` reverse every row, ``trimesh.repair.fix_winding``
/ ``fix_normals`` reverse some, user code may roll them. The corner
attributes did not follow (a tetrahedron's red vertex showed green, yellow
and blue after ``invert()``). :func:`aligned_visual` (used by
:func:`pyshadow.materials.visual_of`) compares the faces with the recorded
ones and re-orders each row's corner attributes the way its face's corners
were re-ordered. Faces renumbered by trimesh without changing their corner
order (``merge_vertices``, ``remove_unreferenced_vertices``, ``unmerge_vertices``)
keep their attributes; faces that use other vertices are refused.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

__all__ = ["barycentrics", "aligned_visual"]

#: The six orders of a face's three corners; the identity first, then the reversal trimesh's ``fliplr`` makes.
_ORDERS = np.array([[0, 1, 2], [2, 1, 0], [1, 2, 0], [2, 0, 1], [0, 2, 1], [1, 0, 2]])


def aligned_visual(visual, mesh, name: str = "visual"):
    """``visual`` with its corner attributes in the corner order of ``mesh.faces`` now.

    Parameters
    ----------
    visual : pyshadow.materials.MeshVisual
        Attributes per face corner with the faces they were attached to
        (:attr:`~pyshadow.materials.MeshVisual.faces`, (T, 3) vertex ids;
        None: returned as it is).
    mesh : trimesh.Trimesh
        The mesh it is kept on, with T faces.
    name : str, optional
        What the visual is called in errors.

    Returns
    -------
    pyshadow.materials.MeshVisual
        ``visual`` itself when the faces are those recorded (or were only
        renumbered: each recorded vertex is one vertex now, or each vertex
        now is a copy, at the same position, of one recorded vertex);
        otherwise a copy whose ``colours`` and ``uv`` of each face whose
        corners were re-ordered (reversed, rolled) are re-ordered the same
        way, with ``mesh.faces`` recorded.

    Raises
    ------
    ValueError
        When faces use other vertices than those recorded (attributes of
        another mesh, or faces renumbered and re-ordered together).
    """
    was = visual.faces
    now = np.asarray(mesh.faces)
    if was is None or (now.shape == was.shape and np.array_equal(now, was)):
        return visual
    last = visual._aligned               # the answer for the faces of the last call: a render asks once per item
    if last and last[0].shape == now.shape and np.array_equal(last[0], now):
        return visual if last[1] is None else last[1]
    out = _aligned(visual, was, np.array(now, dtype=np.int64).reshape(-1, 3), mesh, name)
    visual._aligned[:] = [out.faces, out] if out is not visual else [np.array(now), None]
    return out


def _aligned(visual, was, now, mesh, name):
    """:func:`aligned_visual` for faces ``now`` (T, 3) int64 that differ from those recorded, ``was``."""
    rows = np.flatnonzero((now != was).any(axis=1))
    order, old = np.full(len(rows), -1), was[rows]
    for k in range(len(_ORDERS) - 1, -1, -1):           # the first order that matches wins (a repeated vertex)
        order[(old[:, _ORDERS[k]] == now[rows]).all(axis=1)] = k
    if (order >= 0).all():
        corner = np.tile(np.arange(3), (len(now), 1))
        corner[rows] = _ORDERS[order]
        turn = (lambda a: None if a is None else np.ascontiguousarray(np.take_along_axis(a, corner[:, :, None], 1)))
        return replace(visual, colours=turn(visual.colours), uv=turn(visual.uv), faces=now)
    if _renumbered(was, now, np.asarray(mesh.vertices)):
        return visual
    t = int(rows[order < 0][0])
    raise ValueError(f"{name} holds attributes of another mesh: {int((order < 0).sum())} of {len(now)} faces use "
                     f"other vertices than those its corners were attached to (face {t}: {now[t].tolist()}, "
                     f"attached to {was[t].tolist()})")


def _renumbered(was, now, vertices) -> bool:
    """Are faces ``now`` (T, 3) faces ``was`` with their vertices renumbered and every corner in place?

    Yes when each recorded vertex is one vertex now (trimesh's ``merge_vertices``, a renumbering), or each
    vertex now comes from one recorded vertex and its copies lie at the same position (``unmerge_vertices``:
    positions a transform moved alike; a re-ordered corner put copies of other vertices together).
    """
    a, b = was.ravel(), now.ravel()
    pairs = np.unique(np.stack([a, b], axis=1), axis=0)
    if len(np.unique(pairs[:, 0])) == len(pairs):
        return True
    if len(np.unique(pairs[:, 1])) != len(pairs) or b.max(initial=-1) >= len(vertices) or b.min(initial=0) < 0:
        return False
    _, first, group = np.unique(a, return_index=True, return_inverse=True)
    return bool(np.array_equal(vertices[b], vertices[b[first]][group.ravel()]))


def barycentrics(points, triangles) -> np.ndarray:
    """Barycentric coordinates of points in the plane of their triangles, (N, 3) float64.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Points on (or near) the triangles, any frame.
    triangles : ndarray, shape (N, 3, 3)
        Corners ``a, b, c`` in the same frame.

    Returns
    -------
    ndarray, shape (N, 3), float64
        Weights of ``a, b, c`` for the point's projection onto the plane,
        clamped to [0, 1] and renormalised to sum 1 (a pixel centre lies in
        its triangle up to the G-buffer's float32 depth).
    """
    p = np.asarray(points, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.float64)
    e1, e2, d = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0], p - t[:, 0]
    # each triangle scaled by a power of two to edges of about 1 (exact: the weights are those of the
    # unscaled triangle): the Gram determinant's fourth powers of the size underflowed to 0 below about
    # 1e-77 (every point got a's weight) and overflowed above about 1e77
    m = np.maximum(np.abs(e1).max(axis=1, initial=0.0), np.abs(e2).max(axis=1, initial=0.0))
    k = -np.frexp(np.where((m > 0) & (m < np.inf), m, 1.0))[1][:, None]
    e1, e2, d = np.ldexp(e1, k), np.ldexp(e2, k), np.ldexp(d, k)
    d11, d12, d22 = (np.einsum("ij,ij->i", x, y) for x, y in ((e1, e1), (e1, e2), (e2, e2)))
    d1, d2 = np.einsum("ij,ij->i", d, e1), np.einsum("ij,ij->i", d, e2)
    gram = d11 * d22 - d12 * d12
    den = np.where(gram > 0, gram, 1.0)
    v = (d22 * d1 - d12 * d2) / den
    w = (d11 * d2 - d12 * d1) / den
    # a sliver (sin^2 of its angle at a below 1e-10, the Gram determinant's weights off by up to 1e-6): that
    # determinant cancels to noise or 0 (a point then got a's weight); |e1 x e2|^2 and the triple products
    # lose only half as many digits
    thin = np.flatnonzero(~(gram > 1e-10 * d11 * d22))
    if len(thin):
        n = np.cross(e1[thin], e2[thin])
        nn = np.einsum("ij,ij->i", n, n)
        ok = nn > 0
        k, n, nn = thin[ok], n[ok], nn[ok]
        v[k] = np.einsum("ij,ij->i", np.cross(d[k], e2[k]), n) / nn
        w[k] = np.einsum("ij,ij->i", np.cross(e1[k], d[k]), n) / nn
    b = np.maximum(np.column_stack([1.0 - v - w, v, w]), 0.0)
    s = b.sum(axis=1, keepdims=True)
    return np.where(s > 0, b / np.where(s > 0, s, 1.0), 1.0 / 3.0)

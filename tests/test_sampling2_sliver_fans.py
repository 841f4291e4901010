"""Concave vertices whose fan is closed by a zero-area sliver (a T-junction filled watertight).

A face with three collinear corners has no plane (its rounded cross product points anywhere) but it
still closes the fans of its corners; references: the same corner without the T-junction, and the
exact fraction of the sample directions that stay in the notch's open octant.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from test_vertexao_corners import voxel_faces
from pyshadow.sampling import sample_directions
from pyshadow.vertex_points import concave_vertices

S = pyshadow.Sampling(64)
# a cube of side 1 about the origin with the octant x, y, z > 0 removed: a concave corner at the origin
_CUBES = [(i, j, k) for i in (0, 1) for j in (0, 1) for k in (0, 1) if (i, j, k) != (1, 1, 1)]


def _voxel_notch():
    """The notch as a closed mesh of unit-cube faces (each outer square two triangles), merged."""
    pad = np.zeros((4, 4, 4), bool)
    for c in _CUBES:
        pad[1 + c[0], 1 + c[1], 1 + c[2]] = True
    v, faces = voxel_faces(pad)
    return (v - 2.0) / 2.0, faces


def _t_junction(v, f):
    """``(v, f)`` with one face at the origin's vertex split at the midpoint of its edge from the origin,
    and the zero-area sliver (origin, far end, midpoint) that keeps the mesh watertight."""
    o = int(np.argmin(np.linalg.norm(v, axis=1)))
    f = f.tolist()
    i = next(i for i, t in enumerate(f) if o in t)
    k = f[i].index(o)
    a, x = f[i][(k + 1) % 3], f[i][(k + 2) % 3]
    m = len(v)
    v = np.vstack([v, (v[o] + v[a]) / 2])
    f[i] = [o, m, x]
    f += [[m, a, x], [o, a, m]]
    return v, np.array(f), o, a


@pytest.mark.parametrize("rotate", [False, True])
@pytest.mark.parametrize("scale, offset", [(1.0, 0.0), (1e-3, 1e4), (1e3, 0.0)])
def test_a_sliver_closing_a_t_junction_keeps_the_corner_concave(rotate, scale, offset):
    """Was: the notch's concave corner was not found (no concave vertex at all) once a T-junction at it
    was closed by a zero-area sliver: axis-aligned the sliver (area exactly 0) was left out, which opened
    the fan; rotated, its rounded cross product (about 1e-17) gave it a plane at random."""
    v, f = _voxel_notch()
    base = set(concave_vertices(v, f)[0].tolist())
    v2, f2, o, _ = _t_junction(v, f)
    assert trimesh.Trimesh(v2, f2, process=False).is_watertight
    if rotate:
        r = trimesh.transformations.rotation_matrix(0.7, [1.0, 2.0, 3.0])[:3, :3]
        v2 = v2 @ r.T
    idx, normals = concave_vertices(v2 * scale + offset, f2)
    assert base == {o}
    assert set(idx.tolist()) == base                    # the same vertices as without the T-junction
    assert np.isfinite(normals).all()
    used = np.linalg.norm(normals, axis=2) > 0
    assert np.allclose(np.linalg.norm(normals[used], axis=1), 1.0)


def test_vertex_ao_of_the_corner_behind_a_sliver():
    """Was: with the sliver the corner was not corrected and read 0.81 (16x32 maps @ 64^2) where the
    exact answer of its sample directions (and Embree) is 0.42; now as without the sliver (0.36)."""
    v, f = _voxel_notch()
    v2, f2, o, _ = _t_junction(v, f)
    mesh = trimesh.Trimesh(v2, f2, process=False)
    csm = pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(16, 32), resolution=64, progress=False)
    scene = pyshadow.Scene()
    k = scene.add(csm, mesh=mesh)
    p, n = scene.vertex_points(k)
    d = sample_directions(n, sampling=S)[o].astype(np.float64)
    exact = float((d > 0).all(axis=1).mean())           # the samples that stay in the open octant
    ao = scene.vertex_ao(k, sampling=S)
    assert abs(exact - 0.42) < 0.05
    assert abs(float(ao[o]) - exact) < 0.12


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_points_are_refused(bad):
    """Was: one NaN (or inf, with RuntimeWarnings) corner of a room (a box seen from inside, all 8 corners
    concave) was taken silently: the faces at it were dropped and 2 of the 8 corners came back."""
    box = trimesh.creation.box((1, 1, 1))
    v = box.vertices.copy()
    v[7, 0] = bad
    with pytest.raises(ValueError, match="points: 1 rows are not finite"):
        concave_vertices(v, box.faces[:, ::-1])

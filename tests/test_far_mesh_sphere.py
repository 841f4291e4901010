"""The bounding sphere (a CSM's frame) of a mesh far from the origin is the same mesh's at the origin, moved.

Before, qhull saw the raw coordinates: spot placed 1e12 from the origin (its extent about 1) fell back to
the box's centre, a sphere 5.2 % wider (its CSM then not the unit mesh's). The fit now sees such a mesh
moved to its box's centre, exactly, where the offset exceeds 2**20 extents.
"""
import numpy as np
import pytest
import trimesh

from pyshadow.data import mesh
from pyshadow.mesh import bounding_sphere


@pytest.mark.parametrize("name", ["spot", "torus", "fandisk"])
@pytest.mark.parametrize("offset", [1e9, 1e12])
def test_far_sphere_is_the_near_one_moved(name, offset):
    m = mesh(name)
    c0, r0 = bounding_sphere(m)
    move = np.array([offset, -offset / 3, offset / 7])
    c, r = bounding_sphere(trimesh.Trimesh(m.vertices + move, m.faces, process=False))
    # the vertices themselves are rounded by float64 at the offset: 2**-52 * 1e12 = 2.2e-4 at most
    tol = 4 * np.spacing(offset) / r0 + 1e-9
    assert r / r0 - 1 == pytest.approx(0.0, abs=tol)
    assert np.abs(c - move - c0).max() <= 4 * np.spacing(offset) + 1e-9 * r0

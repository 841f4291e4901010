"""Differential checks of view sets, sampling, the camera, shading normals and materials at their extremes.

Each test compares two computations that must agree (a mesh and the same mesh scaled by a power of two,
which float64 scales exactly) on input the functions accept.
"""
import math

import numpy as np
import pytest
import trimesh

from pyshadow.shading_normals import corner_normals


@pytest.mark.parametrize("exponent", [-1030, -1060, -1070])
def test_corner_normals_of_a_mesh_scaled_by_a_power_of_two_are_the_unit_meshs(exponent):
    """A mesh whose coordinates are all subnormal (below 2**-1022) raised OverflowError (34, 'Numerical
    result out of range') in corner_normals: its vertices were to be scaled by ``2.0 ** 1028`` (and more),
    a float beyond float64. Scaling by a power of two changes no direction or angle: the corner normals
    must equal those of the unscaled mesh bit for bit."""
    # a 4 x 4 height field of dyadic heights (exact at every exponent here): gentle slopes, smoothed
    i, j = np.meshgrid(np.arange(4.0), np.arange(4.0), indexing="ij")
    v = np.column_stack([i.ravel(), ((i * j) % 3).ravel() / 8.0, j.ravel()])
    q = (4 * i[:3, :3] + j[:3, :3]).ravel().astype(np.int64)
    faces = np.concatenate([np.column_stack([q, q + 1, q + 5]), np.column_stack([q, q + 5, q + 4])])
    unit = trimesh.Trimesh(v, faces, process=False)
    scaled = trimesh.Trimesh(np.ldexp(v, exponent), faces, process=False)
    assert (np.ldexp(np.asarray(scaled.vertices), -exponent) == v).all()      # the scaling itself is exact
    for crease in (0.0, math.radians(30.0), math.radians(60.0)):
        want, want_smooth = corner_normals(unit, crease, return_smooth=True)
        got, smooth = corner_normals(scaled, crease, return_smooth=True)
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(smooth, want_smooth)
    assert corner_normals(scaled, math.radians(30.0), return_smooth=True)[1].all()    # every face smoothed

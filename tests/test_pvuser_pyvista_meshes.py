"""A pyvista user's own meshes: per-vertex results back onto their points, and standing them on the ground.

``Scene.add(pv_mesh)`` cleans the mesh (coincident points merged, unused points dropped, a volume's
surface taken), so ``vertex_ao`` answers per vertex of the cleaned mesh; ``viz.point_values`` puts the
answers back on the dataset's own points. ``stand_on_ground`` takes a pyvista mesh as ``load_mesh`` does.
"""
import numpy as np
import pytest

pv = pytest.importorskip("pyvista")

import pyshadow  # noqa: E402
from pyshadow import viz  # noqa: E402


def _split_meshes():
    return [pv.Cylinder(center=(0.0, 0.5, 0.0), direction=(0.0, 1.0, 0.0), radius=0.4, height=1.0),
            pv.Cube(center=(0.0, 0.5, 0.0), clean=False),
            pv.Sphere(radius=500.0, center=(1e5, 500.0, 2e5)).compute_normals(split_vertices=True,
                                                                              feature_angle=10.0)]


@pytest.mark.parametrize("k", range(3))
def test_point_values_follow_positions_of_split_points(k):
    """Each of the dataset's points takes the value of the cleaned mesh's vertex at its position (millimetres
    far from the origin too); before, the only route was ``poly["ao"] = ao``, which pyvista refused
    (200 values for 400 points on the cylinder)."""
    poly = _split_meshes()[k]
    mesh = pyshadow.load_mesh(poly)
    assert len(mesh.vertices) < poly.n_points                      # points were merged
    index = viz.point_values(poly, mesh, np.arange(len(mesh.vertices)))
    assert index.shape == (poly.n_points,) and not np.isnan(index).any()
    np.testing.assert_array_equal(mesh.vertices[index.astype(np.int64)], np.asarray(poly.points, np.float64))
    rows = viz.point_values(poly, mesh, np.asarray(mesh.vertices, np.float32))    # (V, 3): rows kept, float32
    assert rows.shape == (poly.n_points, 3) and rows.dtype == np.float32


def test_vertex_ao_onto_a_cube_with_split_corners():
    """End to end on a receiver-only scene: the AO of each of the 24 points is that of its corner."""
    cube = pv.Cube(center=(0.0, 0.5, 0.0), clean=False)
    scene = pyshadow.Scene(ground=0.0)
    i = scene.add(cube, casts=False)
    ao = scene.vertex_ao(i, sampling=pyshadow.Sampling(16))
    cube["ao"] = viz.point_values(cube, scene.instances[i].mesh, ao)
    corners = np.asarray(scene.instances[i].mesh.vertices)
    for p, value in zip(np.asarray(cube.points), cube["ao"]):
        assert value == ao[np.flatnonzero((corners == p).all(axis=1))[0]]
    low = np.asarray(cube.points)[:, 1] == 0.0                     # the corners on the ground are darker
    assert cube["ao"][low].max() < cube["ao"][~low].min()


def test_point_values_of_a_volume_leave_interior_points_nan():
    grid = pv.ImageData(dimensions=(4, 4, 4), spacing=(0.2, 0.2, 0.2))
    mesh = pyshadow.load_mesh(grid)
    out = viz.point_values(grid, mesh, np.ones(len(mesh.vertices)))
    inside = ((grid.points > 0.01) & (grid.points < 0.59)).all(axis=1)
    assert inside.sum() == 8
    assert np.isnan(out[inside]).all() and (out[~inside] == 1.0).all()


def test_point_values_errors_name_the_argument():
    poly = pv.Cube(clean=False)
    mesh = pyshadow.load_mesh(poly)
    with pytest.raises(ValueError, match=r"point_values: values must have shape \(8,\)"):
        viz.point_values(poly, mesh, np.zeros(24))
    with pytest.raises(TypeError, match="point_values: dataset must be a pyvista dataset"):
        viz.point_values(mesh, mesh, np.zeros(8))
    with pytest.raises(TypeError, match="point_values: mesh must be a trimesh.Trimesh"):
        viz.point_values(poly, poly, np.zeros(8))
    with pytest.raises(TypeError, match="point_values: values must be real numbers"):
        viz.point_values(poly, mesh, ["a"] * 8)


def test_stand_on_ground_takes_a_pyvista_mesh():
    """It raised AttributeError ('PolyData' object has no attribute 'vertices'), while Scene.add and load_mesh
    take the same mesh."""
    cyl = pv.Cylinder(center=(3.0, 2.0, 1.0), radius=0.4, height=1.0)
    T = viz.stand_on_ground(cyl, radius=0.5, position=(1.0, -2.0), ground=0.25)
    np.testing.assert_array_equal(T, pyshadow.stand_on_ground(pyshadow.load_mesh(cyl), radius=0.5,
                                                              position=(1.0, -2.0), ground=0.25))
    scene = pyshadow.Scene(ground=0.25)
    i = scene.add(cyl, T, casts=False)
    assert scene.vertex_points(i)[0][:, 1].min() == pytest.approx(0.25, abs=1e-12)
    with pytest.raises(TypeError, match="stand_on_ground: mesh must be a trimesh.Trimesh or a pyvista mesh"):
        viz.stand_on_ground([[0.0, 0.0, 0.0]])

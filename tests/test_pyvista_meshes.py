"""pyvista meshes given to load_mesh and Scene.add: their surface's triangles, as the same mesh from trimesh."""
import warnings

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.viz import polydata_to_mesh

pv = pytest.importorskip("pyvista")


def _corners(mesh):
    """The triangles' corner positions, sorted per triangle and then over triangles (an order-free form)."""
    tri = np.sort(np.asarray(mesh.vertices)[np.asarray(mesh.faces)].reshape(-1, 9).reshape(-1, 3, 3), axis=1)
    return tri[np.lexsort(tri.reshape(-1, 9).T[::-1])]


@pytest.mark.parametrize("make", [lambda: pv.Sphere(radius=0.5, theta_resolution=12, phi_resolution=8),
                                  lambda: pv.Cube(x_length=1.0, y_length=2.0, z_length=0.5),
                                  lambda: pv.Cube().cast_to_unstructured_grid(),
                                  lambda: pv.Cylinder(resolution=10)],
                         ids=["sphere", "cube", "grid", "cylinder"])
def test_load_mesh_takes_a_pyvista_mesh(make):
    """Was: load_mesh(pv.Sphere()) and Scene.add(pv.PolyData) raised TypeError ('expects a path or a
    trimesh.Trimesh/Scene'): a pyvista user wrote the faces array's reshape by hand. Now the surface's
    triangles (VTK's triangulate): the same area and enclosed volume as VTK measures, every point kept."""
    poly = make()
    with warnings.catch_warnings():         # pyvista 0.49's notice of a default to change
        warnings.simplefilter("ignore")
        surface = poly if isinstance(poly, pv.PolyData) else poly.extract_surface()
    mesh = pyshadow.load_mesh(poly)
    assert mesh.faces.shape[1] == 3 and len(mesh.faces) >= surface.n_cells
    np.testing.assert_allclose(mesh.area, surface.area, rtol=1e-9)
    assert mesh.is_watertight == (surface.clean().n_open_edges == 0)      # (load_mesh merges coincident points)
    if mesh.is_watertight:
        np.testing.assert_allclose(abs(mesh.volume), surface.volume, rtol=1e-9)
    raw = polydata_to_mesh(poly)
    assert raw.vertices.dtype == np.float64 and raw.faces.dtype == np.int64
    np.testing.assert_array_equal(raw.vertices, np.asarray(surface.points, np.float64))


def test_a_scene_of_a_pyvista_mesh_answers_as_its_trimesh_twin():
    """Scene.add of a pyvista cube and of the trimesh box it equals (the same faces, each square split along
    the other diagonal): the same AO, within the CSM's lookup error (one sample of 16 at a few points)."""
    poly = pv.Cube(x_length=1.0, y_length=1.0, z_length=1.0)
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    a, b = pyshadow.load_mesh(poly), pyshadow.load_mesh(box)
    np.testing.assert_allclose(a.area, b.area, rtol=1e-12)
    np.testing.assert_allclose(a.bounds, b.bounds, rtol=0, atol=1e-15)
    assert a.is_watertight and len(a.faces) == 12
    views = pyshadow.ViewSet.zigzag(4, 8)
    T = trimesh.transformations.translation_matrix([0.0, 0.5, 0.0])
    rng = np.random.default_rng(0)
    p = np.c_[rng.uniform(-1.5, 1.5, 300), np.zeros(300), rng.uniform(-1.5, 1.5, 300)]
    up = np.tile([0.0, 1.0, 0.0], (300, 1))
    ao = []
    for obj in (poly, box):
        s = pyshadow.Scene(ground=0.0, views=views, resolution=16)
        s.add(obj, T)
        ao.append(s.ambient_occlusion(p, up, sampling=pyshadow.Sampling(16)))
    assert ao[0].min() < 0.9                    # points beside the cube are shadowed by it
    diff = np.abs(ao[0] - ao[1])
    assert diff.max() <= 1 / 16 + 1e-6 and (diff > 0).mean() <= 0.05


def test_points_or_lines_only_are_refused():
    """A pyvista mesh with no polygons is refused with a message, not an empty mesh."""
    with pytest.raises(ValueError, match="no polygons"):
        pyshadow.load_mesh(pv.Line())
    with pytest.raises(TypeError, match="pyvista dataset"):
        polydata_to_mesh(trimesh.creation.box())

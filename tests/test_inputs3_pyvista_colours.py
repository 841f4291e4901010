"""A pyvista dataset's colours (VTK's 'RGB' / 'RGBA' arrays, as pv.read names a PLY's) reach the lit render."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.lighting import DirectionalLight, Lighting

pv = pytest.importorskip("pyvista")
from pyshadow.viz import polydata_to_mesh  # noqa: E402


def _red_sphere_file(tmp_path):
    m = trimesh.creation.icosphere(2)
    rgba = np.zeros((len(m.vertices), 4), np.uint8)
    rgba[:, 0], rgba[:, 3] = 200, 255
    m.visual.vertex_colors = rgba
    path = tmp_path / "red.ply"
    m.export(path)
    return path


def _lit(obj):
    scene = pyshadow.Scene(ground=-1.0, views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
    scene.add(obj)
    sun = DirectionalLight(np.array([0.3, 1.0, 0.5]) / np.linalg.norm([0.3, 1.0, 0.5]), [1.0, 1.0, 1.0])
    frame = pyshadow.render.render(scene, pyshadow.Camera((0, 1.5, 3.5), (0, 0, 0), width=16, height=12),
                                   sampling=pyshadow.Sampling(4), lighting=Lighting(sun=sun, albedo=1.0))
    return np.asarray(frame.radiance)


def test_a_read_ply_draws_in_its_colours_as_the_file_does(tmp_path):
    """Was: ``Scene.add(pv.read("red.ply"))`` drew the sphere grey (0.244 0.244 0.244 at the centre pixel) where
    ``Scene.add("red.ply")`` drew it red (0.141 0 0): polydata_to_mesh read no point data."""
    path = _red_sphere_file(tmp_path)
    poly = pv.read(path)
    assert "RGBA" in poly.point_data
    np.testing.assert_array_equal(polydata_to_mesh(poly).visual.vertex_colors, poly.point_data["RGBA"])
    file_image, pv_image = _lit(path), _lit(poly)
    assert file_image[6, 8, 0] > 0.0 and (file_image[6, 8, 1:] == 0.0).all()        # the sphere, red
    np.testing.assert_allclose(pv_image, file_image, rtol=0, atol=1e-6)


def test_cell_colours_skip_vertex_and_line_cells():
    """Cell colours of a PolyData with a vertex and a line cell before its polygons: the polygons' own rows."""
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0]], float)
    poly = pv.PolyData(pts, faces=[4, 0, 1, 2, 3], lines=[2, 1, 4], verts=[1, 4])
    rgb = np.array([[1, 1, 1], [2, 2, 2], [200, 10, 20]], np.uint8)       # vertex, line, quad
    poly.cell_data["RGB"] = rgb
    mesh = polydata_to_mesh(poly)
    assert len(mesh.faces) == 2
    np.testing.assert_array_equal(mesh.visual.face_colors[:, :3], [[200, 10, 20]] * 2)


def test_other_arrays_are_not_colours():
    """Float 'RGB', or uint8 arrays under other names, are not read as colours (the mesh has none)."""
    for name, values in (("RGB", np.full((8, 3), 0.5)), ("Colors", np.full((8, 3), 9, np.uint8))):
        cube = pv.Cube()
        cube.point_data[name] = values[: cube.n_points]
        assert not polydata_to_mesh(cube).visual.defined

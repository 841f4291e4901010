"""load_mesh, hole filling and the bounding sphere."""
import warnings

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.mesh import float32_unit, mesh_hash

from conftest import load, mesh_path


def test_load_mesh_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="not found"):
        pyshadow.load_mesh(tmp_path / "nope.obj")


def test_load_mesh_unknown_format(tmp_path):
    p = tmp_path / "mesh.xyzq"
    p.write_text("hello")
    with pytest.raises(ValueError, match=r"mesh\.xyzq.*(unknown|unsupported)"):
        pyshadow.load_mesh(p)


def test_load_mesh_empty_file(tmp_path):
    p = tmp_path / "empty.obj"
    p.write_text("")
    with pytest.raises(ValueError, match="empty.obj.*empty mesh"):
        pyshadow.load_mesh(p)


def test_load_mesh_vertices_only(tmp_path):
    p = tmp_path / "points.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    with pytest.raises(ValueError, match="points.obj"):
        pyshadow.load_mesh(p)


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf"])
def test_load_mesh_non_finite_vertex(tmp_path, bad):
    p = tmp_path / "bad.obj"
    p.write_text(f"v 0 0 0\nv 1 0 {bad}\nv 0 1 0\nv 0 0 1\nf 1 3 4\nf 1 2 3\n")
    with pytest.raises(ValueError, match=r"bad.obj: 1 of 4 vertices are not finite"):
        pyshadow.load_mesh(p)


def test_load_mesh_removes_degenerate_and_duplicate_faces(tmp_path):
    p = tmp_path / "dirty.obj"
    p.write_text(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 2 0 0\n"
        "f 1 2 3\n"      # good
        "f 1 3 4\n"      # good
        "f 1 2 5\n"      # degenerate: collinear (zero area)
        "f 2 2 3\n"      # degenerate: repeated vertex
        "f 3 2 1\n"      # duplicate of face 1 (reversed winding)
        "f 2 3 1\n"      # duplicate of face 1 (rotated)
    )
    with pytest.warns(pyshadow.MeshCleanupWarning, match="removed 2 degenerate and 2 duplicate faces of 6"):
        m = pyshadow.load_mesh(p)
    assert len(m.faces) == 2
    corners = {tuple(sorted(map(tuple, m.vertices[f].tolist()))) for f in m.faces}
    assert corners == {((0, 0, 0), (0, 1, 0), (1, 0, 0)), ((0, 0, 0), (0, 0, 1), (0, 1, 0))}


def test_load_mesh_all_degenerate_is_empty(tmp_path):
    p = tmp_path / "flat.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
    with pytest.raises(ValueError, match="empty mesh"), pytest.warns(pyshadow.MeshCleanupWarning):
        pyshadow.load_mesh(p)


def test_load_mesh_triangulates_quads(tmp_path):
    p = tmp_path / "quad.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    m = pyshadow.load_mesh(p)
    assert m.faces.shape == (2, 3)
    assert np.isclose(m.area, 1.0)


def test_load_mesh_glb_scene_applies_node_transforms(tmp_path):
    box = trimesh.creation.box(extents=(1, 1, 1))
    scene = trimesh.Scene()
    scene.add_geometry(box, node_name="a", transform=trimesh.transformations.translation_matrix([3, 0, 0]))
    scene.add_geometry(box, node_name="b", transform=trimesh.transformations.translation_matrix([0, -2, 0]))
    p = tmp_path / "scene.glb"
    scene.export(p)
    m = pyshadow.load_mesh(p)
    assert len(m.faces) == 24
    np.testing.assert_allclose(m.bounds, [[-0.5, -2.5, -0.5], [3.5, 0.5, 0.5]], atol=1e-6)


@pytest.mark.parametrize("name", ["stanford-bunny.obj", "teapot.obj", "fandisk.obj", "suzanne.ply",
                                  "torus.STL", "featuretype.STL", "pyvista:airplane"])
def test_load_mesh_real_meshes(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pyshadow.MeshCleanupWarning)
        m = pyshadow.load_mesh(mesh_path(name))
    assert len(m.faces) > 100
    assert np.isfinite(m.vertices).all()
    # no duplicates or degenerates left
    key = np.sort(m.faces, axis=1)
    assert len(np.unique(key, axis=0)) == len(key)
    assert (np.diff(np.sort(m.faces, axis=1), axis=1) > 0).all()


def test_fill_holes_closes_the_bunny():
    open_bunny = load("stanford-bunny.obj")
    filled = load("stanford-bunny.obj", fill_holes=True)
    assert not open_bunny.is_watertight
    assert filled.is_watertight
    assert filled.is_winding_consistent
    assert len(filled.faces) > len(open_bunny.faces)
    # the original faces are kept unchanged, in order
    np.testing.assert_array_equal(filled.faces[: len(open_bunny.faces)], open_bunny.faces)


def test_fill_holes_on_closed_mesh_changes_nothing():
    fan = load("fandisk.obj")
    filled = load("fandisk.obj", fill_holes=True)
    np.testing.assert_array_equal(fan.faces, filled.faces)


def test_bounding_sphere_encloses_and_is_minimal():
    m = load("stanford-bunny.obj")
    c, r = pyshadow.bounding_sphere(m)
    d = np.linalg.norm(m.vertices - c, axis=1)
    assert d.max() <= r
    assert d.max() >= r * (1 - 1e-6)         # tight: some vertex lies on it
    # minimal: the centre-of-bounds sphere is never smaller
    lo, hi = m.bounds
    assert r <= np.linalg.norm(m.vertices - (lo + hi) / 2, axis=1).max() + 1e-12
    c2, r2 = pyshadow.bounding_sphere(m)
    assert r2 == r and (c2 == c).all()       # deterministic


def test_bounding_sphere_of_box_is_half_diagonal():
    box = pyshadow.load_mesh(trimesh.creation.box(extents=(2, 4, 6)))
    c, r = pyshadow.bounding_sphere(box)
    np.testing.assert_allclose(c, 0, atol=1e-7)
    np.testing.assert_allclose(r, np.sqrt(1 + 4 + 9), rtol=1e-7)


@pytest.mark.parametrize("scale, offset", [(1e-3, 0.0), (1e4, 0.0), (1.0, 1e5), (1e-20, 0.0), (1e20, 0.0)])
def test_normalised_frame_is_scale_and_position_invariant(scale, offset):
    m = load("fandisk.obj")
    moved = trimesh.Trimesh(m.vertices * scale + offset, m.faces, process=False)
    c0, r0 = pyshadow.bounding_sphere(m)
    c1, r1 = pyshadow.bounding_sphere(moved)
    np.testing.assert_allclose(r1, r0 * scale, rtol=1e-6)
    p0 = (m.vertices - c0) / r0
    p1 = (moved.vertices - c1) / r1
    np.testing.assert_allclose(p1, p0, atol=1e-6)


@pytest.mark.parametrize("k", [-70, -21, 21, 70])
def test_bounding_sphere_of_a_mesh_scaled_by_a_power_of_two_is_scaled_exactly(k):
    """Outside the unit band the fit runs on the mesh scaled back near unit size by a power of two:
    centre and radius are those of the unscaled mesh times 2**k, bit for bit (trimesh's own fit
    fails on hulls of such sizes: no warning escapes either)."""
    m = load("fandisk.obj")
    c0, r0 = pyshadow.bounding_sphere(m)
    c1, r1 = pyshadow.bounding_sphere(trimesh.Trimesh(m.vertices * 2.0 ** k, m.faces, process=False))
    np.testing.assert_array_equal(c1, c0 * 2.0 ** k)
    assert r1 == r0 * 2.0 ** k


def test_bounding_sphere_names_vertices_that_are_not_finite():
    box = trimesh.creation.box()
    v = box.vertices.copy()
    v[3, 1] = np.inf
    with pytest.raises(ValueError, match=r"bounding_sphere: 1 of 8 vertices are not finite .*vertex 3"):
        pyshadow.bounding_sphere(trimesh.Trimesh(v, box.faces, process=False))


def test_float32_unit_is_one_inside_the_band_and_a_power_of_two_outside():
    from pyshadow.mesh import UNIT_BAND

    for m in (1.0, 2.0 ** UNIT_BAND, 2.0 ** -UNIT_BAND, 3.7, 0.0, np.inf, np.nan):
        assert float32_unit(m) == 1.0
    for m in (2.0 ** (UNIT_BAND + 1), 3e30, 2.0 ** -(UNIT_BAND + 1), 7e-25):
        u = float32_unit(m)
        assert np.frexp(u)[0] == 0.5 and 0.5 <= m * u <= 2.0     # a power of two bringing m near 1


def test_mesh_hash_changes_with_geometry():
    m = load("suzanne.ply")
    h = mesh_hash(m)
    m2 = m.copy()
    m2.vertices[0, 0] += 1e-9
    assert mesh_hash(m2) != h
    assert mesh_hash(m.copy()) == h

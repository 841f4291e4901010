"""OBJ files as exporters write them, read by pyshadow.load_mesh, checked against the triangles the text means."""
import numpy as np
import pytest

from pyshadow.mesh import load_mesh, mesh_hash

TWO_QUADS = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0]], [[0, 0, 0], [1, 1, 0], [0, 1, 0]],
                      [[0, 0, 1], [1, 0, 1], [1, 1, 1]], [[0, 0, 1], [1, 1, 1], [0, 1, 1]]], float)


def _triangles(mesh):
    """The mesh's triangles as a sorted array of corner coordinates (winding kept, start corner rotated)."""
    tri = np.asarray(mesh.vertices)[np.asarray(mesh.faces)]
    out = []
    for t in tri:
        k = min(range(3), key=lambda i: tuple(t[i]))
        out.append(np.roll(t, -k, axis=0))
    out = np.array(out)
    return out[np.lexsort(out.reshape(len(out), -1).T[::-1])]


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_negative_indices_of_each_object(tmp_path):
    """Was: trimesh resolved a negative index against the whole file's vertices, so the first object's
    ``f -4 -3 -2 -1`` took the second object's vertices: its 2 triangles duplicated the second quad's and
    were removed (MeshCleanupWarning "2 duplicate faces"), the quad at z = 0 was lost (area 1 of 2)."""
    text = ("o first\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf -4 -3 -2 -1\n"
            "o second\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf -4 -3 -2 -1\n")
    mesh = load_mesh(_write(tmp_path, "two.obj", text))
    assert len(mesh.faces) == 4
    np.testing.assert_array_equal(_triangles(mesh), _triangles_of(TWO_QUADS))
    assert mesh.area == pytest.approx(2.0, abs=1e-12)


def _triangles_of(tri):
    class M:
        vertices = tri.reshape(-1, 3)
        faces = np.arange(len(tri) * 3).reshape(-1, 3)
    return _triangles(M)


def test_negative_indices_equal_absolute_ones(tmp_path):
    """Was: a triangle of relative ``v/vt`` indices followed by another object's vertices was replaced by
    that object's triangle (1 face kept of 2 with a MeshCleanupWarning, bounds z 5..5 instead of 0..5);
    now the file loads as the same text with absolute indices does."""
    rel = ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf -3/-3 -2/-2 -1/-1\n"
           "v 5 5 5\nv 6 5 5\nv 5 6 5\nf -3 -2 -1\n")
    ab = ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n"
          "v 5 5 5\nv 6 5 5\nv 5 6 5\nf 4 5 6\n")
    a, b = load_mesh(_write(tmp_path, "rel.obj", rel)), load_mesh(_write(tmp_path, "abs.obj", ab))
    assert len(a.faces) == 2 and a.bounds[0, 2] == 0.0
    np.testing.assert_array_equal(_triangles(a), _triangles(b))


def test_negative_index_before_first_vertex(tmp_path):
    """Was: ValueError "index -4 is out of bounds for axis 0 with size 3", naming no line of the file;
    now the message names line 4 (an index before the first vertex is an error, as before)."""
    with pytest.raises(ValueError, match="line 4"):
        load_mesh(_write(tmp_path, "bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 -3 -2\n"))


def test_tab_and_indent_separated_lines(tmp_path):
    """Was: ``v\\t0 0 0`` lines (tab after the keyword) read no vertex: ValueError "the file holds no
    geometry"; indented lines gave "not a triangle mesh (trimesh returned PointCloud)"."""
    plain = load_mesh(_write(tmp_path, "plain.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"))
    for name, text in (("tab.obj", "v\t0 0 0\nv\t1 0 0\nv\t0 1 0\nf\t1 2 3\n"),
                       ("indent.obj", "  v 0 0 0\n  v 1 0 0\n  v 0 1 0\n  f 1 2 3\n")):
        assert mesh_hash(load_mesh(_write(tmp_path, name, text))) == mesh_hash(plain), name


def test_negative_indices_keep_materials(tmp_path):
    """Was: the red object's ``f -3 -2 -1`` took the blue object's vertices and was removed as a duplicate
    (MeshCleanupWarning, 1 face of 2 left, no red face); now each face keeps its own ``usemtl`` colour."""
    _write(tmp_path, "m.mtl", "newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n")
    text = ("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf -3 -2 -1\n"
            "v 0 0 1\nv 1 0 1\nv 0 1 1\nusemtl blue\nf -3 -2 -1\n")
    mesh = load_mesh(_write(tmp_path, "mat.obj", text))
    visual = mesh.metadata["pyshadow_visual"]
    z = np.asarray(mesh.vertices)[np.asarray(mesh.faces)][:, 0, 2]
    colour = visual.colours[:, 0, :]
    np.testing.assert_array_equal(colour[z == 0.0], [[1, 0, 0]])
    np.testing.assert_array_equal(colour[z == 1.0], [[0, 0, 1]])


def test_comments_after_data(tmp_path):
    """Was: a comment at the end of a face or vertex line (``f 1 2 3 # lid``) failed the whole file:
    ValueError "could not be read as a mesh (string or file could not be read to its end due to unmatched
    data)"; now the comment is skipped, as OBJ says."""
    plain = load_mesh(_write(tmp_path, "plain.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n"))
    text = "v 0 0 0 # origin\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3 # lid\nf 2 4 3\n"
    assert mesh_hash(load_mesh(_write(tmp_path, "comments.obj", text))) == mesh_hash(plain)


def test_plain_obj_read_as_it_is(tmp_path):
    """Was: an ordinary OBJ was parsed from its own bytes; it still is (the rewrite finds nothing to change)."""
    from pyshadow.mesh_files import obj_text
    text = b"# header - a dash\nv -1 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/1\n"
    assert obj_text(text) is None and obj_text(text, force=True) is None


L_FLOOR = ("v 2 0 1\nv 1 0 1\nv 1 0 2\nv 0 0 2\nv 0 0 0\nv 2 0 0\n"       # an L-shaped floor, y up, 3 m^2
           "vt 1 0.5\nvt 0.5 0.5\nvt 0.5 1\nvt 0 1\nvt 0 0\nvt 1 0\nvn 0 1 0\n")


def test_concave_polygon_is_tiled(tmp_path):
    """Was: trimesh split every polygon into a fan from its first corner: an L-shaped floor (6 corners, 3 m^2)
    starting at a corner that does not see the whole L got a triangle turned against the floor over the
    missing square: area 4 m^2 instead of 3, and a ray down through (1.2, 1.2) hit a floor that is not there."""
    text = L_FLOOR + "f 1/1/1 2/2/1 3/3/1 4/4/1 5/5/1 6/6/1\n"
    mesh = load_mesh(_write(tmp_path, "floor.obj", text))
    assert len(mesh.faces) == 4
    assert mesh.area == pytest.approx(3.0, abs=1e-12)
    centres = mesh.triangles_center
    assert not ((centres[:, 0] > 1.0) & (centres[:, 2] > 1.0)).any()       # nothing over the missing square
    t = np.asarray(mesh.vertices)[np.asarray(mesh.faces)][:, :, [0, 2]] - [1.2, 1.2]
    turn = t[:, [0, 1, 2], 0] * t[:, [1, 2, 0], 1] - t[:, [0, 1, 2], 1] * t[:, [1, 2, 0], 0]
    assert not ((turn > 0).all(axis=1) | (turn < 0).all(axis=1)).any()      # no triangle over (1.2, 1.2)
    assert (mesh.face_normals[:, 1] < -0.999).all()                # the file's winding (clockwise seen from +y)
    uv = mesh.metadata["pyshadow_visual"].uv                                  # each corner keeps its vt
    xz = np.asarray(mesh.vertices)[np.asarray(mesh.faces)][:, :, [0, 2]]
    np.testing.assert_allclose(uv, xz / 2, atol=1e-7)                       # vt = (x, z) / 2 in the file


def test_concave_polygon_after_relative_indices(tmp_path):
    """Was: relative indices took the wrong vertices, and the L's fan covered 4 m^2; now the L of negative
    indices tiles 3 m^2 exactly as the one of absolute indices."""
    rel = L_FLOOR + "f -6 -5 -4 -3 -2 -1\n"
    ab = L_FLOOR + "f 1 2 3 4 5 6\n"
    a, b = load_mesh(_write(tmp_path, "rel.obj", rel)), load_mesh(_write(tmp_path, "abs.obj", ab))
    assert a.area == pytest.approx(3.0, abs=1e-12)
    np.testing.assert_array_equal(_triangles(a), _triangles(b))


def test_convex_polygons_keep_the_fan():
    """Was: a convex n-gon was split into trimesh's fan; it still is (the text is not rewritten)."""
    from pyshadow.mesh_files import obj_polygons
    hexagon = "".join(f"v {np.cos(a)!r} 0 {np.sin(a)!r}\n" for a in np.linspace(0, 2 * np.pi, 7)[:-1].tolist())
    assert obj_polygons((hexagon + "f 1 2 3 4 5 6\n").encode()) is None
    assert obj_polygons((L_FLOOR + "f 5 6 1 2 3 4\n").encode()) is None        # from a corner that sees it all
    assert obj_polygons((L_FLOOR + "f 1 2 3 4 5 6\n").encode()) is not None

"""PLY and OFF polygons, PLY face properties and OFF comments read by pyshadow.load_mesh, against brute force.

The references are written here: a polygon's area from its Newell normal (the vector area, exact for a
planar polygon whatever its shape), and each face's colour looked up by the polygon that holds a triangle's
centre.
"""
import struct

import numpy as np
import pytest

from pyshadow.mesh import load_mesh, mesh_hash

# an L-shaped floor in z = 0 (3 m^2) whose corner 0 does not see the whole L: a fan from it covers 4 m^2
L_XYZ = np.array([[2, 1, 0], [1, 1, 0], [1, 2, 0], [0, 2, 0], [0, 0, 0], [2, 0, 0]], np.float64)
# beside it a convex pentagon (1.25 m^2), and above it the same L listed from its corner 2 (a fan from it
# covers ground outside too)
XYZ = np.vstack([L_XYZ, [[3, 0, 0], [3, 1, 0], [2.5, 1.5, 0]], L_XYZ + [0, 3, 0]])
POLYS = [[0, 1, 2, 3, 4, 5], [5, 6, 7, 8, 0], [11, 12, 13, 14, 9, 10]]
COLOURS = [(255, 0, 0), (0, 255, 0), (0, 0, 255)]


def _newell_area(xyz, polys):
    """Brute force: the sum of each polygon's |vector area| (planar polygons of any shape)."""
    total = 0.0
    for p in polys:
        q = xyz[p]
        total += 0.5 * np.linalg.norm(np.cross(q, np.roll(q, -1, axis=0)).sum(axis=0))
    return total


def _inside(point, poly2d):
    """Brute force even-odd test of a 2D point in a polygon."""
    x, y = point
    hit = False
    for (x0, y0), (x1, y1) in zip(poly2d, np.roll(poly2d, -1, axis=0)):
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            hit = not hit
    return hit


def _ply(form, xyz, polys, colours=None, count="uchar", index="int"):
    props = "".join(f"property uchar {c}\n" for c in ("red", "green", "blue")) if colours else ""
    head = (f"ply\nformat {form} 1.0\ncomment written by a test\nelement vertex {len(xyz)}\nproperty double x\n"
            f"property double y\nproperty double z\nelement face {len(polys)}\n"
            f"property list {count} {index} vertex_indices\n{props}end_header\n").encode()
    if form == "ascii":
        rows = "".join(" ".join(map(repr, v)) + "\n" for v in xyz.tolist())
        for k, p in enumerate(polys):
            rows += f"{len(p)} {' '.join(map(str, p))}" + (" %d %d %d" % colours[k] if colours else "") + "\n"
        return head + rows.encode()
    order = "<" if form == "binary_little_endian" else ">"
    codes = {"uchar": "B", "ushort": "H", "int": "i", "uint": "I"}
    body = xyz.astype(order + "f8").tobytes()
    for k, p in enumerate(polys):
        body += struct.pack(f"{order}{codes[count]}{len(p)}{codes[index]}", len(p), *p)
        body += bytes(colours[k]) if colours else b""
    return head + body


@pytest.mark.parametrize("form", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_concave_polygons_are_tiled(tmp_path, form):
    """Was: trimesh fanned every PLY polygon from its first corner: the L (3 m^2) and the concave hexagon
    listed from its corner 2 (3 m^2 each) covered 4 m^2 each: the three faces loaded 9.25 m^2 instead of
    the Newell area 7.25, in ASCII, little- and big-endian binary alike."""
    path = tmp_path / "floor.ply"
    path.write_bytes(_ply(form, XYZ, POLYS, count="uchar" if form == "ascii" else "ushort", index="uint"))
    mesh = load_mesh(path)
    assert mesh.area == pytest.approx(_newell_area(XYZ, POLYS), abs=1e-12)
    assert len(mesh.faces) == sum(len(p) - 2 for p in POLYS)
    assert (mesh.face_normals[:, 2] > 0.999).all()                   # the file's winding (counter-clockwise)
    for hole in ([1.5, 1.5], [1.5, 4.5]):                           # the Ls' missing squares are not covered
        t = mesh.vertices[mesh.faces][:, :, :2] - hole
        turn = t[:, [0, 1, 2], 0] * t[:, [1, 2, 0], 1] - t[:, [0, 1, 2], 1] * t[:, [1, 2, 0], 0]
        assert not (turn > 0).all(axis=1).any()


def test_ply_binary_and_ascii_polygons_load_the_same(tmp_path):
    """Was: equal (each fanned the same wrong way); still equal, now each tiled (ASCII, both byte orders)."""
    hashes = set()
    for form in ("ascii", "binary_little_endian", "binary_big_endian"):
        (tmp_path / f"{form}.ply").write_bytes(_ply(form, XYZ, POLYS))
        hashes.add(mesh_hash(load_mesh(tmp_path / f"{form}.ply")))
    assert len(hashes) == 1


@pytest.mark.parametrize("form", ["ascii", "binary_little_endian"])
def test_ply_face_colours_follow_their_polygons(tmp_path, form):
    """Was: IndexError "index 3 is out of bounds for axis 0 with size 3" from load_mesh: trimesh split the
    polygons into 12 triangles but kept 3 face colours (a quad's second triangle took the next face's colour
    where the counts happened to fit). Now every triangle has the colour of the polygon that holds it."""
    path = tmp_path / "colours.ply"
    path.write_bytes(_ply(form, XYZ, POLYS, COLOURS))
    mesh = load_mesh(path)
    assert mesh.area == pytest.approx(_newell_area(XYZ, POLYS), abs=1e-12)
    colours = mesh.metadata["pyshadow_visual"].colours
    for centre, colour in zip(mesh.triangles_center, colours):
        owner = [k for k, p in enumerate(POLYS) if _inside(centre[:2], XYZ[p, :2])]
        assert len(owner) == 1
        want = np.array(COLOURS[owner[0]]) / 255.0                      # pure primaries: sRGB 0/1 stay 0/1
        np.testing.assert_allclose(colour, np.tile(want, (3, 1)), atol=1e-6)


def test_ply_quads_with_face_colours(tmp_path):
    """Was: IndexError "index 2 is out of bounds for axis 0 with size 2" for two coloured quads (trimesh gave
    4 triangles and 2 colours). Now 4 triangles, each coloured as its quad, area 2."""
    xyz = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]], np.float64)
    path = tmp_path / "quads.ply"
    path.write_bytes(_ply("binary_little_endian", xyz, [[0, 1, 2, 3], [1, 4, 5, 2]], [(255, 0, 0), (0, 0, 255)]))
    mesh = load_mesh(path)
    assert mesh.area == pytest.approx(2.0, abs=1e-12)
    red = mesh.metadata["pyshadow_visual"].colours[:, 0, 0] > 0.5
    np.testing.assert_array_equal(red, mesh.triangles_center[:, 0] < 1.0)


def test_binary_ply_lists_that_add_up_are_not_misread(tmp_path):
    """Was: a quad, a triangle and a pentagon (12 corners = 3 x the first face's 4) passed trimesh's length
    check, which reads every list as long as the first: 6 triangles of misplaced vertices, area 516.5 instead
    of 3.0, without a word (2,000 vertices, so the misread indices still named vertices)."""
    xyz = np.zeros((2000, 3))
    xyz[:, 0] = np.arange(2000)
    xyz[:8] = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0], [3, 0, 0], [3, 1, 0]]
    polys = [[0, 1, 2, 3], [1, 4, 2], [4, 6, 7, 5, 2]]
    path = tmp_path / "mixed.ply"
    path.write_bytes(_ply("binary_little_endian", xyz, polys, index="uint"))
    mesh = load_mesh(path)
    assert mesh.area == pytest.approx(_newell_area(xyz, polys), abs=1e-12)
    assert len(mesh.faces) == 6 and mesh.vertices.max() <= 3.0


def _off(xyz, polys, head="OFF\n", tails=None):
    rows = "".join(" ".join(map(repr, v)) + "\n" for v in xyz.tolist())
    rows += "".join(f"{len(p)} {' '.join(map(str, p))}{tails[k] if tails else ''}\n" for k, p in enumerate(polys))
    return f"{head}{len(xyz)} {len(polys)} 0\n{rows}"


def test_off_concave_polygons_are_tiled(tmp_path):
    """Was: ValueError "could not be read as a mesh (The 'out' kwarg is necessary when using the string
    multiply ufunc directly...)": trimesh fans OFF faces of 5 or more corners from their text where faces
    of other sizes are beside them; a file of the L alone loaded 4 m^2 instead of 3. Now the L, the pentagon
    and the second L tile 7.25 m^2 (the Newell area), also with a colour after each face."""
    for name, tails in (("plain.off", None), ("coloured.off", [" 1 0 0", " 0 1 0 1", " 0.2"])):
        (tmp_path / name).write_text(_off(XYZ, POLYS, tails=tails))
        mesh = load_mesh(tmp_path / name)
        assert mesh.area == pytest.approx(_newell_area(XYZ, POLYS), abs=1e-12)
        assert len(mesh.faces) == 11 and (mesh.face_normals[:, 2] > 0.999).all()
    assert mesh_hash(load_mesh(tmp_path / "plain.off")) == mesh_hash(load_mesh(tmp_path / "coloured.off"))


CUBE = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float64)
CUBE_FACES = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]


@pytest.mark.parametrize("where", ["counts", "vertex", "face"])
def test_off_comment_after_data(tmp_path, where):
    """Was: trimesh's comment stripping repeated the text before the first comment, shifting every line
    after it, without a word for this 2 m cube of integer corners (area 24, volume 8): "8 6 0 # ..." made
    a vertex (8, 6, 0): area 80.49; after a vertex: "removed 2 degenerate and 1 duplicate faces of 6" (the
    lines misread); after the first face: 1 of 6 faces kept, area 4."""
    text = _off(CUBE.astype(int), CUBE_FACES)
    lines = text.splitlines()
    at = {"counts": 1, "vertex": 3, "face": 10}[where]
    lines[at] += "  # a comment"
    (tmp_path / "cube.off").write_text("\n".join(lines) + "\n")
    mesh = load_mesh(tmp_path / "cube.off")
    assert mesh.area == pytest.approx(24.0, abs=1e-12) and mesh.volume == pytest.approx(8.0, abs=1e-12)
    np.testing.assert_array_equal(np.unique(mesh.vertices, axis=0), CUBE)


def test_ply_ascii_extra_properties_and_count_types(tmp_path):
    """Was already right, kept so: vertex properties beside x, y, z (normals, a confidence) and list counts
    of int type read the positions exactly (triangles only: the text is not rewritten)."""
    from pyshadow import mesh_files
    head = ("ply\nformat ascii 1.0\nelement vertex 4\nproperty float nx\nproperty float x\nproperty float y\n"
            "property float confidence\nproperty float z\nelement face 2\nproperty list int int vertex_indices\n"
            "end_header\n")
    rows = "0 0 0 9 0\n0 1 0 9 0\n0 1 1 9 0\n0 0 1 9 0.5\n3 0 1 2\n3 0 2 3\n"
    (tmp_path / "extra.ply").write_text(head + rows)
    mesh = load_mesh(tmp_path / "extra.ply")
    np.testing.assert_array_equal(np.unique(mesh.vertices, axis=0), [[0, 0, 0], [0, 1, 0.5], [1, 0, 0], [1, 1, 0]])
    assert getattr(mesh_files, "ply_polygons", lambda text: None)((head + rows).encode()) is None

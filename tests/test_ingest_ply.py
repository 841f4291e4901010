"""Binary PLY files with faces of several sizes (as Blender writes n-gons), read by pyshadow.load_mesh."""
import struct

import numpy as np
import pytest

from pyshadow.mesh import load_mesh, mesh_hash

VERTS = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0.25]], np.float32)
COLOURS = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 0], [10, 20, 30]], np.uint8)
FACES = [[0, 1, 2, 3], [1, 4, 2]]                      # a quad, then a triangle


def _header(form, face_props="property list uchar uint vertex_indices\n"):
    return (f"ply\nformat {form} 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
            f"property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 2\n{face_props}"
            "end_header\n")


def _binary(order, flags=False):
    dt = np.dtype([("x", order + "f4"), ("y", order + "f4"), ("z", order + "f4"),
                   ("r", "u1"), ("g", "u1"), ("b", "u1")])
    rows = np.empty(5, dt)
    rows["x"], rows["y"], rows["z"] = VERTS.T
    rows["r"], rows["g"], rows["b"] = COLOURS.T
    body = rows.tobytes()
    for f in FACES:
        body += (struct.pack(order + "B", 7) if flags else b"") + struct.pack(f"{order}B{len(f)}I", len(f), *f)
    return body


def _ascii():
    lines = [" ".join(map(repr, v.tolist())) + " " + " ".join(map(str, c.tolist())) for v, c in zip(VERTS, COLOURS)]
    return _header("ascii") + "\n".join(lines) + "\n" + "".join(f"{len(f)} {' '.join(map(str, f))}\n" for f in FACES)


@pytest.mark.parametrize("form,order", [("binary_little_endian", "<"), ("binary_big_endian", ">")])
def test_binary_quads_and_triangles(tmp_path, form, order):
    """Was: ValueError "could not be read as a mesh (PLY is unexpected length!)": trimesh's binary reader
    takes every face to have the first face's 4 corners; the same file in ASCII loaded 3 triangles (area 1.515)."""
    (tmp_path / "a.ply").write_text(_ascii())
    (tmp_path / "b.ply").write_bytes(_header(form).encode() + _binary(order))
    a, b = load_mesh(tmp_path / "a.ply"), load_mesh(tmp_path / "b.ply")
    assert len(b.faces) == 3 and b.area == pytest.approx(1.0 + 0.5 * np.sqrt(1.0625), abs=1e-6)
    assert mesh_hash(a) == mesh_hash(b)
    np.testing.assert_array_equal(b.vertices[np.lexsort(b.vertices.T[::-1])], VERTS[np.lexsort(VERTS.T[::-1])])
    np.testing.assert_array_equal(a.metadata["pyshadow_visual"].colours, b.metadata["pyshadow_visual"].colours)


def test_binary_face_property_before_list(tmp_path):
    """Was: ValueError "PLY is unexpected length!" for a ``flags`` byte before a list of 4 then 3 corners;
    now the same 3 triangles as without the byte."""
    (tmp_path / "flags.ply").write_bytes(
        _header("binary_little_endian", "property uchar flags\nproperty list uchar uint vertex_indices\n").encode()
        + _binary("<", flags=True))
    (tmp_path / "plain.ply").write_text(_ascii())
    assert mesh_hash(load_mesh(tmp_path / "flags.ply")) == mesh_hash(load_mesh(tmp_path / "plain.ply"))


def test_truncated_binary_ply_still_refused(tmp_path):
    """Was: ValueError naming the path ("PLY is unexpected length!"); a file cut short still is refused so."""
    data = _header("binary_little_endian").encode() + _binary("<")
    (tmp_path / "cut.ply").write_bytes(data[:-3])
    with pytest.raises(ValueError, match="cut.ply"):
        load_mesh(tmp_path / "cut.ply")


def test_ascii_text_reads_back_bit_for_bit():
    """Was: no ASCII form; float32 and float64 values now read back from it exactly (9 / 17 digits)."""
    from pyshadow.mesh_files import ply_ascii
    x = np.array([0.1, 1 / 3, 1e-30, 123456.789, -2.5e10], np.float64)
    head = "ply\nformat binary_little_endian 1.0\nelement v 5\nproperty double a\nproperty float b\nend_header\n"
    rows = np.empty(5, [("a", "<f8"), ("b", "<f4")])
    rows["a"], rows["b"] = x, x.astype(np.float32)
    text = ply_ascii(head.encode() + rows.tobytes()).decode().split("end_header\n")[1].split()
    np.testing.assert_array_equal(np.array(text[0::2], np.float64), x)
    np.testing.assert_array_equal(np.array(text[1::2], np.float64).astype(np.float32), x.astype(np.float32))

"""Concave quads in PLY files trimesh reads as they are (quads, or triangles and quads, without colours)."""
import struct

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.mesh_files import _read_ply

# a dart, reflex at corner 1: trimesh's fan from corner 0 covers the triangle (0, 1, 2) outside it
DART = [(2.0, 0.0, 0.0), (0.5, 0.0, 0.5), (0.0, 0.0, 2.0), (0.0, 0.0, 0.0)]            # area 1
PENTAGON = [(5.0, 0.0, 0.0), (7.0, 0.0, 0.0), (7.0, 0.0, 2.0), (6.0, 0.0, 0.5), (5.0, 0.0, 2.0)]   # area 2.5
TRIANGLE = [(5.0, 0.0, 0.0), (6.0, 0.0, 0.0), (5.0, 0.0, 1.0)]                          # area 0.5
SQUARE = [(5.0, 0.0, 0.0), (6.0, 0.0, 0.0), (6.0, 0.0, 1.0), (5.0, 0.0, 1.0)]           # area 1


def _ply(polygons, binary=False) -> bytes:
    verts = [v for poly in polygons for v in poly]
    faces, k = [], 0
    for poly in polygons:
        faces.append(list(range(k, k + len(poly))))
        k += len(poly)
    head = (f"ply\nformat {'binary_little_endian' if binary else 'ascii'} 1.0\nelement vertex {len(verts)}\n"
            "property float x\nproperty float y\nproperty float z\n"
            f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n").encode()
    if binary:
        body = b"".join(struct.pack("<3f", *v) for v in verts)
        body += b"".join(struct.pack(f"<B{len(f)}i", len(f), *f) for f in faces)
        return head + body
    return head + "".join(f"{x} {y} {z}\n" for x, y, z in verts).encode() + "".join(
        f"{len(f)} {' '.join(map(str, f))}\n" for f in faces).encode()


@pytest.mark.parametrize("polygons, area, binary", [
    ([DART], 1.0, False), ([DART], 1.0, True), ([DART, SQUARE], 2.0, False), ([DART, SQUARE], 2.0, True),
    ([DART, TRIANGLE], 1.5, False), ([PENTAGON], 2.5, False), ([PENTAGON], 2.5, True), ([DART, PENTAGON], 3.5, False)])
def test_concave_polygons_keep_their_area(tmp_path, polygons, area, binary):
    """Was: a PLY of quads (or triangles and quads) without colours was read as trimesh fans it, and a dart's fan
    from corner 0 covered ground outside it: area 3.0 for the dart's 1.0 (3.5 for a dart and a triangle's 1.5).
    Now concave quads are tiled as OBJ's and OFF's are (an ear clipping in the polygon's plane)."""
    path = tmp_path / "dart.ply"
    path.write_bytes(_ply(polygons, binary))
    mesh = pyshadow.load_mesh(path)
    assert mesh.area == pytest.approx(area, rel=1e-6)
    assert len(mesh.faces) == sum(len(p) - 2 for p in polygons)


def test_convex_quads_are_read_as_trimesh_reads_them(tmp_path):
    """A PLY of convex quads is not rewritten: trimesh's own read, its fans unchanged."""
    path = tmp_path / "square.ply"
    path.write_bytes(_ply([SQUARE, [(x, y + 1.0, z) for x, y, z in SQUARE]]))
    raw = trimesh.load(str(path), process=False)
    read = _read_ply(path)
    assert np.array_equal(read.faces, raw.faces) and np.array_equal(read.vertices, raw.vertices)


def test_a_ply_read_from_its_bytes_is_the_file_read(tmp_path):
    """``_read_ply(None, data)`` (a PLY's contents, as pyshadow.data holds them) reads as the file does, and
    suzanne's two concave (nearly flat) quads are tiled: its area drops by their fans' excess."""
    a = pyshadow.load_mesh(_read_ply(None, pyshadow.data.mesh_bytes("suzanne.ply")))
    b = pyshadow.load_mesh(pyshadow.data.mesh_file("suzanne.ply", tmp_path))
    assert a.vertices.tobytes() == b.vertices.tobytes() and a.faces.tobytes() == b.faces.tobytes()
    fanned = trimesh.load(tmp_path / "suzanne.ply", process=False)
    assert len(a.faces) == 968 and fanned.area - a.area == pytest.approx(2 * (0.00586 - 0.00523), rel=0.02)

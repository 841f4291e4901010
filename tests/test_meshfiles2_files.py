"""Mesh files read by load_mesh: damaged glTF buffers, empty files, an OBJ after a byte order mark, a PLY's
per-corner texcoord lists of triangles and quads, ASCII STLs cut short (helper meshfiles2, second pass).

References: areas and UVs of the same geometry written by hand as triangles; every error names the file.
"""
import base64
import json
import struct

import numpy as np
import pytest
import trimesh

from pyshadow.materials import visual_of
from pyshadow.mesh import load_mesh

SQUARE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
TRIS = np.array([0, 1, 2, 0, 2, 3], np.uint16)


def _gltf(extra_views=(), **accessor):
    """(JSON dict, binary buffer) of one square of two triangles (positions accessor 0, indices accessor 1)."""
    blob = SQUARE.tobytes() + TRIS.tobytes()
    tree = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
            "buffers": [{"byteLength": len(blob)}],
            "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                            {"buffer": 0, "byteOffset": 48, "byteLength": 12}],
            "accessors": [dict({"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                                "min": [0, 0, 0], "max": [1, 1, 0]}, **accessor),
                          {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}]}
    return tree, blob


def _glb(tree, blob, cut=0, bin_chunk=True):
    js = json.dumps(tree).encode()
    js += b" " * (-len(js) % 4)
    body = struct.pack("<II", len(js), 0x4E4F534A) + js
    if bin_chunk:
        body += struct.pack("<II", len(blob), 0x004E4942) + blob
    data = b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body
    return data[:len(data) - cut]


def _load_error(path):
    with pytest.raises(ValueError) as err:
        load_mesh(path)
    assert str(path) in str(err.value)
    return str(err.value)


def test_gltf_buffer_file_cut_short_says_so(tmp_path):
    """Was: a .gltf whose .bin holds 10 of its 60 bytes: 'could not be read as a mesh ()' (an empty reason)."""
    tree, blob = _gltf()
    tree["buffers"][0]["uri"] = "part.bin"
    (tmp_path / "part.bin").write_bytes(blob[:10])
    path = tmp_path / "m.gltf"
    path.write_text(json.dumps(tree))
    message = _load_error(path)
    assert "buffer 0" in message and "'part.bin' holds 10" in message and "60" in message
    (tmp_path / "part.bin").write_bytes(blob + b"\0" * 8)           # longer than it needs: read
    assert load_mesh(path).area == pytest.approx(1.0)


def test_gltf_data_uri_cut_short_says_so(tmp_path):
    """Was: a data: URI of 20 of the buffer's 60 bytes: 'could not be read as a mesh ()'."""
    tree, blob = _gltf()
    path = tmp_path / "m.gltf"
    for size, ok in ((20, False), (60, True)):
        tree["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(blob[:size]).decode()
        path.write_text(json.dumps(tree))
        if ok:
            assert load_mesh(path).area == pytest.approx(1.0)
        else:
            assert "data: URI holds 20" in _load_error(path)


@pytest.mark.parametrize("cut, bin_chunk, was", [(20, True, "chunk was not expected length!"),
                                                 (0, False, "list index out of range")])
def test_glb_cut_short_or_without_binary_chunk_says_so(tmp_path, cut, bin_chunk, was):
    """Was: a GLB cut 20 bytes short: 'chunk was not expected length!'; without its binary chunk: 'list index
    out of range'."""
    path = tmp_path / "m.glb"
    path.write_bytes(_glb(*_gltf(), cut=cut, bin_chunk=bin_chunk))
    message = _load_error(path)
    assert "buffer 0 has 60 bytes" in message and was not in message


@pytest.mark.parametrize("accessor, was", [(0, "cannot reshape array of size 12 into shape (40,3)"),
                                           (1, "cannot reshape array of size 6 into shape (60,1)")])
def test_gltf_accessor_past_its_view_says_so(tmp_path, accessor, was):
    """Was: an accessor counting 10x the elements its view holds: 'cannot reshape array of size 12 into shape
    (40,3)', which named neither accessor nor view."""
    tree, blob = _gltf()
    tree["accessors"][accessor]["count"] *= 10
    path = tmp_path / "m.glb"
    path.write_bytes(_glb(tree, blob))
    message = _load_error(path)
    assert f"accessor {accessor}" in message and f"bufferView {accessor}" in message and was not in message


def test_gltf_interleaved_and_offset_accessors_still_read(tmp_path):
    """Was and is: interleaved positions (byteStride 24, the last element ending at byte 96) and an accessor's
    byteOffset read; the checks of accessors against their views refuse none of them."""
    inter = np.hstack([SQUARE, np.tile(np.float32([0, 0, 1]), (4, 1))]).astype(np.float32)
    tree, _ = _gltf(byteOffset=0)
    blob = inter.tobytes() + TRIS.tobytes()
    tree["buffers"][0]["byteLength"] = len(blob)
    tree["bufferViews"] = [{"buffer": 0, "byteOffset": 0, "byteLength": 96, "byteStride": 24},
                           {"buffer": 0, "byteOffset": 96, "byteLength": 12}]
    tree["accessors"].append({"bufferView": 0, "byteOffset": 12, "componentType": 5126, "count": 4,
                              "type": "VEC3"})
    tree["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = 2
    path = tmp_path / "m.glb"
    path.write_bytes(_glb(tree, blob))
    mesh = load_mesh(path)
    assert mesh.area == pytest.approx(1.0) and np.allclose(mesh.bounds, [[0, 0, 0], [1, 1, 0]])


@pytest.mark.parametrize("case", ["no uri", "no position", "not json"])
def test_gltf_damaged_json_is_not_called_an_unknown_format(tmp_path, case):
    """Was: a .gltf buffer without uri: "unknown or unsupported mesh format '.gltf' ('uri')"; a primitive
    without POSITION: "unknown or unsupported mesh format '.glb' ('POSITION')"; a .gltf that is no JSON:
    'could not be read as a mesh (model.gltf)'."""
    tree, blob = _gltf()
    path = tmp_path / ("m.glb" if case == "no position" else "m.gltf")
    if case == "no position":
        tree["meshes"][0]["primitives"][0]["attributes"] = {}
        path.write_bytes(_glb(tree, blob))
    else:
        path.write_text("solid garbage" if case == "not json" else json.dumps(tree))
    message = _load_error(path)
    assert "unknown or unsupported" not in message and "model.gltf" not in message
    assert {"no uri": "buffer 0 has no uri", "no position": "'POSITION'",
            "not json": "no glTF JSON"}[case] in message


@pytest.mark.parametrize("suffix", [".obj", ".ply", ".stl", ".off", ".glb", ".gltf"])
def test_empty_file_says_so(tmp_path, suffix):
    """Was: an empty .ply: 'Not a ply file!', .glb: 'index 0 is out of bounds', .off: 'not enough values to
    unpack', .obj/.stl: 'holds no geometry'."""
    path = tmp_path / f"empty{suffix}"
    path.write_bytes(b"")
    assert "the file is empty (0 bytes" in _load_error(path)


def test_obj_after_a_byte_order_mark(tmp_path):
    """Was: an OBJ written with UTF-8's byte order mark before its first 'v' line: 'index 161 is out of bounds
    for axis 0 with size 161' (trimesh read no vertex from that line)."""
    sphere = trimesh.creation.icosphere(2)
    text = trimesh.exchange.obj.export_obj(sphere, include_normals=False).encode()
    text = text[text.index(b"\nv ") + 1:]
    path = tmp_path / "bom.obj"
    path.write_bytes(b"\xef\xbb\xbf" + text)
    mesh = load_mesh(path)
    assert len(mesh.faces) == 320 and mesh.area == pytest.approx(sphere.area, rel=1e-7)
    assert path.read_bytes()[:3] == b"\xef\xbb\xbf"                 # read, not modified


def _ply(faces):
    rows = ["0 0 0", "2 0 0", "2 1 0", "1 1 0", "1 2 0", "0 2 0"]
    head = ["ply", "format ascii 1.0", "element vertex 6", "property float x", "property float y",
            "property float z", f"element face {len(faces)}", "property list uchar int vertex_indices",
            "property list uchar float texcoord", "end_header"]
    return ("\n".join(head + rows + faces) + "\n").encode()


def test_ply_texcoord_lists_of_triangles_and_quads(tmp_path):
    """Was: a PLY with per-corner texcoord lists of a quad and a triangle (MeshLab's wedge UVs): 'could not be
    read as a mesh (setting an array element with a sequence.)'; one quad: "object of type 'numpy.int64' has
    no len()". Now as the same faces written as triangles by hand: corners and UVs equal."""
    mixed, by_hand = tmp_path / "mixed.ply", tmp_path / "tris.ply"
    mixed.write_bytes(_ply(["4 0 1 2 3 8 0 0 1 0 1 .5 .5 .5", "3 0 3 4 6 0 0 .2 .3 .4 .9"]))
    by_hand.write_bytes(_ply(["3 0 1 2 6 0 0 1 0 1 .5", "3 0 2 3 6 0 0 1 .5 .5 .5", "3 0 3 4 6 0 0 .2 .3 .4 .9"]))
    a, b = load_mesh(mixed), load_mesh(by_hand)
    assert np.array_equal(a.vertices[a.faces], b.vertices[b.faces]) and a.area == pytest.approx(2.0)
    assert np.array_equal(visual_of(a).uv, visual_of(b).uv)
    one = tmp_path / "one.ply"
    one.write_bytes(_ply(["4 0 1 2 3 8 0 0 1 0 1 .5 .5 .5"]))
    assert load_mesh(one).area == pytest.approx(1.5)


def _ascii_stl(tris, name, end=True):
    facets = "".join("facet normal 0 0 1\n outer loop\n" + "".join(f"  vertex {x} {y} {z}\n" for x, y, z in t)
                     + " endloop\nendfacet\n" for t in tris)
    return (f"solid {name}\n{facets}" + (f"endsolid {name}\n" if end else "")).encode()


def test_ascii_stl_cut_short_says_so(tmp_path):
    """Was: an ASCII STL of two solids whose second has no 'endsolid' (a file cut short) read as the first
    alone (area 1 for 2, without a word); one solid without it: 'the file holds no geometry'."""
    tris = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[1, 0, 0], [1, 1, 0], [0, 1, 0]]], float)
    path = tmp_path / "cut.stl"
    for data in (_ascii_stl(tris, "a") + _ascii_stl(tris + [0, 0, 1], "b", end=False),
                 _ascii_stl(tris, "solid_part")[:-40]):
        path.write_bytes(data)
        assert "'endsolid' lines (cut short?)" in _load_error(path)
    path.write_bytes(_ascii_stl(tris, "a") + _ascii_stl(tris + [0, 0, 1], "SolidWorks b"))
    assert load_mesh(path).area == pytest.approx(2.0)


@pytest.mark.parametrize("corner", ["{}", "{}/{}", "{}//{}"])
def test_obj_counting_from_zero_is_refused(tmp_path, corner):
    """Was: an OBJ written counting from 0 (a common exporter bug) read without a word, index 0 taken for the
    last vertex: a unit box's area 5.83 for 6 (2 faces 'degenerate'), an icosphere's 93.6 for 12.3. Now refused,
    naming the line; the same file counting from 1 reads as the box."""
    box = trimesh.creation.box()
    verts = "".join("v %g %g %g\nvn 0 0 1\n" % tuple(v) for v in box.vertices)
    for base, ok in ((0, False), (1, True)):
        faces = "".join("f " + " ".join(corner.format(i + base, i + base) for i in f) + "\n" for f in box.faces)
        path = tmp_path / f"from{base}.obj"
        path.write_text("# 0 based? \n" + verts + faces)
        if ok:
            mesh = load_mesh(path)
            assert mesh.area == pytest.approx(6.0) and mesh.is_watertight
        else:
            message = _load_error(path)
            assert "has index 0" in message and f"line {2 * len(box.vertices) + 2}" in message


def test_obj_zero_in_coordinates_comments_and_large_indices_still_reads(tmp_path):
    """Was and is: zeros in v lines, in comments after a face, and indices 10, 21, 100 read (no false alarm)."""
    verts = "".join(f"v {i % 10} {i // 10} 0\n" for i in range(101))
    path = tmp_path / "ok.obj"
    path.write_text(verts + "f 1 11 2 # 0\nf 10 21 100\nf 101 100 91\n")
    assert len(load_mesh(path).faces) == 3


@pytest.mark.parametrize("form", ["ascii", "binary_little_endian"])
def test_ply_without_faces_says_so(tmp_path, form):
    """Was: a PLY of 3 vertices and 0 faces: 'not a triangle mesh (trimesh returned PointCloud)'; now the message
    counts the points and says there are no faces."""
    head = (f"ply\nformat {form} 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 0\nproperty list uchar int vertex_indices\nend_header\n").encode()
    rows = np.float32([[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    path = tmp_path / "points.ply"
    path.write_bytes(head + (b"0 0 0\n1 0 0\n0 1 0\n" if form == "ascii" else rows.tobytes()))
    assert "3 points and no faces" in _load_error(path)

"""glTF files whose geometry trimesh cannot decode are refused with the reason (not read wrongly)."""
import json
import struct

import numpy as np
import pytest

from pyshadow.mesh import load_mesh

from conftest import glb_bytes

TETRA = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float) * 0.5
FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.uint16)


def _tetra_glb(positions, component, normalized=False, stride=12, extensions=None, prim_ext=None):
    blob = FACES.tobytes() + positions.tobytes()
    prim = {"attributes": {"POSITION": 1}, "indices": 0}
    if prim_ext:
        prim["extensions"] = prim_ext
    acc = {"bufferView": 1, "componentType": component, "count": 4, "type": "VEC3",
           "min": positions[:, :3].min(axis=0).tolist(), "max": positions[:, :3].max(axis=0).tolist()}
    if normalized:
        acc["normalized"] = True
    tree = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [prim]}], "buffers": [{"byteLength": len(blob)}],
            "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": FACES.nbytes},
                            {"buffer": 0, "byteOffset": FACES.nbytes, "byteLength": positions.nbytes,
                             "byteStride": stride}],
            "accessors": [{"bufferView": 0, "componentType": 5123, "count": 12, "type": "SCALAR"}, acc]}
    if extensions:
        tree["extensionsUsed"] = tree["extensionsRequired"] = extensions
    return glb_bytes(tree, blob)


def test_plain_float_glb_loads(tmp_path):
    """Was: a float32 tetrahedron GLB loaded with its own coordinates; it still does (the checks pass it)."""
    (tmp_path / "t.glb").write_bytes(_tetra_glb(TETRA.astype(np.float32), 5126))
    mesh = load_mesh(tmp_path / "t.glb")
    np.testing.assert_allclose(mesh.bounds, [[0, 0, 0], [0.5, 0.5, 0.5]], atol=1e-7)
    assert len(mesh.faces) == 4


def test_normalized_int16_positions_refused(tmp_path):
    """Was: KHR_mesh_quantization positions (int16, normalized) were taken as the integers: the 0.5-sized
    tetrahedron loaded with bounds 0..16384 (32767 times too large) and no message."""
    q = np.zeros((4, 4), np.int16)
    q[:, :3] = np.round(TETRA * 32767)
    (tmp_path / "q.glb").write_bytes(_tetra_glb(q, 5122, normalized=True, stride=8,
                                                extensions=["KHR_mesh_quantization"]))
    with pytest.raises(ValueError, match="normalized integers"):
        load_mesh(tmp_path / "q.glb")


def test_unnormalized_int_positions_still_load(tmp_path):
    """Was: integer positions without ``normalized`` loaded as their values (as glTF means); they still do."""
    q = np.zeros((4, 4), np.int16)
    q[:, :3] = TETRA * 4
    (tmp_path / "i.glb").write_bytes(_tetra_glb(q, 5122, stride=8, extensions=["KHR_mesh_quantization"]))
    np.testing.assert_array_equal(load_mesh(tmp_path / "i.glb").bounds, [[0, 0, 0], [2, 2, 2]])


def test_draco_without_dracopy_refused(tmp_path):
    """Was: trimesh read a Draco-compressed primitive as placeholder zeros without DracoPy, and load_mesh
    said "every face is degenerate (empty mesh after cleaning)"; now the message names Draco and DracoPy."""
    import importlib.util
    if importlib.util.find_spec("DracoPy") is not None:
        pytest.skip("DracoPy is installed: trimesh decodes Draco")
    ext = {"KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {"POSITION": 0}}}
    data = _tetra_glb(TETRA.astype(np.float32), 5126, extensions=["KHR_draco_mesh_compression"], prim_ext=ext)
    n = struct.unpack_from("<I", data, 12)[0]
    tree = json.loads(data[20:20 + n])
    for acc in tree["accessors"]:                 # Draco's accessors have no buffer view of their own
        acc.pop("bufferView")
    (tmp_path / "d.glb").write_bytes(glb_bytes(tree, data[20 + n + 8:]))
    with pytest.raises(ValueError, match="DracoPy"):
        load_mesh(tmp_path / "d.glb")


def test_meshopt_refused(tmp_path):
    """Was: ValueError "could not be read as a mesh (list index out of range)" for a GLB whose buffer views
    are EXT_meshopt_compression data over a fallback buffer; now the message names meshopt."""
    blob = b"\x01" * 64
    mo = {"EXT_meshopt_compression": {"buffer": 0, "byteOffset": 0, "byteLength": 20, "byteStride": 2,
                                      "mode": "TRIANGLES", "count": 12}}
    mo2 = {"EXT_meshopt_compression": {"buffer": 0, "byteOffset": 20, "byteLength": 40, "byteStride": 12,
                                       "mode": "ATTRIBUTES", "count": 4}}
    tree = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "extensionsUsed": ["EXT_meshopt_compression"], "extensionsRequired": ["EXT_meshopt_compression"],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 1}, "indices": 0}]}],
            "buffers": [{"byteLength": 64},
                        {"byteLength": 72, "extensions": {"EXT_meshopt_compression": {"fallback": True}}}],
            "bufferViews": [{"buffer": 1, "byteOffset": 0, "byteLength": 24, "extensions": mo},
                            {"buffer": 1, "byteOffset": 24, "byteLength": 48, "byteStride": 12, "extensions": mo2}],
            "accessors": [{"bufferView": 0, "componentType": 5123, "count": 12, "type": "SCALAR"},
                          {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3",
                           "min": [0, 0, 0], "max": [1, 1, 1]}]}
    (tmp_path / "m.glb").write_bytes(glb_bytes(tree, blob))
    with pytest.raises(ValueError, match="EXT_meshopt_compression"):
        load_mesh(tmp_path / "m.glb")


def test_triangle_fan_refused(tmp_path):
    """Was: trimesh left out a TRIANGLE_FAN primitive (mode 6) without a word: a GLB of a fan beside a
    triangle list loaded only the list (4 of 6 triangles, no message)."""
    fan = np.array([[0, 0, 2], [1, 0, 2], [1, 1, 2], [0, 1, 2]], np.float32)       # 2 triangles as a fan
    pos = np.vstack([TETRA.astype(np.float32), fan])
    blob = FACES.tobytes() + pos.tobytes()
    tree = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 1}, "indices": 0},
                                       {"attributes": {"POSITION": 2}, "mode": 6}]}],
            "buffers": [{"byteLength": len(blob)}],
            "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": FACES.nbytes},
                            {"buffer": 0, "byteOffset": FACES.nbytes, "byteLength": pos.nbytes}],
            "accessors": [{"bufferView": 0, "componentType": 5123, "count": 12, "type": "SCALAR"},
                          {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3",
                           "min": [0, 0, 0], "max": [0.5, 0.5, 0.5]},
                          {"bufferView": 1, "byteOffset": 48, "componentType": 5126, "count": 4, "type": "VEC3",
                           "min": [0, 0, 2], "max": [1, 1, 2]}]}
    (tmp_path / "fan.glb").write_bytes(glb_bytes(tree, blob))
    with pytest.raises(ValueError, match="triangle fan"):
        load_mesh(tmp_path / "fan.glb")


def test_sparse_positions_refused(tmp_path):
    """Was: trimesh read a sparse POSITION accessor without its sparse values: a tetrahedron whose 4th
    vertex is moved by the sparse part to (0, 0, 3) loaded with bounds z 0..0.5 instead of 0..3."""
    pos = TETRA.astype(np.float32)
    moved = np.array([[0, 0, 3]], np.float32)
    sparse_idx = np.array([3], np.uint16)
    blob = FACES.tobytes() + pos.tobytes() + sparse_idx.tobytes() + b"\0\0" + moved.tobytes()
    off = FACES.nbytes + pos.nbytes
    tree = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 1}, "indices": 0}]}],
            "buffers": [{"byteLength": len(blob)}],
            "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": FACES.nbytes},
                            {"buffer": 0, "byteOffset": FACES.nbytes, "byteLength": pos.nbytes},
                            {"buffer": 0, "byteOffset": off, "byteLength": 2},
                            {"buffer": 0, "byteOffset": off + 4, "byteLength": 12}],
            "accessors": [{"bufferView": 0, "componentType": 5123, "count": 12, "type": "SCALAR"},
                          {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3",
                           "min": [0, 0, 0], "max": [0.5, 0.5, 3],
                           "sparse": {"count": 1, "indices": {"bufferView": 2, "componentType": 5123},
                                      "values": {"bufferView": 3}}}]}
    (tmp_path / "sparse.glb").write_bytes(glb_bytes(tree, blob))
    with pytest.raises(ValueError, match="sparse"):
        load_mesh(tmp_path / "sparse.glb")

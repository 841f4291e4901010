"""glTF files naming their buffers and images by percent-encoded URIs (as Blender writes them)."""
import base64
import json
import struct
import zlib

import numpy as np
import pytest

import pyshadow
from pyshadow.bake.assets import bake_asset, side_files
from pyshadow.bake.params import AssetParams

V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]], np.float32)
F = np.array([[0, 1, 2], [0, 2, 3], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]], np.uint16)
UV = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]], np.float32)
IMG = (np.arange(4 * 4 * 3) * 37 % 256).astype(np.uint8).reshape(4, 4, 3)


def _png(img):
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    rows = b"".join(b"\0" + row.tobytes() for row in img)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", img.shape[1], img.shape[0], 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


BLOB = V.tobytes() + UV.tobytes() + F.tobytes()


def _tree(bin_uri, img_uri, sampler=False):
    tree = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "textures": [{"source": 0}], "images": [{"uri": img_uri}],
        "buffers": [{"uri": bin_uri, "byteLength": len(BLOB)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 60}, {"buffer": 0, "byteOffset": 60,
                        "byteLength": 40}, {"buffer": 0, "byteOffset": 100, "byteLength": 36}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 5, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 1]},
                      {"bufferView": 1, "componentType": 5126, "count": 5, "type": "VEC2"},
                      {"bufferView": 2, "componentType": 5123, "count": 18, "type": "SCALAR"}]}
    if sampler:         # nearest: pyshadow.gltf_materials reads the buffers itself then
        tree["samplers"] = [{"magFilter": 9728, "minFilter": 9728}]
        tree["textures"][0]["sampler"] = 0
    return tree


def _write(folder, bin_uri, img_uri, bin_file, img_file, name="m.gltf", sampler=False):
    for file, data in ((bin_file, BLOB), (img_file, _png(IMG))):
        if file:
            (folder / file).parent.mkdir(parents=True, exist_ok=True)
            (folder / file).write_bytes(data)
    text = json.dumps(_tree(bin_uri, img_uri, sampler)).encode()
    if name.endswith(".glb"):           # a GLB of only its JSON chunk, the files beside it
        text += b" " * (-len(text) % 4)
        data = b"glTF" + struct.pack("<II", 2, 20 + len(text)) + struct.pack("<II", len(text), 0x4E4F534A) + text
        (folder / name).write_bytes(data)
    else:
        (folder / name).write_bytes(text)
    return folder / name


def _read(path):
    mesh = pyshadow.load_mesh(path)
    vis = mesh.metadata["pyshadow_visual"]
    return mesh.vertices, mesh.faces, vis.uv, vis.texture, vis.sampler


CASES = {   # buffer uri, image uri, buffer file, image file
    "space": ("my%20chair.bin", "my%20tex.png", "my chair.bin", "my tex.png"),
    "utf8": ("caf%C3%A9.bin", "t%C3%A9%20x.png", "café.bin", "té x.png"),
    "folders": ("./sub/m%20x.bin", "textures/a%20b.png", "sub/m x.bin", "textures/a b.png"),
    "raw": ("my chair.bin", "té x.png", "my chair.bin", "té x.png"),
    "percent": ("100%25.bin", "t%2520.png", "100%.bin", "t%20.png"),
}


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
@pytest.mark.parametrize("sampler", [False, True])
@pytest.mark.parametrize("case", sorted(CASES))
def test_encoded_names_read_like_plain_names(tmp_path, case, sampler, suffix):
    """Was: an encoded buffer URI failed ("m.gltf: could not be read as a mesh (my%20chair.bin)"), an
    encoded image URI was dropped without a word (texture None: the mesh read white), and a GLB without a
    binary chunk lost its nearest sampler (read (10497, 10497, False)). Now vertices, faces, UVs, texture
    pixels and sampler equal those of the same model with plain names, exactly (raw names already read)."""
    (tmp_path / "plain").mkdir()
    (tmp_path / "named").mkdir()
    want = _read(_write(tmp_path / "plain", "m.bin", "t.png", "m.bin", "t.png", "m" + suffix, sampler))
    got = _read(_write(tmp_path / "named", *CASES[case], name="m" + suffix, sampler=sampler))
    assert want[3] is not None and want[3].shape == (4, 4, 3)
    for a, b in zip(want[:4], got[:4]):
        np.testing.assert_array_equal(a, b)
    assert got[4] == want[4] and (want[4][2] if sampler else True)


def test_data_uris_read_like_files(tmp_path):
    """Was already right, kept so: embedded (data:) buffer and image read as files beside it do."""
    want = _read(_write(tmp_path, "m.bin", "t.png", "m.bin", "t.png"))
    tree = _tree("data:application/octet-stream;base64," + base64.b64encode(BLOB).decode(),
                 "data:image/png;base64," + base64.b64encode(_png(IMG)).decode())
    (tmp_path / "d.gltf").write_text(json.dumps(tree))
    for a, b in zip(want[:4], _read(tmp_path / "d.gltf")[:4]):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("bin_uri, img_uri, files, words", [
    ("no%20pe.bin", "t.png", ("", "t.png"),
     "buffer 0 names the file 'no pe.bin' (uri 'no%20pe.bin'), which is not"),
    ("m.bin", "my%20tex.png", ("m.bin", ""), "image 0 names the file 'my tex.png' (uri 'my%20tex.png'), which is not"),
    ("../up.bin", "t.png", ("../up.bin", "t.png"), "buffer 0 names the file '../up.bin', which lies outside"),
    ("m.bin", "..%2Fup.png", ("m.bin", "../up.png"),
     "image 0 names the file '../up.png' (uri '..%2Fup.png'), which lies outside"),
])
def test_missing_or_outside_files_are_named(tmp_path, bin_uri, img_uri, files, words):
    """Was: a missing buffer failed as "could not be read as a mesh (no%20pe.bin)"; a missing image, or one
    outside the folder, was left out without a word (texture None, the mesh read white); a buffer outside
    it failed naming trimesh's "FilePathResolver(path, allow_anywhere=True)", which load_mesh cannot take.
    Now a ValueError names the buffer, its decoded name and why; a UserWarning names an image the same way,
    and the mesh is read without it (geometry, AO and shadows need none)."""
    (tmp_path / "d").mkdir()
    path = _write(tmp_path / "d", bin_uri, img_uri, *files)
    if words.startswith("buffer"):
        with pytest.raises(ValueError, match="m.gltf: its ") as info:
            pyshadow.load_mesh(path)
        assert words in str(info.value)
        return
    with pytest.warns(UserWarning, match="m.gltf: its ") as info:
        mesh = pyshadow.load_mesh(path)
    assert any(words in str(w.message) for w in info)
    visual = pyshadow.materials.visual_of(mesh)
    assert len(mesh.faces) == 6 and (visual is None or visual.texture is None)


def test_side_files_find_encoded_names_and_the_bake_reads_them(tmp_path):
    """Was: side_files left out files named by encoded URIs ({'t.png'} of 'my%20chair.bin' and
    'textures/a%20b.png'), so the worker's copy failed ("could not be read as a mesh (my%20chair.bin)").
    Now both files travel under their decoded names and the asset bakes (5 vertices, 6 faces)."""
    path = _write(tmp_path, "my%20chair.bin", "textures/a%20b.png", "my chair.bin", "textures/a b.png")
    side = side_files(path)
    assert side == {"my chair.bin": tmp_path / "my chair.bin", "textures/a b.png": tmp_path / "textures" / "a b.png"}
    params = AssetParams(theta=4, phi=8, resolution=16, samples=4).to_dict()
    res = bake_asset("m", ".gltf", path.read_bytes(), params, "key", {k: p.read_bytes() for k, p in side.items()})
    assert res["record"]["status"] == "baked", res["record"]["error"]
    assert res["record"]["mesh"]["vertices"] == 5 and res["record"]["mesh"]["faces"] == 6


def test_side_files_keep_plain_names_as_written(tmp_path):
    """Was already right, kept so (the names key the bake's cache): plain URIs, ./ included, are the keys."""
    path = _write(tmp_path, "./m.bin", "t.png", "m.bin", "t.png")
    assert side_files(path) == {"./m.bin": tmp_path / "m.bin", "t.png": tmp_path / "t.png"}

"""glTF's baseColorFactor as the file gives it (a float multiplier, glTF 2.0 section 3.9.2), against the numbers
written into hand-made .gltf/.glb files: trimesh keeps it as 8-bit RGBA, which pyshadow.load_mesh used."""
import io
import json

import numpy as np
import pytest
from PIL import Image

import pyshadow
from pyshadow.io import srgb_to_linear
from pyshadow.materials import point_colours, visual_of

from conftest import gltf_bytes

TRI = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
UV = np.array([[0.1, 0.2], [0.9, 0.3], [0.4, 0.8]], np.float32)
IMG = np.random.default_rng(5).integers(0, 256, (4, 6, 3), dtype=np.uint8)


def gltf(materials, uv=False, glb=True, sampler=None):
    """One triangle per material (each its own mesh and node); with ``uv`` the IMG texture and ``sampler``."""
    blob, views, accs = bytearray(), [], []

    def add(arr, kind):
        blob.extend(b"\0" * (-len(blob) % 4))
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": arr.nbytes})
        blob.extend(arr.tobytes())
        accs.append({"bufferView": len(views) - 1, "componentType": 5126 if arr.dtype == np.float32 else 5125,
                     "count": len(arr), "type": kind})
        if kind == "VEC3":
            accs[-1].update(min=arr.min(0).tolist(), max=arr.max(0).tolist())
        return len(accs) - 1

    meshes = []
    for k in range(len(materials)):
        attrs = {"POSITION": add(TRI, "VEC3")}
        if uv:
            attrs["TEXCOORD_0"] = add(UV, "VEC2")
        meshes.append({"primitives": [{"attributes": attrs, "indices": add(np.arange(3, dtype=np.uint32), "SCALAR"),
                                       "material": k}]})
    tree = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": list(range(len(materials)))}],
            "nodes": [{"mesh": k, "translation": [2.0 * k, 0, 0]} for k in range(len(materials))],
            "meshes": meshes, "materials": materials}
    if uv:
        png = io.BytesIO()
        Image.fromarray(IMG).save(png, format="PNG")
        blob.extend(b"\0" * (-len(blob) % 4))
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(png.getvalue())})
        blob.extend(png.getvalue())
        tree.update(images=[{"bufferView": len(views) - 1, "mimeType": "image/png"}], samplers=[sampler or {}],
                    textures=[{"source": 0, "sampler": 0}])
    blob.extend(b"\0" * (-len(blob) % 4))
    tree.update(buffers=[{"byteLength": len(blob)}], bufferViews=views, accessors=accs)
    return gltf_bytes(tree, blob, glb)


def load(tmp_path, data, name):
    (tmp_path / name).write_bytes(data)
    return pyshadow.load_mesh(tmp_path / name)


@pytest.mark.parametrize("glb", [True, False])
def test_base_colour_factor_keeps_its_float_value(tmp_path, glb):
    """Was: the factor came out in 8 bits: (0.5, 0.3, 0.001) read as (0.50196, 0.29804, 0), (0.18, 0.0015, 0.9)
    as (0.18039, 0, 0.90196): dark channels lost entirely (relative error 1.0), others off by up to 0.65 %."""
    for rgb in ([0.5, 0.3, 0.001], [0.18, 0.0015, 0.9]):
        mat = {"name": "paint", "pbrMetallicRoughness": {"baseColorFactor": rgb + [1.0]}}
        mesh = load(tmp_path, gltf([mat], glb=glb), "m.glb" if glb else "m.gltf")
        np.testing.assert_allclose(visual_of(mesh).factor, rgb, rtol=1e-6, atol=0)


def test_each_material_of_a_scene_keeps_its_factor(tmp_path):
    """Was: two materials 0.001 and 0.002 apart in blue both read 8-bit (0 and 0.00392: 2x); the faces' colours
    were off by up to 100 %. Unnamed materials are matched by their 8-bit factors."""
    mats = [{"pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.001, 1.0]}},
            {"name": "b", "pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.05, 0.002, 1.0]}}]
    mesh = load(tmp_path, gltf(mats), "two.glb")
    # the two triangles' colours at their centres, in the order the scene's meshes were joined
    got = point_colours(visual_of(mesh), [0, 1], np.full((2, 3), 1 / 3))
    want = np.array([m["pbrMetallicRoughness"]["baseColorFactor"][:3] for m in mats])
    order = np.argsort(mesh.triangles_center[:, 0])
    np.testing.assert_allclose(got[order], want, rtol=1e-6, atol=0)


def test_textured_factor_is_float_and_the_files_sampler_still_found(tmp_path):
    """Was: texel times the 8-bit factor (0.003 read as 0.00392, +31 %); the float factor must not stop
    pyshadow.gltf_materials from matching the primitive (its NEAREST sampler is used: texels, not blends)."""
    factor = [0.25, 0.6, 0.003, 1.0]
    mat = {"pbrMetallicRoughness": {"baseColorFactor": factor, "baseColorTexture": {"index": 0}}}
    mesh = load(tmp_path, gltf([mat], uv=True, sampler={"magFilter": 9728}), "t.glb")
    bary = np.random.default_rng(1).dirichlet([1, 1, 1], 50)
    uv = bary @ UV.astype(np.float64)
    h, w = IMG.shape[:2]
    texel = srgb_to_linear(IMG[np.floor(uv[:, 1] * h).astype(int), np.floor(uv[:, 0] * w).astype(int)] / 255.0)
    got = point_colours(visual_of(mesh), np.zeros(len(bary), int), bary)
    np.testing.assert_allclose(got, texel * factor[:3], rtol=1e-4, atol=1e-7)


def test_factor_of_a_material_whose_image_file_is_missing(tmp_path):
    """Was: 8 bits as well (0.001 read as 0: the surface black); the image is left out with a warning and the
    float factor (the colour the surface keeps) is the file's."""
    mat = {"name": "tex", "pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.001, 0.35, 1.0],
                                                   "baseColorTexture": {"index": 0}}}
    tree = json.loads(gltf([mat], uv=True, glb=False))
    tree["images"] = [{"uri": "caf%C3%A9%20missing.png"}]
    (tmp_path / "m.gltf").write_text(json.dumps(tree))
    with pytest.warns(UserWarning, match="missing.png"):
        mesh = pyshadow.load_mesh(tmp_path / "m.gltf")
    np.testing.assert_allclose(visual_of(mesh).factor, [0.6, 0.001, 0.35], rtol=1e-6, atol=0)

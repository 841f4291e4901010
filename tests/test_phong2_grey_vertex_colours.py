"""Greyscale per-vertex colours ((V,), (V, 1), grey + alpha (V, 2)) of a textured mesh (pyshadow.materials)."""
import io

import numpy as np
import pytest
import trimesh
from conftest import glb_bytes

import pyshadow
from pyshadow.materials import mesh_visual, point_colours, visual_of

def _srgb(c):
    """sRGB-encoded [0, 1] -> linear, float64 (IEC 61966-2-1)."""
    c = np.asarray(c, np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


GREY = np.array([0.1, 0.4, 0.7, 1.0], np.float32)      # one per vertex of the quad below


def _glb(colour, component_type):
    """A textured quad (white 2x2 texture) whose COLOR_0 is a SCALAR accessor (a grey per vertex)."""
    from PIL import Image

    pos = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    idx = np.array([0, 1, 2, 0, 2, 3], np.uint16)
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)
    png = io.BytesIO()
    Image.new("RGB", (2, 2), (255, 255, 255)).save(png, "PNG")
    blob, views = b"", []
    for chunk in (pos.tobytes(), idx.tobytes(), uv.tobytes(), colour.tobytes(), png.getvalue()):
        chunk += b"\0" * (-len(chunk) % 4)
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(chunk)})
        blob += chunk
    acc = [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
           {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"},
           {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
           {"bufferView": 3, "componentType": component_type, "count": 4, "type": "SCALAR", "normalized": True}]
    tree = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 2, "COLOR_0": 3},
                                        "indices": 1, "material": 0}]}],
            "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
            "textures": [{"source": 0}], "images": [{"bufferView": 4, "mimeType": "image/png"}],
            "accessors": acc, "bufferViews": views, "buffers": [{"byteLength": len(blob)}]}
    return glb_bytes(tree, blob)


@pytest.mark.parametrize("colour, ctype", [(GREY, 5126), ((GREY * 65535).round().astype(np.uint16), 5123),
                                           ((GREY * 255).round().astype(np.uint8), 5121)])
def test_glb_scalar_colour_0_is_grey(tmp_path, colour, ctype):
    """Was: a textured glTF primitive whose COLOR_0 is one grey per vertex (trimesh reads it as (V, 1)) loaded,
    and its visual then failed every render: "colours must have shape (T, 3, 3), got (2, 3, 1)"."""
    path = tmp_path / "grey.glb"
    path.write_bytes(_glb(colour, ctype))
    mesh = pyshadow.load_mesh(str(path))
    v = visual_of(mesh)
    faces = np.asarray(mesh.faces)
    verts = np.asarray(mesh.vertices)
    # the grey of each vertex (linear: glTF's COLOR_0) found by its position on the quad
    corner = {(0, 0): 0, (1, 0): 1, (1, 1): 2, (0, 1): 3}
    unit = colour / (1.0 if colour.dtype.kind == "f" else float(np.iinfo(colour.dtype).max))
    want_v = np.array([unit[corner[(round(x), round(y))]] for x, y, _ in verts], np.float64)
    bary = np.array([[0.2, 0.3, 0.5]] * len(faces))
    got = point_colours(v, np.arange(len(faces)), bary)
    want = (bary * want_v[faces]).sum(axis=1)
    np.testing.assert_allclose(got, np.repeat(want[:, None], 3, axis=1), atol=1e-6, rtol=0)   # float32 colours


@pytest.mark.parametrize("shape", ["(V,)", "(V,1)", "(V,2)"])
def test_built_mesh_grey_vertex_attribute(shape):
    """Was: a TextureVisuals whose vertex_attributes["color"] is a (V,) grey raised IndexError ("index 3 is out of
    bounds for axis 0 with size 3": the first three vertices' greys read as one colour); (V, 1) and (V, 2) gave
    (T, 3, 1) / (T, 3, 2) colours that every render refused."""
    box = trimesh.creation.box()
    n = len(box.vertices)
    grey = (np.arange(n) * 30 + 10).astype(np.uint8)
    col = {"(V,)": grey, "(V,1)": grey[:, None], "(V,2)": np.column_stack([grey, np.full(n, 128, np.uint8)])}[shape]
    mesh = trimesh.Trimesh(box.vertices, box.faces, process=False)
    mesh.visual = trimesh.visual.TextureVisuals(uv=np.zeros((n, 2)))
    mesh.visual.vertex_attributes["color"] = col
    v = mesh_visual(mesh)
    bary = np.array([[0.6, 0.3, 0.1]] * len(box.faces))
    got = point_colours(v, np.arange(len(box.faces)), bary)
    want = (bary * _srgb(grey / 255.0)[np.asarray(box.faces)]).sum(axis=1)      # sRGB: not a glTF
    np.testing.assert_allclose(got, np.repeat(want[:, None], 3, axis=1), atol=1e-6, rtol=0)


def test_vertex_colours_of_five_channels_refused():
    """Was: (V, 5) vertex colours were read as their first three channels without a word."""
    box = trimesh.creation.box()
    n = len(box.vertices)
    mesh = trimesh.Trimesh(box.vertices, box.faces, process=False)
    mesh.visual = trimesh.visual.TextureVisuals(uv=np.zeros((n, 2)))
    mesh.visual.vertex_attributes["color"] = np.zeros((n, 5), np.uint8)
    with pytest.raises(ValueError, match=r"five.ply: vertex or face colours must have shape .*got \(8, 5\)"):
        mesh_visual(mesh, source="five.ply")

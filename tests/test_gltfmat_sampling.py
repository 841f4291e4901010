"""glTF colours that trimesh's reader loses, read from the file (pyshadow.gltf_materials), against NumPy references
written from the glTF 2.0 specification: COLOR_0 without a material (normalized ushort, float), the base colour
texture's sampler (wrap modes, NEAREST magnification), its texCoord set and KHR_texture_transform."""
import io

import numpy as np
import pytest
from PIL import Image

import pyshadow
from pyshadow.io import srgb_to_linear
from pyshadow.materials import point_colours, visual_of

from conftest import gltf_bytes

REPEAT, CLAMP, MIRROR, NEAREST = 10497, 33071, 33648, 9728
TRI = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
CT = {"float32": 5126, "uint16": 5123, "uint8": 5121, "uint32": 5125}
IMG = np.random.default_rng(2).integers(0, 256, (5, 7, 3), dtype=np.uint8)
LIN = srgb_to_linear(IMG / 255.0)
UV0 = np.array([[-1.3, -0.7], [2.4, -0.2], [0.1, 1.9]], np.float32)      # glTF's UVs (v down), outside [0, 1]
UV1 = np.array([[0.05, 0.1], [0.9, 0.2], [0.3, 0.95]], np.float32)
BARY = np.random.default_rng(3).dirichlet([1, 1, 1], 300)


def gltf_file(prims, materials=(), sampler=None, image=True, glb=True):
    """A glTF of one triangle mesh per entry of ``prims`` (dicts of attribute -> (array, normalized) and an
    optional "material"), each on a node shifted by 2 in x; the ``IMG`` texture with ``sampler``."""
    blob, views, accs = bytearray(), [], []

    def add(arr, normalized=False):
        arr = np.ascontiguousarray(arr)
        blob.extend(b"\0" * (-len(blob) % 4))
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": arr.nbytes})
        blob.extend(arr.tobytes())
        acc = {"bufferView": len(views) - 1, "componentType": CT[arr.dtype.name], "count": len(arr),
               "type": "SCALAR" if arr.ndim == 1 else f"VEC{arr.shape[1]}", "normalized": normalized}
        if arr.ndim == 2 and arr.shape[1] == 3 and arr.dtype == np.float32:
            acc.update(min=arr.min(0).tolist(), max=arr.max(0).tolist())
        accs.append(acc)
        return len(accs) - 1

    meshes = []
    for p in prims:
        prim = {"attributes": {"POSITION": add(TRI)}, "indices": add(np.arange(3, dtype=np.uint32))}
        prim["attributes"].update({k: add(*v) for k, v in p.items() if k != "material"})
        if "material" in p:
            prim["material"] = p["material"]
        meshes.append({"primitives": [prim]})
    tree = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": list(range(len(prims)))}],
            "nodes": [{"mesh": k, "translation": [2.0 * k, 0, 0]} for k in range(len(prims))],
            "meshes": meshes, "materials": list(materials), "extensionsUsed": ["KHR_texture_transform"]}
    if image:
        png = io.BytesIO()
        Image.fromarray(IMG).save(png, format="PNG")
        blob.extend(b"\0" * (-len(blob) % 4))
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(png.getvalue())})
        blob.extend(png.getvalue())
        tree["images"] = [{"bufferView": len(views) - 1, "mimeType": "image/png"}]
        tree["samplers"] = [sampler or {}, {}]
        tree["textures"] = [{"source": 0, "sampler": 0}, {"source": 0, "sampler": 1}]
    blob.extend(b"\0" * (-len(blob) % 4))
    tree.update(buffers=[{"byteLength": len(blob)}], bufferViews=views, accessors=accs)
    return gltf_bytes(tree, blob, glb)


def textured(info, sampler=None, glb=True):
    material = {"pbrMetallicRoughness": {"baseColorTexture": info}}
    return gltf_file([{"TEXCOORD_0": (UV0, False), "TEXCOORD_1": (UV1, False), "material": 0}], [material],
                     sampler, glb=glb)


def load(tmp_path, data, name="m.glb"):
    (tmp_path / name).write_bytes(data)
    return pyshadow.load_mesh(tmp_path / name)


def colours(mesh, face=0):
    return point_colours(visual_of(mesh), np.full(len(BARY), face), BARY)


def wrapped(i, n, mode):
    """OpenGL's wrap of texel index ``i`` (an int) into [0, n)."""
    if mode == CLAMP:
        return min(max(i, 0), n - 1)
    if mode == MIRROR:
        r = i % (2 * n)
        return r if r < n else 2 * n - 1 - r
    return i % n


def reference(uv, wrap_s=REPEAT, wrap_t=REPEAT, nearest=False):
    """The texel colour at each glTF uv (v down: row 0 at v = 0), texel centres at (i + 0.5) / size."""
    h, w = LIN.shape[:2]
    out = []
    for u, v in uv:
        if nearest:
            out.append(LIN[wrapped(int(np.floor(v * h)), h, wrap_t), wrapped(int(np.floor(u * w)), w, wrap_s)])
            continue
        x, y = u * w - 0.5, v * h - 0.5
        j, i = int(np.floor(x)), int(np.floor(y))
        fx, fy = x - j, y - i
        t = [[LIN[wrapped(i + a, h, wrap_t), wrapped(j + b, w, wrap_s)] for b in (0, 1)] for a in (0, 1)]
        out.append((1 - fy) * ((1 - fx) * t[0][0] + fx * t[0][1]) + fy * ((1 - fx) * t[1][0] + fx * t[1][1]))
    return np.array(out)


@pytest.mark.parametrize("wrap_s", [REPEAT, CLAMP, MIRROR])
@pytest.mark.parametrize("wrap_t", [CLAMP, MIRROR])
@pytest.mark.parametrize("mag", [None, NEAREST])
def test_the_sampler_wrap_modes_and_nearest_filter_are_used(tmp_path, wrap_s, wrap_t, mag):
    """Was: every texture was sampled bilinearly with repeat wrap whatever its sampler: with UVs in [-1.3, 2.4]
    57 to 100 % of the points were off, by up to 0.87 (linear RGB), under CLAMP_TO_EDGE or MIRRORED_REPEAT or a
    NEAREST magnification filter."""
    sampler = {"wrapS": wrap_s, "wrapT": wrap_t, **({"magFilter": mag} if mag else {})}
    mesh = load(tmp_path, textured({"index": 0}, sampler))
    want = reference(BARY @ UV0.astype(float), wrap_s, wrap_t, mag == NEAREST)
    np.testing.assert_allclose(colours(mesh), want, atol=1e-4)


def test_a_clamped_texture_does_not_bleed_across_its_edge(tmp_path):
    """Was: with CLAMP_TO_EDGE and UVs in [0, 1], the half texel along each edge blended in the opposite edge
    (repeat wrap): a seam line on every atlas border; the corner texels came out off by up to 0.45."""
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], np.float32)
    material = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}
    mesh = load(tmp_path, gltf_file([{"TEXCOORD_0": (uv, False), "material": 0}], [material],
                                     {"wrapS": CLAMP, "wrapT": CLAMP}))
    corners = point_colours(visual_of(mesh), [0, 0, 0], np.eye(3))
    np.testing.assert_allclose(corners, LIN[[0, 0, -1], [0, -1, 0]], atol=1e-6)


@pytest.mark.parametrize("glb", [True, False])
def test_the_texcoord_set_of_the_texture_is_used(tmp_path, glb):
    """Was: TEXCOORD_0 was used whatever set baseColorTexture.texCoord named: colours off by up to 0.81."""
    mesh = load(tmp_path, textured({"index": 0, "texCoord": 1}, glb=glb), "m.glb" if glb else "m.gltf")
    np.testing.assert_allclose(colours(mesh), reference(BARY @ UV1.astype(float)), atol=1e-4)


def test_khr_texture_transform_is_applied(tmp_path):
    """Was: KHR_texture_transform was ignored: colours off by up to 0.88. Here the specification's example (the
    lower left quadrant of the image, turned clockwise by 90 degrees) and a transform that names TEXCOORD_1."""
    quarter = {"offset": [0, 1], "rotation": np.pi / 2, "scale": [0.5, 0.5]}
    mesh = load(tmp_path, textured({"index": 0, "extensions": {"KHR_texture_transform": quarter}}))
    u, v = (BARY @ UV0.astype(float)).T
    # u' = cos r * 0.5 u + sin r * 0.5 v, v' = -sin r * 0.5 u + cos r * 0.5 v + 1 at r = 90 degrees
    np.testing.assert_allclose(colours(mesh), reference(np.column_stack([0.5 * v, 1 - 0.5 * u])), atol=1e-4)
    other = {"texCoord": 1, "scale": [2.0, 3.0], "offset": [0.25, -0.5]}
    mesh = load(tmp_path, textured({"index": 0, "extensions": {"KHR_texture_transform": other}}), "n.glb")
    np.testing.assert_allclose(colours(mesh), reference(BARY @ UV1.astype(float) * [2, 3] + [0.25, -0.5]),
                               atol=1e-4)


@pytest.mark.parametrize("dtype", ["uint16", "float32"])
@pytest.mark.parametrize("width", [3, 4])
def test_colour_0_without_a_material_keeps_its_precision(tmp_path, dtype, width):
    """Was: COLOR_0 of a primitive without a material went through trimesh's 8-bit vertex colours: normalized
    unsigned shorts wrapped modulo 256 (40000/65535 = 0.61 came out 64/255 = 0.25, errors up to 0.50) and floats
    were rounded to 1/255 (errors up to 0.0020)."""
    values = np.array([[0.61036, 0.1234567, 0.999, 1.0], [0.3, 0.70001, 0.2, 0.5], [0.0, 1.0, 0.0021, 1.0]])
    if dtype == "uint16":
        stored = np.round(values[:, :width] * 65535).astype(np.uint16)
        want = stored[:, :3] / 65535.0
    else:
        stored = values[:, :width].astype(np.float32)
        want = stored[:, :3].astype(float)
    mesh = load(tmp_path, gltf_file([{"COLOR_0": (stored, dtype == "uint16")}], image=False))
    np.testing.assert_allclose(colours(mesh), BARY @ want, atol=1e-6)


def test_scene_parts_keep_their_own_samplers(tmp_path):
    """Was: samplers were ignored. Two meshes of the same triangle share one image through a clamped and a
    repeating texture: each part samples with its own (one image, two samplers after joining; the primitive of
    each mesh is told apart by its material's name)."""
    materials = [{"name": f"m{k}", "pbrMetallicRoughness": {"baseColorTexture": {"index": k}}} for k in (0, 1)]
    prims = [{"TEXCOORD_0": (UV0, False), "material": k} for k in (0, 1)]
    mesh = load(tmp_path, gltf_file(prims, materials, {"wrapS": CLAMP, "wrapT": MIRROR}))
    first = int(np.argmin(mesh.vertices[mesh.faces].mean(axis=1)[:, 0]))
    uv = BARY @ UV0.astype(float)
    np.testing.assert_allclose(colours(mesh, first), reference(uv, CLAMP, MIRROR), atol=1e-4)
    np.testing.assert_allclose(colours(mesh, 1 - first), reference(uv), atol=1e-4)


def test_a_mesh_changed_after_reading_keeps_trimeshs_reading(tmp_path):
    """Was (and is): a mesh object whose vertices differ from the file's primitive is read as trimesh has it: the
    file is not matched to it, so its repeat-wrapped texture stays (nothing is taken from another primitive)."""
    import trimesh

    (tmp_path / "m.glb").write_bytes(textured({"index": 0}, {"wrapS": CLAMP, "wrapT": CLAMP}))
    scene = trimesh.load(tmp_path / "m.glb", process=False)
    next(iter(scene.geometry.values())).apply_translation([0.5, 0, 0])
    mesh = pyshadow.load_mesh(scene)
    np.testing.assert_allclose(colours(mesh), reference(BARY @ UV0.astype(float)), atol=1e-4)


@pytest.mark.parametrize("dtype", ["uint16", "uint8"])
def test_normalized_integer_uvs_are_scaled(tmp_path, dtype):
    """Was: KHR_mesh_quantization's normalized integer UVs were taken as their integers (and v flipped in
    unsigned arithmetic): colours off by up to 0.87. Unnormalized ones with a transform's scale (as gltfpack
    writes them) are the integers times the scale."""
    top = np.iinfo(dtype).max
    quantised = np.round(UV1 * top).astype(dtype)
    material = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}
    mesh = load(tmp_path, gltf_file([{"TEXCOORD_0": (quantised, True), "material": 0}], [material]))
    np.testing.assert_allclose(colours(mesh), reference(BARY @ (quantised / top)), atol=1e-4)
    scaled = {"index": 0, "extensions": {"KHR_texture_transform": {"scale": [1 / top, 1 / top]}}}
    material = {"pbrMetallicRoughness": {"baseColorTexture": scaled}}
    mesh = load(tmp_path, gltf_file([{"TEXCOORD_0": (quantised, False), "material": 0}], [material]), "n.glb")
    np.testing.assert_allclose(colours(mesh), reference(BARY @ (quantised / top)), atol=1e-4)

"""Bad and unusual surface-colour input (pyshadow.materials): material colours without a texture, 16-bit
and float textures, vertex colours of other dtypes than uint8, colours that are not finite."""
import struct
import zlib

import numpy as np
import pytest
import trimesh
from PIL import Image

import pyshadow
from pyshadow.io import srgb_to_linear
from pyshadow.materials import mesh_visual, point_colours, visual_of

V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
UV = np.array([[0.25, 0.25], [0.75, 0.25], [0.25, 0.75]])
CENTRE = [[1 / 3] * 3]


def triangle(visual):
    return trimesh.Trimesh(V, [[0, 1, 2]], process=False, visual=visual)


def colour_at_centre(visual):
    return point_colours(visual, [0], CENTRE)[0]


def test_a_gltf_material_colour_without_uvs_is_kept(tmp_path):
    """A GLB whose material is only a baseColorFactor (no texture, no TEXCOORD_0) rendered white: the factor
    was read only next to UVs. It is linear (glTF), so red (1, 0, 0) stays (1, 0, 0)."""
    pbr = trimesh.visual.material.PBRMaterial(baseColorFactor=[1.0, 0.0, 0.0, 1.0])
    path = tmp_path / "red.glb"
    triangle(trimesh.visual.TextureVisuals(material=pbr)).export(path)
    visual = visual_of(pyshadow.load_mesh(path))
    assert visual is not None and visual.uv is None and visual.source == str(path)
    np.testing.assert_array_equal(colour_at_centre(visual), [1.0, 0.0, 0.0])
    # the factor and the texture of a textured glTF material still multiply (texture sRGB, factor linear)
    img = Image.fromarray(np.full((2, 2, 3), 188, np.uint8))
    pbr = trimesh.visual.material.PBRMaterial(baseColorTexture=img, baseColorFactor=[1.0, 0.0, 0.0, 1.0])
    got = colour_at_centre(mesh_visual(triangle(trimesh.visual.TextureVisuals(uv=UV, material=pbr))))
    np.testing.assert_allclose(got, [srgb_to_linear(188 / 255), 0, 0], rtol=1e-6)


def obj_with_mtl(tmp_path, mtl, uvs):
    (tmp_path / "m.mtl").write_text(mtl)
    vt = "vt 0.25 0.25\nvt 0.75 0.25\nvt 0.25 0.75\n" if uvs else ""
    face = "f 1/1 2/2 3/3" if uvs else "f 1 2 3"
    path = tmp_path / "m.obj"
    path.write_text(f"mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n{vt}usemtl m\n{face}\n")
    return path


@pytest.mark.parametrize("uvs", [False, True])
def test_an_obj_material_diffuse_colour_is_kept(tmp_path, uvs):
    """An OBJ whose MTL gives `Kd 1 0.5 0` (no map_Kd) rendered white with or without UVs. Kd is sRGB like
    the 8-bit colours (trimesh packs it as an sRGB texel when it merges several materials)."""
    path = obj_with_mtl(tmp_path, "newmtl m\nKd 1 0.5 0\n", uvs)
    got = colour_at_centre(visual_of(pyshadow.load_mesh(path)))
    np.testing.assert_allclose(got, srgb_to_linear(np.array([255, 128, 0]) / 255), rtol=1e-6)


def test_an_unset_obj_diffuse_colour_stays_white_and_a_grey_kd_is_kept(tmp_path):
    """Without Kd trimesh invents a grey diffuse (102): that is no colour of the file. `Kd 0.4 0.4 0.4`
    quantises to the same grey but was given."""
    unset = obj_with_mtl(tmp_path, "newmtl m\nNs 10\n", uvs=False)
    assert visual_of(pyshadow.load_mesh(unset)) is None
    grey = obj_with_mtl(tmp_path, "newmtl m\nKd 0.4 0.4 0.4\n", uvs=True)
    np.testing.assert_allclose(colour_at_centre(visual_of(pyshadow.load_mesh(grey))),
                               [srgb_to_linear(102 / 255)] * 3, rtol=1e-6)
    # UVs without any material file (trimesh's placeholder material): no colour either, also once trimesh
    # wrote that placeholder to an OBJ (as map_Kd, with its grey as Kd)
    uv_only = triangle(trimesh.visual.TextureVisuals(uv=UV))
    assert mesh_visual(uv_only).factor.tolist() == [1.0, 1.0, 1.0]
    (tmp_path / "out").mkdir()
    uv_only.export(tmp_path / "out" / "uv.obj")
    visual = visual_of(pyshadow.load_mesh(tmp_path / "out" / "uv.obj"))
    assert visual.texture is None and visual.factor.tolist() == [1.0, 1.0, 1.0]


def png16(path, grey):
    """Write a 16-bit greyscale PNG of uint16 ``grey`` (h, w) (Pillow cannot write one)."""
    h, w = grey.shape
    raw = b"".join(b"\x00" + row.astype(">u2").tobytes() for row in grey)

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 16, 0, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def test_a_16_bit_greyscale_texture_is_not_saturated(tmp_path):
    """A 16-bit greyscale PNG (Pillow mode I;16) went through convert("RGB"), which clips at 255: every
    texel above 255/65535 became white."""
    grey = np.array([[0, 64], [128, 255]], np.uint16) * 257
    png16(tmp_path / "g16.png", grey)
    (tmp_path / "t.mtl").write_text("newmtl m\nmap_Kd g16.png\n")
    path = tmp_path / "t.obj"
    path.write_text("mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.25 0.25\nvt 0.75 0.25\nvt 0.25 0.75\n"
                    "usemtl m\nf 1/1 2/2 3/3\n")
    visual = visual_of(pyshadow.load_mesh(path))
    want = srgb_to_linear(grey / 65535.0)
    np.testing.assert_allclose(visual.texture, np.repeat(want[..., None], 3, axis=-1), rtol=1e-6)
    # corner 0 (u, v = 0.25, 0.25) is the bottom-left texel, 128 * 257
    np.testing.assert_allclose(point_colours(visual, [0], [[1, 0, 0]])[0], [want[1, 0]] * 3, rtol=1e-6)


def test_a_float_greyscale_texture_is_not_clipped_to_black_and_white():
    grey = np.array([[0.0, 0.25], [0.5, 1.0]], np.float32)
    visual = mesh_visual(triangle(trimesh.visual.TextureVisuals(uv=UV, image=Image.fromarray(grey, "F"))))
    np.testing.assert_allclose(visual.texture[..., 0], srgb_to_linear(grey), rtol=1e-6)


@pytest.mark.parametrize("colours", [np.array([[0.5, 0.25, 1.0, 1.0]] * 3, np.float32),
                                     np.round(np.array([[0.5, 0.25, 1.0, 1.0]] * 3) * 65535).astype(np.uint16)],
                         ids=["float32", "uint16"])
def test_colour_attribute_of_a_textured_mesh_is_scaled_by_its_type(colours):
    """A colour attribute next to a texture (as trimesh keeps glTF's COLOR_0: the accessor's raw float or
    normalised uint16 data) was divided by 255 like uint8 (float: near black; uint16: clipped to white).
    Built in code, the mesh is no glTF: its colours are sRGB; with gltf=True they are linear."""
    visual = trimesh.visual.TextureVisuals(uv=UV, image=Image.fromarray(np.full((2, 2, 3), 255, np.uint8)))
    visual.vertex_attributes["color"] = colours
    got = colour_at_centre(mesh_visual(triangle(visual)))
    np.testing.assert_allclose(got, srgb_to_linear([0.5, 0.25, 1.0]), rtol=1e-4)
    got = colour_at_centre(mesh_visual(triangle(visual), gltf=True))
    np.testing.assert_allclose(got, [0.5, 0.25, 1.0], rtol=1e-4)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_colours_that_are_not_finite_are_refused_where_applied(bad):
    """A NaN in float COLOR_0 gave NaN colours silently (inf a clipped 1). As non-finite UVs, the mesh keeps
    them (geometry and AO need none) and applying them names the source and the count."""
    visual = trimesh.visual.TextureVisuals(uv=UV, image=Image.fromarray(np.full((2, 2, 3), 255, np.uint8)))
    visual.vertex_attributes["color"] = np.array([[bad, 0, 0, 1], [1, 0, 0, 1], [1, 0, 0, 1]], np.float32)
    mesh = pyshadow.load_mesh(triangle(visual))
    with pytest.raises(ValueError) as e:
        point_colours(visual_of(mesh), [0], [[0, 1, 0]])     # corner 1 is finite: still refused
    assert str(e.value) == "<Trimesh>: 1 of 3 colours (of face corners) are not finite (NaN or inf)"
    img = Image.fromarray(np.array([[bad, 0.5]], np.float32), "F")
    with pytest.raises(ValueError, match=r"^mesh: 1 of 2 texels of its texture are not finite"):
        point_colours(mesh_visual(triangle(trimesh.visual.TextureVisuals(uv=UV, image=img))), [0], CENTRE)

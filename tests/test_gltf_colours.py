"""glTF's colour space and the visuals of scenes (several meshes) through pyshadow.load_mesh.

glTF 2.0 (section 3.9.2) defines ``COLOR_0`` as a *linear* multiplier of the base colour; PLY/OBJ vertex
colours and 8-bit images are sRGB-encoded. A scene's meshes each keep their own colours, material colour
and texture when pyshadow concatenates them (no packed atlas, no default grey), with the vertices, faces
and mesh_hash of before.
"""
import io
import warnings

import numpy as np
import trimesh
from PIL import Image

import pyshadow
import pyshadow.data
from pyshadow.bake.assets import baked_mesh_bytes
from pyshadow.io import linear_to_srgb, srgb_to_linear
from pyshadow.materials import mesh_visual, point_colours, visual_of
from pyshadow.mesh import mesh_hash

PBR = trimesh.visual.material.PBRMaterial
V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
UV = np.array([[0.25, 0.25], [0.75, 0.25], [0.25, 0.75]])
RGB = np.array([[200, 100, 30, 255], [10, 220, 90, 255], [255, 0, 128, 255]], np.uint8)


def tri(visual=None, shift=0.0):
    return trimesh.Trimesh(V + [shift, 0, 0], [[0, 1, 2]], process=False, visual=visual)


def colour_at(mesh, point):
    """The colour of ``mesh`` at its vertex ``point`` (a corner of the first face that has it)."""
    hit = np.isclose(mesh.vertices[mesh.faces], point, atol=1e-9).all(axis=-1)
    face, corner = (int(i[0]) for i in np.nonzero(hit))
    visual = visual_of(mesh)
    return np.ones(3) if visual is None else point_colours(visual, [face], [np.eye(3)[corner]])[0]


def colour_near(mesh, point):
    """The colour of ``mesh`` at the centroid of the face whose centroid is nearest ``point``."""
    face = int(np.argmin(np.linalg.norm(mesh.vertices[mesh.faces].mean(axis=1) - point, axis=1)))
    visual = visual_of(mesh)
    return np.ones(3) if visual is None else point_colours(visual, [face], [[1 / 3] * 3])[0]


def test_gltf_colour_0_is_read_as_linear(tmp_path):
    """COLOR_0 of a GLB was decoded from sRGB: 128 became 0.216 instead of 0.502 (glTF says linear). The same
    colours in a PLY stay sRGB-encoded."""
    tri(trimesh.visual.ColorVisuals(vertex_colors=RGB)).export(tmp_path / "c.glb")
    want = (RGB[:, :3] / 255.0).astype(np.float32)
    for src in (tmp_path / "c.glb", trimesh.load(tmp_path / "c.glb", process=False),
                trimesh.load(tmp_path / "c.glb", force="mesh", process=False)):
        np.testing.assert_array_equal(visual_of(pyshadow.load_mesh(src)).colours[0], want)
    tri(trimesh.visual.ColorVisuals(vertex_colors=RGB)).export(tmp_path / "c.ply")
    np.testing.assert_allclose(visual_of(pyshadow.load_mesh(tmp_path / "c.ply")).colours[0],
                               srgb_to_linear(want), rtol=1e-6)


def test_the_gltf_rule_of_a_mesh_object():
    """A trimesh object counts as glTF when trimesh's glTF reader made it ("from_gltf_primitive" in its
    metadata); otherwise its colours are sRGB unless mesh_visual is told gltf=True."""
    from pyshadow.materials import is_gltf

    colours = np.array([[0.5, 0.25, 1.0, 1.0]] * 3, np.float32)      # float COLOR_0 beside a texture
    visual = trimesh.visual.TextureVisuals(uv=UV, material=PBR(baseColorTexture=Image.new("RGB", (2, 2), "white")))
    visual.vertex_attributes["color"] = colours
    plain = tri(visual)
    gltf = plain.copy()
    gltf.visual.vertex_attributes["color"] = colours
    gltf.metadata["from_gltf_primitive"] = False
    assert is_gltf(gltf) and not is_gltf(plain)
    centre = [[1 / 3] * 3]
    np.testing.assert_allclose(point_colours(mesh_visual(gltf), [0], centre)[0], [0.5, 0.25, 1.0], rtol=1e-6)
    np.testing.assert_allclose(point_colours(mesh_visual(plain), [0], centre)[0], srgb_to_linear([0.5, 0.25, 1.0]),
                               rtol=1e-5)
    np.testing.assert_allclose(point_colours(mesh_visual(plain, gltf=True), [0], centre)[0], [0.5, 0.25, 1.0],
                               rtol=1e-6)


def test_glb_bake_writes_linear_ao_into_colour_0():
    """The GLB bake wrote AO sRGB-encoded into COLOR_0 (0.5 -> 188), which a glTF viewer shows too bright; the
    PLY keeps its sRGB grey. Read back by load_mesh, the GLB's colour is the AO."""
    mesh = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2], [0, 3, 1]], process=False)
    ao = np.array([0.0, 0.2, 0.5, 1.0], np.float32)
    bent = np.tile([0.0, 0.0, 1.0], (4, 1)).astype(np.float32)
    glb = trimesh.load(io.BytesIO(baked_mesh_bytes(mesh, ao, bent, "glb")), file_type="glb", process=False)
    part = next(iter(glb.geometry.values()))
    np.testing.assert_array_equal(part.visual.vertex_colors[:, 0], np.round(255 * ao))
    back = pyshadow.load_mesh(glb)
    for v in range(4):
        np.testing.assert_allclose(colour_at(back, mesh.vertices[v]), [ao[v]] * 3, atol=0.5 / 255)
    ply = trimesh.load(io.BytesIO(baked_mesh_bytes(mesh, ao, bent, "ply")), file_type="ply", process=False)
    np.testing.assert_array_equal(ply.visual.vertex_colors[:, 0], np.round(255 * linear_to_srgb(ao)))


def textured_with_colour_0(grey=188):
    """A triangle with a uniform texture and COLOR_0 per vertex (RGB)."""
    image = Image.fromarray(np.full((2, 2, 3), grey, np.uint8))
    visual = trimesh.visual.TextureVisuals(uv=UV, material=PBR(baseColorTexture=image))
    visual.vertex_attributes["color"] = RGB.copy()
    return tri(visual)


def test_a_gltf_scene_keeps_colour_0_of_a_textured_mesh(tmp_path):
    """COLOR_0 next to a texture was lost on every GLB load (trimesh's copy of a scene's mesh drops it): the
    texture alone was used, and with a second mesh no colour was kept at all."""
    texel = srgb_to_linear(188 / 255)
    for n in (1, 2):
        scene = trimesh.Scene([textured_with_colour_0(), tri(shift=2.0)][:n])
        scene.export(tmp_path / f"s{n}.glb")
        mesh = pyshadow.load_mesh(tmp_path / f"s{n}.glb")
        for v in range(3):
            np.testing.assert_allclose(colour_at(mesh, V[v]), RGB[v, :3] / 255 * texel, rtol=1e-5)
        if n == 2:
            np.testing.assert_array_equal(colour_near(mesh, [2.3, 0.3, 0]), [1, 1, 1])


def test_an_uncoloured_part_of_a_scene_is_white_not_trimesh_grey(tmp_path):
    """Concatenated with a coloured mesh, a mesh without colours got trimesh's default grey (102): it rendered
    dark grey instead of white."""
    trimesh.Scene([tri(trimesh.visual.ColorVisuals(vertex_colors=RGB)), tri(shift=2.0)]).export(tmp_path / "s.glb")
    mesh = pyshadow.load_mesh(tmp_path / "s.glb")
    np.testing.assert_array_equal(colour_near(mesh, [2.3, 0.3, 0]), [1, 1, 1])
    np.testing.assert_allclose(colour_at(mesh, V[1]), RGB[1, :3] / 255, rtol=1e-6)


CHECKER = np.array([[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [255, 255, 255]]], np.uint8)


def texel_at(image, uv):
    """The texel of a 2x2 ``image`` whose centre is ``uv`` (repeat wrap, v up)."""
    u, v = np.mod(uv, 1.0)
    return srgb_to_linear(image[int(v < 0.5), int(u >= 0.5)] / 255.0)


def test_gltf_scene_parts_keep_their_own_factors_and_textures(tmp_path):
    """Several meshes with their own material: a baseColorFactor 0.5 beside an uncoloured mesh was lost (no
    visual at all), and two textures were packed by trimesh into one atlas that broke the repeat wrap and
    bled between the images (a red texel came out (0.51, 0.38, 0.46))."""
    other = CHECKER[::-1, ::-1].copy()
    scene = trimesh.Scene([
        tri(trimesh.visual.TextureVisuals(material=PBR(baseColorFactor=[0.5, 0.25, 1.0, 1.0]))),
        tri(shift=2.0),
        tri(trimesh.visual.TextureVisuals(uv=UV + 1.0, material=PBR(baseColorTexture=Image.fromarray(CHECKER))), 4.0),
        tri(trimesh.visual.TextureVisuals(uv=UV, material=PBR(baseColorTexture=Image.fromarray(other))), 6.0)])
    scene.export(tmp_path / "s.glb")
    for fill in (False, True):
        mesh = pyshadow.load_mesh(tmp_path / "s.glb", fill_holes=fill)
        np.testing.assert_allclose(colour_near(mesh, [0.3, 0.3, 0]), [128 / 255, 64 / 255, 1.0], rtol=1e-6)
        np.testing.assert_array_equal(colour_near(mesh, [2.3, 0.3, 0]), [1, 1, 1])
        for shift, image in ((4.0, CHECKER), (6.0, other)):
            for v in range(3):
                np.testing.assert_allclose(colour_at(mesh, V[v] + [shift, 0, 0]), texel_at(image, UV[v]), atol=1e-6)


def test_obj_materials_keep_their_own_textures(tmp_path):
    """An OBJ with two textured materials (trimesh gives a scene of one mesh per material) had its images
    packed into one atlas: every texel of the first came out as the same blend."""
    Image.fromarray(CHECKER).save(tmp_path / "a.png")
    Image.fromarray(CHECKER[::-1, ::-1].copy()).save(tmp_path / "b.png")
    (tmp_path / "m.mtl").write_text("newmtl a\nmap_Kd a.png\nnewmtl b\nmap_Kd b.png\nKd 1 1 1\n")
    (tmp_path / "m.obj").write_text(
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nv 3 0 0\nv 2 1 0\n"
        "vt 1.25 1.25\nvt 1.75 1.25\nvt 1.25 1.75\nusemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 4/1 5/2 6/3\n")
    mesh = pyshadow.load_mesh(tmp_path / "m.obj")
    for shift, image in ((0.0, CHECKER), (2.0, CHECKER[::-1, ::-1])):
        for v in range(3):
            np.testing.assert_allclose(colour_at(mesh, V[v] + [shift, 0, 0]), texel_at(image, UV[v]), atol=1e-6)


def test_instanced_and_mirrored_nodes_keep_their_corner_colours(tmp_path):
    """One textured mesh with COLOR_0 drawn by two nodes, one of them mirroring (trimesh reverses the faces'
    corners there): each world vertex keeps its own colour."""
    scene = trimesh.Scene()
    scene.add_geometry(textured_with_colour_0(255), geom_name="g", node_name="a")
    mirror = np.diag([-1.0, 1.0, 1.0, 1.0])
    mirror[0, 3] = -3.0
    scene.graph.update(frame_to="b", frame_from=scene.graph.base_frame, matrix=mirror, geometry="g")
    scene.export(tmp_path / "m.glb")
    loaded = trimesh.load(tmp_path / "m.glb", process=False)
    assert len(loaded.geometry) == 1 and len(loaded.graph.nodes_geometry) == 2
    # the scene built here is no glTF (its colours are sRGB); the file is
    for src, want in ((scene, srgb_to_linear(RGB[:, :3] / 255)), (tmp_path / "m.glb", RGB[:, :3] / 255)):
        mesh = pyshadow.load_mesh(src, fill_holes=src is scene)
        for v in range(3):
            np.testing.assert_allclose(colour_at(mesh, V[v]), want[v], rtol=1e-6)
            np.testing.assert_allclose(colour_at(mesh, V[v] * [-1, 1, 1] - [3, 0, 0]), want[v], rtol=1e-6)


def test_merged_gltf_primitives_keep_their_material_colours():
    """trimesh's merge_primitives=True gives one mesh with a MultiMaterial and a material per face; its
    baseColorFactors were ignored (white)."""
    visual = trimesh.visual.TextureVisuals(
        material=trimesh.visual.material.MultiMaterial([PBR(baseColorFactor=[1.0, 0.0, 0.0, 1.0]),
                                                        PBR(baseColorFactor=[0.0, 0.5, 1.0, 1.0])]),
        face_materials=[1, 0])
    mesh = trimesh.Trimesh(np.vstack([V, V + [2, 0, 0]]), [[3, 4, 5], [0, 1, 2]], process=False, visual=visual)
    got = point_colours(mesh_visual(mesh), [0, 1], [[1 / 3] * 3] * 2)
    np.testing.assert_allclose(got, [[0.0, 128 / 255, 1.0], [1.0, 0.0, 0.0]], rtol=1e-6)


#: mesh_hash of every bundled mesh (pyshadow.data.mesh(name)), as the code before the visuals of scenes were
#: joined per part computed them: caches and CSMs key on them. suzanne's changed when its two concave quads
#: were tiled inside them rather than fanned over ground outside them (tests/test_inputs3_ply_quads.py).
BUNDLED_HASHES = {
    "cow.obj": "ead803d1f4b7e4e036aedd6d105ad1da8a8edd5761a79afb0ae06252224a4d86",
    "fandisk.obj": "b69e19fe72be696b148fb078d5cfbdb68588ef93b22043fe40c26d121c4b1edf",
    "featuretype.STL": "dcdaadad6b3849004c52c03f405e57e800249f3e323e5516ff0759542f1f1128",
    "homer.obj": "69b5ed6f7e6fa8f0726b86adc60de5e023622fedec0250451185f547a0f9459d",
    "spot.obj": "9c28da03f02b4f4c34f415a07c3a56874abdd4d4a09bc608f432b1538855e0c6",
    "stanford-bunny.obj": "c552984a877b87d63df9852656fd2f8c426cee87e50e958872999cf18e24cefe",
    "suzanne.ply": "b52c7ae7695ccf927c62889ddc4445fcdebc698a9eee8f464609172251f3cd71",
    "teapot.obj": "4cb1ac1f365c2b0a11ab2a8defee82be98ab041cc587666a89e3638368e7b43d",
    "torus.STL": "7ef88c9853a54adef3f1170d31033aa0b0a80439f89a5f6921c6b4c079d9b7cc",
}


def test_geometry_and_hashes_are_unchanged(tmp_path):
    """The visuals take no part in the geometry: every bundled mesh hashes as before, and a scene (with a
    mirroring node) loads to the vertices and faces of trimesh's Scene.to_geometry."""
    assert set(BUNDLED_HASHES) == set(pyshadow.data.MESHES)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pyshadow.MeshCleanupWarning)
        for name, digest in BUNDLED_HASHES.items():
            assert mesh_hash(pyshadow.data.mesh(name)) == digest, name
        scene = trimesh.Scene()
        scene.add_geometry(pyshadow.data.mesh("spot"), node_name="a")
        scene.add_geometry(textured_with_colour_0(), node_name="b", transform=np.diag([-2.0, 1.0, 1.0, 1.0]))
        scene.add_geometry(pyshadow.data.mesh("suzanne"), node_name="c",
                           transform=trimesh.transformations.rotation_matrix(0.7, [1, 2, 3], [0.5, 0, 0]))
        scene.export(tmp_path / "s.glb")
        for src in (scene, tmp_path / "s.glb"):
            raw = trimesh.load(src, process=False) if not isinstance(src, trimesh.Scene) else src
            want = raw.to_geometry()
            bare = trimesh.Trimesh(want.vertices, want.faces, process=False)
            assert mesh_hash(pyshadow.load_mesh(src)) == mesh_hash(pyshadow.load_mesh(bare))

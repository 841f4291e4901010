"""Materials and shading normals (issue 19, item 5): crease-aware corner normals, the smooth render and
its hemisphere rule against Embree on identical rays, the torus's facet bands, vertex colours and
textures kept by load_mesh, per-instance albedo and bad input."""
import math
import re

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling, embree, load_mesh
from pyshadow.mesh import mesh_hash
from pyshadow.io import srgb_to_linear
from pyshadow.lighting import Lighting
from pyshadow.lighting.transfer import sample_visibility
from pyshadow.materials import VISUAL_KEY, barycentrics, point_colours, visual_of
from pyshadow.render import render
from pyshadow.sampling import ao_from_samples
from pyshadow.shading_normals import below_geometric, corner_normals, pixel_surface, shading_gbuffer


@pytest.fixture(scope="module")
def torus_scene():
    """The default scene's torus (64 x 24 sections) on the ground, CSM of 32x64 maps at 64^2, and a camera."""
    from pyshadow.data import default_parts

    _, torus, T, _ = default_parts()[1]
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(32, 64), resolution=64)
    scene.add(torus, T)
    c = scene.instances[0].world_sphere()[0]
    cam = pyshadow.Camera(c + np.array([1.2, 1.0, 1.3]), c, fov_y=40.0, width=96, height=72)
    return scene, cam


# ---------------------------------------------------------------------------
# corner normals
# ---------------------------------------------------------------------------
def test_cube_keeps_every_crease_and_renders_as_flat(small_scene):
    box = load_mesh(trimesh.creation.box())
    normals, smooth = corner_normals(box, return_smooth=True)
    np.testing.assert_array_equal(normals, np.repeat(np.asarray(box.face_normals)[:, None], 3, axis=1))
    assert not smooth.any()
    cam = pyshadow.Camera([2.0, 1.5, 3.0], [0.0, 0.3, 0.0], width=48, height=32)
    flat = render(small_scene, cam, sampling=Sampling(16))
    smooth_frame = render(small_scene, cam, sampling=Sampling(16), normals="smooth")
    for k in ("ao", "bent_normal", "depth", "normal", "object_id", "position"):
        np.testing.assert_array_equal(getattr(smooth_frame, k), getattr(flat, k), err_msg=k)
    np.testing.assert_array_equal(smooth_frame.geometric_normal, flat.normal)
    assert flat.geometric_normal is None and "geometric_normal" not in flat


@pytest.mark.parametrize("subdivisions", [0, 1])
def test_symmetric_icosphere_corner_normals_are_radial(subdivisions):
    """Every vertex of an icosahedron and of its first subdivision sits on a rotation axis of the
    solid that maps its ring of faces onto itself, so the angle-weighted normal is the radial
    direction up to float64 rounding (1e-12). The crease angle is opened so no edge is a crease
    (the icosahedron's faces meet at 41.8 degrees)."""
    ico = load_mesh(trimesh.creation.icosphere(subdivisions=subdivisions))
    normals = corner_normals(ico, 1.5)
    v = np.asarray(ico.vertices)[np.asarray(ico.faces)]
    np.testing.assert_allclose(normals, v / np.linalg.norm(v, axis=2, keepdims=True), atol=1e-12)
    flat, smooth = corner_normals(ico, return_smooth=True)   # 30 degrees: the icosahedron is all creases
    if subdivisions == 0:
        assert not smooth.any() and (flat == flat[:, :1]).all()          # each face keeps one normal, exactly
        np.testing.assert_allclose(flat[:, 0], ico.face_normals, atol=1e-15)


def test_corner_normals_equal_trimesh_weighted_vertex_normals_without_creases():
    """An independent oracle: trimesh's angle-weighted vertex normals (Thuermer and Wuethrich)."""
    ico = load_mesh(trimesh.creation.icosphere(subdivisions=3))
    want = trimesh.geometry.weighted_vertex_normals(len(ico.vertices), ico.faces, ico.face_normals,
                                                    ico.face_angles)
    np.testing.assert_allclose(corner_normals(ico), want[np.asarray(ico.faces)], atol=1e-12)
    assert np.abs(np.linalg.norm(corner_normals(ico), axis=2) - 1).max() < 1e-14


def test_cylinder_rims_stay_sharp():
    cyl = load_mesh(trimesh.creation.cylinder(radius=1.0, height=2.0, sections=32))
    normals = corner_normals(cyl)
    fn = np.asarray(cyl.face_normals)
    cap = np.abs(fn[:, 2]) > 0.99
    assert (normals[cap] == normals[cap][:, :1]).all()                   # one normal per cap face, exactly
    np.testing.assert_allclose(normals[cap][:, 0], fn[cap], atol=1e-15)
    side = normals[~cap]
    v = np.asarray(cyl.vertices)[np.asarray(cyl.faces)][~cap]
    radial = v * [1.0, 1.0, 0.0]
    np.testing.assert_allclose(side, radial / np.linalg.norm(radial, axis=2, keepdims=True), atol=1e-12)


def test_crease_angle_checks(small_scene, no_launch):
    cam = pyshadow.Camera([2.0, 1.5, 3.0], [0.0, 0.3, 0.0], width=8, height=8)
    for bad in (math.pi / 2, -0.1, float("nan"), "wide", True):
        with pytest.raises(ValueError, match="crease_angle"):
            render(small_scene, cam, normals="smooth", crease_angle=bad)
    with pytest.raises(ValueError, match="normals must be 'flat' or 'smooth'"):
        render(small_scene, cam, normals="phong")


# ---------------------------------------------------------------------------
# the smooth render
# ---------------------------------------------------------------------------
def test_smooth_normals_are_unit_and_on_the_geometric_side(torus_scene):
    scene, cam = torus_scene
    items = scene.draw_items()[0]
    g = pyshadow.render_gbuffer(items, cam)
    s = shading_gbuffer(items, g, cam)
    hit = g["object_id"] >= 0
    n, ng = s["normal"][hit].astype(np.float64), s["geometric_normal"][hit].astype(np.float64)
    assert np.abs(np.linalg.norm(n, axis=1) - 1).max() < 1e-6            # float32 rounding
    cos = np.einsum("ij,ij->i", n, ng)
    assert cos.min() > math.cos(math.radians(30.0)) - 1e-6               # within the crease angle
    torus = g["object_id"] == 0
    assert (s["normal"][torus] != g["normal"][torus]).any(axis=1).mean() > 0.99   # the torus is smoothed
    np.testing.assert_array_equal(s["normal"][~torus], g["normal"][~torus])      # the ground is flat


def test_smooth_ao_applies_the_hemisphere_rule_on_embree(torus_scene):
    """The render's Embree AO equals the rule computed here: the AO directions about the shading
    normal, those at or below the geometric plane occluded, the rest traced by Embree."""
    scene, cam = torus_scene
    s = Sampling(36)
    f = embree.render(scene, cam, sampling=s, normals="smooth")
    items = scene.draw_items()[0]
    g = shading_gbuffer(items, embree.gbuffer(items, cam), cam)
    idx = np.flatnonzero(g["object_id"].reshape(-1) == 0)
    ray = cam.ray_directions().reshape(-1, 3)[idx]
    p = cam.eye + g["depth"].reshape(-1)[idx, None].astype(np.float64) * ray
    n, ng = g["normal"].reshape(-1, 3)[idx], g["geometric_normal"].reshape(-1, 3)[idx]
    dirs, lit = sample_visibility(scene, p, n, backend="embree", sampling=s, indices=idx, geometric_normals=ng)
    below = below_geometric(dirs, ng)
    assert below.any() and not lit[below].any()
    ao, _ = ao_from_samples(dirs, lit, n, return_bent_normals=True)
    # points with a direction below the plane went through visible(); the rest through Embree's AO rays,
    # whose origins are lifted along the normal instead of the direction: equal up to those rays
    redo = below.any(axis=1)
    np.testing.assert_array_equal(f.ao.reshape(-1)[idx][redo], ao[redo])
    assert np.abs(f.ao.reshape(-1)[idx] - ao).mean() < 1e-3


def ray_agreement(scene, cam, normals):
    """Per-ray agreement of "csm" with "embree" over every covered pixel's AO directions (traced ones)."""
    items = scene.draw_items()[0]
    g = pyshadow.render_gbuffer(items, cam)
    ng = None
    if normals == "smooth":
        g = shading_gbuffer(items, g, cam)
    idx = np.flatnonzero(g["object_id"].reshape(-1) >= 0)
    ray = cam.ray_directions().reshape(-1, 3)[idx]
    p = cam.eye + g["depth"].reshape(-1)[idx, None].astype(np.float64) * ray
    sid = np.where(g["object_id"].reshape(-1)[idx] == 0, 0, -2).astype(np.int32)
    n = g["normal"].reshape(-1, 3)[idx]
    if normals == "smooth":
        ng = g["geometric_normal"].reshape(-1, 3)[idx]
    got = {b: sample_visibility(scene, p, n, backend=b, sampling=Sampling(36), indices=idx, surface_ids=sid,
                                geometric_normals=ng) for b in ("csm", "embree")}
    dirs = got["csm"][0]
    traced = np.ones(dirs.shape[:2], bool) if ng is None else ~below_geometric(dirs, ng)
    return (got["csm"][1] == got["embree"][1])[traced].mean()


def test_smooth_ao_agrees_with_embree_as_well_as_flat(torus_scene):
    """Measured (96x72, 36 directions): flat 99.2937 %, smooth 99.2925 % of the traced rays agree. The
    margin, 0.1 percentage point, is a seventh of the flat path's own disagreement: a leaking rule or a
    shading normal turned the wrong way changes whole pixels' rays (percents)."""
    scene, cam = torus_scene
    flat, smooth = ray_agreement(scene, cam, "flat"), ray_agreement(scene, cam, "smooth")
    assert flat > 0.99
    assert smooth >= flat - 1e-3
    s = Sampling(36)
    f = render(scene, cam, sampling=s, normals="smooth")
    e = embree.render(scene, cam, sampling=s, normals="smooth")
    np.testing.assert_array_equal(f.object_id, e.object_id)
    hit = f.object_id != -1
    assert np.abs(f.ao - e.ao)[hit].mean() < 0.01


def banding(frame, instance_id=0):
    """Mean |second difference| of AO along rows and columns over triples of pixels on one instance:
    a step at a facet edge counts, a smooth gradient hardly does."""
    ao, on = frame.ao.astype(np.float64), frame.object_id == instance_id
    rows = np.abs(ao[:, 2:] - 2 * ao[:, 1:-1] + ao[:, :-2])[on[:, 2:] & on[:, 1:-1] & on[:, :-2]]
    cols = np.abs(ao[2:] - 2 * ao[1:-1] + ao[:-2])[on[2:] & on[1:-1] & on[:-2]]
    return np.concatenate([rows, cols]).mean()


def test_smooth_normals_remove_the_torus_facet_bands(torus_scene):
    """One direction pattern for every pixel (patterns=1), so AO is a smooth function of the normal:
    flat normals step at every facet edge; smooth ones do not. Measured: 0.0386 flat, 0.0163 smooth (what
    remains are the torus's real AO edges: silhouettes, the inner rim and its contact shadow)."""
    scene, cam = torus_scene
    s = Sampling(64, patterns=1)
    flat = banding(render(scene, cam, sampling=s))
    smooth = banding(render(scene, cam, sampling=s, normals="smooth"))
    assert smooth < 0.6 * flat


# ---------------------------------------------------------------------------
# materials
# ---------------------------------------------------------------------------
VERTICES = [(0, 0, 0, 255, 0, 0), (1, 0, 0, 0, 255, 0), (0, 1, 0, 0, 0, 255), (0, 0, 1, 10, 128, 200),
            (0, 0, 0, 1, 2, 3)]                      # vertex 4 coincides with vertex 0
FACES = [(0, 1, 2), (0, 2, 3), (4, 3, 1), (0, 0, 1)]   # the last one is degenerate


def ply(colours: bool) -> str:
    """An ASCII PLY of VERTICES and FACES, with or without uchar vertex colours."""
    head = ["ply", "format ascii 1.0", "element vertex 5", "property float x", "property float y",
            "property float z"]
    head += ["property uchar red", "property uchar green", "property uchar blue"] if colours else []
    head += ["element face 4", "property list uchar int vertex_indices", "end_header"]
    rows = [" ".join(map(str, v if colours else v[:3])) for v in VERTICES]
    return "\n".join(head + rows + ["3 %d %d %d" % f for f in FACES]) + "\n"


def test_vertex_colours_survive_load_mesh_as_linear_rgb(tmp_path):
    path, path2 = tmp_path / "coloured.ply", tmp_path / "plain.ply"
    path.write_text(ply(True))
    path2.write_text(ply(False))
    with pytest.warns(pyshadow.mesh.MeshCleanupWarning):
        mesh = load_mesh(path)
    with pytest.warns(pyshadow.mesh.MeshCleanupWarning):
        bare = load_mesh(path2)
    # merging (vertex 4 coincides with vertex 0) and cleaning (face 3 is degenerate) as without colours
    np.testing.assert_array_equal(mesh.vertices, bare.vertices)
    np.testing.assert_array_equal(mesh.faces, bare.faces)
    assert mesh_hash(mesh) == mesh_hash(bare) and visual_of(bare) is None
    visual = mesh.metadata[VISUAL_KEY]
    assert len(mesh.vertices) == 4 and mesh.faces[2, 0] == 0     # vertex 4 merged into vertex 0 ...
    rgb = np.array([v[3:] for v in VERTICES])
    want = srgb_to_linear(rgb[[[0, 1, 2], [0, 2, 3], [4, 3, 1]]] / 255.0).astype(np.float32)   # ... its colour kept
    np.testing.assert_array_equal(visual.colours, want)
    assert visual.colours.dtype == np.float32 and visual.uv is None
    filled = pyshadow.mesh.close_holes(mesh)                      # the open side gets a fan, colours follow
    assert len(visual_of(filled).colours) == len(filled.faces) > len(mesh.faces)


def test_texture_and_uvs_survive_load_mesh():
    from PIL import Image

    img = np.zeros((2, 2, 3), np.uint8)
    img[0, 0], img[0, 1], img[1, 0], img[1, 1] = (255, 0, 0), (0, 255, 0), (0, 0, 255), (200, 200, 200)
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    uv = np.array([[0.25, 0.25], [0.75, 0.25], [0.25, 0.75]])
    m = trimesh.Trimesh(v, [[0, 1, 2]], process=False,
                        visual=trimesh.visual.TextureVisuals(uv=uv, image=Image.fromarray(img)))
    visual = visual_of(load_mesh(m))
    np.testing.assert_array_equal(visual.uv, uv[None].astype(np.float32))
    np.testing.assert_array_equal(visual.texture, srgb_to_linear(img / 255.0).astype(np.float32))
    # corner 2 sits on texel (0, 0) (top left, v up), corner 0 on texel (1, 0): exact texel values
    got = point_colours(visual, [0, 0], [[0, 0, 1], [1, 0, 0]])
    np.testing.assert_allclose(got, srgb_to_linear(np.array([[255, 0, 0], [0, 0, 255]]) / 255.0), atol=1e-7)
    b = barycentrics(np.array([[0.2, 0.3, 0.0]]), v[None])
    np.testing.assert_allclose(b, [[0.5, 0.2, 0.3]], atol=1e-15)


def test_radiance_multiplies_vertex_colours_by_the_instance_albedo():
    """A box whose vertex colours are pure red, lit by a white sky: red light only; a per-instance
    albedo (Lighting(albedos=)) scales it; the ground (no colours) stays grey."""
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    box.visual.vertex_colors = np.tile([255, 0, 0, 255], (len(box.vertices), 1))
    mesh = load_mesh(box)
    scene = pyshadow.Scene(ground=-0.5, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(mesh, casts=False)
    cam = pyshadow.Camera([2.0, 1.5, 3.0], [0.0, 0.0, 0.0], width=32, height=24)
    sky = np.zeros((9, 3))
    sky[0] = 2.0 * math.sqrt(math.pi)                                   # constant radiance 1
    f = render(scene, cam, sampling=Sampling(16), lighting=Lighting(sky, albedo=1.0, albedos={0: (0.5, 1, 1)}))
    on = f.object_id == 0
    assert on.sum() > 50
    assert (f.radiance[on][:, 1:] == 0).all() and (f.radiance[on][:, 0] > 0).all()
    grey = f.radiance[f.object_id == pyshadow.scene.GROUND_ID]
    np.testing.assert_array_equal(grey[:, 0], grey[:, 1])
    np.testing.assert_allclose(f.radiance[on][:, 0], 0.5 * f.ao[on], rtol=1e-5)   # albedo/pi * pi * AO


@pytest.mark.parametrize("albedo, match", [((math.nan, 0.2, 0.2), "not finite"),
                                           ((1.5, 0.2, 0.2), r"in \[0, 1\]"),
                                           ((-0.1, 0.2, 0.2), r"in \[0, 1\]"),
                                           ((0.2, 0.2), "shape"), ("red", "shape")])
def test_bad_albedo_is_refused(albedo, match):
    with pytest.raises(ValueError, match=match):
        Lighting(albedos={0: albedo})
    with pytest.raises(ValueError, match=match):
        Lighting(albedo=albedo)


def test_a_gbuffer_without_faces_is_refused_for_smooth_normals(small_scene, no_launch):
    cam = pyshadow.Camera([2.0, 1.5, 3.0], [0.0, 0.3, 0.0], width=8, height=8)
    g = {"object_id": np.full((8, 8), -1, np.int32), "depth": np.full((8, 8), np.inf, np.float32),
         "normal": np.zeros((8, 8, 3), np.float32), "position": np.full((8, 8, 3), np.nan, np.float32)}
    with pytest.raises(ValueError, match="no 'face' buffer"):
        render(small_scene, cam, gbuffer=g, normals="smooth")
    with pytest.raises(ValueError, match="no 'face' buffer"):
        pixel_surface([], g, cam)


def test_a_foreign_visual_is_refused():
    mesh = load_mesh(trimesh.creation.box())
    mesh.metadata[VISUAL_KEY] = "red"
    with pytest.raises(TypeError, match="MeshVisual"):
        visual_of(mesh)


def test_scene_render_passes_the_shading_normals_on():
    s, cam = pyshadow.data.default_scene(views=pyshadow.ViewSet.zigzag(8, 16), resolution=32, width=64, height=48)
    a = s.render(cam, sampling=pyshadow.Sampling(8), normals="smooth", crease_angle=0.3)
    b = pyshadow.render.render(s, cam, sampling=pyshadow.Sampling(8), normals="smooth", crease_angle=0.3)
    assert np.array_equal(a.ao, b.ao) and np.array_equal(a.normal, b.normal)
    flat = s.render(cam, sampling=pyshadow.Sampling(8))
    assert not np.array_equal(a.normal, flat.normal) and a.geometric_normal is not None
    np.testing.assert_array_equal(a.geometric_normal, flat.normal)


def test_crease_angle_refuses_numpy_bools():
    """Was: True was refused but np.True_ taken as 1 radian."""
    from pyshadow.shading_normals import check_crease_angle

    got = re.escape(repr(np.True_))             # np.True_ (NumPy 2), True before
    with pytest.raises(ValueError, match=rf"^crease_angle: expected radians in \[0, pi/2\) \(got {got}\)"):
        check_crease_angle(np.True_)
    assert check_crease_angle(np.float32(0.5)) == np.float32(0.5)


def test_smooth_ao_checks_geometric_normals_and_indices(small_scene):
    """Was: zero geometric normals gave AO 0 (every direction 'below the plane'), NaN ones switched the rule
    off, one row for two points was broadcast, float indices truncated -- all without an error."""
    from pyshadow.shading_normals import ambient_occlusion

    p = np.array([[2.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    ns = np.array([[0.5, 1.0, 0.0], [0.0, 1.0, 0.0]])
    ns /= np.linalg.norm(ns, axis=1, keepdims=True)
    ng = np.tile([0.0, 1.0, 0.0], (2, 1))
    s = Sampling(16)
    ao, _ = ambient_occlusion(small_scene, p, ns, ng, backend="numpy", sampling=s)
    assert np.array_equal(ambient_occlusion(small_scene, p, ns, ng * 5, backend="numpy", sampling=s)[0], ao)
    for bad, err, msg in [(np.zeros((2, 3)), ValueError, "geometric_normals: 2 rows are zero vectors"),
                          (np.full((2, 3), np.nan), ValueError, "geometric_normals: 2 rows are not finite"),
                          (ng[:1], ValueError, "geometric_normals has 1 rows but normals has 2 (shapes must match)"),
                          (ng[0], ValueError, "geometric_normals must have shape (N, 3), got (3,)")]:
        with pytest.raises(err, match=f"^{re.escape(msg)}$"):
            ambient_occlusion(small_scene, p, ns, bad, backend="numpy", sampling=s)
    with pytest.raises(TypeError, match="^indices must be integers, got dtype float64$"):
        ambient_occlusion(small_scene, p, ns, ng, backend="numpy", sampling=s, indices=[0.5, 1.7])

"""More extreme and bad input: directions of any length on every visibility backend, texture coordinates
that are not finite. Each case once answered wrongly (or NaN) with a RuntimeWarning; now it is answered
right or refused with a message naming the source."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import visibility
from pyshadow.materials import point_colours, visual_of


# ------------------------------------------------------------------------- directions of any length
@pytest.fixture(scope="module")
def sphere_scene():
    """A sphere of radius 0.5 floating at height 1 over the ground plane y = 0."""
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    scene.add(trimesh.creation.icosphere(2, radius=0.5), trimesh.transformations.translation_matrix([0, 1, 0]))
    return scene


# four points under the sphere looking up along directions of very different lengths, one in the open
POINTS = np.array([[0.0, 0.2, 0.0]] * 4 + [[3.0, 0.2, 0.0]])
DIRECTIONS = np.array([[0, 1.0, 0], [0, 1e200, 0], [1e-300, 1e200, 0], [0, 1e-200, 0], [0, 1e200, 0]])


@pytest.mark.parametrize("backend", ["csm", "csm-vote", "numpy", "numpy-vote", "embree"])
@pytest.mark.parametrize("max_distance", [None, 10.0])
def test_visible_with_directions_of_any_length(sphere_scene, backend, max_distance):
    """The NumPy mirror and Embree normalised by np.linalg.norm: squares overflowed above ~1e154 (the rays
    came back lit, or 'nearest: directions must be finite and non-zero') and underflowed below ~1e-154
    (divide by zero), with RuntimeWarnings. The kernels were right."""
    got = visibility.visible(sphere_scene, POINTS, DIRECTIONS, backend=backend, max_distance=max_distance)
    assert got.tolist() == [False, False, False, False, True]


@pytest.mark.parametrize("backend", ["numpy", "embree"])
def test_zero_and_non_finite_directions_are_still_refused(sphere_scene, backend):
    d = DIRECTIONS.copy()
    d[1:3] = 0.0
    with pytest.raises(ValueError) as e:
        visibility.visible(sphere_scene, POINTS, d, backend=backend)
    assert str(e.value) == "directions: 2 rows are zero vectors"
    d[1] = np.inf
    with pytest.raises(ValueError) as e:
        visibility.visible(sphere_scene, POINTS, d, backend=backend)
    assert str(e.value) == "directions: 1 rows are not finite"


@pytest.mark.parametrize("backend", ["csm", "numpy", "embree"])
def test_ambient_occlusion_with_normals_of_any_length(sphere_scene, backend):
    """The NumPy mirror refused a normal of 1e200 as 'not finite' (its length overflowed)."""
    n = np.array([[0, 1.0, 0], [0, 1e200, 0], [0, 1e-200, 0], [0, 3e-320, 0]])
    ao = visibility.ambient_occlusion(sphere_scene, POINTS[:4], n, backend=backend, indices=[0, 0, 0, 0])
    assert ao.tolist() == [ao[0]] * 4 and 0.3 < ao[0] < 0.8


def test_viewset_lookups_with_directions_of_any_length():
    """ViewSet.nearest normalised by np.linalg.norm: (0.3, 1, 0.2) 2**700 came back as map 15 (it is map 1)
    with an overflow warning, (0.3, 1, 0.2) 2**-700 was refused as zero. Scaled by a power of two, each
    answers exactly as the unscaled direction."""
    views = pyshadow.ViewSet.zigzag(4, 8)
    d = np.array([[0.3, 1.0, 0.2]]) * [[1.0], [2.0**700], [2.0**-700]]
    assert views.nearest(d).tolist() == [1, 1, 1]
    maps, weights = views.filter_window(d)
    assert maps.tolist() == [[1, 3, 5, 7]] * 3
    np.testing.assert_array_equal(weights[1:], weights[[0, 0]])
    with pytest.raises(ValueError, match=r"^nearest: directions must be finite and non-zero$"):
        views.nearest(np.array([[0.0, 0.0, 0.0]]))
    with pytest.raises(ValueError, match=r"^filter_window: directions must be finite and non-zero$"):
        views.filter_window(np.array([[np.nan, 1.0, 0.0]]))


# ----------------------------------------------------------------------- UVs that are not finite
IMAGE = np.array([[(255, 0, 0), (0, 255, 0)], [(0, 0, 255), (200, 200, 200)]], np.uint8)
OBJ = ("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0.25 0.25\nvt 0.75 0.25\nvt nan nan\nvt inf 0.5\n"
       "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\nf 1/1 4/4 2/2\n")


def test_non_finite_uvs_of_a_textured_obj_are_refused_where_the_texture_is_applied(tmp_path):
    """`vt nan nan` was kept and the texture lookup gave NaN colours (and a cast RuntimeWarning). The mesh
    still loads (shadows and AO need no UVs); applying its texture names the file and the count."""
    from PIL import Image

    Image.fromarray(IMAGE).save(tmp_path / "tex.png")
    (tmp_path / "tex.mtl").write_text("newmtl m\nKd 1 1 1\nmap_Kd tex.png\n")
    path = tmp_path / "textured.obj"
    path.write_text("mtllib tex.mtl\nusemtl m\n" + OBJ)
    mesh = pyshadow.load_mesh(path)
    visual = visual_of(mesh)
    assert len(mesh.faces) == 3 and visual.texture.shape == (2, 2, 3) and visual.source == str(path)
    with pytest.raises(ValueError) as e:
        point_colours(visual, [0], [[1.0, 0.0, 0.0]])      # corner 0 of face 0 has finite UVs: still refused
    assert str(e.value) == (f"{path}: 4 of 9 texture coordinates (UVs of face corners) are not finite "
                            "(NaN or inf): its texture cannot be applied")
    filled = pyshadow.mesh.close_holes(mesh)                # the fan faces take the loop's UVs, NaN too
    with pytest.raises(ValueError, match=r"^.*textured\.obj: \d+ of \d+ texture coordinates"):
        point_colours(visual_of(filled), [0], [[1.0, 0.0, 0.0]])


def test_non_finite_uvs_without_a_texture_are_harmless(tmp_path):
    path = tmp_path / "plain.obj"
    path.write_text(OBJ)
    visual = visual_of(pyshadow.load_mesh(path))
    assert visual.texture is None and int((~np.isfinite(visual.uv)).any(axis=2).sum()) == 4
    assert point_colours(visual, [0, 1, 2], np.full((3, 3), 1 / 3)).tolist() == [[1.0, 1.0, 1.0]] * 3


def test_non_finite_uvs_of_a_trimesh_object_are_refused():
    from PIL import Image

    m = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], process=False,
                        visual=trimesh.visual.TextureVisuals(uv=[[0.25, 0.25], [np.nan, 0.25], [0.25, 0.75]],
                                                             image=Image.fromarray(IMAGE)))
    with pytest.raises(ValueError) as e:
        point_colours(visual_of(pyshadow.load_mesh(m)), [0], [[1 / 3] * 3])
    assert str(e.value) == ("<Trimesh>: 1 of 3 texture coordinates (UVs of face corners) are not finite "
                            "(NaN or inf): its texture cannot be applied")

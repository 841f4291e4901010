"""The render stage on bad input, second round: render options given as arrays, ground sizes float64 cannot
draw, surface colours of arrays not of their documented form (8-bit textures, RGBA, empty images, a factor
that is NaN, negative or a list), barycentric coordinates of slivers, depth maps of bases that are not
right-handed orthonormal, and a ``facing`` flag that is no bool."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import ViewSet
from pyshadow import render as render_stage
from pyshadow.materials import VISUAL_KEY, MeshVisual, barycentrics, point_colours, visual_of
from pyshadow.raster import DepthRenderer, render_depth, render_depth_reference

UV = np.array([[[0.25, 0.25], [0.75, 0.25], [0.25, 0.75]]], np.float32)
CENTRE = [[1 / 3, 1 / 3, 1 / 3]]


def small_camera(width=12, height=8):
    return pyshadow.Camera([2.0, 1.5, 3.0], [0.0, 0.3, 0.0], width=width, height=height)


@pytest.mark.parametrize("option, value, message", [
    ("denoise", np.array(["box", "box"]), "denoise must be None, 'bilateral', 'separable' or 'box', got"),
    ("normals", np.array(["flat", "smooth"]), "normals must be 'flat' or 'smooth', got"),
])
def test_render_refuses_options_given_as_arrays(small_scene, no_launch, option, value, message):
    """``value in (names)`` compared the array with each name and failed with NumPy's 'The truth value of
    an array with more than one element is ambiguous', naming no argument."""
    with pytest.raises(ValueError, match=message):
        render_stage.render(small_scene, small_camera(), **{option: value})


@pytest.mark.parametrize("size, message", [
    (10**400, "ground_size must be a finite number > 0"),
    (5e-324, "ground_size 5e-324 is too small to draw at the scene's anchor"),
])
def test_ground_quad_refuses_sizes_float64_cannot_draw(small_scene, size, message):
    """A Python int beyond float64 failed with NumPy's "ufunc 'isfinite' not supported for the input
    types"; a size whose half rounds to 0 gave a quad of four equal corners, which draws no ground."""
    with pytest.raises(ValueError, match=message):
        render_stage.ground_quad(small_scene, size)
    quad = render_stage.ground_quad(small_scene, 1e-3)             # small, yet a quad
    assert quad.area == pytest.approx(1e-6, rel=1e-9)


def visual(**kw):
    args = dict(colours=None, uv=UV, texture=np.full((2, 2, 3), 0.5, np.float32), factor=np.ones(3, np.float32))
    args.update(kw)
    return MeshVisual(**args)


@pytest.mark.parametrize("kw, error, message", [
    (dict(texture=np.full((2, 2, 3), 128, np.uint8)), TypeError, r"texture must be floats \(linear RGB"),
    (dict(uv=None, colours=np.full((1, 3, 3), 200, np.uint8)), TypeError, r"colours must be floats"),
    (dict(uv=np.full((1, 3, 2), 1, np.int64)), TypeError, r"uv must be floats \(texture coordinates\)"),
    (dict(texture=np.full((2, 2, 4), 0.5, np.float32)), ValueError, r"a texture must be an RGB image .* \(2, 2, 4\)"),
    (dict(texture=np.zeros((0, 0, 3), np.float32)), ValueError, r"a texture must be an RGB image .* \(0, 0, 3\)"),
    (dict(texture=np.array([[0.0, 1.0], [1.0, 0.0]], np.float32)), ValueError, r"a texture must be an RGB image"),
    (dict(uv=None, colours=np.full((1, 3, 4), 0.5, np.float32)), ValueError, r"colours must have shape \(T, 3, 3\)"),
    (dict(uv=np.full((1, 3, 3), 0.5, np.float32)), ValueError, r"uv must have shape \(T, 3, 2\)"),
    (dict(factor=np.array([np.nan, 1, 1], np.float32)), ValueError, r"factor must be three finite numbers >= 0"),
    (dict(factor=np.array([-1, 1, 1], np.float32)), ValueError, r"factor must be three finite numbers >= 0"),
], ids=["uint8-texture", "uint8-colours", "int-uv", "rgba", "empty-texture", "grey-texture", "rgba-colours",
        "uvw", "nan-factor", "negative-factor"])
def test_point_colours_refuse_arrays_not_of_their_documented_form(kw, error, message):
    """MeshVisual documents float32 colours (T, 3, 3), UVs (T, 3, 2), an RGB texture (h, w, 3) and a
    factor of three. Before: an 8-bit texture or 8-bit colours came out 255 times too bright (128 and 200
    for about 0.5 and 0.78; no error), integer UVs and a third UV coordinate were used as given, an RGBA
    texture or RGBA colours failed with NumPy's 'operands could not be broadcast', an empty texture with a
    divide-by-zero warning, a grey (h, w) texture was sampled without an error, a NaN factor gave NaN
    colours and a negative one a negative colour. Each now names the visual's source and the array."""
    v = visual(**kw)
    with pytest.raises(error, match=message):
        point_colours(v, [0, 0, 0], CENTRE * 3)
    mesh = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], process=False)
    mesh.metadata[VISUAL_KEY] = v
    with pytest.raises(error, match=r"mesh.metadata\['pyshadow_visual'\]: " + message):
        visual_of(mesh)


def test_a_lit_render_refuses_an_8_bit_texture(small_scene, no_launch):
    """The lit render multiplied the albedo by the 8-bit texels as they were: texels of 128 gave a radiance
    255 times that of texels of 128 / 255 as floats. It now stops before rasterising."""
    from pyshadow.lighting import Lighting

    mesh = small_scene.instances[0].mesh
    n = len(mesh.faces)
    mesh.metadata[VISUAL_KEY] = visual(uv=np.repeat(UV, n, axis=0), texture=np.full((2, 2, 3), 128, np.uint8))
    with pytest.raises(TypeError, match="texture must be floats"):
        render_stage.render(small_scene, small_camera(), lighting=Lighting(np.zeros((9, 3))))


def test_a_factor_given_as_a_list_is_applied():
    """A factor given as a list failed with "'list' object has no attribute 'astype'"."""
    v = MeshVisual(None, None, None, [0.5, 0.25, 1.0])
    np.testing.assert_array_equal(point_colours(v, [0, 0], CENTRE * 2), [[0.5, 0.25, 1.0]] * 2)


@pytest.mark.parametrize("tri", [
    [[0, 0, 0], [1, 0, 0], [0.3, 1e-9, 0]],                  # a needle: its angle at a is 3e-9 radians
    [[0, 0, 0], [1e3, 0, 0], [0.3, 1e-9, 0]],
    [[0.5, 1e-10, 0], [0, 0, 0], [1, 0, 0]],                # a cap: its angle at a is pi - 4e-10
], ids=["needle", "long-needle", "cap"])
def test_barycentrics_of_slivers(tri):
    """The Gram determinant |e1|^2 |e2|^2 - (e1.e2)^2 of a sliver cancels to 0 (or noise), and its points
    got the weights (1, 0, 0) of corner a (the colour and the smooth normal of one corner) whatever they
    were: the needle's point (0.5, 0, 0), halfway along b's edge, came out (1, 0, 0) for (0.5, 0.5, 0).
    From |e1 x e2|^2 and triple products the weights hold to 1e-9 (the float64 error of the corner
    differences over the sliver's height)."""
    t = np.array(tri, np.float64)
    w = np.array([[0.5, 0.5, 0.0], [0.2, 0.3, 0.5], [0.0, 0.1, 0.9], [0.25, 0.5, 0.25]])
    p = w @ t
    got = barycentrics(p, np.broadcast_to(t, (len(w), 3, 3)))
    np.testing.assert_allclose(got, w, atol=1e-9)


def test_barycentrics_of_ordinary_triangles_are_unchanged():
    """The triangles beyond the sliver rule keep the Gram formula's weights bit for bit."""
    t = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.5, 1.5, 0.0]])
    w = np.array([[0.2, 0.3, 0.5]])
    e1, e2, d = t[1] - t[0], t[2] - t[0], w[0] @ t - t[0]
    den = e1 @ e1 * (e2 @ e2) - (e1 @ e2) ** 2
    v = (e2 @ e2 * (d @ e1) - e1 @ e2 * (d @ e2)) / den
    u = (e1 @ e1 * (d @ e2) - e1 @ e2 * (d @ e1)) / den
    b = np.array([1 - v - u, v, u])
    np.testing.assert_array_equal(barycentrics(w @ t, t[None]), [b / b.sum()])


@pytest.fixture(scope="module")
def renderer():
    return DepthRenderer(trimesh.creation.icosphere(subdivisions=1), 4, 1)


def _bases(kind):
    b = ViewSet.zigzag(2, 4).bases[:2].copy()
    if kind == "nan":
        b[0, 0, 0] = np.nan
    elif kind == "scaled":
        b[1] *= 3.0
    elif kind == "left-handed":
        b[1, 0] *= -1.0
    elif kind == "zero":
        b[0] = 0.0
    return b


@pytest.mark.parametrize("kind, message", [("nan", "bases: 1 bases are not finite"),
                                           ("scaled", "bases: 1 are not right-handed orthonormal"),
                                           ("left-handed", "bases: 1 are not right-handed orthonormal"),
                                           ("zero", "bases: 1 are not right-handed orthonormal")])
def test_depth_renderer_refuses_bases_that_are_not_right_handed_orthonormal(renderer, kind, message):
    """DepthRenderer.render took any (B, 3, 3) numbers: a NaN basis gave a map of +inf (no surface), a
    scaled one depths outside [0, 1] (down to -0.9), a mirrored one a mirrored map whose facing flags were
    all off (a box's faces towards the light taken as facing away), a zero one an empty map; all without
    a word. A ViewSet's rule (BASIS_TOL) now applies."""
    with pytest.raises(ValueError, match=message):
        renderer.render(_bases(kind))
    renderer.render(_bases("ok"))                                   # a ViewSet's bases pass


@pytest.mark.parametrize("facing", ["no", np.array([True, False]), 1])
def test_depth_maps_refuse_a_facing_that_is_no_bool(facing):
    """``facing="no"`` was true (render_depth returned the pair (depth, front) where an array was
    expected), an array failed with NumPy's 'truth value ... is ambiguous', 1 passed for True."""
    mesh = trimesh.creation.box((1.0, 1.0, 1.0))
    views = ViewSet.zigzag(2, 4)
    for call in (lambda: render_depth(mesh, views, resolution=2, facing=facing),
                 lambda: render_depth_reference(mesh, views, resolution=2, facing=facing),
                 lambda: DepthRenderer(mesh, 2, 1, facing=facing)):
        with pytest.raises(TypeError, match=r"facing: expected True or False \(got "):
            call()


@pytest.mark.parametrize("which", ["object_id.T", "depth.T", "normal.T", "other camera"])
def test_covered_pixels_refuses_buffers_of_another_shape(small_scene, which):
    """covered_pixels read every buffer flat: a transposed (W, H) object_id or depth (PIL's (width,
    height) order) put the points at other pixels, and a 4 x 6 object_id of another camera selected
    pixels 0..23 of the 8 x 12 image, all without a word."""
    cam = small_camera(12, 8)
    g = {k: np.array(v) for k, v in pyshadow.embree.gbuffer(small_scene.draw_items(30.0)[0], cam).items()}
    obj = np.where(g["object_id"] >= 0, 0, -1).astype(np.int32)
    base = render_stage.covered_pixels(cam, g, obj)
    assert len(base.index) == int((obj != -1).sum()) > 0
    if which == "object_id.T":
        obj = np.ascontiguousarray(obj.T)
    elif which == "other camera":
        obj = np.zeros((4, 6), np.int32)
    else:
        key = which.split(".")[0]
        g[key] = np.ascontiguousarray(np.swapaxes(g[key], 0, 1))
    with pytest.raises(ValueError, match=r"has shape \((12, 8|4, 6)(, 3)?\); the camera needs \(8, 12"):
        render_stage.covered_pixels(cam, g, obj)


def ground(half):
    return trimesh.Trimesh([[-half, 0, -half], [half, 0, -half], [half, 0, half], [-half, 0, half]],
                           [[0, 2, 1], [0, 3, 2]], process=False)


@pytest.mark.parametrize("half", [1e4, 1e5, 1e6])
def test_gbuffer_of_a_large_ground_seen_from_nearby(half):
    """The kernel intersects each pixel's ray with its triangle's plane from float32 corners: a ground quad
    of half-side 1e4 .. 1e6 seen from 1.5 m put the distances off by 3e-4 .. 6e-2 (relative) and the
    positions up to 0.5 mm .. 9 cm above or below the ground. Those pixels now get the float64
    intersection: the distance to y = 0 within float32's rounding of the stored value (2 ulp)."""
    cam = pyshadow.Camera([0.3, 1.5, 0.2], [0.0, 0.0, -2.0], width=16, height=12)
    g = pyshadow.render_gbuffer([(ground(half), np.eye(4))], cam)
    assert (g["object_id"] == 0).all()
    want = (1.5 / -cam.ray_directions()[..., 1]).astype(np.float32)
    np.testing.assert_allclose(g["depth"], want, rtol=2.4e-7)
    assert np.abs(g["position"][..., 1]).max() <= 1e-6


def test_ao_on_a_large_ground_is_that_of_a_small_one(small_scene):
    """With ground_size=2e5 (a ground to the horizon) the ground's pixels sat up to 4 mm below it in
    float32 and half of them came out with AO 0 (black); the drawn ground's size no longer changes the AO."""
    cam = pyshadow.Camera([2.0, 1.5, 3.0], [0.0, 0.3, 0.0], width=48, height=32)
    s = pyshadow.Sampling(16)
    small = render_stage.render(small_scene, cam, sampling=s, ground_size=30.0)
    large = render_stage.render(small_scene, cam, sampling=s, ground_size=2e5)
    on = (small.object_id == -2) & (large.object_id == -2)
    assert on.sum() > 1000
    np.testing.assert_array_equal(large.ao[on], small.ao[on])


def test_gbuffer_refuses_a_ground_the_near_plane_would_cut_in_view():
    """The near plane is 1e-6 of the farthest geometry in view: a ground quad of half-side 1e7 seen from
    1.5 m put it 10 m from the eye, cut away every bit of ground in view, and the G-buffer came back empty
    (no pixel covered, no error). Only a vertex nearer than the near plane was refused."""
    cam = pyshadow.Camera([0.0, 1.5, 0.0], [0.0, 0.0, -2.0], width=16, height=12)
    with pytest.raises(ValueError, match=r"face \d of item 0 reaches into the view nearer than the near plane 10 "):
        pyshadow.render_gbuffer([(ground(1e7), np.eye(4))], cam)
    g = pyshadow.render_gbuffer([(ground(1e6), np.eye(4))], cam)          # near plane 1 m: nothing cut
    assert (g["object_id"] == 0).all()
    edge_on = pyshadow.Camera([0.0, 0.0, 0.0], [0.0, 0.0, -2.0], width=16, height=12)
    assert (pyshadow.render_gbuffer([(ground(1e7), np.eye(4))], edge_on)["object_id"] == -1).all()

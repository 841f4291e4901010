"""The render stage's camera and frame (second audit pass): a camera changed after creation against a camera made
anew with the same values, and the dtypes of a frame rendered from a caller's G-buffer.

Each test whose docstring starts "Was:" failed on the code before the fix and says what happened; the others pin
what the fix leaves alone.
"""
from __future__ import annotations

import copy

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.render import render

_FRAME = ("eye", "target", "forward", "right", "up")


@pytest.fixture(scope="module")
def box_scene():
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix((0.0, 0.5, 0.0)))
    return scene


def _same_camera(a, b):
    for k in _FRAME:
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)
    assert (a.fov_y, a.width, a.height) == (b.fov_y, b.width, b.height)
    np.testing.assert_array_equal(a.ray_directions(), b.ray_directions())


def test_moved_eye_turns_the_camera_to_its_target(box_scene):
    """Was: ``camera.eye = p`` kept the forward, right and up of the old eye, so the camera looked past its target
    along the old direction: a unit box on the ground seen from (-3, 2, -4) towards (0, 0.5, 0) covered (box and
    ground) 11 of 48 pixels of an 8x6 image instead of 32, and ``camera.target`` no longer was where it looked.
    Now the frame follows ``target - eye`` as at creation: the moved camera equals one made at the new eye, bit for
    bit."""
    cam = pyshadow.Camera((3.0, 2.0, 4.0), (0.0, 0.5, 0.0), width=8, height=6)
    cam.ao = None                           # other attributes are set as on any object
    cam.eye = np.array([-3.0, 2.0, -4.0])
    fresh = pyshadow.Camera((-3.0, 2.0, -4.0), (0.0, 0.5, 0.0), width=8, height=6)
    _same_camera(cam, fresh)
    items = box_scene.draw_items()[0]
    moved = pyshadow.render_gbuffer(items, cam)["object_id"]
    np.testing.assert_array_equal(moved, pyshadow.render_gbuffer(items, fresh)["object_id"])
    assert (moved != -1).sum() == 32 and (moved == 0).sum() > 0


def test_moved_target_and_up_turn_the_camera():
    """Was: ``camera.target = q`` and ``camera.up = u`` changed nothing the camera rendered (forward stayed
    (-0.575, -0.287, -0.766) with the target moved to (30, 0.5, 0)). ``camera.eye += step`` moves it too."""
    cam = pyshadow.Camera((3.0, 2.0, 4.0), (0.0, 0.5, 0.0), up=(0.0, 0.0, 1.0), fov_y=30.0, width=5, height=3)
    cam.target = (30.0, 0.5, 0.0)
    _same_camera(cam, pyshadow.Camera((3.0, 2.0, 4.0), (30.0, 0.5, 0.0), up=(0.0, 0.0, 1.0), fov_y=30.0,
                                      width=5, height=3))
    cam.up = (0.0, 1.0, 0.0)
    _same_camera(cam, pyshadow.Camera((3.0, 2.0, 4.0), (30.0, 0.5, 0.0), fov_y=30.0, width=5, height=3))
    cam.eye += np.array([1.0, 0.0, 0.0])
    _same_camera(cam, pyshadow.Camera((4.0, 2.0, 4.0), (30.0, 0.5, 0.0), fov_y=30.0, width=5, height=3))
    twin = copy.deepcopy(cam)
    twin.eye = (0.0, 9.0, 9.0)
    np.testing.assert_array_equal(cam.eye, (4.0, 2.0, 4.0))


def test_moving_the_eye_keeps_the_up_hint_given():
    """The frame of a moved eye comes from the up hint given at creation (as a new camera's would), not from the
    old frame's up: from straight above with up (0, 0, -1), then moved to the side."""
    cam = pyshadow.Camera((0.0, 5.0, 0.0), (0.0, 0.0, 0.0), up=(0.0, 0.0, -1.0), width=4, height=4)
    cam.eye = (4.0, 3.0, 5.0)
    _same_camera(cam, pyshadow.Camera((4.0, 3.0, 5.0), (0.0, 0.0, 0.0), up=(0.0, 0.0, -1.0), width=4, height=4))


@pytest.mark.parametrize("name, value, error, match", [
    ("fov_y", np.nan, ValueError, "fov_y must be in"),
    ("fov_y", 200.0, ValueError, "fov_y must be in"),
    ("fov_y", -45.0, ValueError, "fov_y must be in"),
    ("fov_y", "45", TypeError, "fov_y must be a number"),
    ("width", 0, ValueError, "width must be an int"),
    ("width", 2.5, ValueError, "width must be an int"),
    ("height", -3, ValueError, "height must be an int"),
    ("height", True, ValueError, "height must be an int"),
    ("eye", (np.nan, 0.0, 0.0), ValueError, "eye must be 3 finite numbers"),
    ("target", (0.0, np.inf, 0.0), ValueError, "target must be 3 finite numbers"),
    ("target", (3.0, 2.0, 4.0), ValueError, "coincide"),
    ("up", (3.0, 1.5, 4.0), ValueError, "parallel"),
    ("up", (0.0, 0.0, 0.0), ValueError, "zero vector"),
])
def test_bad_values_set_later_are_refused_and_change_nothing(box_scene, name, value, error, match):
    """Was: values the constructor refuses were taken when set later: a NaN, 200 or -45 degree ``fov_y`` rendered
    an empty frame (0 pixels covered instead of 32 of 48, no error), ``width = 0`` raised ZeroDivisionError,
    ``width = 2.5`` NumPy's "expected a sequence of integers", ``height = -3`` "negative dimensions are not
    allowed", a NaN eye "its transform places vertices beyond float64's range". Now each is the constructor's
    error, and the camera is left as it was."""
    cam = pyshadow.Camera((3.0, 2.0, 4.0), (0.0, 0.5, 0.0), width=8, height=6)
    before = copy.deepcopy(cam)
    with pytest.raises(error, match=match):
        setattr(cam, name, value)
    _same_camera(cam, before)
    assert (render(box_scene, cam, sampling=pyshadow.Sampling(4)).object_id != -1).sum() == 32


def test_forward_and_right_cannot_be_set():
    """Was: ``camera.forward = d`` was taken without turning right and up (a frame no longer orthonormal)."""
    cam = pyshadow.Camera((3.0, 2.0, 4.0), (0.0, 0.5, 0.0), width=8, height=6)
    for name in ("forward", "right"):
        with pytest.raises(AttributeError, match="follows from eye, target and up"):
            setattr(cam, name, (1.0, 0.0, 0.0))


def test_size_and_field_of_view_set_later_still_work():
    """Was: a valid size and field of view set later were taken as given: an ``np.float32(30.0)`` field of view
    made ``tan_half`` in float32 (3.1e-8 off the constructor's, rays 3.8e-8 off). Now they are taken as the
    constructor takes them (float, int) and the kept rays follow them, bit for bit."""
    cam = pyshadow.Camera((3.0, 2.0, 4.0), (0.0, 0.5, 0.0), width=8, height=6)
    cam.fov_y, cam.width, cam.height = np.float32(30.0), np.int64(5), 3
    assert type(cam.fov_y) is float and type(cam.width) is int
    _same_camera(cam, pyshadow.Camera((3.0, 2.0, 4.0), (0.0, 0.5, 0.0), fov_y=30.0, width=5, height=3))


@pytest.mark.parametrize("ao_scale, normals", [(1, "flat"), (2, "flat"), (1, "smooth")])
def test_frame_of_a_float64_gbuffer_is_float32(box_scene, ao_scale, normals):
    """Was: a caller's float64 G-buffer (``render(gbuffer=)``) came back as float64 ``depth``, ``normal`` and
    ``position`` buffers of the Frame, which documents them float32. Now they are the G-buffer's values rounded
    to float32: the same frame as from the float32 G-buffer, whose arrays the frame keeps as they are."""
    cam = pyshadow.Camera((3.0, 2.0, 4.0), (0.0, 0.5, 0.0), width=7, height=5)
    g32 = pyshadow.render_gbuffer(box_scene.draw_items()[0], cam)
    g64 = {k: v.astype(np.float64) if v.dtype.kind == "f" else v for k, v in g32.items()}
    kw = dict(sampling=pyshadow.Sampling(4), ao_scale=ao_scale, normals=normals)
    a, b = render(box_scene, cam, gbuffer=g64, **kw), render(box_scene, cam, gbuffer=g32, **kw)
    assert list(a) == list(b)
    for k in a:
        assert a[k].dtype == b[k].dtype == (np.int32 if k == "object_id" else np.float32), k
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    if normals == "flat":
        assert b.depth is g32["depth"] and b.position is g32["position"]


@pytest.mark.parametrize("call", ["render", "surface_points"])
def test_a_scene_camera_pair_or_a_mesh_is_no_scene(box_scene, call):
    """Was: ``render((scene, camera), camera)`` (the pair ``pyshadow.data.default_scene()`` returns) raised
    "AttributeError: 'tuple' object has no attribute 'draw_items'", a Trimesh "'Trimesh' object has no attribute
    'draw_items'", from inside (``surface_points`` too). Now the TypeError the visibility backends give, with
    its hint."""
    from pyshadow import render as stage

    cam = pyshadow.Camera((3.0, 2.0, 4.0), (0.0, 0.5, 0.0), width=4, height=3)
    with pytest.raises(TypeError, match=r"scene must be a pyshadow.Scene, got tuple \(a tuple whose first item"):
        getattr(stage, call)((box_scene, cam), cam)
    with pytest.raises(TypeError, match="scene must be a pyshadow.Scene, got Trimesh"):
        getattr(stage, call)(trimesh.creation.box(), cam)


def test_no_camera_with_a_given_gbuffer(box_scene):
    """Was: with a G-buffer given, ``render(scene, None, gbuffer=g)``, ``surface_points`` likewise and
    ``covered_pixels(None, g, ids)`` raised "AttributeError: 'NoneType' object has no attribute 'height'" (without
    one the G-buffer's TypeError came first). Now "camera must be a pyshadow.Camera" for each."""
    from pyshadow.render import covered_pixels, surface_points

    cam = pyshadow.Camera((3.0, 2.0, 4.0), (0.0, 0.5, 0.0), width=4, height=3)
    g = pyshadow.render_gbuffer(box_scene.draw_items()[0], cam)
    for call in (lambda: render(box_scene, None, gbuffer=g), lambda: surface_points(box_scene, None, gbuffer=g),
                 lambda: covered_pixels(None, g, g["object_id"]), lambda: render(box_scene, (cam,))):
        with pytest.raises(TypeError, match="camera must be a pyshadow.Camera, got (NoneType|tuple)"):
            call()

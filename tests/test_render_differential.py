"""The render stage (pyshadow/render.py) against independent computations of the same answers: the exact
ground plane, Embree's visibility on the same G-buffer.

Each test whose docstring starts "Was:" failed on the code before the fix and says what happened.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling
from pyshadow.contact import ground_tolerance
from pyshadow.scene import GROUND_ID


@pytest.fixture(scope="module")
def box_scene():
    """A unit box standing on the ground y = 0."""
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    pose = np.eye(4)
    pose[1, 3] = 0.5
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), pose)
    return scene


@pytest.mark.parametrize("width", [1000, 2000])
def test_one_row_image_points_lie_on_the_ground(box_scene, width):
    """Was: the G-buffer kernel's float32 ray of pixel column c, ``(2 (c + 1/2) / W - 1) tan_x``, is off by
    about 6e-8 tan_x, and a one-row image has a large tan_x (1155 for 2000 x 1 pixels at fov_y 60): its
    depths were off the exact ray's by up to 300 float32 spacings (1.8e-5 relative) while the render stage
    kept them, as it does when 16 spacings of the farthest depth stay within the ground's tolerance (8.7e-6
    here). Of the two ground pixels of the 1000 x 1 and the 2000 x 1 image, one point lay 1.7e-5 below the
    ground (the other up to 2.7e-5 above it) and its AO came out 0 (the ground occluding every ray) where
    Embree's visibility on the same G-buffer gives 1. Now that tolerance is divided by the image's largest tangent and those points are put
    on the plane: both lie on it to float64 rounding and their AO is Embree's, 1."""
    cam = pyshadow.Camera([2.0, 1.5, 3.0], [0.0, 0.5, 0.0], width=width, height=1, fov_y=60.0)
    sp = pyshadow.render.surface_points(box_scene, cam)
    ground = sp.surface_ids == GROUND_ID
    assert ground.sum() == 2
    assert np.abs(sp.points[ground, 1]).max() <= 1e-12 < ground_tolerance(box_scene)
    s = Sampling(8)
    csm = pyshadow.render.render(box_scene, cam, sampling=s)
    ref = pyshadow.render.render(box_scene, cam, sampling=s, visibility="embree")
    on = csm.object_id == GROUND_ID
    np.testing.assert_array_equal(csm.object_id, ref.object_id)
    np.testing.assert_array_equal(ref.ao[on], [1.0, 1.0])
    np.testing.assert_array_equal(csm.ao[on], [1.0, 1.0])

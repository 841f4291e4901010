"""The reduced-resolution AO pass of ``render(..., ao_scale=)`` at faces seen edge-on (pyshadow/ao_pass.py).

With ``ao_scale`` > 1 AO is computed at every s-th pixel and upsampled with the G-buffer
(:func:`pyshadow.filters.upsample`). A pixel whose upsampling window holds no low-res sample on its own
surface got another surface's AO: the pass only checked for a sample of the same *instance*, and a box's
top face seen as a one-pixel band takes its samples from the box's front or side face at a right angle.
Reference: the same render at full resolution (the same sampling pattern per pixel, so a pixel whose AO is
computed in the pass holds exactly the full-resolution value).
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling
from pyshadow.render import render


@pytest.fixture(scope="module")
def box_scene():
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)    # Embree answers
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    scene.add(box, trimesh.transformations.translation_matrix([0.0, 0.5, 0.0]))
    scene.add(trimesh.creation.icosphere(2), trimesh.transformations.translation_matrix([1.6, 1.0, -0.5]))
    scene.add(box, trimesh.transformations.translation_matrix([-1.2, 0.25, 0.8]) @ np.diag([0.5, 0.5, 0.5, 1.0]))
    return scene


def _top_band(frame):
    """The pixels of the first box's top face (normal +y): a band one pixel tall from this camera."""
    return (frame.object_id == 0) & (frame.normal[..., 1] > 0.99)


@pytest.mark.parametrize("ao_scale", [2, 4])
def test_a_box_top_seen_edge_on_gets_its_own_ao_not_the_front_faces(box_scene, ao_scale):
    """Was: the box's top face, seen from 0.1 above it as a band one pixel tall, took the upsampled AO of the
    samples of the box's faces below and beside it (at a right angle to it): 160x120, 64 samples, Embree:
    34 of its 34 pixels off the full-resolution AO, by up to 0.48 at ao_scale=2 and 0.72 at ao_scale=4 (a
    dark line along the box's top edge; 34 covered pixels off by more than 0.3 at either scale). Now a pixel
    without a low-res sample on its own surface (same instance, normals within 82 degrees, depths within
    8.6 %) gets its own AO: the band equals the full-resolution AO exactly, no pixel is 0.3 off (0.26 the
    worst, at the sphere's contact)."""
    cam = pyshadow.Camera([0.5, 1.1, 4.0], [0.0, 0.6, 0.0], fov_y=45, width=160, height=120)
    sampling = Sampling(64)
    full = render(box_scene, cam, visibility="embree", sampling=sampling)
    low = render(box_scene, cam, visibility="embree", sampling=sampling, ao_scale=ao_scale)
    band = _top_band(full)
    assert band.sum() >= 30 and (band.sum(axis=0) <= 1).all()       # a band one row tall
    np.testing.assert_array_equal(low.ao[band], full.ao[band])
    covered = full.object_id != -1
    err = np.abs(low.ao - full.ao)[covered]
    assert (err > 0.3).sum() == 0, np.sort(err)[-5:]


def test_a_one_row_face_over_a_face_at_a_right_angle_is_in_the_pass():
    """Was: the pass took a pixel's window to hold its surface wherever a sample of its instance lay there:
    a one-row face (normal +y) over a face of the same instance at a right angle (normal +z) got none of
    its own AO (none of its 16 pixels, all off the sample grid), so upsampling gave it the lower face's. Now
    those pixels are in the pass; a plane at a gentle slope (normals 10 degrees apart, the same depth) and
    the lower face's own pixels are not. As before, a thin pole (another instance, one column) before the
    ground is in it, the background never is, and every covered sample pixel is."""
    from pyshadow.ao_pass import ao_pass

    H, W = 8, 16
    obj = np.zeros((H, W), np.int32)
    depth = np.full((H, W), 5.0, np.float32)
    normal = np.zeros((H, W, 3), np.float32)
    normal[..., 2] = 1.0
    normal[3, :] = (0.0, 1.0, 0.0)                  # row 3: off the grid for scale 2 (rows 0, 2, 4, 6)
    keep = ao_pass(obj, depth, normal, 2, 2)
    assert keep[3].all()
    grid = np.zeros((H, W), bool)
    grid[::2, ::2] = True
    assert (keep[np.arange(H) != 3] == grid[np.arange(H) != 3]).all()
    tilt = np.radians(10.0)
    normal[3, :] = (0.0, np.sin(tilt), np.cos(tilt))
    assert (ao_pass(obj, depth, normal, 2, 2) == grid).all()

    obj[:, 5] = 1                                   # a pole one column wide, then the background's top row
    obj[0, :] = -1
    depth[0, :] = np.inf
    keep = ao_pass(obj, depth, normal, 2, 2)
    assert keep[1:, 5].all() and not keep[0].any()
    assert keep[2::2, ::2].all()

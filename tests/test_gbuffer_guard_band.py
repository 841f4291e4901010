"""Triangles reaching far outside the view are rasterised clipped to a guard band (pyshadow/gbuffer.py
``raster_triangles``, ``GUARD_BAND``).

A triangle crossing the near plane (1e-6 of the farthest geometry in view) outside the view, such as a ground
quad or a wall reaching behind the camera, kept corners whose screen coordinates reach 1e8 - 1e9 pixels,
where the kernel's float32 edge functions and interpolated depths lose whole pixels. Each test whose
docstring starts "Was:" failed on the code before the fix and says what happened; the others pin what the
fix leaves alone. Embree's primary rays are the truth.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree, gbuffer
from pyshadow.gbuffer import render_gbuffer_reference

QUAD = trimesh.Trimesh([[-8, 0, -8], [8, 0, -8], [8, 0, 8], [-8, 0, 8]], [[0, 2, 1], [0, 3, 2]], process=False)


def _plate_on_ground(thickness):
    """A 2 x 2 plate of ``thickness`` lying on the default 16 x 16 ground quad (which reaches behind the camera)."""
    plate = trimesh.creation.box((2.0, thickness, 2.0))
    plate.apply_translation([0, thickness / 2, 0])
    return [(plate, np.eye(4)), (QUAD, np.eye(4))]


@pytest.mark.parametrize("thickness, was", [(1e-2, 173), (1e-3, 1471)])
def test_a_thin_plate_on_the_ground_wins_its_pixels(thickness, was):
    """Was: the ground's depth, interpolated from corners 1e-5 from the eye, came out up to 7 % off and beat the plate:
    ``was`` pixels' ids differed from Embree's at 160 x 120 (1 cm and 1 mm thick; Scene.render then gave them the
    ground's id and AO 0 from the contact footprint). Now every pixel shows what Embree's ray meets, as the float64
    reference does."""
    cam = pyshadow.Camera([1.2, 1.0, 2.0], [0.0, 0.0, 0.0], width=160, height=120)
    items = _plate_on_ground(thickness)
    g, e = pyshadow.render_gbuffer(items, cam), embree.gbuffer(items, cam)
    assert (e["object_id"] == 0).sum() > 6000
    np.testing.assert_array_equal(g["object_id"], e["object_id"])
    np.testing.assert_array_equal(render_gbuffer_reference(items, cam)["object_id"], e["object_id"])


def test_a_poster_on_a_wall_that_reaches_behind_the_camera():
    """Was: a side wall reaching behind the camera beat a poster hung 1 mm in front of it: 914 pixels' ids differed from
    Embree's (160 x 120). Now none."""
    wall = trimesh.Trimesh([[-5, 0, -5], [-5, 0, 5], [-5, 3, 5], [-5, 3, -5]], [[0, 1, 2], [0, 2, 3]], process=False)
    poster = trimesh.creation.box((0.002, 1.0, 1.5))
    poster.apply_translation([-4.998, 1.5, -2.0])
    items = [(wall, np.eye(4)), (poster, np.eye(4))]
    cam = pyshadow.Camera([-3.5, 1.6, 0.5], [-5.0, 1.5, -2.0], width=160, height=120)
    g, e = pyshadow.render_gbuffer(items, cam), embree.gbuffer(items, cam)
    assert (e["object_id"] == 1).sum() > 1500
    np.testing.assert_array_equal(g["object_id"], e["object_id"])


@pytest.mark.parametrize("width, height, was", [(320, 240, 163), (640, 480, 584)])
def test_the_far_edge_of_the_ground_quad_lies_where_the_rays_leave_it(width, height, was):
    """Was: the far edge of a ground quad the camera stands over was drawn up to 4.8 pixels off at 640 x 480: ``was``
    pixels differed from Embree's ids. Now none."""
    cam = pyshadow.Camera([1.2, 1.0, 2.0], [0.0, 0.4, 0.0], width=width, height=height)
    g, e = pyshadow.render_gbuffer([(QUAD, np.eye(4))], cam), embree.gbuffer([(QUAD, np.eye(4))], cam)
    assert 0.2 < (e["object_id"] == 0).mean() < 0.9
    np.testing.assert_array_equal(g["object_id"], e["object_id"])


def test_a_clipped_triangle_keeps_its_own_plane(monkeypatch):
    """What the fix leaves alone: a pixel's distance, position and normal come from its source triangle's corners, as
    before, so wherever the same triangle wins a pixel the G-buffer is the same bit for bit with and without the guard
    band (without it: the band at 1e30 half-widths, which clips nothing). A wall 200 wide, 3 in front of the eye
    (nothing crosses the near plane, so each face is one triangle), and a sphere before it."""
    wall = trimesh.Trimesh([[-100, -100, -3], [100, -100, -3], [100, 100, -3], [-100, 100, -3]], [[0, 1, 2], [0, 2, 3]],
                           process=False)
    ball = trimesh.creation.icosphere(2, 0.5)
    items = [(wall, np.eye(4)), (ball, trimesh.transformations.translation_matrix([0.3, 0, -2]))]
    cam = pyshadow.Camera([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], width=160, height=120)
    tris = gbuffer.gbuffer_triangles(items, cam)[0]
    raster, src = gbuffer.raster_triangles(tris, cam)
    assert tris[..., 2].min() > 1.0                             # nothing near-clipped: a face is one triangle
    assert src is not None and len(raster) > len(tris)          # the wall's triangles are cut
    with_band = pyshadow.render_gbuffer(items, cam)
    monkeypatch.setattr(gbuffer, "GUARD_BAND", 1e30)
    assert gbuffer.raster_triangles(tris, cam)[1] is None
    without = pyshadow.render_gbuffer(items, cam)
    same = (with_band["object_id"] == without["object_id"]) & (with_band["face"] == without["face"])
    assert same.mean() > 0.99 and (with_band["object_id"] == 1).sum() > 1000
    for k in ("depth", "position", "normal"):
        np.testing.assert_array_equal(with_band[k][same], without[k][same], err_msg=k)


def test_the_pieces_lie_in_the_band_and_share_their_cut_edges():
    """The pieces of a clipped triangle lie within the guard band (screen coordinates within one image width of the
    image, up to float64 rounding), and an edge two triangles share is cut at the same point in both (bit for bit):
    the quad's diagonal, cut by the band, leaves the two halves' pieces with equal corners there."""
    cam = pyshadow.Camera([1.2, 1.0, 2.0], [0.0, 0.4, 0.0], width=64, height=48)
    tris = gbuffer.gbuffer_triangles([(QUAD, np.eye(4))], cam)[0]
    raster, src = gbuffer.raster_triangles(tris, cam)
    fx = cam.width / (2 * cam.tan_half * cam.aspect)
    fy = cam.height / (2 * cam.tan_half)
    sx, sy = gbuffer._screen(raster, cam.width, cam.height, fx, fy)
    assert np.abs(sx - (cam.width - 1) / 2).max() <= gbuffer.GUARD_BAND * cam.width / 2 * (1 + 1e-9)
    assert np.abs(sy - (cam.height - 1) / 2).max() <= gbuffer.GUARD_BAND * cam.height / 2 * (1 + 1e-9)
    corners = [{tuple(c) for t in raster[src == k] for c in t} for k in (0, 1)]
    shared = corners[0] & corners[1]
    assert len(shared) >= 2                                     # the diagonal's two ends (or its cut points)

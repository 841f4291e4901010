"""Cube-map projection: which probe sees a surface point seen at a grazing angle from the probe.

References: a bare ground plane, which every probe above it sees whole (no occluder); a camera at the
probe's own centre, whose every surface pixel the probe sees by construction; Embree's segment from the
probe's centre to each pixel's point in the wall scene of tests/test_cubemap.py.
"""
from __future__ import annotations

import numpy as np
import pytest

import pyshadow
from conftest import wall_scene
from pyshadow.cubemap import CubeMapAO
from pyshadow.render import surface_points
from pyshadow.scene import GROUND_ID

HEIGHT = 0.35          # the probe's height above the ground y = 0


def ground_maps(R: int, **kw):
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    maps = CubeMapAO(scene, 1.0, resolution=R, ground_size=100.0, **kw)
    maps.add_probe([0.0, HEIGHT, 0.0])
    return maps


def test_ground_points_far_from_the_probe_are_seen():
    """Was: a ground point more than 10 probe heights away (``|n.u| < 0.1`` from the probe) was unseen: the
    centre depth of its grazing texel differs from its distance by far more than the 2 % tolerance. 22 of
    these 30 points (3.5 to 15 away, R = 64) were unseen; the probe sees them all."""
    maps = ground_maps(64, estimator=None)
    dist = np.linspace(0.5, 15.0, 30)
    pts = np.stack([0.3 * dist, np.zeros_like(dist), -dist], axis=1)
    probe, quality = maps.assign(pts, np.tile([0.0, 1.0, 0.0], (len(pts), 1)), np.full(len(pts), GROUND_ID))
    assert (probe == 0).all()
    assert (quality > 0).all()


def test_a_probe_at_the_camera_eye_covers_its_ground_pixels():
    """Was: a camera at the probe's centre looking down the ground had 16 % of its ground pixels (the far
    ones) uncovered (coverage 0.842, NaN AO there), and ``place(camera, threshold=1)`` put a new probe at the
    same eye on each call (True, True) although that probe sees every one of those pixels."""
    maps = ground_maps(64, sampling=pyshadow.Sampling(8))
    cam = pyshadow.Camera([0.0, HEIGHT, 0.0], [0.0, 0.0, -3.0], fov_y=60, width=32, height=32)
    pr = maps.project(cam)
    surface = pr.probe != -2
    assert surface.sum() > 400
    assert pr.covered[surface].all()
    np.testing.assert_allclose(pr.ao[surface], 1.0)          # an open ground plane: nothing occludes
    assert not maps.place(cam, threshold=1.0)
    assert len(maps.probes) == 1


def seen_by_embree(scene, centre, points):
    """Nothing between ``centre`` and each point (Embree, from the point towards the centre)."""
    v = np.asarray(centre) - points
    r = np.linalg.norm(v, axis=1)
    return pyshadow.embree.visible(scene, points, v / r[:, None], max_distance=r * (1 - 1e-3))


@pytest.mark.parametrize("centre, after, truth", [((10.0, 1.0, 2.0), 159, 179), ((0.0, 1.0, -38.0), 0, 0)])
def test_floor_pixels_seen_at_a_grazing_angle_against_embree(centre, after, truth):
    """Was: of a 16 x 12 camera's pixels a probe 10 to the side of it sees (Embree: 179, most on the floor at
    a grazing angle) 133 were covered; now 159, none falsely. A probe behind the 10-high wall sees none of
    them, and none is covered, as before: the ground under the wall is the same plane, and taking a grazing
    texel's plane depth without asking how far that plane is seen covered 91 of the 192 through the wall."""
    scene = wall_scene()
    maps = CubeMapAO(scene, 1.0, resolution=16, estimator=None)
    maps.add_probe(centre)
    cam = pyshadow.Camera([0.2, 1.3, 2.5], [0.3, 0.2, 0.5], width=16, height=12)
    sp = surface_points(scene, cam)
    n = sp.normals.astype(np.float64)
    got = maps.assign(sp.points, n, sp.surface_ids)[0] >= 0
    ref = seen_by_embree(scene, centre, sp.points) & (np.einsum("ij,ij->i", n, np.asarray(centre) - sp.points) > 0)
    assert len(sp.points) == 192 and ref.sum() == truth
    assert not (got & ~ref).any()
    assert got.sum() == after

"""Differential test of pyshadow.render_gbuffer's distances on a large ground seen at grazing angles, against
the float64 closed form (the ray's distance to the plane y = 0)."""
import numpy as np
import pytest
import trimesh

from pyshadow.camera import Camera
from pyshadow.gbuffer import render_gbuffer

QUAD = trimesh.Trimesh([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], [[0, 2, 1], [0, 3, 2]], process=False)


def _ground_error(half, height, target, size=(160, 90)):
    cam = Camera((0.5, height, 3.0), target, width=size[0], height=size[1])
    g = render_gbuffer([(QUAD, np.diag([half, 1.0, half, 1.0]))], cam)
    d = cam.ray_directions()
    hit = g["object_id"] >= 0
    exact = height / -d[..., 1][hit]
    assert hit.sum() > 1000 and (d[..., 1][hit] < 0).all()
    return np.abs(g["depth"][hit] - exact) / exact, np.abs(g["position"][hit][:, 1])


@pytest.mark.parametrize("half, height, target", [(1e3, 0.05, (0.0, 0.3, 0.0)), (1e3, 1.5, (0.0, 0.0, 0.0)),
                                                  (1e4, 1.5, (0.0, 1.4, 0.0))])
def test_grazing_ground_distances_match_the_plane(half, height, target):
    """Was: the kernel's distance along each ray came from the triangle's plane offset n . a computed at a
    corner 1e3 away (cancellation, about 6e-8 of the corner's distance), and the host redid it in float64
    only where a corner reached beyond 256 times the pixel's own distance, not the plane's distance from the
    eye: a ground of side 2e3 seen from 5 cm had distances off by up to 4.0e-4 of theirs (2.8 mm at 7 m), from
    1.5 m up to 2.0e-5; one of side 2e4 seen from 1.5 m towards the horizon 2.0e-5, its points up to 3.1e-5 off
    the ground. Now pixels are redone where a corner reaches beyond 256 times the plane's distance (and a large
    triangle beyond 16 times gets its plane from float64): within 1e-6 (float32 depths; measured 6e-8), the
    points within 1e-6 of the ground."""
    rel, off = _ground_error(half, height, target)
    assert rel.max() < 1e-6
    assert off.max() < 1e-6


def test_ordinary_ground_is_still_the_kernels():
    """The ordinary case (a ground of side 20 seen from 1.5 m: corners within 16 plane distances) keeps the
    float32 kernel's planes, within the documented 1e-7 times the ratio (here below 1e-6)."""
    rel, _ = _ground_error(10.0, 1.5, (0.0, 0.0, 0.0))
    assert rel.max() < 1e-6


@pytest.mark.parametrize("half", [250.0, 380.0])
def test_large_ground_seen_from_above_stays_within_its_tolerance(half):
    """Was: a ground of side 500-760 seen from 1.5 m straight down (corners within 256 times the plane's distance,
    so no pixel was redone in float64) had its plane's offset from float32 corners 250-380 away: points up to
    7.9e-6 (side 500) and 1.6e-5 (side 760; 9600 of 19200 pixels below -1e-5) off the ground, beyond the ground's
    tolerance 1e-5 of a unit scene, while the depths' 16 float32 spacings (3.8e-6) let the renderer keep them.
    Now a large triangle whose corners reach beyond 16 times its plane's distance gets its plane from float64:
    within 1e-6 (measured 3e-7)."""
    cam = Camera((0.3, 1.5, 0.2), (0.0, 0.0, 0.0), up=(0, 0, -1), width=160, height=120, fov_y=45)
    g = render_gbuffer([(QUAD, np.diag([half, 1.0, half, 1.0]))], cam)
    hit = g["object_id"] >= 0
    assert hit.all()
    d = cam.ray_directions()[hit]
    points = cam.eye + g["depth"][hit].astype(np.float64)[:, None] * d      # as the renderer makes them
    assert np.abs(points[:, 1]).max() < 1e-6
    exact = 1.5 / -d[:, 1]
    assert (np.abs(g["depth"][hit] - exact) / exact).max() < 1e-6


def test_large_ground_ao_is_open_away_from_the_bodies():
    """Was: Scene.render of a box on a ground of side 760 seen from 1.5 m straight down gave AO 0 at 9 of the
    404 ground pixels more than 0.8 from the box (their points below the ground), 0.94-1 elsewhere and at
    ground_size 20 or 1000. Now none is below 0.5."""
    import pyshadow

    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=32)
    scene.add(trimesh.creation.box((0.5, 0.5, 0.5)), trimesh.transformations.translation_matrix([0, 0.25, 0]))
    cam = Camera((0.3, 1.5, 0.2), (0.0, 0.0, 0.0), up=(0, 0, -1), width=80, height=60, fov_y=45)
    out = scene.render(cam, sampling=pyshadow.Sampling(16), ground_size=760.0)
    ao = np.asarray(out["ao"] if isinstance(out, dict) else getattr(out, "ao", out))
    g = render_gbuffer(scene.draw_items(760.0)[0], cam)
    ground = (g["object_id"] == g["object_id"].max()) & (np.abs(g["position"][..., 0]) > 0.8)
    assert ground.sum() > 300
    assert ao[ground].min() >= 0.5

"""The reduced-resolution AO pass (pyshadow/ao_pass.py) and what upsampling makes of the pixels it leaves out.

A covered pixel left out of the pass gets :func:`pyshadow.filters.upsample`'s value: the weighted mean of its
window's low-res samples, weight = spatial x depth x normal term, or, where the total weight is below 1e-6, the
tap nearest in depth whatever its normal. Reference: those weights recomputed here in float64 (the filter's
documented formula), and the same render at full resolution on Embree (the same pattern per pixel).
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling
from pyshadow.ao_pass import ON_SURFACE_WEIGHT, ao_pass
from pyshadow.render import render

R = 2       # render's upsampling radius (low-res taps per side)


def _tap_weights(obj, depth, normal, s, r, c):
    """Upsampling weights of pixel (r, c)'s window taps (float64) and whether each is on its surface
    (the same instance, weight >= ON_SURFACE_WEIGHT)."""
    H, W = obj.shape
    w, own = [], []
    for i in range(r // s - R + 1, r // s + R + 1):
        for j in range(c // s - R + 1, c // s + R + 1):
            if 0 <= i and 0 <= j and s * i < H and s * j < W and np.isfinite(depth[s * i, s * j]):
                e = ((s * i - r) ** 2 + (s * j - c) ** 2) / (s / 2) ** 2
                e += ((float(depth[s * i, s * j]) - depth[r, c]) / depth[r, c] / 0.02) ** 2
                e += (max(0.0, 1.0 - float(normal[r, c] @ normal[s * i, s * j])) / 0.2) ** 2
                w.append(np.exp(-0.5 * e))
                own.append(obj[s * i, s * j] == obj[r, c] and w[-1] >= ON_SURFACE_WEIGHT)
    return np.array(w), np.array(own, bool)


@pytest.fixture(scope="module")
def rod():
    """A thin horizontal rod (radius 0.03, along z) over the ground: its normal turns ~20 degrees a pixel."""
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)   # Embree answers
    scene.add(trimesh.creation.cylinder(0.03, 2.0), trimesh.transformations.translation_matrix([-0.8, 1.0, 0.6]))
    cam = pyshadow.Camera([2.0, 1.5, 3.0], [0.0, 0.3, 0.0], width=61, height=47)
    return scene, cam, render(scene, cam, visibility="embree", sampling=Sampling(64))


@pytest.mark.parametrize("ao_scale", [2, 4])
def test_pixels_left_out_of_the_pass_take_their_ao_from_their_own_surface(rod, ao_scale):
    """Was: a sample counted as on the pixel's surface by its depth and normal terms alone; one across the
    window (spatial weight down to exp(-16)) kept its pixel out of the pass while upsampling fell back to
    the tap nearest in depth (total weight < 1e-6) or took most of its weight from taps at 120 degrees:
    at the rod's edges 4 (ao_scale 2) and 7 (ao_scale 4) pixels fell back and 54 and 74 more drew most
    of their weight off their surface (61x47). Now the spatial term counts:
    no pixel out of the pass falls back or takes under half its weight from its own surface."""
    _, _, full = rod
    obj, depth, normal = full.object_id, full.depth, full.normal.astype(np.float64)
    keep = ao_pass(obj, full.depth, full.normal, ao_scale, R)
    rows, cols = np.nonzero((obj != -1) & ~keep)
    assert len(rows) > 500
    for r, c in zip(rows, cols):
        w, own = _tap_weights(obj, depth, normal, ao_scale, r, c)
        assert w.sum() >= 1e-6, (r, c, w.sum())
        assert w[own].sum() >= 0.5 * w.sum(), (r, c, w[own].sum(), w.sum())


def test_the_rods_underside_at_ao_scale_2_is_its_own_ao(rod):
    """Was: 7 pixels of the rod's underside at ao_scale=2 read their neighbours' AO (off by 0.45 to
    0.84 against the full-resolution render; RMSE over the covered pixels 0.042). Now they
    are in the pass and equal to the full-resolution AO; no rod pixel is 0.6 off (0.52 the worst, a
    neighbour 67 degrees round the rod), RMSE 0.020."""
    scene, cam, full = rod
    low = render(scene, cam, visibility="embree", sampling=Sampling(64), ao_scale=2)
    covered = full.object_id != -1
    err = np.abs(low.ao - full.ao)
    assert err[full.object_id == 0].max() < 0.6, np.sort(err[full.object_id == 0])[-5:]
    assert np.sqrt(np.mean(err[covered] ** 2)) < 0.03


def test_a_like_sample_across_the_window_does_not_keep_a_pixel_out():
    """Was: pixel (2, 3) of instance 0 before a wall of instance 1 (the same depth and normal), whose only
    sample of instance 0 is (6, 6), 5 pixels away (spatial weight exp(-12.5) = 3.7e-6 at ao_scale 2), stayed
    out of the pass: upsampling gave it the wall's AO (the wall's 15 taps weigh 1.57 in all, its own sample
    2.4e-6 of the total). Now it is in the pass; of the wall's pixels off the grid only those next to the
    sample (6, 6), which takes over a quarter of their weight, are."""
    H, W = 8, 8
    obj = np.ones((H, W), np.int32)
    obj[2, 3] = obj[6, 6] = 0
    depth = np.full((H, W), 5.0, np.float32)
    normal = np.zeros((H, W, 3), np.float32)
    normal[..., 2] = 1.0
    w, own = _tap_weights(obj, depth, normal.astype(np.float64), 2, 2, 3)
    same = np.array([obj[2 * i, 2 * j] == 0 for i in range(0, 4) for j in range(0, 4)])
    assert w[same].sum() < 3e-6 * w.sum() and not own.any()
    keep = ao_pass(obj, depth, normal, 2, R)
    assert keep[2, 3]
    grid = np.zeros((H, W), bool)
    grid[::2, ::2] = True
    keep[2, 3] = False
    keep[5:, 5:] &= grid[5:, 5:]
    assert (keep == grid).all()


@pytest.fixture(scope="module")
def pipe():
    """A pipe (radius 0.06) lying along a wall: its front at the wall's depth (1.5 % off) and normal."""
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)   # Embree answers
    scene.add(trimesh.creation.box((4.0, 3.0, 0.2)), trimesh.transformations.translation_matrix([0.0, 1.5, -0.1]))
    scene.add(trimesh.creation.cylinder(0.06, 3.0, sections=24),
              trimesh.transformations.translation_matrix([0.0, 1.2, 0.06])
              @ trimesh.transformations.rotation_matrix(np.pi / 2, [0.0, 1.0, 0.0]))
    cam = pyshadow.Camera([0.5, 1.5, 4.0], [0.0, 1.2, 0.0], width=64, height=48, fov_y=40)
    return scene, cam, render(scene, cam, visibility="embree", sampling=Sampling(64))


@pytest.mark.parametrize("ao_scale", [2, 4])
def test_a_pipe_along_a_wall_gets_its_own_ao_not_the_walls(pipe, ao_scale):
    """Was: a pipe pixel with one sample on its own surface stayed out of the pass while the wall's samples
    (another instance at its depth and normal) carried up to 100 % of its upsampling weight: the pipe read the
    wall's AO, RMSE 0.171 (ao_scale 2) and 0.187 (4) against the full-resolution render, 45 and 50 of its 100
    pixels off by more than 0.2 (up to 0.31); 52 and 170 pixels out of the pass took under 3/4 of their weight
    from their own surface. Now those pixels are in the pass: the pipe's RMSE 0.016 and 0.019 (0.085 the worst
    pixel) and every pixel out of the pass takes at least OWN_SHARE (3/4) of its weight from its surface."""
    scene, cam, full = pipe
    low = render(scene, cam, visibility="embree", sampling=Sampling(64), ao_scale=ao_scale)
    on_pipe = full.object_id == 1
    err = np.abs(low.ao - full.ao)[on_pipe]
    assert on_pipe.sum() >= 90
    assert np.sqrt(np.mean(err ** 2)) < 0.05 and err.max() < 0.2, np.sort(err)[-5:]
    obj, normal = full.object_id, full.normal.astype(np.float64)
    keep = ao_pass(obj, full.depth, full.normal, ao_scale, R)
    for r, c in zip(*np.nonzero((obj != -1) & ~keep)):
        w, own = _tap_weights(obj, full.depth, normal, ao_scale, r, c)
        assert w[own].sum() >= 0.75 * w.sum() * (1 - 1e-6), (r, c, w[own].sum() / w.sum())      # OWN_SHARE

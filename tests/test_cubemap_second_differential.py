"""Cube-map AO, second differential pass: degenerate but valid cameras, receivers between a probe and a caster.

What agreed and is not tested again here: the NumPy march and the kernel (0 of 6,400 rays differ at scale
1e-3 .. 1e4 and 1e6 .. 1e7 from the origin, six option sets), both against Embree on identical rays (every
resolvable ray agrees, probes at 0.02 above the floor, over the box, 3 units off), the march against the
closed form of a floor point in a square room (four walls, h = 0.75, 0.8, 0.9: within 0.002 at 2,048 rays),
per-texel AO and the projection under a uniform scale (raymarch: the same bits; horizon: ties of texels
only), seed_box_filter and coverage_grid against brute force.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from conftest import wall_scene
from pyshadow.cubemap import CubeMapAO, CubeProbe, direction_texels, raymarch_visible
from pyshadow.cubemap.analysis import unseen_rays

PROBE = np.array([0.0, 1.0, 2.0])


@pytest.mark.parametrize("size", [(1, 1), (5, 1), (4, 4), (9, 7)])
def test_place_on_a_camera_smaller_than_the_grid(size):
    """Before: with a probe placed, ``place`` on any camera under 8 pixels a side raised ``ValueError: grid
    must be an int in 1..4, got 8`` (the default grid, which the caller never gave). Now such an image is
    counted pixel by pixel along its short side: the answer is coverage_grid's with that grid."""
    from pyshadow.cubemap import coverage_grid

    w, h = size
    cam = pyshadow.Camera(PROBE + [0.2, 0.3, 0.5], PROBE + [0.3, -0.8, -1.5], width=w, height=h)
    for centre, expect in ((PROBE + [0.2, 0.3, 0.5], False), (PROBE + [0.0, 0.0, 40.0], True)):
        maps = CubeMapAO(wall_scene(), 1.0, resolution=16, sampling=pyshadow.Sampling(4))
        maps.add_probe(centre)
        pr = maps.project(cam, on_empty="fallback")
        shaded = coverage_grid(pr.covered, pr.probe == -2, min(8, w, h))
        assert (shaded < 0.75) == expect                 # a probe at the eye shades it, one 40 away none of it
        assert maps.place(cam) is expect
        assert len(maps.probes) == 1 + expect
    with pytest.raises(ValueError, match="grid must be >= 1, got 0"):
        maps.place(cam, grid=0)


def plate_scene(plate_casts: bool):
    """Ground, a 0.4 caster box at the origin and a 2 x 0.75 plate (y 0.45 .. 1.2) at z = 0.6 in front of it."""
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(trimesh.creation.box((0.4, 0.4, 0.4)), trimesh.transformations.translation_matrix([0.0, 0.2, 0.0]))
    scene.add(trimesh.creation.box((2.0, 0.75, 0.02)), trimesh.transformations.translation_matrix([0.0, 0.825, 0.6]),
              casts=plate_casts)
    return scene


def test_unseen_rays_behind_a_receiver():
    """A probe at (0, 1.5, 2) sees the floor point (0, 0, 0.4) below a receiver plate; the ray from it to the
    box's face at height 0.3 passes, just before the box, behind the plate as the probe sees it (the march reads
    the plate there and answers open; Embree: blocked). Before: the sight lines were tested against the casters
    only, so the ray counted as seen (False; 19 of 1,888 floor rays flagged where 1,181 pass behind the plate).
    Now receivers hide space as casters do: the same answer as with the plate a caster."""
    P = np.repeat([[0.0, 0.0, 0.4]], 4, axis=0)
    # to the box's face behind the plate, to its foot below the plate, over the box (its end behind the plate),
    # sideways (below the plate all along)
    W = np.array([[0.0, 0.3, -0.2], [0.0, 0.05, -0.2], [0.0, 1.0, -0.3], [1.0, 0.2, 0.0]])
    got = {}
    for casts in (False, True):
        scene = plate_scene(casts)
        probe = CubeProbe(scene, [0.0, 1.5, 2.0], 16)
        f, r, c, _x, _y = direction_texels(P[:1] - probe.centre, 16)
        assert probe.object_id[f, r, c].tolist() == [pyshadow.scene.GROUND_ID]      # the probe sees the point
        got[casts] = unseen_rays(scene, probe, P, W, 1.0)
        if not casts:       # the march and Embree disagree on the first ray only: the probe cannot know the box there
            unit = W / np.linalg.norm(W, axis=1, keepdims=True)
            assert raymarch_visible(probe, P, unit, 1.0).tolist() == [True, False, True, True]
            assert pyshadow.embree.visible(scene, P, unit, max_distance=1.0).tolist() == [False, False, True, True]
    assert got[False].tolist() == [True, False, True, False]
    assert np.array_equal(got[False], got[True])


def test_place_on_probes_without_ao():
    """Before: on maps built with ``estimator=None`` (probes only, for CubeMapVisibility) ``place`` raised once a
    probe was there ("CubeMapAO.project: built with estimator=None, the probes hold no AO"), though it needs only
    which pixels a probe sees. Now it decides as maps with AO do: at thresholds just above and below the coverage
    (grid 4: 0.75) of a probe 10 to the side, and for a probe at the eye (none added) or 40 away (one added)."""
    from pyshadow.cubemap import coverage_grid

    cam = pyshadow.Camera(PROBE + [0.2, 0.3, 0.5], PROBE + [0.3, -0.8, -1.5], width=16, height=12)
    side = CubeMapAO(wall_scene(), 1.0, resolution=16, estimator="horizon")
    side.add_probe(PROBE + [10.0, 0.0, 0.0])
    pr = side.project(cam, on_empty="fallback")
    cover = coverage_grid(pr.covered, pr.probe == -2, 4)
    assert cover == 0.75
    cases = [(PROBE + [10.0, 0.0, 0.0], t, 4) for t in (cover - 0.01, cover + 0.01)]
    cases += [(PROBE + [0.2, 0.3, 0.5], 0.75, 8), (PROBE + [0.0, 0.0, 40.0], 0.75, 8)]
    got = {}
    for est in (None, "horizon"):
        answers = []
        for centre, threshold, grid in cases:
            maps = CubeMapAO(wall_scene(), 1.0, resolution=16, estimator=est)
            maps.add_probe(centre)
            answers.append(maps.place(cam, threshold=threshold, grid=grid))
        got[est] = answers
    assert got["horizon"] == [False, True, False, True]
    assert got[None] == got["horizon"]

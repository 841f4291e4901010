"""The eye in the plane of a drawn surface: the ground seen edge-on (pyshadow/gbuffer.py ``_edge_on_crossing``,
pyshadow/embree.py ``gbuffer``).

Each test whose docstring starts "Was:" failed on the code before the fix and says what happened; the others pin
what the fix leaves alone.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree


@pytest.fixture(scope="module")
def items():
    """The drawn items of a unit box resting on the ground plane y = 0 (the default ground quad)."""
    s = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    s.add(trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix([0, 0.5, 0]))
    return s.draw_items()[0]


@pytest.mark.parametrize("target_y", [-0.3, 0.1, 1.0])
def test_an_eye_in_the_ground_plane_renders_the_body_alone(items, target_y):
    """Was: with the eye in the ground plane and the view tilted, render_gbuffer refused ("face 0 of item 1 reaches into
    the view nearer than the near plane ... a smaller ground_size"): the rounding of the edge-on quad's area on screen
    decided (looking level it rendered). Now the ground, seen edge-on, covers no pixel and the box's pixels are
    Embree's."""
    cam = pyshadow.Camera([2.0, 0.0, 2.0], [0.0, target_y, 0.0], width=48, height=36)
    g = pyshadow.render_gbuffer(items, cam)
    assert (g["object_id"] == 1).sum() == 0 and (g["object_id"] == 0).sum() > 50
    np.testing.assert_array_equal(g["object_id"], embree.gbuffer(items, cam)["object_id"])


def test_embree_traces_past_a_plane_through_the_eye(items):
    """Was: embree.gbuffer met the ground quad through the eye at depth 0 on every pixel (object 1 everywhere), and
    embree.render then failed on its own G-buffer's depths. Now the ground covers no pixel there."""
    cam = pyshadow.Camera([2.0, 0.0, 2.0], [0.0, 0.0, 0.0], width=16, height=12)
    e = embree.gbuffer(items, cam)
    assert (e["object_id"] == 1).sum() == 0 and (e["object_id"] == 0).sum() > 5
    assert np.isfinite(e["depth"][e["object_id"] == 0]).all() and (e["depth"][e["object_id"] == 0] > 1.0).all()


def test_an_eye_just_above_the_ground_sees_it(items):
    """What the fix leaves alone: 1 mm above the plane the ground is no longer edge-on: the lower half of the view sees
    it, on both rasterisers alike."""
    cam = pyshadow.Camera([2.0, 1e-3, 2.0], [0.0, 0.0, 0.0], width=48, height=36)
    g = pyshadow.render_gbuffer(items, cam)
    assert (g["object_id"] == 1).sum() > 300
    np.testing.assert_array_equal(g["object_id"], embree.gbuffer(items, cam)["object_id"])

"""Embree's AO of float64 points far from the origin (pyshadow.embree, pyshadow._embree_lift.surface_epsilon).

A point float32 holds exactly is lifted at least 4 float32 spacings of its world coordinates, for points that are
float32 samples of a surface (up to 0.87 of a spacing off it). Float64 points on a box placed at whole or half
metres far away are float32-exact by chance: at 1e6 they were lifted 0.25 m, at 1e7 4 m, through the box resting
on them (the corner under the upper box of a stack at 1e7 read AO 1 against the exact 0.219; at 1e6, 4 of 16
vertices read up to 0.047 high). Points given as float64 now keep the lift of points off the float32 grid; points
given as float32 keep the float32 floor (tests/test_bad_input_embree.py). Exact answers: the sample directions
cast from the point itself against the boxes (tests/test_embreelift_contact.py)."""
import numpy as np
import pytest
import trimesh
from test_embreelift_contact import HALF, SAMPLING, STACK, box_scene, vertex_ao

import pyshadow
from pyshadow import embree

SIDE = [((0.0, 0.5, 0.0), HALF), ((1.0, 0.8, 0.3), HALF)]


def _moved(boxes, off):
    return [(tuple(np.asarray(c, float) + off), h) for c, h in boxes]


@pytest.mark.parametrize("off", [1e4, 1e6, 1e7])
@pytest.mark.parametrize("boxes", [STACK, SIDE], ids=["stack", "side"])
def test_float64_box_corners_far_from_the_origin_have_the_exact_ao(boxes, off):
    """The vertices of touching boxes moved by ``off`` along every axis read the exact AO, as at the origin."""
    P, got, exact = vertex_ao(box_scene(_moved(boxes, off)), _moved(boxes, off))
    np.testing.assert_array_equal(got, exact)
    P0, got0, _ = vertex_ao(box_scene(boxes), boxes)
    np.testing.assert_array_equal(got, got0)


def test_float32_points_keep_the_float32_floor_and_float64_ones_the_body_lift():
    """The same far points as float32 and as float64: the float32 ones are lifted 4 spacings of their coordinates
    (their rounding), the float64 ones 2e-5 of their body's radius, and both see open sky from a lone box's top."""
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    scene = pyshadow.Scene(views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(box, trimesh.transformations.translation_matrix([1e6, 1e6, 1e6]))
    P = np.array([[1e6, 1e6 + 0.5, 1e6], [1e6 + 0.25, 1e6 + 0.5, 1e6 - 0.25]])
    N = np.tile([0.0, 1.0, 0.0], (2, 1))
    for p in (P, P.astype(np.float32)):
        assert (embree.ambient_occlusion(scene, p, N, sampling=SAMPLING) == 1.0).all()
        assert embree.visible(scene, p, N).all()
    assert (embree.surface_epsilon(scene, P.astype(np.float32)) == 4.0 * np.spacing(np.float32(1e6))).all()
    assert (embree.surface_epsilon(scene, P, float32_points=False) < 1e-4).all()

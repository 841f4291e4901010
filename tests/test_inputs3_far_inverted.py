"""Guards (no change): translations beyond float32's range, and inside-out closed casters."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree

VIEWS = dict(views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)


def _ground_points(s, t):
    rng = np.random.default_rng(0)
    q = np.c_[rng.uniform(-2, 2, 40), np.full(40, -0.5), rng.uniform(-2, 2, 40)] * s
    q[:, 0] += t
    return q, np.tile([0.0, 1.0, 0.0], (40, 1))


def test_a_body_beyond_float32_from_the_origin_answers_as_at_the_origin():
    """A translation float32 cannot hold (1e39) is not refused: queries are relative to the scene's anchor, and a
    1e33 box at 1e39 answers bit for bit as at the origin (and as Embree); bodies 1e39 apart, whose anchor lies
    beyond float32 from each, are refused by the query (ValueError naming the limit), as README's Limits says."""
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    csm = pyshadow.CoherentShadowMap.build(box, VIEWS["views"], resolution=32, progress=False)
    answers = []
    for t in (0.0, 1e39):
        scene = pyshadow.Scene(ground=-0.5e33, **VIEWS)
        T = np.diag([1e33, 1e33, 1e33, 1.0])
        T[0, 3] = t
        scene.add(csm, T, mesh=box)
        p, n = _ground_points(1e33, t)
        answers.append((scene.ambient_occlusion(p, n), scene.vertex_ao(0)))
        assert np.abs(answers[-1][0] - embree.ambient_occlusion(scene, p, n)).mean() < 0.01
    for a, b in zip(*answers):
        np.testing.assert_array_equal(a, b)
    scene = pyshadow.Scene(**VIEWS)
    far = np.eye(4)
    far[0, 3] = 1e39
    scene.add(csm, np.eye(4), mesh=box)
    scene.add(csm, far, mesh=box)
    with pytest.raises(ValueError, match=r"beyond float32's range .*3\.4e\+38"):
        scene.visible(np.zeros((1, 3)), np.array([[0.0, 1.0, 0.0]]))


def test_an_inside_out_box_shadows_the_ground_as_the_box():
    """An inverted closed mesh (a room, as the project uses it) casts the same ground shadows as the box; its own
    vertices' normals point into it, where Embree and the CSM both answer closed (AO near 0)."""
    answers = []
    for invert in (False, True):
        box = trimesh.creation.box((1.0, 1.0, 1.0))
        if invert:
            box.invert()
        scene = pyshadow.Scene(ground=-0.5, **VIEWS)
        scene.add(box)
        p, n = _ground_points(1.0, 0.0)
        answers.append(scene.ambient_occlusion(p, n))
        if invert:
            pts, nrm = scene.vertex_points(0)
            assert scene.vertex_ao(0).max() <= 0.1
            assert np.asarray(embree.ambient_occlusion(scene, pts, nrm)).max() <= 0.1
    np.testing.assert_array_equal(answers[0], answers[1])

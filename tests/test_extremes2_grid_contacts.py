"""The instance grid's casters set apart (pyshadow.visibility.grid.isolated_casters) and the contact search after
Scene.add (pyshadow.contact_bodies) at the extremes: a stray parked at 1e7 (or 1e6 below) and its duplicate, boxes
of 1e-4 and 1e5, scenes 1e7 from the origin, duplicated bodies. The grid answers as the tree and as every caster
visited, bit for bit; the patches after adds are those of a scene built with the same bodies."""
import numpy as np
import pytest
import trimesh
from test_contact_moves import _digest
from test_instance_bvh import _scene
from test_isolated_casters import answers_three_ways

import pyshadow
from pyshadow.contact_bodies import body_patches
from pyshadow.visibility import csm as csm_backend, grid


@pytest.mark.parametrize("where", [(1e7, 0.3, 0.0), (0.0, -1e6, 0.0)])
def test_a_duplicated_stray_far_away_keeps_answers_bit_identical(monkeypatch, where):
    rng = np.random.default_rng(5)
    s, k = _scene(40, rng)
    spot = pyshadow.data.mesh("spot")
    a = pyshadow.CoherentShadowMap.build(spot, pyshadow.ViewSet.zigzag(8, 16), resolution=32, progress=False)
    T = np.eye(4)
    T[:3, :3] *= 0.4
    T[:3, 3] = where
    s.add(a, np.array([T, T]), mesh=spot)                   # the same body twice, far away
    assert csm_backend.instance_accel(s) == "grid"
    rows = csm_backend._instance_data(s, s.anchor(), "nearest")[0]
    assert grid.isolated_casters(rows["centre"], rows["radius"]).tolist() == [len(rows) - 2, len(rows) - 1]
    got = answers_three_ways(s, rng, k, where, 1200, 41, monkeypatch)
    assert not got[0][::63].all()                           # rays at the stray: it occludes


@pytest.fixture(scope="module")
def box():
    m = trimesh.creation.box((1.0, 1.0, 1.0))
    return m, pyshadow.CoherentShadowMap.build(m, pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)


@pytest.mark.parametrize("k, off", [(1.0, (1e7, 1e7, -1e7)), (1e-4, (0.0, 0.0, 0.0)), (1e-4, (1e6, 0.0, 1e6)),
                                    (1e5, (1e7, 0.0, 0.0))])
def test_patches_after_adds_far_away_and_at_tiny_and_huge_scales_are_those_of_a_scene_built_there(box, k, off):
    """25 x 25 touching boxes, then one on the middle box, one apart, and a duplicate of the first added."""
    def at(p):
        T = np.eye(4)
        T[:3, :3] *= k
        T[:3, 3] = np.asarray(p, float) * k + off
        return T
    K = 25
    T = np.array([at((i % K, 0.5, i // K)) for i in range(K * K)])
    scene = pyshadow.Scene(ground=off[1])
    scene.add(box[1], T, mesh=box[0])
    before = body_patches(scene)
    new = np.array([at((K // 2, 1.5, K // 2)), at((3 * K, 0.5, 0)), at((K // 2, 1.5, K // 2))])
    scene.add(box[1], new, mesh=box[0])
    fresh = pyshadow.Scene(ground=off[1])
    fresh.add(box[1], np.concatenate([T, new]), mesh=box[0])
    got = body_patches(scene)
    assert len(got) > len(before) and _digest(got) == _digest(body_patches(fresh))

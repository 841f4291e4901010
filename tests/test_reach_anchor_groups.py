"""Anchor groups by each point's reach among the casters near it (pyshadow.anchor_reach).

A query point is asked relative to the scene's anchor where that anchor's float32 rounding stays below
both the depth quantum of every caster near it (512 radii) and the rounding its rays already carry to
that caster (their distance to it): one tiny caster no longer splits every query over a scene into
thousands of anchors (one kernel launch each, with the instance tables rebuilt per anchor), while points
near a tiny caster far from the anchor keep anchors of their own. Answers are checked against an exact
float64 slab test of the boxes the scenes are made of.
"""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree
from pyshadow.scene_arrays import ANCHOR_REACH_RADII, anchor_groups, cube_groups

BOX = trimesh.creation.box((1.0, 1.0, 1.0))
S = 16


@pytest.fixture(scope="module")
def csm():
    return pyshadow.CoherentShadowMap.build(BOX, pyshadow.ViewSet.zigzag(8, 16), resolution=32, progress=False)


def _scene(csm, boxes, ground=0.0):
    """A scene of axis-aligned boxes ``[(size, centre)]``."""
    scene = pyshadow.Scene(ground=ground)
    for size, c in boxes:
        T = np.diag([size, size, size, 1.0])
        T[:3, 3] = c
        scene.add(csm, T, mesh=BOX)
    return scene


def _exact_visible(boxes, p, d):
    """Exact float64 answers: True where the ray p + t d (t > 0) enters none of the boxes."""
    lo = np.array([np.subtract(c, s / 2) for s, c in boxes])
    hi = np.array([np.add(c, s / 2) for s, c in boxes])
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        t0, t1 = (lo[None] - p[:, None]) / d[:, None], (hi[None] - p[:, None]) / d[:, None]
        enter, leave = np.nanmax(np.minimum(t0, t1), axis=2), np.nanmin(np.maximum(t0, t1), axis=2)
    return ~((leave > np.maximum(enter, 0.0)) & (leave > 1e-9)).any(axis=1)


def _reach(boxes, p):
    """reach(p) by brute force: min over casters of max(512 r, |c - p| - r) (r: the box's sphere radius)."""
    c = np.array([b[1] for b in boxes], np.float64)
    r = np.array([b[0] for b in boxes]) * np.sqrt(3.0) / 2
    return np.maximum(ANCHOR_REACH_RADII * r, np.linalg.norm(p[:, None] - c[None], axis=2) - r).min(axis=1)


def _grid_with_tiny(tiny=1e-3):
    """10 x 10 unit boxes 6 m apart (a 60 m square) and one ``tiny`` box on the ground between them."""
    xs = (np.arange(10) - 4.5) * 6.0
    return [(1.0, (x, 0.5, z)) for x in xs for z in xs] + [(tiny, (3.0, tiny / 2, 3.0))]


def _ground_rays(p, seed=0):
    n = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    d = pyshadow.sample_directions(n, sampling=pyshadow.Sampling(S, seed=seed)).reshape(-1, 3).astype(np.float64)
    return np.repeat(p, S, axis=0), d, n


def test_one_tiny_caster_does_not_split_a_query_over_the_scene(csm):
    """Was: one 1 mm box among 100 unit boxes over 60 m split the queries of 20,000 ground points spread
    over the scene into 16,947 anchor groups (every point beyond 512 radii of the 1 mm box, 0.44 m, from
    the scene's anchor; cubes of 0.25 m), each a kernel launch with the instance tables rebuilt: AO of
    500 points took 2.6 s against 0.011 s without the box (4,000 bodies). Now 71 groups; every point
    within its own reach of its anchor."""
    boxes = _grid_with_tiny()
    scene = _scene(csm, boxes)
    rng = np.random.default_rng(1)
    p = np.column_stack([rng.uniform(-30, 30, 20000), np.zeros(20000), rng.uniform(-30, 30, 20000)])
    groups = anchor_groups(scene, p)
    assert len(groups) <= 100
    reach = _reach(boxes, p)
    seen = np.zeros(len(p), int)
    for rows, a in groups:
        rows = np.arange(len(p)) if rows is None else rows
        seen[rows] += 1
        assert (np.abs(p[rows] - a).max(axis=1) <= reach[rows]).all()
    assert (seen == 1).all()
    # the scene's own anchor keeps most points (those nearer to the 1 mm box than to the anchor leave it)
    assert np.array_equal(groups[0][1], scene.anchor()) and len(groups[0][0]) > 10000


def test_answers_over_the_scene_agree_with_exact_boxes(csm):
    """Was: the same answers, from 290 anchors for these 290 points (now 19): Embree on the
    identical rays agrees with an exact float64 slab test of the boxes on every ray, and the kernel on all
    but its discretisation's share (0.02 %)."""
    boxes = _grid_with_tiny()
    scene = _scene(csm, boxes)
    rng = np.random.default_rng(2)
    p = np.column_stack([rng.uniform(-30, 30, 300), np.zeros(300), rng.uniform(-30, 30, 300)])
    lo = np.array([np.subtract(c, s / 2) for s, c in boxes])
    hi = np.array([np.add(c, s / 2) for s, c in boxes])
    q = p[:, None, [0, 2]]
    p = p[~((q >= lo[None, :, [0, 2]]) & (q <= hi[None, :, [0, 2]])).all(axis=2).any(axis=1)]     # not under a box
    assert len(anchor_groups(scene, p)) <= 30
    P, D, _ = _ground_rays(p)
    truth = _exact_visible(boxes, P, D)
    assert (~truth).mean() > 0.02                       # the boxes do hide some of these rays
    np.testing.assert_array_equal(embree.visible(scene, P, D), truth)
    sid = np.full(len(P), pyshadow.scene.GROUND_ID, np.int32)
    assert np.mean(scene.visible(P, D, surface_ids=sid) != truth) <= 0.01


@pytest.mark.parametrize("tiny", [1e-3, 1e-2])
def test_points_near_a_tiny_caster_far_from_the_anchor_keep_an_anchor_of_their_own(csm, tiny):
    """Was (a guard: the same before): ground points within 3 radii of a 1 mm (1 cm) box 10 km from the
    scene's other boxes are asked relative to an anchor within 512 of its radii; with the scene's one
    anchor Embree missed 6.7 % of their rays (its float32 lift at 5 km steps over the box) and the
    kernel 3.8 % (1 mm). Embree agrees with the exact boxes on every ray, the kernel on all but 0.2 %."""
    far = np.array([8500.0, tiny / 2, 5300.0])
    boxes = [(1.0, (x, 0.5, z)) for x in (-1.5, 0.0, 1.5) for z in (-1.5, 0.0, 1.5)] + [(tiny, tuple(far))]
    scene = _scene(csm, boxes)
    rng = np.random.default_rng(3)
    r, t = rng.uniform(0.75 * tiny, 3 * tiny, 400), rng.uniform(0, 2 * np.pi, 400)
    p = far * [1, 0, 1] + np.column_stack([r * np.cos(t), np.zeros(400), r * np.sin(t)])
    p = p[(np.abs(p - far).max(axis=1) > tiny / 2)]              # on the ground beside the box, not under it
    radius = tiny * np.sqrt(3.0) / 2
    for rows, a in anchor_groups(scene, p):
        assert rows is not None and (np.abs(p[rows] - a).max(axis=1) <= ANCHOR_REACH_RADII * radius).all()
    P, D, _ = _ground_rays(p)
    truth = _exact_visible(boxes, P, D)
    assert (~truth).mean() > 0.03
    np.testing.assert_array_equal(embree.visible(scene, P, D), truth)
    sid = np.full(len(P), pyshadow.scene.GROUND_ID, np.int32)
    assert np.mean(scene.visible(P, D, surface_ids=sid) != truth) <= 0.002


def test_points_within_the_smallest_reach_keep_one_group_unchanged(csm):
    """Was (a guard): points within 512 radii of the smallest caster from the anchor are one group at the
    scene's anchor, decided by the bound on their coordinates alone (no caster is asked)."""
    scene = _scene(csm, _grid_with_tiny())
    rng = np.random.default_rng(4)
    p = scene.anchor() + rng.uniform(-0.25, 0.25, (500, 3))
    assert [(r, tuple(a)) for r, a in anchor_groups(scene, p)] == [(None, tuple(scene.anchor()))]

    def refuse():
        raise AssertionError("the casters were asked")

    got = cube_groups(p, scene.anchor(), 1.0, None, refuse)
    assert len(got) == 1 and got[0][0] is None


def test_error_model_truth_groups_as_embree(csm, monkeypatch):
    """Was: ``csm.error_model.truth_visible`` grouped by 512 radii of the smallest body alone (here 203
    groups for 229 points, each an Embree scene of every body; now 24); it groups by each point's reach as
    pyshadow.embree does, and its answers are ``embree.visible``'s."""
    from pyshadow.csm.error_model import Body, Layout, truth_visible

    boxes = _grid_with_tiny()
    scene = _scene(csm, boxes)
    bodies = [Body(i.mesh, i.transform, Layout(i.csm.views, i.csm.resolution, i.csm.depth_bits, i.csm.centre,
                                               i.csm.radius, i.csm.box)) for i in scene.instances]
    rng = np.random.default_rng(5)
    p = np.column_stack([rng.uniform(-30, 30, 200), np.zeros(200), rng.uniform(-30, 30, 200)])
    p = np.concatenate([p, [3.0, 0.0, 3.0] + rng.uniform(-0.004, 0.004, (40, 3)) * [1, 0, 1]])
    p = p[np.abs(p - [3.0, 0.0, 3.0]).max(axis=1) > 6e-4]
    P, D, _ = _ground_rays(p)
    want = embree.visible(scene, P, D)
    made = []
    monkeypatch.setattr(embree, "EmbreeScene", lambda *a, _make=embree.EmbreeScene: made.append(1) or _make(*a))
    np.testing.assert_array_equal(truth_visible(bodies, P, D, ground=0.0), want)
    assert len(made) == len(anchor_groups(scene, P)) <= 40

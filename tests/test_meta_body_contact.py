"""Bodies resting on bodies: the face under a closed body is closed in, as the ground under one is
(pyshadow/contact.py, ``_body_patches``).

Metamorphic against Embree on the same rays: a box resting on a larger box, the stack turned about
the vertical, moved 1e4 along the ground and scaled to millimetres, must read what Embree reads (AO
exactly 0 on the lower box's top under the upper box), while the points that are not closed in (the
upper box lifted 1 mm, its own sides just above the contact, the lower box's top beside it) keep the
CSM's answer.
"""
import numpy as np
import pytest
import trimesh
from trimesh.transformations import rotation_matrix, scale_matrix, translation_matrix

import pyshadow
from pyshadow import embree

VIEWS = pyshadow.ViewSet.zigzag(16, 32)
RES = 64
UPPER = (0.3, 1.5, 0.2)         # the unit box's centre on the 2 x 1 x 2 box resting on the ground


def _stack(M=None, lift=0.0):
    """The 2 x 1 x 2 box on the ground and a unit box resting on it (``lift`` above it), under ``M``."""
    M = np.eye(4) if M is None else M
    scene = pyshadow.Scene(ground=float(M[1, 3]), views=VIEWS, resolution=RES)
    scene.add(trimesh.creation.box((2.0, 1.0, 2.0)), M @ translation_matrix([0.0, 0.5, 0.0]))
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), M @ translation_matrix(np.add(UPPER, [0.0, lift, 0.0])))
    return scene


def _under_upper(n, seed, edge=0.02):
    """``n`` points of the lower box's top under the upper box, half of them within ``edge`` of the upper
    box's outline (but farther than 1e-4, ten times the contact's tolerance), and the up normals."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-0.5 + 1e-4, 0.5 - 1e-4, (n, 2))
    k = rng.integers(0, 2, n // 2)
    rows = np.arange(n // 2)
    q[rows, k] = np.sign(q[rows, k]) * (0.5 - rng.uniform(1e-4, edge, n // 2))
    p = np.column_stack([q[:, 0] + UPPER[0], np.ones(n), q[:, 1] + UPPER[2]])
    return p, np.tile([0.0, 1.0, 0.0], (n, 1))


@pytest.mark.parametrize("backend", ["csm", "csm-vote", "numpy"])
def test_the_top_under_a_resting_box_is_closed_in(backend):
    """Was: AO up to 0.56 (mean 0.29) within 5 mm of the upper box's edge, 0.08-0.12 from 5 to 20 mm, on
    the lower box's top, all three backends (Embree: 0 everywhere); the ground under a resting body was
    closed in, a body under one was not."""
    scene = _stack()
    p, up = _under_upper(240 if backend == "numpy" else 1000, 1)
    s = pyshadow.Sampling(32)
    assert embree.ambient_occlusion(scene, p, up, sampling=s).max() == 0.0
    ao, bent = pyshadow.visibility.ambient_occlusion(scene, p, up, sampling=s, surface_ids=0, backend=backend,
                                                     return_bent_normals=True)
    assert ao.max() == 0.0
    np.testing.assert_allclose(bent, up, atol=1e-6)         # no open sample: the normal


def test_rays_into_the_upper_box_from_the_contact_are_occluded():
    """Was: 28.8 % (vote: 25.7 %, with normals: 15.2 %) of the upward rays from points within 2 cm of the
    upper box's edge read visible, Embree none."""
    scene = _stack()
    p, _ = _under_upper(2000, 2)
    d = np.random.default_rng(3).normal(size=(2000, 3))
    d[:, 1] = np.abs(d[:, 1]) + 1e-3
    assert not embree.visible(scene, p, d).any()
    for backend in ("csm", "csm-vote"):
        assert not pyshadow.visibility.visible(scene, p, d, backend=backend).any(), backend
    # with the surface's normal (the rule that reads it)
    assert not scene.visible(p, d, normals=np.tile([0.0, 1.0, 0.0], (2000, 1))).any()


@pytest.mark.parametrize("motion", ["turned", "far 1e4", "millimetres", "turned, far, metres x 1000"])
def test_a_moved_or_scaled_stack_answers_the_same(motion):
    """Was: the same leak in every pose and scale (AO up to 0.47-0.63, 59-61 % of the points above 0);
    Embree reads 0 in all."""
    M = {"turned": rotation_matrix(0.7, [0, 1, 0]),
         "far 1e4": translation_matrix([1e4, 0.0, -3e3]),
         "millimetres": scale_matrix(1e-3),
         "turned, far, metres x 1000": translation_matrix([2e4, 5.0, 1e4]) @ scale_matrix(1e3)
         @ rotation_matrix(-1.2, [0, 1, 0])}[motion]
    scene = _stack(M)
    p, up = _under_upper(600, 4)
    p = p @ M[:3, :3].T + M[:3, 3]
    up = up @ M[:3, :3].T
    up /= np.linalg.norm(up, axis=1, keepdims=True)
    s = pyshadow.Sampling(32)
    assert embree.ambient_occlusion(scene, p, up, sampling=s).max() == 0.0
    assert scene.ambient_occlusion(p, up, sampling=s).max() == 0.0
    # float32 points (spacing 1e-3 at 1e4) round a few of them out of the footprint: Embree's too
    p32 = p.astype(np.float32)
    e = embree.ambient_occlusion(scene, p32, up, sampling=s)
    assert (e == 0).mean() > 0.99 and scene.ambient_occlusion(p32, up, sampling=s)[e == 0].max() == 0.0


def test_what_is_not_closed_in_keeps_the_csms_answer():
    """Was: the same (a guard). The upper box lifted 1 mm (the CSM's alone: it lets through rays a 1 mm
    gap would not, as under a body lifted off the ground), its own sides just above the contact, the lower
    box's top beside it and the upper box's own top: no contact rule (the last three within 0.03 of
    Embree)."""
    s = pyshadow.Sampling(32)
    lifted = _stack(lift=1e-3)
    p, up = _under_upper(600, 5)
    assert lifted.ambient_occlusion(p, up, sampling=s).max() > 0.0
    assert embree.ambient_occlusion(lifted, p, up, sampling=s).max() > 0.0
    scene = _stack()
    rng = np.random.default_rng(6)
    side = np.column_stack([np.full(300, UPPER[0] + 0.5), 1.0 + rng.uniform(0.0, 8e-6, 300),
                            UPPER[2] + rng.uniform(-0.45, 0.45, 300)])
    beside = np.column_stack([rng.uniform(0.85, 0.99, 300), np.ones(300), rng.uniform(-0.9, 0.9, 300)])
    top = np.column_stack([UPPER[0] + rng.uniform(-0.45, 0.45, 300), np.full(300, 2.0),
                           UPPER[2] + rng.uniform(-0.45, 0.45, 300)])
    for pts, n, sid in ((side, [1.0, 0.0, 0.0], 1), (beside, [0.0, 1.0, 0.0], 0), (top, [0.0, 1.0, 0.0], 1)):
        nn = np.tile(n, (300, 1))
        a = scene.ambient_occlusion(pts, nn, sampling=s, surface_ids=sid)
        e = embree.ambient_occlusion(scene, pts, nn, sampling=s)
        assert a.mean() > 0.3 and abs(float(a.mean()) - float(e.mean())) < 0.03
    # the upper box's own bottom, facing down into the lower box: closed in by the lower one's patch
    assert scene.ambient_occlusion(p, -up, sampling=s, surface_ids=1).max() == 0.0


def test_an_inside_out_box_on_a_box_and_a_box_with_a_cavity():
    """Was: an upper box wound inwards, and one with a cavity (a box inside it, wound either way), leaked as
    one wound outwards (AO up to 0.56 at the edge). Now closed in the same: each closed part's winding is
    turned by its volume's sign (a ray into a part meets it again, into a cavity's wall too)."""
    s = pyshadow.Sampling(32)
    p, up = _under_upper(600, 7)
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    inner = trimesh.Trimesh(box.vertices * 0.5, box.faces, process=False)
    for upper in (trimesh.Trimesh(box.vertices, box.faces[:, ::-1], process=False),
                  trimesh.util.concatenate([box, inner]),
                  trimesh.util.concatenate([box, trimesh.Trimesh(inner.vertices, inner.faces[:, ::-1])])):
        scene = pyshadow.Scene(ground=0.0, views=VIEWS, resolution=RES)
        scene.add(trimesh.creation.box((2.0, 1.0, 2.0)), translation_matrix([0.0, 0.5, 0.0]))
        scene.add(upper, translation_matrix(UPPER))
        assert embree.ambient_occlusion(scene, p, up, sampling=s).max() == 0.0
        assert scene.ambient_occlusion(p, up, sampling=s).max() == 0.0


def test_a_box_resting_on_a_receiving_slab_closes_it_in():
    """Was: AO up to 0.53 (mean 0.09) on a receiver-only slab (a table top, no ground plane) under a
    caster box resting on it, within 2 cm of the box's edge, Embree 0. A receiver resting on a caster
    closes nothing in (it casts no shadow): its contact face keeps the CSM's answer."""
    s = pyshadow.Sampling(32)
    p, up = _under_upper(600, 8)
    for slab_casts in (False, True):
        scene = pyshadow.Scene(ground=None, views=VIEWS, resolution=RES)
        scene.add(trimesh.creation.box((4.0, 0.2, 4.0)), translation_matrix([0.0, 0.9, 0.0]), casts=slab_casts)
        scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), translation_matrix(UPPER))
        assert embree.ambient_occlusion(scene, p, up, sampling=s).max() == 0.0
        assert scene.ambient_occlusion(p, up, sampling=s, surface_ids=0).max() == 0.0
    scene = pyshadow.Scene(ground=None, views=VIEWS, resolution=RES)
    scene.add(trimesh.creation.box((4.0, 0.2, 4.0)), translation_matrix([0.0, 0.9, 0.0]))
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), translation_matrix(UPPER), casts=False)
    assert scene.ambient_occlusion(p, up, sampling=s, surface_ids=0).min() == 1.0      # nothing casts above

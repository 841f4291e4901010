"""Embree's ray lift follows the body a ray leaves, not the scene's largest instance
(pyshadow._embree_lift.body_size)."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import Sampling, visibility
from pyshadow._embree_lift import body_size, surface_epsilon
from pyshadow.scene import GROUND_ID

SMALL = 0.01        # a 1 cm box on the ground at the origin
BIG = 1000.0        # a 1 km box 10 km away


def scene_with(big: bool):
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    box = trimesh.creation.box((SMALL, SMALL, SMALL))
    box.apply_translation([0.0, SMALL / 2, 0.0])
    scene.add(box)
    if big:
        far = trimesh.creation.box((BIG, BIG, BIG))
        far.apply_translation([1e4, BIG / 2, 0.0])
        scene.add(far)
    return scene


def ground_ring(n=1500, seed=0):
    g = np.random.default_rng(seed).uniform(-2 * SMALL, 2 * SMALL, (n, 2))
    g = g[(np.abs(g) > 0.52 * SMALL).any(axis=1)]
    return np.column_stack([g[:, 0], np.zeros(len(g)), g[:, 1]])


def test_a_small_caster_beside_a_huge_one_still_shadows_on_embree():
    """Was: every ray was lifted 2e-5 of the scene's largest radius (866 m: 1.7 cm), more than the 1 cm
    box is wide, so Embree's AO of the ground around it was 0.9998 with the 1 km box 10 km away
    against 0.913 without it. The far box cannot meet these rays (they start 10 km from it, and it
    subtends under 0.1 sr from there), so the answers must be those of the scene without it."""
    P = ground_ring()
    N = np.tile([0.0, 1.0, 0.0], (len(P), 1))
    ids = np.full(len(P), GROUND_ID, np.int32)
    s = Sampling(64)
    alone = visibility.ambient_occlusion(scene_with(False), P, N, backend="embree", sampling=s, surface_ids=ids)
    both = visibility.ambient_occlusion(scene_with(True), P, N, backend="embree", sampling=s, surface_ids=ids)
    assert alone.mean() < 0.95                         # the box occludes about a tenth of the sky here
    # the two scenes' rays are relative to other anchors, so float32 rounds them otherwise: rays grazing
    # the box's base on the ground may go either way (22 samples of 89,216 here); at most 0.1 % of them
    # and one sample a point (before: about 8.7 % of the samples)
    assert np.abs(both - alone).max() <= 1.0 / 64 + 1e-6
    assert np.abs(both - alone).sum() * 64 <= 1e-3 * len(P) * 64


def test_body_size_is_the_holding_or_nearest_casters_radius():
    scene = scene_with(True)
    r_small = SMALL * np.sqrt(3) / 2
    r_big = BIG * np.sqrt(3) / 2
    P = np.array([[0.0, SMALL, 0.0],            # on the small box's lid
                  [0.5, 0.0, 0.0],              # on the ground, nearer the small box's sphere
                  [1e4, BIG, 0.0],              # on the big box's lid
                  [9000.0, 0.0, 0.0]])          # on the ground, nearer the big box's sphere
    np.testing.assert_allclose(body_size(scene, P), [r_small, r_small, r_big, r_big], rtol=1e-6)
    eps = surface_epsilon(scene, P[:2], anchor=np.zeros(3))
    assert (eps < 0.01 * SMALL).all()             # well inside the small box's size


@pytest.mark.parametrize("receiver", [False, True])
def test_one_radius_everywhere_keeps_the_scene_scale(receiver):
    """Instances of one mesh (and a scene whose every instance has one radius) keep the scene's scale:
    their lift did not change."""
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    for x in (0.0, 3.0, 6.0):
        T = np.eye(4)
        T[0, 3] = x
        scene.add(box, transform=T, casts=not (receiver and x == 6.0))
    P = np.array([[0.0, 0.5, 0.0], [100.0, 0.0, 0.0]])
    np.testing.assert_array_equal(body_size(scene, P), [scene.scale()] * 2)



def test_the_threaded_tracer_lifts_as_ambient_occlusion_does():
    """EmbreeTracer (pyshadow-bench's Embree rays) equals embree.ambient_occlusion bit for bit, as its
    docstring says, in a scene of casters of other sizes and a larger receiver: both lift each point by
    its own body's size (the tracer lifted every point by the scene's largest)."""
    from pyshadow.embree import EmbreeTracer
    from pyshadow.sampling import sample_directions

    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    box.apply_translation([0.0, 0.5, 0.0])
    scene.add(box)
    ball = trimesh.creation.icosphere(2, 0.3)
    ball.apply_translation([1.2, 0.3, 0.4])
    scene.add(ball)
    wall = trimesh.creation.box((8.0, 4.0, 0.1))
    wall.apply_translation([0.0, 2.0, -2.0])
    scene.add(wall, casts=False)                   # a receiver larger than every caster
    rng = np.random.default_rng(5)
    P = np.column_stack([rng.uniform(-1.5, 2.5, 800), np.zeros(800), rng.uniform(-1.5, 1.5, 800)])
    P = P[(np.abs(P[:, 0]) > 0.5) | (np.abs(P[:, 2]) > 0.5)]
    N = np.tile([0.0, 1.0, 0.0], (len(P), 1))
    s = Sampling(16)
    want = visibility.ambient_occlusion(scene, P, N, backend="embree", sampling=s)
    d = sample_directions(N, sampling=s, indices=np.arange(len(P))).reshape(-1, 3).astype(np.float32)
    with EmbreeTracer(scene, 1) as tracer:
        ground, todo, o, w = tracer.prepare(P, N, d, 16)
        occ = ground.copy()
        occ[todo] = tracer.occluded(o, w)
    ao = (~occ.reshape(len(P), 16)).mean(axis=1).astype(np.float32)
    np.testing.assert_array_equal(ao, want)
    assert want.min() < 0.5 and want.max() == 1.0      # the box and the ball shadow some of these points


def test_error_model_truth_lifts_each_ray_by_its_own_body():
    """Was: ``csm.error_model.truth_visible`` lifted every ray by 2e-5 of the largest body's radius, so
    that beside the 1 km box 10 km away the ground's rays around the 1 cm box stepped over it. Its answers
    must be ``pyshadow.embree.visible``'s, and the far box must not change them."""
    from pyshadow.csm.error_model import Body, Layout, truth_visible

    def bodies(scene):
        return [Body(i.mesh, i.transform, Layout(i.csm.views, i.csm.resolution, i.csm.depth_bits, i.csm.centre,
                                                 i.csm.radius, i.csm.box)) for i in scene.instances]

    P = np.repeat(ground_ring(600), 16, axis=0)
    d = np.random.default_rng(1).normal(size=P.shape)
    d[:, 1] = np.abs(d[:, 1])
    # above 10 degrees: the far box (up to 6 degrees high from here) cannot meet the rays
    keep = d[:, 1] > np.sin(np.radians(10.0)) * np.linalg.norm(d, axis=1)
    P, d = P[keep], d[keep]
    both, alone = scene_with(True), scene_with(False)
    truth = truth_visible(bodies(both), P, d, ground=0.0)
    assert (~truth).mean() > 0.05                       # the small box does occlude these rays
    np.testing.assert_array_equal(truth, pyshadow.embree.visible(both, P, d))
    # other anchors round the rays otherwise: rays grazing the box's edges may go either way
    assert (truth != truth_visible(bodies(alone), P, d, ground=0.0)).sum() <= 1e-3 * len(P)


def test_error_model_truth_is_embree_visible_on_rays_grazing_their_surface():
    """``truth_visible`` traces ``embree.visible``'s rays: rays 0.01 degrees above a plate turned 45 degrees,
    whose lift along themselves leaves them within float32's rounding of it, are traced again off its
    plane there too. Was: 12,193 of 20,000 of them hidden by the plate in the error model's truth, none
    in Embree's answer."""
    from pyshadow.csm.error_model import Body, Layout, truth_visible

    plate = trimesh.creation.box((1.0, 0.003, 1.0))
    csm = pyshadow.CoherentShadowMap.build(plate, pyshadow.ViewSet.zigzag(2, 4), resolution=8, progress=False)
    a, b = np.radians(45.0), np.radians(15.0)
    rz = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(b), -np.sin(b)], [0.0, np.sin(b), np.cos(b)]])
    T = np.eye(4)
    T[:3, :3] = np.round(rz @ rx, 10)
    scene = pyshadow.Scene()
    scene.add(csm, T, mesh=plate)
    R = scene.transform(0)[:3, :3]
    rng = np.random.default_rng(3)
    n = 20000
    p = np.column_stack([rng.uniform(-0.45, 0.45, n), np.full(n, 0.0015), rng.uniform(-0.45, 0.45, n)])
    e, az = np.radians(0.01), rng.uniform(0.0, 2.0 * np.pi, n)
    d = np.column_stack([np.cos(e) * np.cos(az), np.full(n, np.sin(e)), np.cos(e) * np.sin(az)])
    body = [Body(plate, scene.transform(0), Layout(csm.views, csm.resolution, csm.depth_bits, csm.centre,
                                                   csm.radius, csm.box))]
    truth = truth_visible(body, p @ R.T, d @ R.T)
    assert truth.all()
    np.testing.assert_array_equal(truth, pyshadow.embree.visible(scene, p @ R.T, d @ R.T))

"""pyshadow.embree against answers known without it, third pass: ambient occlusion at the foot of a wall
(closed forms: half the cosine-weighted hemisphere beside a wall, three quarters at a box's outer corner),
at several scales and places, turned, distance-limited, and by the threaded tracer."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree

S = 64


def box_scene(scale, offset, R=np.eye(3)):
    """A cube of side ``scale`` standing on the ground y = 0 at ``offset`` (x, z), turned by ``R`` about y."""
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R * scale, [offset[0], 0.5 * scale, offset[1]]
    scene.add(box, T)
    return scene


def foot_points(scale, offset, R=np.eye(3)):
    """Ground points on the foot of the cube's four sides (0.5 exactly beside a wall) and at its four corners
    (0.75); returns (points, expected AO, their (x, z) in the cube's frame, side 1)."""
    g = np.array([-0.5, -0.25, 0.0, 0.375, 0.5])
    loc = np.array([(x, z) for x in g for z in g if abs(x) == 0.5 or abs(z) == 0.5])
    corner = (np.abs(loc) == 0.5).all(axis=1)
    p = np.column_stack([loc[:, 0], np.zeros(len(loc)), loc[:, 1]]) * scale
    p = p @ R.T + [offset[0], 0.0, offset[1]]
    return p, np.where(corner, 0.75, 0.5), loc


def into_the_cube(loc, d):
    """(N, S) whether each direction ``d`` (N, S, 3, cube frame) from the foot point ``loc`` (N, 2) enters the
    cube: upwards, and into every side whose plane holds the point."""
    on = np.abs(loc) == 0.5
    inward = np.sign(loc)[:, None, :] * d[..., [0, 2]] < 0.0
    return (d[..., 1] > 0.0) & (inward | ~on[:, None, :]).all(axis=2)


def turned_about_y(deg):
    a = np.radians(deg)
    return np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]])


@pytest.mark.parametrize("scale, offset", [(1.0, (0.0, 0.0)), (1e-3, (1e3, -2.0)), (1e3, (1e5, 0.0)),
                                           (0.37, (-1e6, 3e5))])
def test_ambient_occlusion_at_the_foot_of_a_wall_is_the_closed_form(scale, offset):
    """Was: the AO ray origin, lifted off the ground along its normal, stayed in the plane of the wall, and
    Embree met the wall at t = 0 along every direction: AO 0 at each of these 16 ground points at the foot
    of a cube (the 12 beside a side: 0.5, half of the cosine-weighted hemisphere lies behind the wall's
    plane; the 4 at the corners: 0.75), at every scale and place (16 of 16 in each case); also with distance
    AO. (EmbreeTracer, the timed Embree path, still reads them hidden: its docstring.) Each sample
    direction's answer is the closed form's (the wall hides exactly the directions into it): the AO of the
    sampled directions."""
    scene = box_scene(scale, offset)
    p, want, loc = foot_points(scale, offset)
    n = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    sampling = pyshadow.Sampling(S)
    d = pyshadow.sample_directions(n, sampling=sampling).astype(np.float64)
    into = into_the_cube(loc, d)        # the closed form on these very directions
    exact = pyshadow.sampling.ao_from_samples(d, ~into, n, False)
    np.testing.assert_allclose(exact.mean(), want.mean(), atol=0.03)    # 64 directions estimate 0.5, 0.75
    np.testing.assert_array_equal(embree.ambient_occlusion(scene, p, n, sampling=sampling), exact)
    far = embree.ambient_occlusion(scene, p, n, sampling=sampling, max_distance=10.0 * scale)
    np.testing.assert_array_equal(far, exact)


@pytest.mark.parametrize("scale, offset", [(1.0, (0.0, 0.0)), (1e-3, (1e3, -2.0)), (0.37, (-1e6, 3e5))])
def test_ambient_occlusion_at_the_foot_of_a_turned_wall_is_the_closed_form(scale, offset):
    """Was: the same with the cube turned by 30 degrees about y (its foot points computed in float64, so on
    the walls' planes only to rounding): AO 0 at 16 of these 16 points at unit size, 11 at the 1 mm cube
    1 km away, 10 at 0.37 m 1e6 m away. Each direction's answer is the closed form's in the cube's frame."""
    R = turned_about_y(30.0)
    p, _, loc = foot_points(scale, offset, R)
    n = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    sampling = pyshadow.Sampling(S)
    ao = embree.ambient_occlusion(box_scene(scale, offset, R), p, n, sampling=sampling)
    d = pyshadow.sample_directions(n, sampling=sampling).astype(np.float64) @ R    # the cube's frame
    exact = pyshadow.sampling.ao_from_samples(d, ~into_the_cube(loc, d), n, False)
    np.testing.assert_array_equal(ao, exact)


def test_ambient_occlusion_at_the_foot_of_a_cube_on_a_plate_is_the_closed_form():
    """Was: the same on a caster plate (no ground plane) under the cube: AO 0 at 16 of these 16 points.
    The plate's top extends on both sides of each wall: each ray is answered as beside a solid."""
    scene = pyshadow.Scene(ground=None, views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    for size, y in (((4.0, 0.5, 4.0), -0.25), ((1.0, 1.0, 1.0), 0.5)):
        box = trimesh.creation.box(size)
        box.apply_translation([0.0, y, 0.0])
        scene.add(box)
    p, _, loc = foot_points(1.0, (0.0, 0.0))
    n = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    sampling = pyshadow.Sampling(S)
    d = pyshadow.sample_directions(n, sampling=sampling).astype(np.float64)
    exact = pyshadow.sampling.ao_from_samples(d, ~into_the_cube(loc, d), n, False)
    np.testing.assert_array_equal(embree.ambient_occlusion(scene, p, n, sampling=sampling), exact)


@pytest.mark.parametrize("scale, offset, inward",
                         [(1.0, 0.0, False), (1.0, 0.0, True), (1e-3, 1e3, False), (0.37, -1e6, True)])
def test_ambient_occlusion_at_the_foot_of_a_room_s_wall_is_the_closed_form(scale, offset, inward):
    """A room of walls without thickness (a box of side 2 without its lid, faces wound outwards or inwards),
    points on its floor at the foot of a wall (and in its corners): a direction is hidden where it points
    into a wall holding the point, or reaches a wall before the opening at y = 2. Was: AO 0 at all 12
    points (every ray met the wall at t = 0; the closed form is 0.14-0.20), also with distance AO. Moved
    off the wall to the side each ray leaves (right beside a solid), the rays into the wall would leave the
    room: the origin moves to the side the floor lies on."""
    box = trimesh.creation.box((2.0, 2.0, 2.0))
    box.apply_translation([0.0, 1.0, 0.0])
    room = trimesh.Trimesh(box.vertices, box.faces[box.face_normals[:, 1] < 0.5], process=False)
    if inward:
        room.invert()
    T = np.eye(4)
    T[:3, :3] *= scale
    T[:3, 3] = offset
    scene = pyshadow.Scene(ground=None, views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    scene.add(room, T)
    loc = np.array([(-1.0, z) for z in (-0.5, 0.0, 0.375, 0.75)] + [(x, 1.0) for x in (-0.25, 0.5, 0.875)]
                   + [(-1.0, -1.0), (1.0, 1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 0.25)])
    p = np.column_stack([loc[:, 0], np.zeros(len(loc)), loc[:, 1]]) * scale + offset
    n = np.tile([0.0, 1.0, 0.0], (len(p), 1))
    sampling = pyshadow.Sampling(S)
    d = pyshadow.sample_directions(n, sampling=sampling).astype(np.float64)
    on = np.abs(loc) == 1.0
    into = (on[:, None, :] & (np.sign(loc)[:, None, :] * d[..., [0, 2]] > 0.0)).any(axis=2)
    top = loc[:, None, :] + 2.0 / d[..., 1:2] * d[..., [0, 2]]         # where each ray reaches y = 2
    exact = pyshadow.sampling.ao_from_samples(d, ~into & (np.abs(top) < 1.0).all(axis=2), n, False)
    assert 0.1 < exact.mean() < 0.3
    np.testing.assert_array_equal(embree.ambient_occlusion(scene, p, n, sampling=sampling), exact)
    far = embree.ambient_occlusion(scene, p, n, sampling=sampling, max_distance=100.0 * scale,
                                  obscurance=1e-9)        # hidden rays weigh 1e-9 of their distance: 0
    np.testing.assert_allclose(far, exact, atol=1e-6)

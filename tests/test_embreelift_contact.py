"""Embree's AO at points where bodies touch: a point's rays start lifted along its normal, which at the corner
of a box resting on another body points into that body; the origin is moved out of it
(pyshadow._embree_lift.off_crossed_planes). Exact answers: the same sample directions cast from the point
itself against the boxes (float64 slabs), a direction blocked where it enters a box's interior or, down, the
ground or the sheet a box stands on."""
import numpy as np
import trimesh

import pyshadow
from pyshadow import Sampling, embree
from pyshadow._embree_lift import off_crossed_planes, point_surfaces, surface_epsilon
from pyshadow.sampling import ao_from_samples, sample_directions

HALF = np.full(3, 0.5)
SAMPLING = Sampling(64)


def box_scene(boxes, ground=None, sheet=False):
    """A scene of axis-aligned boxes ``[(centre, half sizes)]``, and a casting quad y = 0 (up) with ``sheet``."""
    scene = pyshadow.Scene(ground=ground, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    if sheet:
        scene.add(trimesh.Trimesh([[-3, 0, -3], [3, 0, -3], [3, 0, 3], [-3, 0, 3]], [[0, 2, 1], [0, 3, 2]],
                                  process=False))
    for c, h in boxes:
        T = np.eye(4)
        T[:3, 3] = c
        scene.add(trimesh.creation.box(2.0 * np.asarray(h, float)), T)
    return scene


def exact_hits(p, dirs, boxes, floor):
    """(N, S) first-hit distances of the rays from the points ``p`` along ``dirs`` (N, S, 3): where each
    enters a box's interior, or the plane y = ``floor`` (None: none) going down; inf for none."""
    L = np.full(dirs.shape[:2], np.inf)
    for c, h in boxes:
        lo, hi = np.asarray(c) - h, np.asarray(c) + h
        with np.errstate(divide="ignore", invalid="ignore"):
            t0, t1 = (lo - p[:, None]) / dirs, (hi - p[:, None]) / dirs
        near, far = np.nanmax(np.minimum(t0, t1), axis=2), np.nanmin(np.maximum(t0, t1), axis=2)
        L = np.where(far > np.maximum(near, 0.0) + 1e-12, np.minimum(L, np.maximum(near, 0.0)), L)
    if floor is not None:
        with np.errstate(divide="ignore", invalid="ignore"):
            L = np.minimum(L, np.where(dirs[..., 1] < 0, (p[:, None, 1] - floor) / -dirs[..., 1], np.inf))
    return L


def vertex_ao(scene, boxes, floor=None, max_distance=None):
    """Embree's AO and the exact AO at every vertex of ``scene`` (vertex normals), ``Sampling(64)``."""
    P, N = (np.concatenate(a) for a in zip(*(scene.vertex_points(i) for i in range(len(scene.instances)))))
    got = embree.ambient_occlusion(scene, P, N, sampling=SAMPLING, max_distance=max_distance)
    dirs = sample_directions(N, sampling=SAMPLING).astype(np.float64)
    L = exact_hits(P, dirs, boxes, floor)
    return P, got, ao_from_samples(dirs, np.isinf(L) if max_distance is None else L > max_distance, N, False)


STACK = [((0.0, 0.5, 0.0), HALF), ((0.5, 1.5, 0.5), HALF)]       # one corner on the other's face, each way


def test_a_corner_resting_on_a_face_is_not_lifted_into_the_body_below():
    """Was: the upper box's corner over the lower's face (vertex normal down and out) and the lower's corner
    under the upper's face started their rays inside the other box: AO 0 against 0.2188 and 0.1875."""
    P, got, exact = vertex_ao(box_scene(STACK), STACK)
    np.testing.assert_array_equal(got, exact)
    touching = np.flatnonzero((P[:, 1] == 1.0) & (np.abs(P[:, [0, 2]] - 0.25).max(axis=1) == 0.25))
    assert len(touching) == 2 and (got[touching] > 0.18).all()


def test_distance_ao_at_those_corners_is_exact():
    """Was 0.3906 and 0.375 at the two corners (exact 0.1875, 0.2188): rays down from inside the lower box
    met its far face 1 below, beyond max_distance, and read open."""
    _, got, exact = vertex_ao(box_scene(STACK), STACK, max_distance=0.7)
    np.testing.assert_array_equal(got, exact)


def test_boxes_touching_side_to_side_and_random_stacks():
    """A box against another's side, offset (was AO 0 at two corners), and 48 boxes of random sizes in 16
    stacks on the ground (was AO 0 at 21 of 384 vertices, 0.03-0.22 exact)."""
    side = [((0.0, 0.5, 0.0), HALF), ((1.0, 0.8, 0.3), HALF)]
    _, got, exact = vertex_ao(box_scene(side), side)
    np.testing.assert_array_equal(got, exact)
    rng = np.random.default_rng(3)
    stacks = []
    for x in range(4):
        for z in range(4):
            y = 0.0
            for _ in range(3):
                h = rng.uniform(0.2, 0.5, 3)
                stacks.append(((x * 1.2 + rng.uniform(-0.1, 0.1), y + h[1], z * 1.2 + rng.uniform(-0.1, 0.1)), h))
                y += 2 * h[1]
    _, got, exact = vertex_ao(box_scene(stacks, ground=0.0), stacks, floor=0.0)
    np.testing.assert_array_equal(got, exact)


def test_a_box_standing_on_a_sheet_sees_the_sheet_below_its_corners():
    """A box on a casting quad without thickness: its bottom corners were lifted under the sheet, whence the
    rays down met nothing (AO 0.78-0.81 against 0.19-0.22); the open rays of a moved point are traced again too."""
    boxes = [((0.3, 0.5, 0.2), HALF)]
    P, got, exact = vertex_ao(box_scene(boxes, sheet=True), boxes, floor=0.0)
    bottom = np.flatnonzero(P[:, 1] == 0.0)[4:]     # the box's (the sheet's 4 corners come first; an infinite
    assert len(bottom) == 4                         # floor models the sheet for the rays starting on it)
    np.testing.assert_array_equal(got[bottom], exact[bottom])


def test_bodies_apart_move_no_origin():
    """Away from contacts the rule moves nothing: no point of a box, a concave room corner or a box 1 mm
    above another is reported moved by off_crossed_planes."""
    scene = box_scene([((0.0, 0.5, 0.0), HALF), ((0.3, 1.501, 0.2), HALF)])
    room = trimesh.creation.box((4.0, 3.0, 4.0))
    room.invert()
    scene.add(room)
    P, N = (np.concatenate(a) for a in zip(*(scene.vertex_points(i) for i in range(len(scene.instances)))))
    rays, anchor = embree.caster_scene(scene)
    lift = surface_epsilon(scene, P, anchor)
    dirs = sample_directions(N, sampling=SAMPLING).astype(np.float64).reshape(-1, 3)
    S = SAMPLING.samples
    origins = np.repeat(P - anchor + lift[:, None] * N, S, axis=0)
    moved = []
    t = off_crossed_planes(rays, origins, dirs, (*point_surfaces(scene, P, N, lift), np.arange(len(dirs)) // S),
                           moved)
    assert len(moved) == 1 and len(moved[0]) == 0 and np.isfinite(t).any()

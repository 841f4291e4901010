"""Free space behind a caster's first surface: a ball in a bowl, points in a room (csm.cl's fold, "Free space")."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow import embree
from pyshadow.csm import (both_sided_faces, compress_reference, first_slope, footprint_corners, front_margin,
                          open_sheet)

VIEWS = pyshadow.ViewSet.zigzag(8, 16)
R = 32


def _bowl():
    """The lower part of a unit sphere, wound outwards: an open mesh whose hollow is open to the sky."""
    sp = trimesh.creation.icosphere(3)
    bowl = trimesh.Trimesh(sp.vertices, sp.faces[sp.triangles_center[:, 1] < 0.2], process=False)
    bowl.remove_unreferenced_vertices()
    return bowl


def _room():
    """A closed 2 m cube wound inwards (trimesh's invert): its inside is the free space."""
    return trimesh.creation.box(extents=[2.0, 2.0, 2.0]).invert()


def _build(mesh, **kw):
    return pyshadow.CoherentShadowMap.build(mesh, VIEWS, resolution=R, progress=False, **kw)


def test_ball_in_bowl_agrees_with_embree():
    """Was: a ball resting in a bowl read 0.48 of its AO rays open (Embree 0.16): 36 % of them wrong with the
    one-texel lookup, 33 % with the vote. The bowl's maps stored a depth anywhere between its near wall and
    its far wall, so points in the hollow between them were lit. Now 3.5 % / 2.6 % at these 8 x 16 maps of
    32 texels (the CSM's own error at this size: the bowl's own inner AO disagrees 4 %)."""
    bowl, ball = _bowl(), trimesh.creation.icosphere(2, radius=0.25)
    ball.vertices += [0.3, -0.6, 0.0]
    scene = pyshadow.Scene()
    for m in (bowl, ball):
        scene.add(_build(m), mesh=m)
    rng = np.random.default_rng(0)
    f = rng.choice(len(ball.faces), 200)
    p = np.einsum("ij,ijk->ik", rng.dirichlet([1, 1, 1], 200), ball.triangles[f])
    n = ball.face_normals[f]
    P, N = np.repeat(p + 1e-4 * n, 16, axis=0), np.repeat(n, 16, axis=0)
    D = pyshadow.sample_directions(n, sampling=pyshadow.Sampling(16)).reshape(-1, 3)
    truth = embree.visible(scene, P, D)
    assert 0.1 < truth.mean() < 0.25                # most of the ball's sky is the bowl's wall
    for lookup in ("nearest", "vote"):
        ours = scene.visible(P, D, surface_ids=1, normals=N, lookup=lookup)
        assert np.mean(ours != truth) < 0.06, lookup


def test_points_inside_a_room_are_in_shadow():
    """Was: points inside a closed room (a cube wound inwards; layers='auto' gives it rule 3) read 46 % of
    their rays open with the one-texel lookup and 42 % with the vote, where every ray meets a wall. The wall
    nearest the light is seen from behind: the free space starts at it. Now 5.4 % / 1.7 % (points within the
    slope term, at most 3 texels of depth, behind a wall may read lit)."""
    room = _room()
    csm = _build(room)
    assert csm.layer_rule == 3
    scene = pyshadow.Scene()
    scene.add(csm, mesh=room)
    rng = np.random.default_rng(0)
    P = np.repeat(rng.uniform(-0.9, 0.9, (300, 3)), 16, axis=0)
    D = rng.normal(size=(len(P), 3))
    D /= np.linalg.norm(D, axis=1, keepdims=True)
    assert not embree.visible(scene, P, D).any()
    assert scene.visible(P, D).mean() < 0.08
    assert scene.visible(P, D, lookup="vote").mean() < 0.04


@pytest.mark.parametrize("mesh, kw", [(_bowl, {}), (_bowl, {"footprint": True}), (_bowl, {"two_sided": True}),
                                      (_bowl, {"depth_bits": 32}), (_room, {}), (_room, {"layers": 2})])
def test_build_matches_its_numpy_mirror(mesh, kw):
    """The fold's free-space rule, bit for bit against compress_reference."""
    mesh = mesh()
    csm = _build(mesh, **kw)
    frame = (csm.centre, csm.radius)
    both = both_sided_faces(mesh, frame, csm.layer_rule, kw.get("two_sided", "auto"))
    layers, front = pyshadow.render_depth(mesh, VIEWS, resolution=R, layers=csm.layer_rule, frame=frame,
                                          facing=True, both_sides=both)
    corners = {}
    if kw.get("footprint"):
        cz, cf = footprint_corners(mesh, VIEWS, R, csm.layer_rule, frame, both_sides=both)
        corners = {"corners": cz, "corner_front": cf}
    offsets, iend, depth = compress_reference(layers, front, csm.layer_rule, csm.depth_bits,
                                              two_sided=kw.get("two_sided") is True,
                                              open_air=open_sheet(mesh, both), **corners)
    np.testing.assert_array_equal(offsets, csm.offsets)
    np.testing.assert_array_equal(iend, csm.iend)
    np.testing.assert_array_equal(depth, csm.depth)


def test_first_slope_of_a_plane():
    """first_slope: the depth a tilted plane gains from a texel's centre to its deepest corner; one side of an
    axis lost at a hole; the cap where a neighbour lies far behind."""
    margin = front_margin(64)                      # 3/64: above this plane's slope term
    r, c = np.mgrid[0:8, 0:8].astype(np.float32)
    z1 = (np.float32(0.3) + np.float32(0.002) * c - np.float32(0.001) * r).astype(np.float32)
    np.testing.assert_allclose(first_slope(z1, margin)[1:-1, 1:-1], 0.5 * (0.002 + 0.001), rtol=1e-3)
    z1[4, 4] = np.inf                              # (4, 3) keeps only its shallower left neighbour on x
    np.testing.assert_allclose(first_slope(z1, margin)[4, 3], 0.5 * 0.001, rtol=1e-3)
    z1[2, 2] = np.float32(0.9)                     # a surface far behind (2, 1)'s right: capped
    assert first_slope(z1, margin)[2, 1] == np.float32(margin)


def test_closed_outward_meshes_are_unchanged():
    """A closed mesh wound outwards is never in free space behind z1: the rule must not change its CSM (the
    mirror with every first surface facing the light gives the same arrays)."""
    box = trimesh.creation.box(extents=[1.0, 0.6, 0.4])
    csm = _build(box)
    frame = (csm.centre, csm.radius)
    layers, front = pyshadow.render_depth(box, VIEWS, resolution=R, layers=csm.layer_rule, frame=frame, facing=True)
    lit = front.copy()
    lit[:, 0] = True
    plain = compress_reference(layers, lit, csm.layer_rule, csm.depth_bits)
    np.testing.assert_array_equal(plain[0], csm.offsets)
    np.testing.assert_array_equal(plain[2], csm.depth)

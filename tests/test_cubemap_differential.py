"""Cube-map probes compared with themselves under a rigid motion of the whole scene.

A probe's float32 world positions are rounded by 0.06 world units at 1e6
from the origin (6e-5 at 1e3), far more than its float32 distances from
its own centre: every plane or vector the probe's users take must come from
the distances (:meth:`CubeProbe.texel_offsets`), which are bit for bit the
same wherever the scene lies.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.cubemap import CubeMapAO, CubeProbe, raymarch_visible_reference
from pyshadow.cubemap.device import raymarch_device
from pyshadow.cubemap.estimators import march_defaults

D = 1.0
PROBE = np.array([0.0, 1.0, 2.0])
R = 32


def wall_scene(shift: float, box_lift: float = 0.0):
    """The wall scene of tests/test_cubemap.py (a thick wall, a 0.3 box, ground y = 0), moved by ``shift`` along
    each axis; ``box_lift``: the box raised by that much above the ground."""
    T = np.full(3, shift)
    scene = pyshadow.Scene(ground=shift, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    wall = trimesh.creation.box((40.0, 10.0, 0.5))
    wall.apply_translation(np.array([0.0, 5.0, -0.25]) + T)
    scene.add(wall)
    scene.add(trimesh.creation.box((0.3, 0.3, 0.3)),
              trimesh.transformations.translation_matrix(np.array([0.8, 0.15 + box_lift, 0.7]) + T))
    return scene


@pytest.fixture(scope="module")
def probes():
    """The probe in the scene at the origin and in the scene moved by 1e3, 1e5 and 1e6 (not powers of two)."""
    return {s: CubeProbe(wall_scene(s), PROBE + s, R) for s in (0.0, 1e3, 1e5, 1e6)}


@pytest.fixture(scope="module")
def rays(probes):
    """Rays from 300 of the origin probe's texel points near the wall's foot and the box, 8 each (relative to 0)."""
    idx, pts, nrm = probes[0.0].texel_points()
    keep = np.flatnonzero((pts[:, 1] < 0.8) & (pts[:, 2] < 0.9) & (np.abs(pts[:, 0]) < 1.5))
    sel = np.random.default_rng(0).choice(keep, 300, replace=False)
    dirs = pyshadow.Sampling(8).directions(nrm[sel], indices=idx[sel]).astype(np.float64)
    return np.repeat(pts[sel], 8, axis=0), np.repeat(nrm[sel], 8, axis=0), dirs.reshape(-1, 3)


def test_texel_offsets_are_the_same_under_a_rigid_motion(probes):
    """Depth times the texel's centre direction: the same bits at the origin and 1e6 away. Before: no such
    helper (AttributeError); the probe's users took ``P - c`` from the float32 world positions, whose
    difference from the origin scene's reaches 0.025 in ``n . (P - c)`` at 1e6 (2.4e-5 at 1e3)."""
    ref = probes[0.0].texel_offsets()
    seen = np.isfinite(probes[0.0].depth.reshape(-1))
    assert np.array_equal(np.isnan(ref).any(axis=1), ~seen)
    for s in (1e3, 1e5, 1e6):
        assert np.array_equal(probes[s].texel_offsets(), ref, equal_nan=True)
    # they are the surface points: the wall's front face z = 0 and the ground y = 0, relative to the centre
    P = ref + PROBE
    oid = probes[0.0].object_id.reshape(-1)
    wall = (oid == 0) & (np.abs(probes[0.0].normal.reshape(-1, 3)[:, 2] - 1) < 1e-6)
    np.testing.assert_allclose(P[wall, 2], 0.0, atol=1e-5)
    np.testing.assert_allclose(P[oid == pyshadow.scene.GROUND_ID, 1], 0.0, atol=1e-5)


@pytest.mark.parametrize("shift", [1e5, 1e6])
def test_raymarch_reference_is_invariant_under_a_rigid_motion(probes, rays, shift):
    """Before: each texel's plane ``n . (P - c)`` was taken from the float32 world position (0.06 off at 1e6),
    and the NumPy march answered 2 (1e5) and 20 (1e6) of these 2,400 rays differently from the same
    scene at the origin (0 at 1e3 and 1e4); now every one alike."""
    P, _N, W = rays
    ref = raymarch_visible_reference(probes[0.0], P, W, D)
    got = raymarch_visible_reference(probes[shift], P + shift, W, D)
    assert 0.2 < ref.mean() < 0.9                # both answers, plenty of each
    assert np.array_equal(got, ref)


def test_raymarch_device_is_invariant_under_a_rigid_motion(probes, rays):
    """Before: the kernel's texel planes came from the float32 world positions too: 20 of 2,400 rays differed
    at 1e6 (0 now). The rays' float32 origins relative to the centre could still round differently
    (float64 ``p - c`` of points 1e6 out differs by 1e-10 from the origin's): at most 2 rays allowed."""
    P, _N, W = rays
    opt = march_defaults(D)
    ref = raymarch_device(probes[0.0], P, W, opt)
    got = raymarch_device(probes[1e6], P + 1e6, W, opt)
    assert 0.2 < ref.mean() < 0.9
    assert (got != ref).sum() <= 2


def test_assign_is_invariant_under_a_rigid_motion(rays):
    """Before: the depth test of which probe sees a point read the float32 world position (0.06 off at 1e6,
    against a tolerance of 0.02 r): 22 of the 300 points the probes see at the origin were seen by none
    1e6 away (and the quality of others moved by up to 0.22); now the same probe, the quality within 1e-9."""
    P, N, _W = rays
    P, N = P[::8], N[::8]
    got = {}
    for s in (0.0, 1e6):
        maps = CubeMapAO(wall_scene(s), D, resolution=R, estimator=None)
        maps.add_probe(PROBE + s)
        maps.add_probe(PROBE + s + [0.9, 0.3, -0.5])
        got[s] = maps.assign(P + s, N)
    assert (got[0.0][0] >= 0).all()
    assert np.array_equal(got[1e6][0], got[0.0][0])
    np.testing.assert_allclose(got[1e6][1], got[0.0][1], rtol=1e-9)


@pytest.mark.parametrize("shift", [0.0, 1e7, 3e7])
def test_probe_inside_a_body_is_refused_far_from_the_origin(shift):
    """Before: the inside test took the sign of ``fn . (P - c)`` from the float32 world positions (0.5 off at
    1e7): a probe at the centre of the 0.3 box was accepted at 1e7 and 3e7 (its texels' back-face fraction
    fell below one half) and one inside the wall at 3e7 counted 51 % instead of 99 %; now the same fraction
    as at the origin. The box stands 0.01 above the ground: resting on it, its bottom face lay in the ground's
    plane, and which of the two a downward texel showed was decided by rounding (201 of the 1,024 at the
    origin showed the ground, 97 % back faces in all; 395 at 2e7 and 3e7 on an AMD EPYC, 94 %). Lifted, the
    probe sees back faces only: 100 % here and at the origin."""
    scene = wall_scene(shift, box_lift=0.01)
    with pytest.raises(ValueError, match=r"inside instance 1 \(100% of its texels"):
        CubeProbe(scene, np.array([0.8, 0.15, 0.7]) + shift, R)
    with pytest.raises(ValueError, match=r"inside instance 0 \(99% of its texels"):
        CubeProbe(scene, np.array([0.0, 5.0, -0.25]) + shift, R)
    CubeProbe(scene, np.array([0.8, 0.15, 0.9]) + shift, R)           # 0.05 in front of the box: outside


@pytest.mark.parametrize("shift", [1e3, 1e6])
def test_horizon_estimator_is_invariant_under_a_rigid_motion(probes, shift):
    """Was: the thesis's horizon estimator took its texels' points and the horizon samples from the float32 world
    positions: at R = 64 moved by 1e3, 2,810 of 17,716 texels changed by up to 0.086 (by up to 0.21 at 1e6). Now
    from the depths (texel_offsets): the same bits wherever the scene lies. (At the origin 658 texels moved by up to
    0.061; against Embree's distance-limited AO of the same points, 256 rays each, the mean error stays 0.0207.)"""
    from pyshadow.cubemap import texel_ao

    base = texel_ao(probes[0.0], D, estimator="horizon")
    moved = texel_ao(probes[shift], D, estimator="horizon")
    assert np.isfinite(base).sum() > 3000
    np.testing.assert_array_equal(moved, base)

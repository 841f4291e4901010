"""Screen-space AO (pyshadow.ssao): the kernel against its NumPy reference, input checks, and the
analytic cases of benchmarks/analytic_ao.py on the distance-limited definition (radius = D).

SSAO sees only what the camera sees: a sample point at distance D along a
direction counts as occluded when it lies behind the visible surface. For a
thick occluder seen from the front (the wall) that is the ray being blocked
within D, so SSAO agrees with distance-limited Embree AO on the identical
directions up to its depth bias and nearest-pixel lookup. Where a ray
passes through a thin part (a sample beyond the sphere's far side) or the
occluder's visible face is far in front of the pixel (the range check
under the sphere's overhang), it reads too open: those measured errors are
held to the bounds they meet.
"""
import sys

import numpy as np
import pytest

from conftest import REPO

sys.path.insert(0, str(REPO / "benchmarks"))
import analytic_ao as A  # noqa: E402

import pyshadow  # noqa: E402
from pyshadow import ssao, visibility  # noqa: E402
from pyshadow.render import surface_points  # noqa: E402

W, H = 160, 120


@pytest.fixture(scope="module")
def wall():
    scene = A.wall_scene(maps=16, resolution=32)
    cam = pyshadow.Camera(**A.CAMERAS["wall"], width=W, height=H)
    return scene, cam, surface_points(scene, cam)


@pytest.fixture(scope="module")
def sphere():
    scene, _ = A.sphere_scene(maps=16, resolution=32)
    cam = pyshadow.Camera(**A.CAMERAS["sphere"], width=W, height=H)
    return scene, cam, surface_points(scene, cam)


@pytest.mark.parametrize("samples, range_check", [(16, True), (36, False), (64, True)])
def test_kernel_matches_reference(sphere, wall, samples, range_check):
    """Equal at every pixel except where a sample lies within float32 rounding of a decision
    (margin < 1e-4: a pixel edge or a depth threshold); there by whole samples."""
    for _, cam, sp in (sphere, wall):
        got = ssao.screen_space_ao(sp.gbuffer, cam, 0.9, samples=samples, range_check=range_check, seed=3)
        ref, margin = ssao.screen_space_ao_reference(sp.gbuffer, cam, 0.9, samples=samples,
                                                     range_check=range_check, seed=3, return_margin=True)
        assert got.dtype == np.float32 and got.shape == (H, W)
        diff = got != ref
        assert (margin[diff] < 1e-4).all()
        assert diff.mean() < 2e-3
        k = np.abs(got - ref)[diff] * samples
        assert np.allclose(k, np.round(k), atol=1e-4)
        assert 0.1 < got[np.isfinite(sp.gbuffer["depth"])].min() < 0.9       # something is occluded


def test_background_open_floor_and_options(sphere):
    scene, cam, sp = sphere
    g = sp.gbuffer
    ao = ssao.screen_space_ao(g, cam, 0.5, samples=32)
    assert (ao[~np.isfinite(g["depth"])] == 1.0).all()
    pos = np.asarray(g["position"], np.float64)
    s = np.hypot(pos[..., 0], pos[..., 2])
    far = (sp.object_id == -2) & (s > 1.8)      # beyond D of the sphere
    # open floor beyond D of the sphere: open, but for single samples (measured: 0.2 % of those
    # pixels) behind the sphere's silhouette or, far off at grazing angles, stopped by the floor's own
    # nearest-pixel depth (the bias is in world units, not per pixel)
    assert far.sum() > 1000 and (ao[far] == 1.0).mean() > 0.99 and ao[far].min() >= 1 - 2 / 32
    # no range check counts more occluders, never fewer
    assert (ssao.screen_space_ao(g, cam, 0.5, samples=32, range_check=False) <= ao).all()
    # a larger bias counts fewer
    assert (ssao.screen_space_ao(g, cam, 0.5, samples=32, bias=0.2) >= ao).all()


def test_bad_input_launches_nothing(sphere, no_launch):
    _, cam, sp = sphere
    g = sp.gbuffer
    for bad, what in ((0.0, "radius"), (-1.0, "radius"), (np.inf, "radius"), (np.nan, "radius")):
        with pytest.raises(ValueError, match=what):
            ssao.screen_space_ao(g, cam, bad)
    for kw, what in (({"samples": 0}, "samples"), ({"samples": 5000}, "samples"), ({"samples": 2.0}, "samples"),
                     ({"bias": -0.1}, "bias"), ({"bias": np.nan}, "bias")):
        with pytest.raises(ValueError, match=what):
            ssao.screen_space_ao(g, cam, 0.5, **kw)
    other = pyshadow.Camera(**A.CAMERAS["sphere"], width=W + 1, height=H)
    with pytest.raises(ValueError, match="depth"):
        ssao.screen_space_ao(g, other, 0.5)
    with pytest.raises(ValueError, match="normal"):
        ssao.screen_space_ao({"depth": g["depth"]}, cam, 0.5)
    with pytest.raises(TypeError, match="Camera"):
        ssao.screen_space_ao(g, "camera", 0.5)
    with pytest.raises(TypeError, match="radius"):
        ssao.screen_space_ao(g, cam, "far")
    bad = dict(g, normal=np.zeros_like(g["normal"]))
    with pytest.raises(ValueError, match="non-zero"):
        ssao.screen_space_ao(bad, cam, 0.5)


def patch_values(case, scene, cam, sp, point, D, samples, range_check=True):
    rows, cols = A.patch(cam, sp, point)
    pos = np.asarray(sp.gbuffer["position"], np.float64)[rows, cols]
    if case == "wall":
        truth = np.mean([A.wall_ao(-q[2], D=D) for q in pos])
    else:
        truth = np.mean([A.sphere_ao(np.hypot(q[0], q[2]), A.SPHERE["r"], D=D) for q in pos])
    ao = ssao.screen_space_ao(sp.gbuffer, cam, D, samples=samples, range_check=range_check)[rows, cols]
    emb = visibility.ambient_occlusion(scene, pos, np.tile([0.0, 1.0, 0.0], (len(pos), 1)), backend="embree",
                                       sampling=pyshadow.Sampling(samples), indices=rows * W + cols,
                                       max_distance=D)
    return float(ao.mean()), float(truth), float(emb.mean()), len(pos)


@pytest.mark.parametrize("x", A.WALL["x"])
def test_wall_against_closed_form(wall, x):
    """Thick occluder seen from the front: SSAO within 0.02 of Embree on the identical rays (its
    bias and lookup; measured <= 0.012 at 320x240) and of the closed form (plus 4 sigma)."""
    scene, cam, sp = wall
    S = 128
    got, truth, emb, n = patch_values("wall", scene, cam, sp, (0.0, 0.0, -x), A.WALL["D"], S)
    assert n >= 20
    assert abs(got - emb) <= 0.02
    assert abs(got - truth) <= 0.02 + A.noise_bound(truth, n * S)


def test_sphere_against_closed_form(sphere):
    """Measured screen-space limits on the sphere: where the whole ray stays inside the body SSAO
    agrees (s = 1, 1.5); under the overhang (s = 0.5) the range check drops the sphere's front face
    (reads ~0.4 too open) and, without it, samples past the sphere's far side read ~0.06 too open."""
    scene, cam, sp = sphere
    S, D = 128, A.SPHERE["D"]
    errors = {}
    for s in A.SPHERE["s"]:
        for rc in (True, False):
            got, truth, emb, n = patch_values("sphere", scene, cam, sp, (s, 0.0, 0.0), D, S, rc)
            assert n >= 9 and abs(emb - truth) <= A.noise_bound(truth, n * S) + 0.01
            errors[s, rc] = got - truth
    for s in (1.0, 1.5):
        for rc in (True, False):
            assert abs(errors[s, rc]) <= 0.03 + A.noise_bound(0.5, 9 * S)
    assert 0.2 < errors[0.5, True] < 0.5
    assert 0.0 < errors[0.5, False] < 0.12

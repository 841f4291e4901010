"""Differential checks of the rasteriser and the contact footprints (pyshadow/raster.py, pyshadow/contact.py).

No defect was found by these checks (audit of 2026-12): they hold the agreements measured then.
The kernel's coverage against a float64 brute force with vertices exactly on texel centres and
corners (the top-left rule: shared edges cover each texel once, no cracks); the kernel against
its NumPy reference; the footprint mask against Embree (a ground point under a resting body has
AO exactly 0) and under rigid motions to 1e7 and power-of-two scales.
"""
import numpy as np
import pytest
import pyopencl as cl
import scipy.spatial as sp
import trimesh

import pyshadow
from pyshadow import _cl, contact, embree
from pyshadow.raster import DepthRenderer, render_depth, render_depth_reference

FRAME = (np.zeros(3), 1.0)


def _render(mesh, R, bases, layers=2):
    out = np.empty((len(bases), layers, R, R), np.float32)
    cl.enqueue_copy(_cl.queue(), out, DepthRenderer(mesh, R, layers, frame=FRAME).render(bases))
    return out


def _turns():
    """Bases looking down -z: the four quarter turns about d, and two flipped (u or v reversed)."""
    q = [np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]) for c, s in ((1, 0), (0, 1), (-1, 0), (0, -1))]
    return np.array(q + [np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0])])


@pytest.mark.parametrize("R", [1, 2, 3, 8, 9])
def test_a_flat_triangulation_through_texel_centres_covers_each_texel_once(R):
    """Delaunay triangulations of vertices on texel centres or corners (edges exactly through
    centres): every texel centre strictly inside the hull is covered (no crack), none strictly
    outside, and none twice (layer 2 empty), for 6 orientations of the map."""
    rng = np.random.default_rng(R)
    bases = _turns()
    s = 2 * (np.arange(R) + 0.5) / R - 1
    Y, X = np.meshgrid(s, s, indexing="ij")
    checked = 0
    for trial in range(8):
        c = rng.integers(0, R, (12, 2)) if trial % 2 == 0 else rng.integers(0, R + 1, (12, 2)) - 0.5
        xy = np.unique(0.7 * (2 * (c + 0.5) / R - 1), axis=0)
        if len(xy) < 3 or np.linalg.matrix_rank(xy - xy[0]) < 2:
            continue
        tri = sp.Delaunay(xy)
        mesh = trimesh.Trimesh(np.column_stack([xy, np.zeros(len(xy))]), tri.simplices, process=False)
        d = _render(mesh, R, bases)
        A = sp.ConvexHull(xy).equations
        for k, b in enumerate(bases):
            q = (X[..., None] * b[0] + Y[..., None] * b[1])[..., :2].reshape(-1, 2)
            dist = (q @ A[:, :2].T + A[:, 2]).max(axis=1).reshape(R, R)
            covered = np.isfinite(d[k, 0])
            assert not (covered & (dist > 1e-9)).any() and (covered | (dist >= -1e-9)).all()
            assert not np.isfinite(d[k, 1]).any()
            np.testing.assert_allclose(d[k, 0][covered], 0.5, rtol=0, atol=1.2e-7)   # 2 float32 ulps
            checked += 1
    assert checked >= 6


@pytest.mark.parametrize("R", [1, 5, 8])
def test_the_kernel_agrees_with_its_reference_with_three_layers_and_facing(R):
    """Same texels covered and same facing flags in every layer; depths within float32 rounding."""
    views = pyshadow.ViewSet.zigzag(2, 4)
    mesh = trimesh.creation.annulus(0.3, 0.6, 0.5, sections=12)
    d, f = render_depth(mesh, views, resolution=R, layers=3, facing=True)
    r, g = render_depth_reference(mesh, views, resolution=R, layers=3, facing=True)
    np.testing.assert_array_equal(np.isfinite(d), np.isfinite(r))
    np.testing.assert_array_equal(f, g)
    fin = np.isfinite(d)
    assert np.abs(d[fin] - r[fin]).max() <= 1e-6


def test_depth_maps_do_not_change_under_a_far_translation_and_power_of_two_scale():
    """A mesh moved to 1e5 and scaled by 2^-10 .. 2^13 (its own bounding sphere as the frame): the
    same texels covered, depths within 1e-6 (float32 rounding of the normalised vertices)."""
    views = pyshadow.ViewSet.zigzag(2, 4)
    mesh = trimesh.creation.annulus(0.3, 0.6, 0.5, sections=12)
    d0 = render_depth(mesh, views, resolution=12, layers=3)
    for s in (2.0**-10, 2.0**13):
        moved = mesh.copy()
        moved.vertices = mesh.vertices * s + np.array([1e5, -1e5, 3e4])
        d = render_depth(moved, views, resolution=12, layers=3)
        np.testing.assert_array_equal(np.isfinite(d), np.isfinite(d0))
        fin = np.isfinite(d0)
        assert np.abs(d[fin] - d0[fin]).max() <= 1e-6


def _scene(mesh, ground=0.0):
    scene = pyshadow.Scene(ground=ground, views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    scene.add(mesh)
    return scene


def _resting(name):
    m = {"annulus": trimesh.creation.annulus(0.3, 0.6, 0.4, sections=24),
         "cylinder": trimesh.creation.cylinder(0.5, 0.4, sections=17),
         "tet": trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 0, 1], [0.2, 1, 0.2]],
                                [[0, 1, 2], [0, 3, 1], [1, 3, 2], [0, 2, 3]])}[name]
    if name != "tet":
        m.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))
    m.apply_translation([0.123, -m.bounds[0, 1], -0.27])
    return m


@pytest.mark.parametrize("name", ["annulus", "cylinder", "tet"])
@pytest.mark.parametrize("at", [0.0, 1e5])
def test_the_footprint_mask_is_embrees_closed_ground(name, at):
    """Ground points in the body's box (the annulus' hole included): the mask is True exactly where
    Embree's AO (upward normal) is 0."""
    mesh = _resting(name)
    mesh.apply_translation([at, 0.0, at])
    scene = _scene(mesh)
    rng = np.random.default_rng(7)
    lo, hi = mesh.bounds
    p = np.column_stack([rng.uniform(lo[0], hi[0], 800), np.zeros(800), rng.uniform(lo[2], hi[2], 800)])
    mask = contact.contact_mask(scene, p)
    ao = embree.ambient_occlusion(scene, p, np.tile([0.0, 1.0, 0.0], (len(p), 1)), sampling=pyshadow.Sampling(16))
    assert 200 < mask.sum() < 800
    np.testing.assert_array_equal(mask, ao == 0)


def test_the_footprint_mask_does_not_change_under_rigid_motion_and_scale():
    """A resting unit box, ground points inside, outside and within 1e-3 of its edges: the same mask at
    (x, z) up to 1e7, ground heights 1e3 .. 1e5, sizes 2^-10 .. 2^13, float64 and float32 points."""
    rng = np.random.default_rng(0)
    n = 2000
    u = rng.uniform(-0.6, 0.6, (n, 2))
    pick = rng.choice([0, 1], (n // 2, 2))
    u[: n // 2] = pick * np.sign(u[: n // 2]) * (0.5 - rng.uniform(-1e-3, 1e-3, (n // 2, 2))) + (1 - pick) * u[: n // 2]

    def mask(at, s, gy):
        box = trimesh.creation.box((s, s, s))
        box.apply_translation([at, gy + s / 2, at])
        p = np.column_stack([at + s * u[:, 0], np.full(n, gy), at + s * u[:, 1]])
        return contact.contact_mask(_scene(box, gy), p)

    m0 = mask(0.0, 1.0, 0.0)
    assert 800 < m0.sum() < 1500
    for at, s, gy in ((1e7, 1.0, 0.0), (1e4, 2.0**-10, 0.0), (0.0, 2.0**13, 0.0), (0.0, 1.0, 1e3), (0.0, 1.0, 1e5)):
        np.testing.assert_array_equal(mask(at, s, gy), m0)

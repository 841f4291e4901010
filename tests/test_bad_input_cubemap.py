"""Cube-map AO under bad or extreme input: a clear error naming the argument, or the right answer.

Each case was a crash, a hang, a RuntimeWarning or a silently wrong answer
before (wrong shapes flattened into rows, NaN points answered as unseen or
open, directions of huge or tiny length, distances beyond float32).
"""
from __future__ import annotations

import re

import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.cubemap import (CubeMapAO, CubeMapVisibility, CubeProbe, coverage_grid, direction_texels, normal_hash,
                              quality, raymarch_visible, raymarch_visible_reference, seed_box_filter)

ORIGIN, TOWARDS_WALL = [[0.0, 1.0, 1.0]], [[0.0, 0.0, -1.0]]     # the wall's front face is 1 away


@pytest.fixture(scope="module")
def scene():
    """Ground y = 0 and a thick wall (front face z = 0), a probe's worth of scene."""
    sc = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    wall = trimesh.creation.box((40.0, 10.0, 0.5))
    wall.apply_translation([0.0, 5.0, -0.25])
    sc.add(wall)
    return sc


@pytest.fixture(scope="module")
def probe(scene):
    return CubeProbe(scene, (0.0, 1.0, 2.0), 16)


@pytest.fixture(scope="module")
def maps(scene):
    m = CubeMapAO(scene, 1.0, resolution=16, device=False)
    m.add_probe((0.0, 1.0, 2.0))
    return m


# ---------------------------------------------------------------------------
# rays through a probe
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("march", [raymarch_visible, raymarch_visible_reference])
@pytest.mark.parametrize("p_shape, w_shape", [((4, 3), (3, 4)), ((1, 6), (1, 6)), ((2, 3, 1), (2, 3, 1))])
def test_ray_arrays_of_another_shape_are_refused_not_flattened(probe, march, p_shape, w_shape):
    msg = f"points and directions must both be (N, 3), got {p_shape} and {w_shape}"
    with pytest.raises(ValueError, match=f"^{re.escape(msg)}$"):
        march(probe, np.ones(p_shape), np.ones(w_shape), 2.0)


def test_one_ray_as_two_3_vectors_still_works(probe):
    assert raymarch_visible(probe, ORIGIN[0], TOWARDS_WALL[0], 2.0).tolist() == [False]


@pytest.mark.parametrize("length", [1e-200, 1e-310, 1e200, 1e308])
@pytest.mark.parametrize("device", [True, False])
def test_direction_length_does_not_matter(probe, length, device):
    """Was: 1e200 overflowed (RuntimeWarning; the ray, divided by inf, stood still and was answered open),
    1e-200 and subnormals were refused as zero."""
    w = np.array(TOWARDS_WALL) * length
    assert raymarch_visible(probe, ORIGIN, w, 2.0, device=device).tolist() == [False]
    assert raymarch_visible(probe, ORIGIN, [[0.0, length, 0.0]], 2.0, device=device).tolist() == [True]


def test_zero_direction_message_is_kept(probe):
    with pytest.raises(ValueError, match="^directions must be non-zero$"):
        raymarch_visible(probe, ORIGIN, [[0.0, 0.0, 0.0]], 2.0)


def test_non_numeric_rays_are_a_type_error(probe):
    with pytest.raises(TypeError, match="^points must be numeric, got complex128$"):
        raymarch_visible(probe, np.array(ORIGIN, complex), TOWARDS_WALL, 2.0)


@pytest.mark.parametrize("device", [True, False])
def test_distance_beyond_float32_is_refused(probe, device):
    """Was: the device read D = inf (RuntimeWarning, the wall 1 away answered open); the reference
    overflowed from about 1e154 on and answered open."""
    assert raymarch_visible(probe, ORIGIN, TOWARDS_WALL, 3.4e38, device=device).tolist() == [False]
    with pytest.raises(ValueError, match=r"^max_distance must be at most 3\.40282e\+38 \(the march runs in float32 "
                                         r"on the device\), got 1e\+39$"):
        raymarch_visible(probe, ORIGIN, TOWARDS_WALL, 1e39, device=device)
    with pytest.raises(ValueError, match=r"^thickness must be at most 3\.40282e\+38 .*got 1e\+300$"):
        raymarch_visible(probe, ORIGIN, TOWARDS_WALL, 2.0, device=device, thickness=1e300)


# ---------------------------------------------------------------------------
# texel arithmetic, quality, coverage, the filter
# ---------------------------------------------------------------------------
def test_direction_texels_needs_a_resolution_of_at_least_one():
    """Was: resolution 0 gave row and column -1 (reads wrapped to the last texel), 2.5 was truncated."""
    with pytest.raises(ValueError, match="^resolution must be >= 1, got 0$"):
        direction_texels(np.eye(3), 0)
    with pytest.raises(TypeError, match=r"^resolution must be an int, got 2\.5$"):
        direction_texels(np.eye(3), 2.5)
    face, row, col, _x, _y = direction_texels(np.eye(3), 1)
    assert face.tolist() == [0, 2, 4] and row.tolist() == [0, 0, 0] and col.tolist() == [0, 0, 0]


@pytest.mark.parametrize("D", [-1.0, 0.0, np.nan, np.inf])
def test_quality_needs_a_positive_distance(D):
    """Was: -1 gave NaN (a RuntimeWarning), outside the documented [0, 1]."""
    with pytest.raises(ValueError, match=r"^max_distance must be a finite distance > 0 \(world units\), got "):
        quality([[0.0, 1.0, 0.0]], [[0.0, 1.0, 0.0]], [0.0, 0.0, 0.0], D)


def test_coverage_grid_images_must_agree():
    with pytest.raises(ValueError, match=r"^covered and background must be \(H, W\) images of one shape, got "
                                         r"\(4, 4\) and \(3, 4\)$"):
        coverage_grid(np.ones((4, 4), bool), np.zeros((3, 4), bool), 2)
    with pytest.raises(ValueError, match=r"got \(4,\) and \(4,\)$"):
        coverage_grid(np.ones(4, bool), np.zeros(4, bool), 2)


def test_normal_hash_needs_3_vectors():
    with pytest.raises(ValueError, match=r"^normal must have shape \(\.\.\., 3\), got \(2, 2\)$"):
        normal_hash(np.zeros((2, 2)))


def test_seed_filter_window_larger_than_the_image():
    """Was: a window of 2**31 + 1 failed in np.pad ('array is too big') and one of 10_001 looped 1e8 times;
    offsets beyond the image read only padding, so any larger window equals the image-sized one."""
    rng = np.random.default_rng(0)
    ao = rng.random((5, 6)).astype(np.float32)
    depth = np.ones((5, 6), np.float32)
    n = np.tile([0.0, 1.0, 0.0], (5, 6, 1))
    ref = seed_box_filter(ao, depth, n, size=11)
    assert np.array_equal(seed_box_filter(ao, depth, n, size=10_001), ref)
    assert np.array_equal(seed_box_filter(ao, depth, n, size=2**31 + 1), ref)
    assert np.allclose(ref, ao.mean())


@pytest.mark.parametrize("name", ["depth_threshold", "hash_threshold"])
@pytest.mark.parametrize("value", [np.nan, 0.0, -1.0])
def test_seed_filter_thresholds(name, value):
    """Was: NaN returned the image unfiltered without a word."""
    z = np.ones((3, 3), np.float32)
    with pytest.raises(ValueError, match=rf"^{name} must be a number > 0, got {value!r}$"):
        seed_box_filter(z, z, np.zeros((3, 3, 3)), **{name: value})


# ---------------------------------------------------------------------------
# probes answering points: assign and the visibility backend
# ---------------------------------------------------------------------------
def test_assign_validates_its_points_normals_and_ids(maps):
    """Was: NaN points and zero or NaN normals came back 'seen by no probe' (-1), (3, 4) normals were
    flattened into 4 rows, surface ids of another length a broadcast error."""
    good = [[0.0, 0.0, 0.5]]
    assert maps.assign(good, [[0.0, 1.0, 0.0]])[0].tolist() == [0]
    with pytest.raises(ValueError, match="^points: 1 rows are not finite$"):
        maps.assign([[np.nan, 0.0, 0.5]])
    with pytest.raises(ValueError, match="^normals: 1 rows are zero vectors$"):
        maps.assign(good, [[0.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match="^normals: 1 rows are not finite$"):
        maps.assign(good, [[0.0, np.nan, 0.0]])
    with pytest.raises(ValueError, match=r"^normals must have shape \(N, 3\), got \(3, 4\)$"):
        maps.assign(np.ones((4, 3)), np.ones((3, 4)))
    with pytest.raises(ValueError, match=r"^surface_ids has 3 entries but points has 1 rows \(shapes must match\)$"):
        maps.assign(good, [[0.0, 1.0, 0.0]], [1, 2, 3])


@pytest.mark.parametrize("tol", [-1.0, 0.0, 1.0, np.nan, "x"])
def test_tolerance_in_0_1_everywhere(maps, tol):
    """Was: only project checked it; assign and CubeMapVisibility saw nothing with -1 or NaN."""
    msg = rf"^tolerance must be in \(0, 1\), got {tol!r}$"
    with pytest.raises(ValueError, match=msg):
        maps.assign([[0.0, 0.0, 0.5]], tolerance=tol)
    with pytest.raises(ValueError, match=msg):
        CubeMapVisibility(maps, tolerance=tol)


@pytest.mark.parametrize("unseen", ["error", "open"])
def test_backend_refuses_non_finite_rays(scene, maps, unseen):
    """Was: a NaN point or direction was 'seen by no probe' -- with unseen='open' answered visible."""
    v = CubeMapVisibility(maps, unseen=unseen)
    assert v.visible(scene, [[0.0, 0.0, 0.5]], TOWARDS_WALL).tolist() == [False]
    with pytest.raises(ValueError, match="^points: 1 rows are not finite$"):
        v.visible(scene, [[np.nan, 0.0, 0.5]], TOWARDS_WALL)
    with pytest.raises(ValueError, match="^directions: 1 rows are not finite$"):
        v.visible(scene, [[0.0, 0.0, 0.5]], [[np.nan, 0.0, -1.0]])
    with pytest.raises(ValueError, match="^directions: 1 rows are zero vectors$"):
        v.visible(scene, [[0.0, 0.0, 0.5]], [[0.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match=r"^directions has 2 rows but points has 1 \(shapes must match\)$"):
        v.visible(scene, [[0.0, 0.0, 0.5]], [[0.0, 0.0, -1.0]] * 2)
    with pytest.raises(ValueError, match="^max_distance is empty: the cube-map backend takes one max_distance"):
        v.visible(scene, [[0.0, 0.0, 0.5]], TOWARDS_WALL, max_distance=[])


def test_backend_ao_normals_of_any_length(scene, maps):
    """Was: a zero normal gave a RuntimeWarning and 'normals: 1 rows are not finite'; a normal of length
    1e-200 a division by zero."""
    v = CubeMapVisibility(maps)
    sampling = pyshadow.Sampling(8)
    ref = v.ambient_occlusion(scene, [[0.0, 0.0, 0.5]], [[0.0, 1.0, 0.0]], sampling=sampling)
    tiny = v.ambient_occlusion(scene, [[0.0, 0.0, 0.5]], [[0.0, 1e-200, 0.0]], sampling=sampling)
    assert np.array_equal(tiny, ref) and 0.0 <= ref[0] <= 1.0
    with pytest.raises(ValueError, match="^normals: 1 rows are zero vectors$"):
        v.ambient_occlusion(scene, [[0.0, 0.0, 0.5]], [[0.0, 0.0, 0.0]], sampling=sampling)


@pytest.mark.parametrize("device", [True, False])
def test_points_beyond_float32_from_the_probe_are_refused(probe, device):
    """Was: the device read them as inf (RuntimeWarning 'overflow encountered in cast'), the reference
    overflowed at 1e300."""
    with pytest.raises(ValueError, match=r"^points: 1 rows lie beyond float32's range from the probe's centre "
                                         r"\[0\.0, 1\.0, 2\.0\] \(row 1: \[1e\+39, 1\.0, 1\.0\]; the march reads"):
        raymarch_visible(probe, [ORIGIN[0], [1e39, 1.0, 1.0]], [TOWARDS_WALL[0]] * 2, 2.0, device=device)

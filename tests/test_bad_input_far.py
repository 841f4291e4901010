"""Inputs far out of the ordinary range that used to give a misleading error or NaN: cube cameras far from
the origin, lights beyond float64's squares, overcast skies beyond float64, sample points outside [0, 1]^2."""
import numpy as np
import pytest

from pyshadow.camera import axis_camera
from pyshadow.cubemap.probe import FACE_FORWARD, face_camera
from pyshadow.lighting import DiscLight, overcast_sky
from pyshadow.lighting.area import _check_plane
from pyshadow.sampling import local_directions


@pytest.mark.parametrize("y", [0.5, 1e6, 1e17, 1e30])
def test_cube_face_cameras_far_from_the_origin_look_along_their_axes(y):
    """At 1e17 ``centre + forward`` rounded to ``centre`` ("eye and target coincide"); the target now lies
    max(1, |centre|) along the axis, and the view directions are the axes exactly, as near the origin."""
    for f in range(6):
        cam = face_camera((0.0, y, 0.0), f, 16)
        assert np.array_equal(cam.forward, FACE_FORWARD[f])
        near = face_camera((0.0, 0.5, 0.0), f, 16)
        assert np.array_equal(cam.right, near.right) and np.array_equal(cam.up, near.up)
    assert np.array_equal(axis_camera((3.0, -2.0, 7.0), (0, 0, -1.0), (0, 1.0, 0), 8).forward, [0.0, 0.0, -1.0])


def test_area_light_beyond_float64_distances_is_named():
    """A point 1e300 from a disc light: the distance overflowed, and the point was refused as lying on the
    light's plane; now the overflow is named."""
    light = DiscLight(position=(0.0, 2.0, 0.0), normal=(0.0, -1.0, 0.0), radius=0.5, intensity=1.0)
    with pytest.raises(ValueError, match=r"^point 1 lies too far from the DiscLight \(point \[1e\+300, 0\.0, 0\.0\], "
                                         r"light \[0\.0, 2\.0, 0\.0\]\): their distance overflows float64$"):
        _check_plane(light, np.array([[0.0, 0.0, 0.0], [1e300, 0.0, 0.0]]))
    assert np.allclose(_check_plane(light, np.array([[0.0, 0.0, 0.0], [3.0, 1.0, 0.0]])), [2.0, 1.0])


def test_overcast_sky_beyond_float64_names_the_illuminance():
    with pytest.raises(ValueError, match=r"^horizontal_illuminance: 1e\+308 lux gives a sky luminance beyond "):
        overcast_sky(1e308, height=8)
    sky = overcast_sky(1e300, height=8)             # still finite: kept
    top = 9e300 / (7 * np.pi) * (2.0 + np.cos(np.pi / 8)) / 3.0      # the first row: lz (1 + u0 + u1) / 3
    assert np.isfinite(sky.radiance).all() and sky.radiance.max() == pytest.approx(top)


@pytest.mark.parametrize("bad", [[[0.5, 1.5]], [[-0.1, 0.2]], [[np.nan, 0.2]], [[0.2, 0.3, 0.4]]])
def test_local_directions_refuse_points_outside_the_unit_square(bad):
    """xi1 > 1 gave sqrt(1 - xi1) = NaN (with a warning); xi outside [0, 1]^2 is no sample point."""
    with pytest.raises(ValueError, match=r"^points: expected 2-D sample points in \[0, 1\]\^2"):
        local_directions(bad)
    d = local_directions([[0.0, 0.0], [1.0, 0.25], [0.25, 1.0]])
    assert np.allclose(d, [[0, 1, 0], [0, 0, 1], [0.5, np.sqrt(0.75), 0]], atol=1e-15)


@pytest.mark.parametrize("s", [1e-101, 1e-300, 1e103, 1e300])
def test_rigid_transforms_at_any_scale_are_rigid(s):
    """det(A) underflowed below scales of 1e-100 ("singular") and overflowed beyond 5e102 (a RuntimeWarning,
    then "not rigid ... uniform scale inf"); a turned uniform scale is rigid at any float64 scale."""
    from pyshadow._validate import check_transform, uniform_scale

    T = np.eye(4)
    T[:3, :3] = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]) * s
    assert np.array_equal(check_transform(T, rigid=True), T)
    assert uniform_scale(T[:3, :3]) == s
    A = np.array([[1.0, 2.0, 0.0], [-2.0, 1.0, 0.0], [0.0, 0.0, 5.0 ** 0.5]])        # within det's range: as before
    assert np.array_equal(uniform_scale(np.stack([T[:3, :3], A])), [s, np.cbrt(np.linalg.det(A))])
    with pytest.raises(ValueError, match="is not rigid"):
        check_transform(T @ np.diag([1.0, 1.0, 2.0, 1.0]), rigid=True)
    with pytest.raises(ValueError, match="mirrors"):
        check_transform(T @ np.diag([-1.0, 1.0, 1.0, 1.0]), rigid=True)


def test_transforms_below_float64s_normal_range_stay_singular():
    from pyshadow._validate import check_transform

    with pytest.raises(ValueError, match="transform is singular"):
        check_transform(np.diag([1e-320, 1e-320, 1e-320, 1.0]), rigid=True)
    with pytest.raises(ValueError, match="transform is singular"):
        check_transform(np.diag([1.0, 1.0, 1e-301, 1.0]))


def test_a_caster_scaled_beyond_float32_is_named_not_a_float64_overflow():
    """A body scaled by 1e103 used to be refused as 'not rigid' after an overflow warning; its placement
    is now refused where the kernels' float32 range is checked, and a receiver's scale is its own."""
    import trimesh

    import pyshadow

    box = trimesh.creation.box((1.0, 1.0, 1.0))
    T = np.diag([1e103, 1e103, 1e103, 1.0])
    scene = pyshadow.Scene(ground=None, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(box, T, casts=False)
    assert scene.instances[0].scale == 1e103
    scene.add(box, T @ np.diag([1e-100, 1e-100, 1e-100, 1.0]))
    with pytest.raises(ValueError, match="beyond float32's range"):
        scene.visible(np.array([[0.0, 0.0, 5e103]]), np.array([[0.0, 0.0, -1.0]]))


@pytest.mark.parametrize("row", [[0.0, 0.0, 0.0, 1.000009], [0.0, 0.0, 1e-9, 1.0]])
def test_a_projective_last_row_is_not_affine(row):
    """np.allclose's relative tolerance let w = 1.000009 pass as affine; the rest of the code ignores w."""
    from pyshadow._validate import check_transform

    T = np.eye(4)
    T[3] = row
    with pytest.raises(ValueError, match="must be affine"):
        check_transform(T)
    T[3] = [0.0, 0.0, 0.0, 1.0 + 1e-13]
    assert np.array_equal(check_transform(T), T)

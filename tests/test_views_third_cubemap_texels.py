"""Face and texel of directions from a cube-map probe's centre (pyshadow.cubemap.direction_texels), checked
against a brute-force reference: the face whose axis has the largest dot product with the direction (the first
on ties), and the texel of that face camera whose centre ray meets the image plane nearest the direction's ray."""
from __future__ import annotations

import numpy as np
import pytest

from pyshadow.cubemap import direction_texels, face_camera
from pyshadow.cubemap.probe import CubeProbe, FACE_FORWARD


def _texel_centres(R):
    """Unit centre directions of every texel of a probe of resolution R, in flat texel order (6 R^2, 3)."""
    probe = CubeProbe.__new__(CubeProbe)       # the texel geometry only: no scene is rendered
    probe.resolution = R
    return probe.texel_directions(np.arange(6 * R * R))


def test_faces_and_texels_are_the_brute_force_ones_on_edges_corners_and_signed_zeros():
    """Every texel centre maps to its own texel; random directions, face edges, corners and directions with
    -0.0 components get the face of the largest component (first on ties: x, y, z; + before -) and, inside
    it, the texel of the face camera's image nearest the direction in the image plane."""
    R = 16
    centres = _texel_centres(R)
    f, r, c, _x, _y = direction_texels(centres, R)
    assert np.array_equal((f * R + r) * R + c, np.arange(6 * R * R))
    rng = np.random.default_rng(0)
    special = np.array([[1, 1, 1], [-1, 1, 1], [1, -1, -1], [0, 1, 1], [0, -1, 1], [1, 0, -1], [-0.0, 0.0, 1.0],
                        [0.0, -0.0, -1.0], [-0.0, 1.0, -0.0], [1.0, -0.0, 0.0], [-1.0, 0.0, -0.0], [1, 1, 0]])
    d = np.concatenate([special, rng.normal(size=(5000, 3))])
    f, r, c, x, y = direction_texels(d, R)
    dots = d @ FACE_FORWARD.T
    assert np.array_equal(f, np.argmax(dots, axis=1))           # first of the largest (ties: first face)
    assert (np.abs(x) <= 1).all() and (np.abs(y) <= 1).all()
    # the texel whose centre ray, in the face camera's image plane, is nearest the direction's point there
    # (Chebyshev distance: the texels are the plane's squares), by brute force over the face's R^2 centres
    for k in range(6):
        on = f == k
        cam = face_camera(np.zeros(3), k, R)
        rot = cam.rotation                                          # rows right, up, forward
        rays = cam.ray_directions().reshape(-1, 3) @ rot.T          # camera frame, flat row-major texels
        centre_xy = rays[:, :2] / rays[:, 2:]
        w = d[on] @ rot.T
        xy = w[:, :2] / w[:, 2:]
        cheb = np.abs(xy[:, None, :] - centre_xy[None]).max(axis=2)
        got = cheb[np.arange(on.sum()), r[on] * R + c[on]]
        assert (got <= cheb.min(axis=1) + 1e-12).all()
        assert (got <= 1.0 / R + 1e-12).all()                      # within half a texel (plane side 2/R)


@pytest.mark.parametrize("bad", [[[np.nan, 0.0, 1.0]], [[np.inf, 1.0, 0.0]], [[0.0, -np.inf, 0.0]]])
def test_non_finite_directions_are_refused(bad):
    """Was: a NaN direction had no face and read the centre texel of face 4 (+z), silently ((nan, 0, 1) ->
    face 4, row 8, col 8 at R = 16: x, y NaN set to 0); an infinite one the centre texel of its axis face
    ((inf, 1, 0) -> face 0, (0, -inf, 0) -> face 3, row 8, col 8), where ViewSet.nearest and the AO entry
    points refuse such directions. Now a ValueError naming the rows."""
    with pytest.raises(ValueError, match="not finite"):
        direction_texels(bad, 16)


@pytest.mark.parametrize("bad", [np.ones(6), np.ones((2, 2, 3)), np.ones((4, 2))])
def test_other_shapes_are_refused_not_flattened(bad):
    """Was: any array was reshaped to rows of three: six numbers read as two directions, (2, 2, 3) as four
    (the shape lost), a (4, 2) array failed in NumPy's reshape. Now the shape is (N, 3)
    or (3,), else a ValueError naming it."""
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        direction_texels(bad, 16)


@pytest.mark.parametrize("bad", [[[True, False, False]], [["1", "0", "0"]], [[1j, 0.0, 1.0]]])
def test_non_real_directions_are_a_type_error(bad):
    """Was: booleans read as 0 and 1, strings converted ("1" as 1.0), complex numbers lost their imaginary
    part (a ComplexWarning, an error under pytest). Now a TypeError."""
    with pytest.raises(TypeError, match="numeric"):
        direction_texels(bad, 16)


def test_one_direction_zero_vectors_and_empty_inputs_still_work():
    """A (3,) direction is one row; a zero vector a valid texel of face 0 (documented); no row, no texel."""
    f, r, c, x, y = direction_texels([0.0, 0.0, -2.0], 16)
    assert f.tolist() == [5] and r.tolist() == [8] and c.tolist() == [8] and x.tolist() == [0.0]
    f, r, c, _x, _y = direction_texels([[0.0, 0.0, 0.0]], 16)
    assert f.tolist() == [0] and 0 <= r[0] < 16 and 0 <= c[0] < 16
    f, r, c, x, y = direction_texels(np.zeros((0, 3), np.float32), 16)
    assert f.shape == r.shape == c.shape == x.shape == y.shape == (0,)
    # integers and float32 give the float64 answer
    d = np.array([[3, -1, 2], [-5, 7, 1]])
    for a, b in zip(direction_texels(d, 32), direction_texels(d.astype(np.float32), 32)):
        assert np.array_equal(a, b)

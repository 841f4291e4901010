"""Bad and extreme input to tone mapping, environment maps, cubes and SH irradiance (a second pass).

Each test says in its docstring what happened before ("Was: ..."); valid input is unchanged (the audit
compared hashes of the touched functions' outputs on ordinary input before and after).
"""
import math
import re
import warnings

import numpy as np
import pytest

from pyshadow.lighting import EnvironmentMap, cube, irradiance_sh, tonemap, write_radiance


def test_lat_long_texel_at_the_poles_does_not_depend_on_the_length():
    """Was: texel_index took theta = arccos(y) of the direction as given; a zenith direction of length
    1 - 9.9e-7 (accepted: 1 +- 1e-6) came out 1.4e-3 rad from the pole, in row 1 of a 2400-row map
    (rows 1-3 of 4K-8K maps), the nadir likewise in row H - 2, and lookup() returned row 1's radiance
    (0) instead of the bright pole row's (5). Now the angle is atan2(|(x, z)|, y)."""
    h, w = 2400, 4800
    rad = np.zeros((h, w, 3), np.float32)
    rad[0], rad[-1] = 5.0, 7.0
    env = EnvironmentMap(rad)
    s = 1.0 - 9.9e-7
    t = 0.5 * math.pi / h                                   # centre of row 0, column 0 (phi = pi / w)
    p = math.pi / w
    d = s * np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0],
                      [math.sin(t) * math.cos(p), math.cos(t), math.sin(t) * math.sin(p)],
                      [math.sin(t) * math.cos(p), -math.cos(t), math.sin(t) * math.sin(p)]])
    assert env.texel_index(d).tolist() == [0, (h - 1) * w, 0, (h - 1) * w]
    np.testing.assert_array_equal(env.lookup(d), [[5.0] * 3, [7.0] * 3, [5.0] * 3, [7.0] * 3])
    # the exact unit vectors, as before
    assert env.texel_index(d / s).tolist() == [0, (h - 1) * w, 0, (h - 1) * w]


@pytest.mark.parametrize("curve", [np.array(["srgb", "exponential"]), np.array(["a", "b", "c"])])
def test_tonemap_curve_that_is_no_string_is_named(curve):
    """Was: an array of curve names raised NumPy's "The truth value of an array with more than one
    element is ambiguous" (from ``curve not in CURVES``), naming no argument."""
    one = np.full((1, 1, 3), 0.5)
    with pytest.raises(ValueError, match=r"curve: expected one of srgb, exponential \(got "):
        tonemap(one, curve=curve)
    # the names themselves give what they gave: 0.5 -> sRGB 188; (1 - e^-0.5) ** (1 / 2.2) -> 167
    assert tonemap(one).tolist() == [[[188, 188, 188]]]
    v = (1.0 - math.exp(-0.5)) ** (1.0 / 2.2)
    assert tonemap(one, curve="exponential").tolist() == [[[math.floor(255 * v + 0.5)] * 3]] == [[[167] * 3]]


@pytest.mark.parametrize("call", [lambda r: tonemap(r), lambda r: write_radiance("never-written.exr", r)])
def test_ragged_radiance_is_named(call, tmp_path, monkeypatch):
    """Was: NumPy's "setting an array element with a sequence ... inhomogeneous shape", naming no
    argument (tonemap and write_radiance of a ragged list)."""
    monkeypatch.chdir(tmp_path)
    # tonemap also takes per-vertex radiance (N, 3) and says so; write_radiance an image only
    want = r"radiance: expected shape \(H, W, 3\)( or \(N, 3\))? \(got a ragged sequence\)"
    with pytest.raises(ValueError, match=want):
        call([[[1.0, 2.0, 3.0]], [[1.0, 2.0]]])
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("which", ["coefficients", "normals"])
def test_irradiance_sh_refuses_bools(which):
    """Was: irradiance_sh(np.ones((9, 3), bool), [0, 1, 0]) read True as a coefficient of 1 and returned
    2.405 per channel; bool normals were refused as a ValueError, not the TypeError documented for
    arrays that hold no real numbers."""
    L = np.ones((9, 3), bool) if which == "coefficients" else np.ones((9, 3))
    n = np.array([False, True, False]) if which == "normals" else np.array([0.0, 1.0, 0.0])
    with pytest.raises(TypeError, match=f"{which}: expected real numbers \\(got dtype bool\\)"):
        irradiance_sh(L, n)
    # the same numbers as floats still give Y_0 pi + ... at the zenith
    E = irradiance_sh(np.ones((9, 3)), [0.0, 1.0, 0.0])
    c = [0.5 / math.sqrt(math.pi), math.sqrt(3.0 / (4.0 * math.pi)), math.sqrt(5.0 / (16.0 * math.pi))]
    expected = math.pi * c[0] + 2.0 * math.pi / 3.0 * c[1] + math.pi / 4.0 * 2.0 * c[2]     # Y_0, Y_2, Y_6
    np.testing.assert_allclose(E, [expected] * 3, rtol=1e-14)


@pytest.mark.parametrize("call", [
    lambda: cube.cross_from_faces(np.zeros((6, 2, 2, 3)), "cross"),
    lambda: cube.faces_from_cross(np.zeros((6, 8, 3)), "horizontal"),
    lambda: cube.cross_from_faces(np.zeros((6, 2, 2, 3)), ["vertical-cross"]),
])
def test_cross_layout_is_named(call):
    """Was: a bare KeyError 'cross' (or "unhashable type: 'list'") from the layout table."""
    with pytest.raises(ValueError, match=r"layout: expected 'horizontal-cross' or 'vertical-cross' \(got "):
        call()


@pytest.mark.parametrize("shape", [(10, 13, 3), (2, 3, 3), (12, 15, 3), (9, 16, 3), (16, 12, 3)])
def test_faces_from_a_cross_of_the_wrong_size_are_refused(shape):
    """Was: faces_from_cross(an image 13 x 10 (W x H), "horizontal-cross") cut 3 x 3 faces from the wrong
    cells (N = 10 // 3) and returned them, as for 16 x 9 (4 x 3 faces' worth, cut as 3 x 3); a 3 x 2
    image gave six empty (0, 0) faces; 15 x 12 and 12 x 16 NumPy's "could not broadcast"."""
    with pytest.raises(ValueError, match=r"image: a horizontal-cross is 4 N wide and 3 N tall, N >= 1 \(got shape"):
        cube.faces_from_cross(np.zeros(shape), "horizontal-cross")


@pytest.mark.parametrize("shape", [(5, 2, 2, 3), (6, 2, 3, 3), (6, 0, 0, 3), (6, 2)])
def test_cross_from_faces_of_the_wrong_shape_are_refused(shape):
    """Was: IndexError "index 5 is out of bounds" (five faces), NumPy's "could not broadcast" (faces of
    2 x 3 texels), an empty (0, 0, 3) image for N = 0, IndexError "too many indices" for (6, 2)."""
    with pytest.raises(ValueError, match=r"faces: expected shape \(6, N, N\) or \(6, N, N, C\), N >= 1"):
        cube.cross_from_faces(np.zeros(shape), "vertical-cross")


@pytest.mark.parametrize("layout", ["horizontal-cross", "vertical-cross"])
def test_cross_round_trip_is_unchanged(layout):
    """Was: faces given as a list raised AttributeError "'list' object has no attribute 'shape'"; now
    read as an array. Valid faces round-trip exactly through either cross, as before."""
    faces = np.arange(6 * 3 * 3 * 3, dtype=np.float64).reshape(6, 3, 3, 3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        img = cube.cross_from_faces(faces.tolist(), layout, fill=-1.0)
        np.testing.assert_array_equal(cube.faces_from_cross(img, layout), faces)
    assert (img == -1.0).sum() == 6 * 9 * 3


@pytest.mark.parametrize("f, i, j, value, what", [(3, 1, 2, np.nan, "NaN"), (5, 3, 0, -1.0, "negative"),
                                                  (0, 0, 3, np.inf, "infinite")])
def test_a_bad_cube_texel_is_named_by_its_face_row_and_column(f, i, j, value, what):
    """Was: the six faces were checked as one (6 N, N) image: a NaN at face 3 (-Y), row 1, column 2 of
    4 x 4 faces was reported "at row 13, column 2", a row no face has."""
    faces = np.ones((6, 4, 4, 3))
    faces[f, i, j, 0] = value
    name = cube.FACE_NAMES[f]
    with pytest.raises(ValueError, match=rf"sky\.exr: face {f} \({re.escape(name)}\): 1 texel\(s\) are {what}, "
                                         rf"first at row {i}, column {j} "):
        EnvironmentMap(faces, name="sky.exr")
    faces[f, i, j, 0] = 2.0
    np.testing.assert_array_equal(EnvironmentMap(faces).radiance, faces)


@pytest.mark.parametrize("L, n, name", [([[1.0, 2.0], [3.0]] * 5, [0.0, 1.0, 0.0], "coefficients"),
                                        (np.ones((9, 3)), [[0.0, 1.0, 0.0], [1.0, 0.0]], "normals")])
def test_irradiance_sh_names_a_ragged_argument(L, n, name):
    """Was: NumPy's "setting an array element with a sequence ... inhomogeneous shape", naming neither
    argument."""
    with pytest.raises(ValueError, match=rf"{name}: expected real numbers in rows of equal length \(got a ragged"):
        irradiance_sh(L, n)

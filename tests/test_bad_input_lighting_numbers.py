"""The lighting package's inputs: numbers in its checks (pyshadow/lighting/_checks.py) and lights as values (_value.py).

Each test whose docstring starts "Was:" failed on the code before its fix and says what happened; the
others pin what the fix keeps.
"""
from __future__ import annotations

import numpy as np
import pytest

from pyshadow import lighting
from pyshadow.cubemap.estimators import march_defaults

UP = [0.0, 1.0, 0.0]


@pytest.mark.parametrize("make, match", [
    (lambda: lighting.PointLight([0.0, 2.0, 0.0], "2.5"), r"light intensity: expected .* \(got '2.5'\)"),
    (lambda: lighting.PointLight(["0", "2", "0"], 1.0), r"got \['0', '2', '0'\]"),
    (lambda: lighting.DirectionalLight(np.array([False, True, False]), 1.0), r"got array\(\[False,  True, False\]\)"),
    (lambda: lighting.DirectionalLight(UP, True), r"got True"),
    (lambda: lighting.sh_basis(np.array([[True, False, False]])), "sh_basis: directions: expected"),
    (lambda: lighting.PointLight(np.array([0.0, 2.0, 0.0], dtype=object), [1, "2", 1]), r"got \[1, '2', 1\]"),
])
def test_text_and_bools_are_no_numbers(make, match):
    """Was: text was parsed ("2.5" an intensity of 2.5, ['0', '2', '0'] a position) and bools read as 0
    and 1 (a direction [False, True, False] was +y, an irradiance True was 1): now a ValueError naming
    the argument and what was given. Phong's own text check (``phong._reals``) was this one's."""
    with pytest.raises(ValueError, match=match):
        make()


@pytest.mark.parametrize("call, name", [
    (lambda: lighting.sun_position("45", 172, 12), "latitude"),
    (lambda: lighting.sun_position(45, 172, b"12"), "hour"),
    (lambda: lighting.clear_sky(UP, turbidity="3", height=8), "turbidity"),
    (lambda: lighting.sun_position(np.complex128(45 + 1j), 172, 12), "latitude"),
    (lambda: march_defaults(2.0, step="1"), "step"),
])
def test_text_and_complex_scalars_are_no_numbers(call, name):
    """Was: a latitude "45", an hour b"12" a turbidity "3" and a cube-map march's step "1" were parsed; a NumPy complex latitude 45+1j lost
    its imaginary part with a ComplexWarning (an error under this suite's filters, silent for a user)."""
    with pytest.raises(TypeError, match=f"{name}: must be a number"):
        call()


def test_numbers_still_read_as_before():
    """Ints, floats, NumPy scalars and object arrays of numbers keep reading as their values."""
    a = lighting.sun_position(45, 172, 12)
    np.testing.assert_array_equal(lighting.sun_position(np.float32(45), np.int64(172), 12.0), a)
    light = lighting.PointLight(np.array([0, 2, 0], dtype=object), np.array([1, 2.5, 3], dtype=object))
    np.testing.assert_array_equal(light.intensity, [1.0, 2.5, 3.0])
    assert march_defaults(np.float32(2.0), thickness=1)["thickness"] == 1.0


def _lights():
    d = np.array([0.0, 1.0, 0.0])
    return [lighting.PointLight(np.array([0.0, 2.0, 0.0]), np.array([1.0, 2.0, 3.0])),
            lighting.SpotLight(np.array([0.0, 2.0, 0.0]), 1.0, direction=-d, angle=0.5),
            lighting.DirectionalLight(d, np.array([1.0, 1.0, 1.0])),
            lighting.DiscLight(np.array([0.0, 2.0, 0.0]), -d, 0.5, intensity=1.0),
            lighting.RectLight(np.array([0.0, 2.0, 0.0]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]),
                               intensity=1.0),
            lighting.SunLight(d, np.ones(3), 0.01, np.array([3, 4]), np.ones((2, 3)))]


@pytest.mark.parametrize("k", range(6))
def test_a_light_cannot_be_changed_in_place(k):
    """Was: a light's arrays were writable: ``light.position[1] = nan`` made a light its constructor
    refuses, and a light changed so while a set held it was no longer found (its hash changed). Now every
    array field is a read-only copy; the caller's arrays are neither kept nor locked."""
    light = _lights()[k]
    held = {light}
    arrays = {name: v for name, v in vars(light).items() if isinstance(v, np.ndarray)}
    assert arrays
    for name, a in arrays.items():
        with pytest.raises(ValueError, match="read-only"):
            a[0] = np.nan
    assert light in held and light == _lights()[k]


def test_the_callers_arrays_stay_the_callers():
    """A light keeps copies: changing the arrays given changes nothing, and they stay writable."""
    p, e = np.array([0.0, 2.0, 0.0]), np.array([1.0, 2.0, 3.0])
    light = lighting.PointLight(p, e)
    p[1], e[0] = 5.0, 9.0
    np.testing.assert_array_equal(light.position, [0.0, 2.0, 0.0])
    np.testing.assert_array_equal(light.intensity, [1.0, 2.0, 3.0])

"""Numbers in the lighting package's checks (pyshadow/lighting/_checks.py ``_floats`` and ``_number``).

Each test failed on the code before its fix; its docstring says what happened.
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

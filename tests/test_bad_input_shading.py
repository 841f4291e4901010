"""Bad input to the shading entry points: PhongLighting / phong_shade and Lighting's albedos.

Each test names what happened before the fix."""
import warnings

import numpy as np
import pytest

import pyshadow
from pyshadow.lighting import Lighting
from pyshadow.lighting.phong import PhongLighting, phong_shade

P = [[0.0, 0.0, 0.0]]
N = [[0.0, 1.0, 0.0]]
EYE = [0.0, 5.0, 0.0]


def _lighting(**kw):
    return PhongLighting([0.0, 2.0, 0.0], ambient=0.25, specular=0.5, exponent=8.0, **kw)


def _shade(**kw):
    args = dict(scene=pyshadow.Scene(), points=P, normals=N, eye=EYE, lighting=_lighting(), ao=[0.5],
                backend="numpy", albedo=0.8)
    args.update(kw)
    return phong_shade(**args)


_C3 = np.array([0.5 + 1j, 0.5, 0.5])


@pytest.mark.parametrize("call, name", [
    (lambda: _shade(albedo=_C3), "albedo"),
    (lambda: _shade(ao=np.array([0.5 + 1j])), "ao"),
    (lambda: _shade(eye=np.array([0.0, 5.0 + 1j, 0.0])), "eye"),
    (lambda: _lighting(light_colour=_C3), "light_colour"),
    (lambda: PhongLighting(np.array([0.0, 2.0 + 1j, 0.0])), "light"),
])
def test_complex_phong_inputs_are_refused(call, name):
    """Before: NumPy dropped the imaginary part (a ComplexWarning only), e.g. albedo 0.5+1j shaded as 0.5."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ValueError, match=f"^{name}: expected"):
            call()


@pytest.mark.parametrize("call, name", [
    (lambda: Lighting(albedo=_C3), "albedo"),
    (lambda: Lighting(ground_albedo=_C3), "ground_albedo"),
    (lambda: Lighting(albedos={0: _C3}), r"albedos\[0\]"),
    (lambda: _lighting(albedo=_C3), "albedo"),
    (lambda: Lighting(albedo=np.array("0.5")), "albedo"),
    (lambda: _shade(albedo="0.5"), "albedo"),
])
def test_complex_or_text_albedos_are_refused(call, name):
    """Before: a complex albedo lost its imaginary part (a ComplexWarning only) and the text "0.5" (a
    NumPy string, or any string given to phong_shade) was read as the albedo 0.5."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ValueError, match=f"^{name}: expected"):
            call()


def test_exponent_numpy_bool_is_refused():
    """Before: np.True_ slipped past the bool check and became the exponent 1 (True was refused)."""
    with pytest.raises(ValueError, match="exponent: expected a finite number > 0"):
        _lighting().replace(exponent=np.True_)
    assert _lighting().replace(exponent=np.float32(4.0)).exponent == 4.0


def test_terms_are_checked_by_name():
    """Before: terms of the wrong length failed with NumPy's "cannot reshape array of size 2 into shape
    (1,)", one array with "not enough values to unpack", and NaN terms gave a NaN colour silently."""
    with pytest.raises(ValueError, match=r"terms: diffuse: expected \(1,\) values \(got shape \(2,\)\)"):
        _shade(terms=([0.5, 0.5], [0.1, 0.1]))
    with pytest.raises(ValueError, match="terms: expected a pair"):
        _shade(terms=([0.5],))
    with pytest.raises(ValueError, match="terms: spec: 1 value"):
        _shade(terms=([0.5], [np.nan]))
    # valid terms of any shape holding N values still shade: 0.8 (0.5 * 0.25 + 1 * 1) + 1 * 0.5 * 1 = 1.4
    c, _, _ = _shade(terms=(np.ones((1, 1)), [1.0]))
    np.testing.assert_allclose(c, [[1.4, 1.4, 1.4]], rtol=1e-15)


def test_surface_ids_of_the_wrong_length_with_an_albedo():
    """Before: with ``albedo=`` given, surface_ids of length 2 for 1 point failed deep inside with
    NumPy's "operands could not be broadcast together"."""
    with pytest.raises(ValueError, match=r"surface_ids: expected \(1,\) ints \(got shape \(2,\)"):
        _shade(surface_ids=[-1, -1])
    c, _, _ = _shade(surface_ids=[-1])
    np.testing.assert_allclose(c, [[1.4, 1.4, 1.4]], rtol=1e-15)


def test_bad_ao_values_are_named():
    """Before: text AO failed with "could not convert string to float: 'a'", and NaN or out-of-range AO
    was reported as "got shape (1,)", the shape that was right, not the value that was wrong."""
    with pytest.raises(ValueError, match=r"^ao: expected \(1,\) values in \[0, 1\]"):
        _shade(ao=["a"])
    with pytest.raises(ValueError, match=r"1 value\(s\) are not, e\.g\. nan at point 0"):
        _shade(ao=[np.nan])
    with pytest.raises(ValueError, match=r"e\.g\. 1\.5 at point 1"):
        _shade(points=[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], normals=[N[0], N[0]], ao=[0.5, 1.5])

"""Finite shadow rays and distance AO (pyshadow.visibility.finite): lengths and rates given as Python ints beyond
float64's range are refused by name, before anything is launched."""
import numpy as np
import pytest

from pyshadow import visibility
from pyshadow.visibility.finite import check_ao_options, check_max_distance

HUGE = 10 ** 400        # a Python int: float(HUGE) raises OverflowError


@pytest.mark.parametrize("value", [HUGE, -HUGE, [1.0, HUGE]], ids=["huge", "minus-huge", "list"])
def test_max_distance_beyond_float64_is_named(value):
    """Was: a bare OverflowError "int too large to convert to float" from NumPy, which names neither the
    argument nor what is allowed (every backend: csm, numpy, embree)."""
    with pytest.raises(ValueError, match="max_distance must be within float64's range"):
        check_max_distance(value, 2)


@pytest.mark.parametrize("backend", ["csm", "numpy", "embree"])
def test_visible_refuses_huge_int_length(small_scene, no_launch, backend):
    """Was: OverflowError "int too large to convert to float" from visible(..., max_distance=10**400) on the
    csm, numpy and embree backends alike."""
    p, d = np.array([[3.0, 0.5, 0.0]]), np.array([[0.0, 1.0, 0.0]])
    with pytest.raises(ValueError, match="max_distance"):
        visibility.visible(small_scene, p, d, backend=backend, max_distance=HUGE)


def test_obscurance_beyond_float64_is_named():
    """Was: a bare OverflowError "int too large to convert to float" for obscurance=10**400 (tau)."""
    with pytest.raises(ValueError, match="obscurance"):
        check_ao_options(HUGE, 16, "error")


def test_ordinary_values_still_pass():
    """Ordinary lengths and rates are read as before (ints, floats, inf)."""
    assert check_max_distance(2, 3).tolist() == [2.0, 2.0, 2.0]
    assert check_max_distance([1, np.inf], 2).tolist() == [1.0, np.inf]
    assert check_ao_options(3, 16, "error") == (3.0, 16, "error")

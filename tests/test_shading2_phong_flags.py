"""PhongLighting's ``ao=`` as NumPy bools and arrays (shading, round 2)."""
import numpy as np
import pytest

from pyshadow.lighting import PhongLighting


@pytest.mark.parametrize("flag, mode", [(np.True_, "ao"), (np.False_, "off"), (True, "ao"), (False, "off")])
def test_numpy_bools_choose_the_ambient_mode_as_bools_do(flag, mode):
    """Was: ``ao=np.True_`` raised "ao: expected one of ao, off, normal or a bool (got np.True_)" (a bool
    it is; ``shadows=`` and ``per_vertex=`` take NumPy bools)."""
    assert PhongLighting([0.0, 1.0, 0.0], ao=flag).ao == mode


def test_an_array_of_modes_is_named():
    """Was: a bare "The truth value of an array with more than one element is ambiguous"."""
    with pytest.raises(ValueError, match="ao: expected one of ao, off, normal"):
        PhongLighting([0.0, 1.0, 0.0], ao=np.array(["ao", "off"]))

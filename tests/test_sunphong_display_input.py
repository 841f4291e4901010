"""phong.display refuses what is no display value (text, bools, complex numbers), as tonemap and the rest of
the lighting package do."""
import numpy as np
import pytest

from pyshadow.lighting.phong import display


@pytest.mark.parametrize("colour", [
    [[["0.5", "1", "0"]]],
    np.full((1, 1, 3), 0.5 + 2j),
    np.ones((1, 1, 3), bool),
])
def test_display_refuses_what_is_no_colour(colour):
    """Was: text was parsed ([["0.5", "1", "0"]] showed as (128, 255, 0)), complex values lost their
    imaginary part with only a ComplexWarning (0.5 + 2j showed as 128), bools showed as 0 and 255."""
    with pytest.raises(ValueError, match="colour"):
        display(colour)


def test_display_still_maps_real_values():
    """The frame buffer of ordinary values is unchanged: round(255 clip(c, 0, 1)), +inf white, -inf black."""
    c = np.array([[[0.5, 1.5, -0.2], [np.inf, -np.inf, 0.25]]], np.float32)
    np.testing.assert_array_equal(display(c), [[[128, 255, 0], [255, 0, 64]]])
    np.testing.assert_array_equal(display([[[0, 1, 0]]]), [[[0, 255, 0]]])
    with pytest.raises(ValueError, match="NaN"):
        display(np.full((1, 1, 3), np.nan))

"""image_panel refuses non-numeric images with the TypeError its docstring names."""
import numpy as np
import pytest

pytest.importorskip("pyvista")
from pyshadow.viz.images import image_panel  # noqa: E402


@pytest.mark.parametrize("image", [np.full((2, 2, 3), "0.5"), np.zeros((2, 2, 3), object),
                                   np.array([["0.5", "0.2"]]), np.zeros((2, 2), "M8[s]"), np.zeros((2, 2), object)])
def test_image_panel_refuses_a_non_numeric_image_with_type_error(image):
    """Was: an RGB image of strings ('0.5') or Python objects was taken as numbers and drawn (here the None
    plotter's AttributeError), and a scalar image of strings, dates or objects was a ValueError, though the
    docstring names TypeError for a non-numeric image. The check comes before anything is drawn, so no
    plotter is needed."""
    with pytest.raises(TypeError, match=r"^image_panel: image must be numeric, got "):
        image_panel(None, image)

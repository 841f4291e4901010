"""pyshadow.ssao: a depth buffer with 0 (or negative values) on the background says what the background must be."""
import numpy as np
import pytest

import pyshadow
from pyshadow import ssao


def _gbuffer():
    cam = pyshadow.Camera([0.0, 2.0, 3.0], [0.0, 0.0, 0.0], width=8, height=6)
    depth = np.full((6, 8), 3.5)
    depth[:2] = np.inf                         # the sky
    normal = np.zeros((6, 8, 3))
    normal[..., 1] = 1.0
    return {"depth": depth, "normal": normal}, cam


@pytest.mark.parametrize("value", [0.0, -1.0])
@pytest.mark.parametrize("fn", ["screen_space_ao", "screen_space_ao_reference", "view_depth"])
def test_zero_background_depth_names_the_convention(value, fn):
    """Was: "gbuffer['depth'] must be > 0 where finite (distance from the eye)" for a G-buffer whose renderer
    writes 0 (or -1) on the 16 background pixels: it named neither how many values nor the +inf the background
    must hold (NaN and -inf did get "use +inf for the background"). Now the convention, the count and the least
    value are named."""
    g, cam = _gbuffer()
    g["depth"] = np.where(np.isfinite(g["depth"]), g["depth"], value)
    args = (g, cam) if fn == "view_depth" else (g, cam, 0.5)
    with pytest.raises(ValueError, match=rf"\+inf for the background\), got 16 value\(s\) <= 0, down to {value:g}$"):
        getattr(ssao, fn)(*args)


def test_positive_depths_still_run():
    g, cam = _gbuffer()
    ao = ssao.screen_space_ao(g, cam, 0.5, samples=4)
    assert ao.shape == (6, 8) and (ao[:2] == 1.0).all() and ((ao >= 0) & (ao <= 1)).all()

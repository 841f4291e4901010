"""tonemap(exposure="auto"): the 99th luminance percentile to 0.8, whatever the radiance's unit."""
import numpy as np
import pytest

import pyshadow.lighting as L
from pyshadow.lighting.sky import LUMINANCE_WEIGHTS


@pytest.mark.parametrize("unit", [1e-3, 1.0, 17_000.0, 1e9])
def test_auto_exposure_maps_the_99th_percentile_to_0_8(unit):
    """Was: only a number; the built-in skies' radiance (cd/m^2, a median near 17,000) at the default exposure
    1 made every pixel 255. Now "auto" scales the 99th percentile of the luminance to 0.8: about 1 % clips,
    the same 8-bit image at every unit (within one level: the scaled values agree to rounding)."""
    rng = np.random.default_rng(4)
    base = rng.gamma(2.0, 0.3, size=(48, 64, 3))
    img = base * unit
    lum = img @ LUMINANCE_WEIGHTS
    s = L.auto_exposure(img)
    np.testing.assert_allclose(s, 0.8 / np.percentile(lum, 99.0), rtol=1e-12)
    out = L.tonemap(img, exposure="auto")
    ref = L.tonemap(base, exposure=0.8 / np.percentile(base @ LUMINANCE_WEIGHTS, 99.0))
    assert (np.abs(out.astype(int) - ref.astype(int)) <= 1).all()
    clipped = (out == 255).any(axis=2).mean()            # a channel clips: 3.6 % of these pixels
    assert 0.0 < clipped < 0.05
    assert (L.tonemap(img * 0 + 17_000.0 * unit) == 255).all()      # the default exposure 1 at a sky's unit


def test_auto_exposure_of_covered_pixels_and_black_images():
    """The covered pixels alone set it (a black background is not measured); a black image keeps 1;
    non-finite luminance is left out by default."""
    img = np.zeros((10, 10, 3))
    img[:5] = 2.0
    covered = np.zeros((10, 10), bool)
    covered[:5] = True
    np.testing.assert_allclose(L.auto_exposure(img, covered), 0.4, rtol=1e-12)
    assert L.auto_exposure(np.zeros((4, 4, 3))) == 1.0
    img[0, 0] = np.inf
    np.testing.assert_allclose(L.auto_exposure(img, None), 0.8 / np.percentile(np.r_[np.full(49, 2.0),
                                                                                      np.zeros(50)], 99.0))
    with pytest.raises(TypeError, match="exposure: must be a number"):        # a number or "auto"
        L.tonemap(img, exposure="bright")

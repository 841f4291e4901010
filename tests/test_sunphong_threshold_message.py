"""extract_sun(threshold=) names its limit in words that an infinite threshold does not seem to meet."""
import math

import numpy as np
import pytest

from pyshadow.lighting import EnvironmentMap
from pyshadow.lighting.sun import extract_sun


@pytest.mark.parametrize("t", [math.inf, 0.5, math.nan])
def test_threshold_error_states_the_real_limit(t):
    """Was: "threshold: must lie in [1, inf] (got inf)": inf was refused by a message saying it lies in the
    range. Now "must be a finite number >= 1" for every refused threshold."""
    env = EnvironmentMap(np.ones((8, 16, 3)))
    with pytest.raises(ValueError, match=r"^threshold: must be a finite number >= 1 \(got"):
        extract_sun(env, threshold=t)
    sun, _ = extract_sun(env, threshold=1e300)      # a finite, huge one is taken: the region never grows
    assert np.all(np.isfinite(sun.irradiance))

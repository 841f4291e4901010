"""Parameters of the filters at the edges of their ranges."""
import warnings

import numpy as np

from pyshadow.filters import edge_aware_box, edge_aware_box_reference


def test_edge_aware_box_depth_threshold_beyond_float32():
    """Was: edge_aware_box(..., depth_threshold=1e40) (valid: finite and > 0) raised
    "RuntimeWarning: overflow encountered in cast" from float32(1e40), an error under -W error and
    pytest's filterwarnings=error; edge_aware_box_reference gave [4.5, 5, 6, 6.5] for the row."""
    depth = np.full((3, 4), 2.0, np.float32)
    depth[0, 0] = 2e30                      # a relative difference of 1e30: counted below 1e40
    normal = np.zeros((3, 4, 3), np.float32)
    normal[..., 2] = 1.0
    ao = np.arange(12, dtype=np.float32).reshape(3, 4)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for dt in (1e40, 1e300):
            got = edge_aware_box(ao, depth, normal, size=3, depth_threshold=dt)
            ref = edge_aware_box_reference(ao, depth, normal, size=3, depth_threshold=dt)
            np.testing.assert_allclose(got, ref, rtol=1e-6)
            np.testing.assert_allclose(got[1], [4.5, 5.0, 6.0, 6.5], rtol=1e-6)

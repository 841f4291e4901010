"""ao_from_samples refuses a zero normal when bent normals are asked (the normal is the fallback)."""
from __future__ import annotations

import numpy as np
import pytest

from pyshadow.sampling import ao_from_samples


def test_zero_normal_is_refused_for_bent_normals():
    """Was: a point none of whose directions is open, given a zero normal, got the bent normal (0, 0, 0)
    silently (the fallback is the normal); now ValueError. Unit normals answer as before."""
    d = np.zeros((2, 3, 3))
    d[..., 1] = 1.0
    closed = np.zeros((2, 3), bool)
    n = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match="normals: 1 rows are zero vectors"):
        ao_from_samples(d, closed, n, return_bent_normals=True)
    assert ao_from_samples(d, closed, n).tolist() == [0.0, 0.0]            # AO alone does not read them
    ao, bent = ao_from_samples(d, closed, n[[0, 0]], return_bent_normals=True)
    assert ao.tolist() == [0.0, 0.0] and bent.tolist() == [[0.0, 1.0, 0.0]] * 2

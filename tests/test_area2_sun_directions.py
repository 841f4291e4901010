"""Second audit: sun_directions (the sun's and sky lights' disc samples) checks its arguments (helper area2)."""
import numpy as np
import pytest

from pyshadow.lighting.shade import DirectionalLight, sun_directions

SUN = DirectionalLight([0.0, 1.0, 0.0], [1.0, 1.0, 1.0], 0.01)


@pytest.mark.parametrize("k, err", [(0, ValueError), (-1, ValueError), (2.5, TypeError), (True, TypeError)])
def test_bad_counts_are_refused(k, err):
    """Was: k = 0 and -1 returned (N, 0, 3) (no directions: the mean over them is NaN), k = 2.5 three
    directions placed as strata of 1.2 times the disc's solid angle (cos a = 1 - (j + 1/2) / 2.5 (1 - cos r):
    the last on the rim), True one direction."""
    with pytest.raises(err, match="k"):
        sun_directions(SUN, k, np.arange(2))


@pytest.mark.parametrize("idx, err", [(np.array([-1, 2]), ValueError), (np.array([0.5, 1.5]), TypeError),
                                      (np.arange(6).reshape(2, 3), ValueError)])
def test_bad_indices_are_refused(idx, err):
    """Was: index -1 and 0.5 were taken silently (0.5 as point 0's pattern), a (2, 3) array gave a
    (2, 1, 3, 3) result."""
    with pytest.raises(err, match="indices"):
        sun_directions(SUN, 3, idx)


def test_bad_seed_is_named_and_good_input_unchanged():
    """Was: seed=-1 raised NumPy's 'expected non-negative integer', 1.5 a SeedSequence TypeError; neither
    named the seed. Ordinary input keeps its shape, unit length and spread within the disc; [] gives
    no directions."""
    for seed in (-1, 1.5):
        with pytest.raises(ValueError, match="seed"):
            sun_directions(SUN, 3, np.arange(2), seed)
    d = sun_directions(SUN, np.int32(5), [0, 7, 3], np.int64(2))
    assert d.shape == (3, 5, 3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=2), 1.0, rtol=1e-15)
    assert (np.arccos(np.clip(d @ SUN.direction, -1.0, 1.0)) <= 0.01 + 1e-12).all()
    assert sun_directions(SUN, 3, []).shape == (0, 3, 3)

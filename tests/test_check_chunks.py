"""The batch checks read chunk by chunk (pyshadow._validate.CHECK_ROWS): the same refusals, with the counts of
the whole batch, and the points' bound of pyshadow.scene_arrays.points_bound."""
import numpy as np
import pytest

import pyshadow
from pyshadow import _validate
from pyshadow.scene_arrays import points_bound


@pytest.fixture
def small_chunks(monkeypatch):
    monkeypatch.setattr(_validate, "CHECK_ROWS", 4)


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_bound_is_points_bound(small_chunks, dtype):
    rng = np.random.default_rng(0)
    for n in (1, 3, 4, 5, 17, 40):
        p = (rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-3, 6, size=(n, 1))).astype(dtype)
        assert _validate.checked_bound(p, "points") == points_bound(p)
    assert _validate.checked_bound(np.zeros((0, 3)), "points") == points_bound(np.zeros((0, 3))) == 0.0


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_rows_counted_over_every_chunk(small_chunks, bad):
    p = np.ones((11, 3))
    p[[1, 6, 10], [0, 2, 1]] = bad          # in three chunks of 4 rows
    with pytest.raises(ValueError, match="points: 3 rows are not finite"):
        _validate.checked_bound(p, "points")


def test_zero_directions_counted_over_every_chunk(small_chunks):
    w = np.ones((13, 3), np.float32)
    w[[2, 3, 9, 12]] = 0.0
    w[5, :2] = 0.0                           # two zero entries only: a direction
    with pytest.raises(ValueError, match="directions: 4 rows are zero vectors"):
        _validate._check_chunks(w, "directions", True)
    _validate._check_chunks(w[4:9], "directions", True)


def test_check_both_large_batch_refuses_and_bounds():
    """Above the size checked on two threads: the points' bound comes back; a bad row of either is refused,
    the points' first."""
    n = 100_000
    p = np.zeros((n, 3))
    p[n - 1] = [1.0, -7.5, 2.0]
    w = np.tile([0.0, 1.0, 0.0], (n, 1))
    assert _validate.check_both(p, "points", w, "directions") == 7.5
    w[n // 2] = 0.0
    with pytest.raises(ValueError, match="directions: 1 rows are zero vectors"):
        _validate.check_both(p, "points", w, "directions")
    p[3, 1] = np.nan
    with pytest.raises(ValueError, match="points: 1 rows are not finite"):
        _validate.check_both(p, "points", w, "directions")


def test_visible_refuses_as_before():
    s = pyshadow.Scene(ground=0.0)
    p = np.zeros((5, 3))
    p[2, 0] = np.inf
    with pytest.raises(ValueError, match="points: 1 rows are not finite"):
        s.visible(p, np.tile([0.0, 1.0, 0.0], (5, 1)))

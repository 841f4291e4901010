"""The packed places of a block's segments fit csm_compact's uint32 or the build stops with a clear error."""
import numpy as np
import pytest

from pyshadow.csm.build import _compact_starts


def test_starts_are_the_running_sum_of_the_counts():
    counts = np.array([3, 0, 7, 1, 0], np.uint32)
    total, start = _compact_starts(counts, 6)
    assert total == 11 and start.dtype == np.uint32
    np.testing.assert_array_equal(start, [0, 3, 3, 10, 11])


def test_a_block_of_more_than_two_to_the_32_segments_is_refused():
    """Was: the uint32 running sum wrapped (2^31 + 2^31 -> 0) and csm_compact wrote the third texel's segments
    from place 0 over the first's, then past its output's end."""
    counts = np.array([1 << 31, 1 << 31, 1], np.uint32)
    with pytest.raises(ValueError, match="a block of 1023 maps emitted 4,294,967,297 segments, more than the 2"):
        _compact_starts(counts, 1023)
    total, start = _compact_starts(np.array([1 << 31, (1 << 31) - 1, 1], np.uint32), 1023)   # exactly 2^32: fits
    assert total == 1 << 32 and start[-1] == (1 << 32) - 1

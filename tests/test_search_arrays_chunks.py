"""The device layout of a CSM laid out a chunk of pairs at a time (pyshadow.csm.device.search_arrays):
the same tables at any chunk size, and memory beside them that does not grow with the CSM."""
import tracemalloc

import numpy as np
import pytest

import pyshadow
import pyshadow.csm.device as device
from conftest import load


@pytest.fixture(scope="module")
def csms():
    """A 16-bit CSM with uint16 i_end, and a 32-bit one (float depth: the wide pairs)."""
    views = pyshadow.ViewSet.zigzag(8, 16)
    return [pyshadow.CoherentShadowMap.build(load(name), views, resolution=32, depth_bits=bits, progress=False)
            for name, bits in (("teapot.obj", 16), ("spot.obj", 32))]


@pytest.mark.parametrize("padded", [False, True])
@pytest.mark.parametrize("wide", [None, True])
def test_any_chunk_size_lays_out_the_same_tables(csms, monkeypatch, padded, wide):
    """Chunks of 1, 17 and 1,000 pairs (lists cut at a chunk's end, a list longer than a chunk alone in
    one) give the arrays of one chunk for the whole CSM, to the bit; ``segment=False`` gives them
    without ``segment``. The pairs are each segment's own: ``iend[segment]`` and its depth."""
    for csm in csms:
        whole = device.search_arrays(csm, wide, padded)
        assert len(whole["pairs"]) > 1000              # a chunk of 1,000 cuts the lists somewhere
        for chunk in (1, 17, 1000):
            monkeypatch.setattr(device, "SEARCH_CHUNK", chunk)
            part = device.search_arrays(csm, wide, padded)
            lean = device.search_arrays(csm, wide, padded, segment=False)
            assert set(whole) == set(part) == set(lean) | {"segment"}
            for k, v in whole.items():
                assert part[k].dtype == v.dtype and np.array_equal(part[k], v), (k, chunk)
                if k != "segment":
                    assert lean[k].dtype == v.dtype and np.array_equal(lean[k], v), (k, chunk)
        seg = whole["segment"]
        if wide or csm.depth_bits == 32:
            depth = csm.depth.view(np.uint32) if csm.depth_bits == 32 else csm.depth
            np.testing.assert_array_equal(whole["pairs"][:, 0], csm.iend[seg])
            np.testing.assert_array_equal(whole["pairs"][:, 1], depth[seg])
        else:
            np.testing.assert_array_equal(whole["pairs"] & 0xFFFF, csm.iend[seg])
            np.testing.assert_array_equal(whole["pairs"] >> 16, csm.depth[seg])


def test_the_layout_holds_little_beside_its_tables(csms, monkeypatch):
    """With chunks of 4,096 pairs the padded layout allocates at its peak its tables and besides at most
    six int64 words a texel (offsets, list lengths, block counts and starts: 0.79 MB at 128^2) and 256 kB
    (the temporaries of one chunk: a few int64 arrays of 4,096 entries). Laid out at once it held about ten
    times the CSM's bytes (int64 indices of every pair, several at a time)."""
    monkeypatch.setattr(device, "SEARCH_CHUNK", 4096)
    csm = pyshadow.CoherentShadowMap.build(load("stanford-bunny.obj"), pyshadow.ViewSet.zigzag(16, 32),
                                           resolution=128, progress=False)
    device.search_arrays(csm, None, True, segment=False)         # numpy's first calls allocate caches
    tracemalloc.start()
    try:
        out = device.search_arrays(csm, None, True, segment=False)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    tables = sum(a.nbytes for a in out.values())
    allowance = 6 * 8 * (csm.resolution ** 2 + 1) + 256 * 1024
    assert tables > 3 * allowance
    assert peak <= tables + allowance, (peak, tables)

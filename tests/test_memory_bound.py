"""benchmarks/memory_bound.py: its table is one cycle through every line, and its kernel follows the chains."""
import sys

import numpy as np

from conftest import REPO

sys.path.insert(0, str(REPO / "benchmarks"))
import memory_bound  # noqa: E402


def test_cycle_table_visits_every_line_once():
    t = memory_bound.cycle_table(1000, seed=3)
    assert t.shape == (16000,) and t.dtype == np.uint32
    nxt = t[::16]
    assert not t.reshape(-1, 16)[:, 1:].any()          # one index a 64-byte line, the rest zero
    seen, p = set(), 0
    for _ in range(1000):
        seen.add(p)
        p = int(nxt[p])
    assert p == 0 and len(seen) == 1000                 # back at the start after exactly every line


def test_kernel_follows_each_chain():
    lines, chains, items, steps = 1024, 3, 5, 7
    t = memory_bound.cycle_table(lines, seed=1)
    out, seconds = memory_bound.chase(t, chains, items, steps)
    nxt = t[::16].astype(np.int64)
    stride = memory_bound.starts_stride(lines, items * chains)
    want = []
    for g in range(items):
        acc = 0
        for c in range(chains):
            p = (g * chains + c) * stride % lines
            for _ in range(steps):
                p = nxt[p]
            acc += p
        want.append(acc % 2**32)
    np.testing.assert_array_equal(out, np.array(want, np.uint32))
    assert seconds > 0

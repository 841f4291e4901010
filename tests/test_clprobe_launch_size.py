"""Launches of more work-items than the kernels can number (their ids are 32-bit ints) are refused before
they run. Checked by arithmetic: the driver's launch is replaced by a recorder, so nothing that large runs."""
import pyopencl as cl
import pytest

import pyshadow
from pyshadow import _cl


@pytest.fixture
def recorded(monkeypatch):
    calls = []
    monkeypatch.setattr(cl.Kernel, "__call__", lambda self, q, g, loc, *a, **k: calls.append(tuple(g)))
    return calls


@pytest.mark.parametrize("size", [(2 ** 31,), (2 ** 32 + 5,), (2 ** 16, 2 ** 15 + 1)])
def test_a_launch_beyond_the_kernels_int_ids_is_refused(recorded, size):
    """Was: launched as asked (an SSAO image of more than 2**31 pixels, 47,000 x 47,000, whose largest input,
    26 GB, a 141 GB GPU allocates at once): the kernels' ``int i = get_global_id(0)`` and ``i >= W * H``
    wrap past 2**31 - 1, and they read and write outside their buffers."""
    k = _cl.kernel("ssao.cl", "ssao", {"SAMPLES": 4})
    with pytest.raises(pyshadow.DeviceNotSupportedError, match=r"'ssao' over .* 2,147,483,647 .*ask for less"):
        k(_cl.queue(), size, None)
    assert recorded == []


def test_launches_up_to_the_limit_go_ahead(recorded):
    """Was: (unchanged) launches of up to 2**31 - 1 work-items go to the driver as before."""
    k = _cl.kernel("ssao.cl", "ssao", {"SAMPLES": 4})
    for size in [(2 ** 31 - 1,), (2 ** 16, 2 ** 15 - 1), (1,)]:
        k(_cl.queue(), size, None)
    assert recorded == [(2 ** 31 - 1,), (2 ** 16, 2 ** 15 - 1), (1,)]

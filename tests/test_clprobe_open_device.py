"""A device that is listed but refuses a context (a GPU another process holds in exclusive mode, a driver
whose GPU is gone): a DeviceNotFoundError naming it and PYSHADOW_DEVICE, not the driver's bare error."""
import pyopencl as cl
import pytest

import pyshadow
from pyshadow import _cl


def refuses(code, name):
    def context(*args, **kwargs):
        raise cl.RuntimeError(cl._cl._ErrorRecord("clCreateContext", code, name))
    return context


@pytest.mark.parametrize("code, name", [(-2, "DEVICE_NOT_AVAILABLE"), (-6, "OUT_OF_HOST_MEMORY")])
def test_a_device_that_refuses_a_context_is_named_with_the_fix(monkeypatch, code, name):
    """Was: pyopencl's RuntimeError 'clCreateContext failed: DEVICE_NOT_AVAILABLE' from the first call,
    naming neither the device nor how to choose another."""
    choice = _cl._choose_device()
    monkeypatch.setattr(cl, "Context", refuses(code, name))
    with pytest.raises(pyshadow.DeviceNotFoundError) as info:
        _cl._open(choice)
    msg = str(info.value)
    assert name in msg and choice[3].name.strip() in msg
    assert "%d:%d" % choice[:2] in msg and "PYSHADOW_DEVICE" in msg and "available: 0:0 " in msg
    assert isinstance(info.value.__cause__, cl.RuntimeError)


def test_an_opened_device_is_as_before():
    """Was: (unchanged) a device that opens gives its context and an in-order queue on it."""
    st = _cl._open(_cl._choose_device())
    assert st["queue"].context == st["context"] and st["context"].devices == [st["device"]]
    assert not st["queue"].properties & cl.command_queue_properties.OUT_OF_ORDER_EXEC_MODE_ENABLE

"""POCL_DEVICES naming no kind of device the installed PoCL has (``cpu``, the name PoCL 4 and later give the
device that PoCL 3, pyopencl's wheel's, calls ``pthread``): the error says so instead of asking whether PoCL
is installed."""
import pyopencl as cl
import pytest

import pyshadow
from pyshadow import _cl


class Platform:
    """PoCL as it answers with POCL_DEVICES=cpu: the platform is there, with no device."""
    name = "Portable Computing Language"

    def get_devices(self):
        return []


@pytest.mark.parametrize("want", ["", "cpu", "0:0"])
def test_no_device_under_pocl_devices_names_the_variable(monkeypatch, want):
    """Was: "no OpenCL devices at all (is pocl-binary-distribution installed?)" alone, where it is installed
    and POCL_DEVICES=cpu hid its one device."""
    monkeypatch.setattr(cl, "get_platforms", lambda: [Platform()])
    monkeypatch.setenv("POCL_DEVICES", "cpu")
    with pytest.raises(pyshadow.DeviceNotFoundError) as info:
        _cl._choose_device(want)
    msg = str(info.value)
    assert "no OpenCL devices at all" in msg
    assert "POCL_DEVICES='cpu' is set" in msg and "unset it" in msg and "'pthread' in PoCL 3" in msg


def test_without_pocl_devices_the_message_is_as_before(monkeypatch):
    """Was: (unchanged) without POCL_DEVICES, no device found says what it said."""
    monkeypatch.setattr(cl, "get_platforms", lambda: [Platform()])
    monkeypatch.delenv("POCL_DEVICES", raising=False)
    with pytest.raises(pyshadow.DeviceNotFoundError) as info:
        _cl._choose_device("")
    assert str(info.value) == ("no OpenCL device found: no OpenCL devices at all "
                               "(is pocl-binary-distribution installed?)")

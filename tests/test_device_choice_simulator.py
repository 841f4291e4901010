"""The default device is a real GPU, else PoCL: not a simulator that claims every device type."""
from types import SimpleNamespace

import pyopencl as cl

from pyshadow import _cl

T = cl.device_type


def _dev(pi, di, platform, name, dtype):
    return (pi, di, SimpleNamespace(name=platform), SimpleNamespace(name=name, type=dtype))


def test_a_simulator_typed_cpu_and_gpu_is_not_the_default(monkeypatch):
    """Was: with Oclgrind registered (its device typed DEFAULT | CPU | GPU | ACCELERATOR, 15) pyshadow chose it over
    PoCL as 'the first GPU': every kernel interpreted, hundreds of times slower, at one lane."""
    found = [_dev(0, 0, "Oclgrind", "Oclgrind Simulator", T.DEFAULT | T.CPU | T.GPU | T.ACCELERATOR),
             _dev(1, 0, "Portable Computing Language", "pthread-cpu", T.CPU)]
    monkeypatch.setattr(_cl, "_all_devices", lambda: found)
    assert _cl._choose_device("")[:2] == (1, 0)
    assert _cl._choose_device("0:0")[:2] == (0, 0)          # still there when named
    assert _cl._choose_device("gpu")[:2] == (0, 0)


def test_a_real_gpu_is_still_chosen_first(monkeypatch):
    found = [_dev(0, 0, "Portable Computing Language", "pthread-cpu", T.CPU),
             _dev(1, 0, "NVIDIA CUDA", "NVIDIA H100", T.GPU),
             _dev(2, 0, "Oclgrind", "Oclgrind Simulator", T.DEFAULT | T.CPU | T.GPU | T.ACCELERATOR)]
    monkeypatch.setattr(_cl, "_all_devices", lambda: found)
    assert _cl._choose_device("")[:2] == (1, 0)
    monkeypatch.delenv("PYSHADOW_DEVICE", raising=False)
    assert _cl._choose_device(None)[:2] == (1, 0)

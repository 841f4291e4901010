"""The lane probe's cached verdicts belong to the code PoCL compiles on a host, not to the CPU's name alone.

Emulates a second machine whose PoCL, like the first's, names the device ``pthread-Intel(R) Xeon(R)
Processor`` (a virtual machine's CPU name) but compiles for another CPU: a ``sitecustomize`` makes the
bundled PoCL's own detection (``pocl_get_llvm_cpu_name``) answer ``x86-64`` in that process and in its
probe children, without ``PYSHADOW_POCL_CPU``. Both share one ``lanes.json``, as a home folder shared
by the machines of a cluster does.
"""
import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from pyshadow._cl import pocl_cpu

DETECTS = textwrap.dedent("""
    import ctypes, importlib.util
    spec = importlib.util.spec_from_file_location("_pocl_cpu_emulated", {path!r})
    m = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(m)
    lib = ctypes.CDLL(m._bundled_pocl(), mode=ctypes.RTLD_GLOBAL)
    libc = ctypes.CDLL(None)
    TEXT = ctypes.create_string_buffer({name!r}.encode())
    m._returning_copy(ctypes.cast(lib.pocl_get_llvm_cpu_name, ctypes.c_void_p).value, ctypes.addressof(TEXT),
                      ctypes.cast(libc.strdup, ctypes.c_void_p).value)
""")

QUERY = textwrap.dedent("""
    import json
    import numpy as np
    import pyshadow, trimesh
    from pyshadow import _cl
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(trimesh.creation.icosphere(1), trimesh.transformations.translation_matrix([0, 1.0, 0]))
    rng = np.random.default_rng(5)
    p = np.column_stack([rng.uniform(-2, 2, 2000), np.zeros(2000), rng.uniform(-2, 2, 2000)])
    d = rng.normal(size=(2000, 3)); d[:, 1] = np.abs(d[:, 1])
    try:
        v = scene.visible(p, d, surface_ids=-2).astype(int).tolist()
    except Exception as exc:
        v = f"{type(exc).__name__}: {str(exc)[:300]}"
    print(json.dumps({"lanes": _cl.lanes(), "visible": v}))
""")


def _run(tmp_path, cache, detects=None, extra=None):
    env = {**os.environ, "PYSHADOW_CACHE": str(cache), "PYOPENCL_COMPILER_OUTPUT": "0"}
    for k in (pocl_cpu.ENV, "PYSHADOW_LANES", "POCL_EXTRA_BUILD_FLAGS"):
        env.pop(k, None)
    if detects:
        site = tmp_path / f"site-{detects}"
        site.mkdir(exist_ok=True)
        (site / "sitecustomize.py").write_text(DETECTS.format(path=pocl_cpu.__file__, name=detects))
        env["PYTHONPATH"] = os.pathsep.join([str(site)] + [p for p in [env.get("PYTHONPATH")] if p])
    env.update(extra or {})
    out = subprocess.run([sys.executable, "-c", QUERY], env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def bundled_pocl():
    import pyshadow

    if pyshadow.device_info()["platform"] != "Portable Computing Language" or pocl_cpu._bundled_pocl() is None \
            or not sys.platform.startswith("linux"):
        pytest.skip("the device is not the PoCL bundled with pyopencl on Linux")


def test_a_machine_whose_pocl_compiles_for_another_cpu_probes_again(bundled_pocl, tmp_path):
    """Was: the second machine took the first's verdicts (16 lanes on this AVX-512 host) and its first
    kernel raised KernelBuildError (a vector argument 'changes the ABI' at x86-64); now it probes its own
    widths and answers as the first."""
    cache = tmp_path / "shared-cache"
    first = _run(tmp_path, cache)
    second = _run(tmp_path, cache, detects="x86-64")
    assert isinstance(second["visible"], list), second["visible"]
    assert second["visible"] == first["visible"], (first["lanes"], second["lanes"])
    entries = json.loads((cache / "lanes.json").read_text())["entries"]
    assert len(entries) == 2                    # one entry per machine, the same device name
    assert len({e["device"] for e in entries.values()}) == 1


def test_verdicts_under_pocl_extra_build_flags_do_not_outlive_them(bundled_pocl, tmp_path):
    """POCL_EXTRA_BUILD_FLAGS that PoCL refuses fail every width; was: once unset, the device was still
    refused, from those cached verdicts, until lanes.json was deleted."""
    cache = tmp_path / "cache"
    env = {**os.environ, "PYSHADOW_CACHE": str(cache), "POCL_EXTRA_BUILD_FLAGS": "-no-such-flag"}
    env.pop("PYSHADOW_LANES", None)
    out = subprocess.run([sys.executable, "-c", "import pyshadow; pyshadow.device_info()"], env=env,
                         capture_output=True, text=True, timeout=300)
    assert out.returncode != 0 and "DeviceNotSupportedError" in out.stderr
    # the message names the variable and says PoCL's refusal once for the four widths (was: four copies of
    # pyopencl's text, each cut at 300 characters and naming the device by its address, and no word of the flags)
    message = out.stderr.strip().splitlines()[-1]
    assert "POCL_EXTRA_BUILD_FLAGS='-no-such-flag' is set" in message, message
    assert message.count("-no-such-flag") == 2 and "16, 8, 4, 1: building probe.cl failed" in message, message
    assert " at 0x" not in message, message
    after = _run(tmp_path, cache)
    assert isinstance(after["visible"], list), after["visible"]
    assert 0.2 < np.mean(after["visible"]) < 0.99

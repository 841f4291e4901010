"""PoCL's target CPU on processors its LLVM does not know (pyshadow/_cl/pocl_cpu.py)."""
import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from pyshadow._cl import pocl_cpu

AVX512 = {"avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"}
AVX2 = {"sse2", "ssse3", "sse4_1", "sse4_2", "popcnt", "avx", "avx2", "fma", "bmi1", "bmi2", "f16c", "movbe", "abm",
        "adx"}


@pytest.mark.parametrize("flags, name", [
    (AVX2 | AVX512, "skylake-avx512"),                  # AMD Zen 4 / Zen 5, Intel Skylake-SP and later
    (AVX2 | (AVX512 - {"avx512bw"}), "haswell"),        # AVX-512 without one of its parts: not used
    (AVX2, "haswell"),
    (AVX2 - {"fma"}, "sandybridge"),
    ({"sse2", "ssse3", "sse4_1", "sse4_2", "popcnt"}, "nehalem"),
    ({"sse2"}, "x86-64"),
    (set(), "x86-64"),
])
def test_the_target_is_the_most_capable_one_the_host_can_run(flags, name):
    assert pocl_cpu.choose_target(flags) == name
    need = dict(pocl_cpu.TARGETS)[name]
    assert need <= flags
    # every more capable target needs an instruction set the host lacks
    for other, more in pocl_cpu.TARGETS[:[t for t, _ in pocl_cpu.TARGETS].index(name)]:
        assert not more <= flags, other


def test_apply_is_done_once_and_reports_what_pocl_compiles_for():
    import pyshadow

    pyshadow.device_info()
    first = pocl_cpu.applied()
    assert pocl_cpu.apply() == first                   # once per process: the same answer again
    assert first is None or first in dict(pocl_cpu.TARGETS) or first == os.environ.get(pocl_cpu.ENV)
    assert pyshadow.device_info()["pocl_cpu"] == first


def test_a_forced_cpu_name_is_given_to_pocl_and_its_kernels_answer_the_same(tmp_path):
    """``PYSHADOW_POCL_CPU=x86-64`` (SSE2 only): the probe and the kernels run on that target, and a
    visibility query answers bit for bit as on this process's target."""
    import pyshadow

    if pyshadow.device_info()["platform"] != "Portable Computing Language" or pocl_cpu._bundled_pocl() is None:
        pytest.skip("the device is not the PoCL bundled with pyopencl")
    script = textwrap.dedent("""
        import json, sys
        import numpy as np
        import pyshadow, trimesh
        scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
        scene.add(trimesh.creation.icosphere(2), trimesh.transformations.translation_matrix([0, 1.0, 0]))
        rng = np.random.default_rng(5)
        p = np.column_stack([rng.uniform(-2, 2, 4000), np.zeros(4000), rng.uniform(-2, 2, 4000)])
        d = rng.normal(size=(4000, 3)); d[:, 1] = np.abs(d[:, 1])
        v = scene.visible(p, d, surface_ids=-2)
        info = pyshadow.device_info()
        print(json.dumps({"cpu": info["pocl_cpu"], "lanes": info["lanes"], "visible": v.astype(int).tolist()}))
    """)
    runs = {}
    for name in ("x86-64", None):
        env = {**os.environ, "PYSHADOW_CACHE": str(tmp_path / str(name))}
        env.pop(pocl_cpu.ENV, None)
        env.pop("PYSHADOW_LANES", None)     # each target's own width (a 16-lane run's forced width fails on SSE2)
        if name:
            env[pocl_cpu.ENV] = name
        out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=600)
        assert out.returncode == 0, out.stderr[-2000:]
        runs[name] = json.loads(out.stdout.strip().splitlines()[-1])
    assert runs["x86-64"]["cpu"] == "x86-64"
    a, b = np.array(runs["x86-64"]["visible"]), np.array(runs[None]["visible"])
    assert 0.2 < a.mean() < 0.99
    assert np.array_equal(a, b)


def test_a_cpu_name_pocl_refuses_is_named_in_the_error(tmp_path):
    """A name PoCL's clang does not know (``PYSHADOW_POCL_CPU=no-such-cpu``): every width fails the
    probe, and the error names the setting and how to mend it."""
    import pyshadow

    if pyshadow.device_info()["platform"] != "Portable Computing Language" or pocl_cpu._bundled_pocl() is None:
        pytest.skip("the device is not the PoCL bundled with pyopencl")
    script = textwrap.dedent("""
        import pyshadow
        try:
            pyshadow.device_info()
        except pyshadow.DeviceNotSupportedError as exc:
            print("REFUSED", exc)
    """)
    env = {**os.environ, "PYSHADOW_CACHE": str(tmp_path), pocl_cpu.ENV: "no-such-cpu"}
    env.pop("PYSHADOW_LANES", None)         # the probe's own verdicts, not a forced width's
    out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    msg = out.stdout
    assert "REFUSED" in msg and "unknown target CPU 'no-such-cpu'" in msg
    assert "PYSHADOW_POCL_CPU=no-such-cpu" in msg and "x86-64" in msg

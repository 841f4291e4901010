"""OpenCL runtime: device choice, program cache, build errors, kernel files."""
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import pyshadow
from pyshadow import _cl

from conftest import REPO


def test_device_info_describes_the_device():
    info = pyshadow.device_info()
    assert {"platform", "name", "type", "compute_units", "opencl_version"} <= set(info)
    assert info["compute_units"] >= 1
    assert info["type"] in ("CPU", "GPU", "ACCELERATOR")
    assert info["opencl_version"].startswith("OpenCL ")
    assert any(info["index"] in a for a in info["available"])


def test_kernel_is_built_once_and_cached():
    a = _cl.kernel("raster.cl", "render_depth_layers", {"RES": 16, "LAYERS": 2})
    b = _cl.kernel("raster.cl", "render_depth_layers", {"RES": 16, "LAYERS": 2})
    c = _cl.kernel("raster.cl", "render_depth_layers", {"RES": 32, "LAYERS": 2})
    assert a is b
    assert c is not a
    assert _cl.program("raster.cl", {"RES": 16, "LAYERS": 2}) is _cl.program(
        "raster.cl", {"LAYERS": 2, "RES": 16})


def test_build_error_shows_compiler_log_and_saves_source():
    bad = "__kernel void broken(__global float *x) { x[0] = undefined_name; }"
    with pytest.raises(pyshadow.KernelBuildError) as info:
        _cl.build_source(bad, "broken.cl", {"FOO": 3})
    msg = str(info.value)
    assert "undefined_name" in msg          # the compiler's own words
    assert "-DFOO=3" in msg                 # the options used
    saved = Path(msg.split("full source saved to ")[1].split()[0].rstrip(";"))
    assert saved.read_text() == bad


def test_kernel_source_inlines_headers():
    src = _cl.kernel_source("raster.cl")
    assert '#include "raster_common.h"' not in src
    assert "inline float edge_fn" in src


def _run(code, cwd, env_extra=None):
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    env.update(env_extra or {})
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("value, found", [("gpu", False), ("7:3", False), ("bogus", False),
                                          ("cpu", True), ("0:0", True)])
def test_pyshadow_device_override(value, found, tmp_path):
    has_gpu = "GPU" in " ".join(pyshadow.device_info()["available"])
    if value == "gpu" and has_gpu:
        found = True
    res = _run("import pyshadow; print(pyshadow.device_info()['index'])", tmp_path,
               {"PYSHADOW_DEVICE": value, "PYTHONPATH": str(REPO) if not _installed() else ""})
    if found:
        assert res.returncode == 0, res.stderr
    else:
        assert res.returncode != 0
        assert "DeviceNotFoundError" in res.stderr
        assert "available:" in res.stderr or "found" in res.stderr
        assert "0:0" in res.stderr            # names what was found


def _installed():
    """pyshadow importable from outside the checkout (a real install)?"""
    res = _run("import pyshadow, sys; print(pyshadow.__file__)", "/")
    return res.returncode == 0


def test_kernels_ship_inside_installed_package(tmp_path):
    res = _run("import pyshadow._cl as c; print(c.kernel_dir()); import pyshadow; print(pyshadow.__file__)",
               tmp_path)
    if res.returncode != 0:
        pytest.skip("pyshadow is not installed (running from a source checkout only)")
    kdir, pkg = res.stdout.split()
    if Path(pkg).resolve().parent == (REPO / "pyshadow").resolve():
        pytest.skip("pyshadow is installed in editable mode")
    assert Path(kdir).resolve() == (Path(pkg).resolve().parent / "kernels")
    assert (Path(kdir) / "raster.cl").is_file()
    assert (Path(kdir) / "raster_common.h").is_file()


def test_source_checkout_finds_kernels_beside_package():
    res = _run("import pyshadow, pyshadow._cl as c; print(c.kernel_dir()); print(pyshadow.__file__)",
               REPO, {"PYTHONPATH": str(REPO)})
    assert res.returncode == 0, res.stderr
    kdir, pkg = res.stdout.split()
    assert Path(pkg).resolve() == (REPO / "pyshadow" / "__init__.py").resolve()
    assert Path(kdir).resolve() == (REPO / "kernels").resolve()

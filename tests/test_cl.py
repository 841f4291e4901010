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


# ---------------------------------------------------------------------------
# lane width: probe, cache, override, errors
# ---------------------------------------------------------------------------
import json

import numpy as np
import pyopencl as cl

from pyshadow._cl import probe as lanes_mod
from pyshadow._cl import launch, tables


def test_device_info_reports_lane_width_and_why():
    info = pyshadow.device_info()
    assert info["lanes"] in (1, 4, 8, 16)
    assert info["lanes_reason"]
    assert info["launch"]["lanes"] == info["lanes"] == _cl.lanes()
    assert info["launch"]["query_batch"] % info["lanes"] == 0
    if os.environ.get("PYSHADOW_LANES"):
        assert "PYSHADOW_LANES" in info["lanes_reason"]
    else:
        assert info["lanes"] in info["lanes_supported"]
        assert 1 in info["lanes_supported"]            # one query per work-item always works


def _fake_child(behaviour):
    """Child command lines that crash, hang, fail or pass, per width."""
    code = {
        "abort": "import os; os.abort()",
        "hang": "import time; time.sleep(60)",
        "garbage": "print('not json'); raise SystemExit(3)",
        "wrong": "import json; print(json.dumps({'ok': False, 'why': 'wrong answers'}))",
        "ok": "import json; print(json.dumps({'ok': True, 'why': 'fine'}))",
        "ok-then-abort": "import json, os; print(json.dumps({'ok': True, 'why': 'fine'}), "
                         "flush=True); os.abort()",
    }
    return lambda w: [sys.executable, "-c", code[behaviour[w]]]


def test_probe_survives_children_that_crash_hang_or_fail():
    found = lanes_mod.run_probe(0, 0, {"probe": "", "builds": []}, timeout=5.0,
                                command=_fake_child({16: "abort", 8: "hang", 4: "garbage",
                                                     1: "ok"}))
    assert found[16]["ok"] is False and "signal" in found[16]["why"]
    assert found[8]["ok"] is False and "no answer within 5 s" in found[8]["why"]
    assert found[4]["ok"] is False and "status 3" in found[4]["why"]
    assert found[1] == {"ok": True, "why": "fine"}
    late = lanes_mod.run_probe(0, 0, {"probe": "", "builds": []}, widths=(16,), timeout=5.0,
                               command=_fake_child({16: "ok-then-abort"}))
    assert late[16]["ok"] is False and "then the child process died of signal" in late[16]["why"]


def _choose(monkeypatch, verdicts, source="probe"):
    """_cl's choice for the current device given these probe verdicts."""
    monkeypatch.delenv("PYSHADOW_LANES", raising=False)
    monkeypatch.setattr(lanes_mod, "verdicts", lambda *a, **k: (verdicts, source))
    return _cl._probe_choice(_cl._init())


def test_failed_width_falls_back_narrower_with_a_warning_naming_the_device(monkeypatch):
    v = {16: {"ok": False, "why": "the child process died of signal 11"},
         8: {"ok": False, "why": "wrong answers"}, 4: {"ok": True, "why": "fine"},
         1: {"ok": True, "why": "fine"}}
    name = _cl.device().name.strip()
    if _cl.device().type & cl.device_type.GPU:
        assert _choose(monkeypatch, v)["lanes"] == 1
        return
    with pytest.warns(pyshadow.LaneWidthWarning) as rec:
        choice = _choose(monkeypatch, v)
    assert choice["lanes"] == 4 and choice["supported"] == [4, 1]
    msg = str(rec[0].message)
    assert name in msg and "signal 11" in msg and "Using 4 lanes" in msg
    assert "signal 11" in choice["reason"]
    # a cached verdict says the same, without warning again
    import warnings as _w
    with _w.catch_warnings():
        _w.simplefilter("error")
        assert _choose(monkeypatch, v, source="cache")["lanes"] == 4


def test_device_failing_every_width_is_a_clear_error(monkeypatch):
    v = {w: {"ok": False, "why": f"failed at {w}"} for w in _cl.LANE_WIDTHS}
    with pytest.raises(pyshadow.DeviceNotSupportedError) as info:
        _choose(monkeypatch, v)
    msg = str(info.value)
    assert repr(_cl.device().name.strip()) in msg
    assert all(f"failed at {w}" in msg for w in _cl.LANE_WIDTHS)
    assert "PYSHADOW_DEVICE" in msg and "delete it" not in msg
    # read from the cache, it says where the verdicts are kept and how to probe again (it did not)
    with pytest.raises(pyshadow.DeviceNotSupportedError) as info:
        _choose(monkeypatch, v, source="cache")
    assert f"These verdicts were read from {lanes_mod.cache_file()}: delete it to probe" in str(info.value)


@pytest.mark.parametrize("value", ["5", "0", "32", "eight", "-8", "8.0"])
def test_pyshadow_lanes_rejects_values_outside_1_4_8_16(value, tmp_path):
    res = _run("import pyshadow; print(pyshadow.device_info()['lanes'])", tmp_path,
               {"PYSHADOW_LANES": value, "PYTHONPATH": str(REPO) if not _installed() else ""})
    assert res.returncode == 1, res.stderr          # an exception, not a crash
    assert "ValueError" in res.stderr
    assert f"PYSHADOW_LANES={value!r} is not one of 1, 4, 8, 16" in res.stderr


def test_pyshadow_lanes_overrides_the_choice_checked_by_the_probe(tmp_path):
    """Was: a forced width ran no probe, so one the device cannot run failed at its first kernel. Now the
    width (1: every device runs it) is used as asked, and the probe that checked it cached its verdicts."""
    cache = tmp_path / "cache"
    res = _run("import pyshadow; i = pyshadow.device_info(); print(i['lanes'], i['lanes_reason'])",
               tmp_path, {"PYSHADOW_LANES": "1", "PYSHADOW_CACHE": str(cache),
                          "PYTHONPATH": str(REPO) if not _installed() else ""})
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("1 PYSHADOW_LANES=1 (checked by the probe)")
    entries = json.loads((cache / "lanes.json").read_text())["entries"]
    assert [e["verdicts"]["1"]["ok"] for e in entries.values()] == [True]


def test_probe_verdicts_are_cached_per_device(tmp_path, monkeypatch):
    monkeypatch.setenv("PYSHADOW_CACHE", str(tmp_path))
    st = _cl._init()
    job = _cl._probe_job(st["device"])
    calls = []
    real = lanes_mod.run_probe

    def counting(*a, **k):
        calls.append(1)
        return real(*a, **k)
    monkeypatch.setattr(lanes_mod, "run_probe", counting)
    first, src1 = lanes_mod.verdicts(*st["index"], st["platform"], st["device"], job)
    second, src2 = lanes_mod.verdicts(*st["index"], st["platform"], st["device"], job)
    assert (src1, src2) == ("probe", "cache") and len(calls) == 1
    assert first == second
    assert first[1]["ok"], first[1]                   # the real child, at one lane, passes
    data = json.loads((tmp_path / "lanes.json").read_text())
    assert (data["format"], data["version"]) == ("pyshadow-lanes", 1)
    (entry,) = data["entries"].values()
    assert entry["device"] == st["device"].name.strip()
    assert entry["driver"] == st["device"].driver_version.strip()
    # edited by hand (the checksum no longer matches), of the old unversioned form, or not JSON: probed again
    good = (tmp_path / "lanes.json").read_text()
    for text in (good.replace('"ok": false', '"ok": true').replace('"ok": true', '"ok": 1'),
                 json.dumps(data["entries"]), "{", "[]"):
        (tmp_path / "lanes.json").write_text(text)
        again, src = lanes_mod.verdicts(*st["index"], st["platform"], st["device"], job)
        assert src == "probe" and again == first
    # a forged checksum over an entry of the wrong form is not trusted either
    key = next(iter(data["entries"]))
    for bad in ({"verdicts": {"16": "x", "8": first[8], "4": first[4], "1": first[1]}},
                {"verdicts": {str(w): {"ok": "yes", "why": ""} for w in lanes_mod.LANE_WIDTHS}}):
        entries = {key: bad}
        (tmp_path / "lanes.json").write_text(json.dumps({**data, "entries": entries,
                                                         "sha256": lanes_mod._entries_digest(entries)}))
        again, src = lanes_mod.verdicts(*st["index"], st["platform"], st["device"], job)
        assert src == "probe" and again == first
    assert len(calls) == 7


def test_launch_shape_follows_the_device_kind():
    s = launch.shape()
    assert s.lanes == _cl.lanes()
    if _cl.device().type & cl.device_type.CPU:
        assert (s.kind, s.raster_group, s.query_batch) == ("CPU", 1, 512)
    else:
        assert s.query_batch == s.lanes and s.query_group <= _cl.device().max_work_group_size
    with launch.override(query_chunk=1000):
        assert launch.shape().query_chunk == 1000
    assert launch.shape().query_chunk == launch.QUERY_CHUNK
    with launch.override(query_batch=3 * s.lanes + (1 if s.lanes > 1 else 0)):
        if s.lanes > 1:
            with pytest.raises(ValueError, match="multiple of lanes"):
                launch.shape()


def test_table_structs_match_their_dtypes_on_the_device():
    """The generated C structs have every field at the dtype's byte offset."""
    fields = [("csm_type_t", tables.CSM_TYPE), ("instance_t", tables.INSTANCE), ("bvh_node_t", tables.BVH_NODE),
              ("grid_t", tables.GRID), ("grid_packet_t", tables.GRID_PACKET)]
    lines = []
    for cname, dt in fields:
        lines.append(f"    {{ __global const {cname} *r = (__global const {cname} *)base;")
        lines.append(f"      out[n++] = (int)sizeof({cname});")
        for f in dt.names:
            lines.append(f"      out[n++] = (int)((__global const char *)&r->{f} - base); }}"
                         if f == dt.names[-1] else
                         f"      out[n++] = (int)((__global const char *)&r->{f} - base);")
    src = ('#include "scene_types.h"\n__kernel void offsets(__global const char *base, '
           '__global int *out) {\n    int n = 0;\n' + "\n".join(lines) + "\n}\n")
    from pyshadow._cl.tables import GENERATED_HEADERS
    src = src.replace('#include "scene_types.h"', GENERATED_HEADERS["scene_types.h"])
    prg = _cl.build_source(src, "offsets.cl")
    want = []
    for _c, dt in fields:
        want += [dt.itemsize] + [dt.fields[f][1] for f in dt.names]
    out = np.zeros(len(want), np.int32)
    buf = _cl.empty(out.nbytes)
    prg.offsets(_cl.queue(), (1,), None, _cl.empty(256), buf)
    cl.enqueue_copy(_cl.queue(), out, buf)
    assert out.tolist() == want
    assert tables.CSM_TYPE.itemsize == 88 and tables.INSTANCE.itemsize == 104 and tables.BVH_NODE.itemsize == 32
    assert tables.GRID.itemsize == 52 and tables.GRID_PACKET.itemsize == 80


def test_c_struct_refuses_fields_it_cannot_lay_out_alike():
    with pytest.raises(TypeError, match="4-byte"):
        tables.c_struct(np.dtype([("a", "<f8")]), "bad_t")
    with pytest.raises(ValueError, match="padding"):
        tables.c_struct(np.dtype({"names": ["a", "b"], "formats": ["<i4", "<i4"],
                                  "offsets": [0, 8]}), "gap_t")

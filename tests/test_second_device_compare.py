"""benchmarks/second_device.py: its comparison on the default device against itself, and altered answers reported
as differences (ulp counts, CSM bytes, bool arrays, Oclgrind findings) with the exit status a check needs."""
from __future__ import annotations

import sys

import numpy as np
import pytest

from conftest import REPO

sys.path.insert(0, str(REPO / "benchmarks"))

import second_device as sd  # noqa: E402
from _second_device_cases import run_cases  # noqa: E402

ONLY = ("build_tri", "vis_nearest", "ao_16")


@pytest.fixture(scope="module")
def answers(tmp_path_factory):
    arrays, seconds, errors = run_cases(tmp_path_factory.mktemp("second_device"), only=ONLY)
    assert errors == {}
    assert set(seconds) == set(ONLY)
    return arrays


def _row(rows, case):
    return next(r for r in rows if r["case"] == case)


def test_the_same_answers_agree(answers):
    rows, status = sd.summarize(answers, {k: v.copy() for k, v in answers.items()})
    assert status == 0
    assert [r["case"] for r in rows] == ["build_tri", "ao_16", "vis_nearest"]
    assert _row(rows, "build_tri")["csm"] == "equal"
    assert all(r["ok"] and r["float_equal"] == r["float"] and r["exact_equal"] == r["exact"] for r in rows)


def test_a_float_three_ulps_off_is_counted_but_not_fatal(answers):
    dev = {k: v.copy() for k, v in answers.items()}
    ao = dev["ao_16/ao"]
    assert ao.dtype == np.float32 and ao.size > 5
    x = ao[5]
    for _ in range(3):
        x = np.nextafter(x, np.float32(np.inf))
    ao[5] = x
    rows, status = sd.summarize(answers, dev)
    r = _row(rows, "ao_16")
    assert status == 0 and r["ok"]
    assert r["max_ulp"] == 3
    assert r["max_abs"] == pytest.approx(float(x) - float(answers["ao_16/ao"][5]))
    assert r["float_equal"] == r["float"] - 1


def test_a_flipped_bool_or_csm_byte_fails_the_check(answers):
    dev = {k: v.copy() for k, v in answers.items()}
    dev["vis_nearest/v"][3] = ~dev["vis_nearest/v"][3]
    dev["build_tri/csm"][-1] ^= 1
    rows, status = sd.summarize(answers, dev)
    assert status == 1
    assert _row(rows, "build_tri")["csm"] == "DIFFER"
    vis = _row(rows, "vis_nearest")
    assert (vis["exact_equal"], vis["exact"], vis["ok"]) == (0, 1, False)
    assert _row(rows, "ao_16")["ok"]


def test_an_array_on_one_side_only_or_a_failed_case_fails(answers):
    dev = {k: v for k, v in answers.items() if k != "ao_16/bent"}
    assert sd.summarize(answers, dev)[1] == 1
    assert sd.summarize(answers, answers, dev_err={"vis_nearest": "RuntimeError: x"})[1] == 1
    err = {"ao_16": "RuntimeError: x"}
    assert sd.summarize(answers, answers, base_err=err, dev_err=err)[1] == 1


OCLGRIND = """=== CASE shadow_map
Read-write data race at global memory address 0x2a00000000012c
\tKernel: sm_raster
\t
\tFirst entity:  Global(4,0,0) Local(0,0,0) Group(4,0,0)
\tAt line 161 (column 30) of input.cl:
=== CASE vis_nearest
Invalid read of size 4 at global memory address 0x1000000000040
\tKernel: scene_visible
\tEntity: Global(7,0,0) Local(7,0,0) Group(0,0,0)
\tAt line 88 (column 12) of input.cl:
=== CASE ao_16
Oclgrind - OpenCL runtime error detected
	Function: clGetDeviceInfo
	Error:    CL_INVALID_VALUE
	For argument 'param_name'
"""


def test_oclgrind_findings_by_case(answers):
    found = sd.parse_findings(OCLGRIND)
    assert found == {"shadow_map": {("race", "sm_raster", "161"): 1},
                     "ao_16": {("api", "clGetDeviceInfo", "CL_INVALID_VALUE"): 1},
                     "vis_nearest": {("invalid read", "scene_visible", "88"): 1}}
    assert sd.fatal_findings(found) == 1
    rows, status = sd.summarize(answers, answers, findings=found)
    assert status == 1
    assert not _row(rows, "vis_nearest")["ok"]
    assert _row(rows, "shadow_map")["ok"] and _row(rows, "ao_16")["ok"]      # the known benign ones alone
    assert sd.fatal_findings(sd.parse_findings(OCLGRIND.replace("sm_raster", "sm_lookup"))) == 2


def test_a_device_that_does_not_exist_is_refused_with_the_list(capsys):
    assert sd.main(["--device", "99:0"]) == 2
    err = capsys.readouterr().err
    assert "'99:0' names no device; available: 0:0" in err

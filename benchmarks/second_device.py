"""pyshadow on a second OpenCL device, checked against another (the default one unless told).

    python benchmarks/second_device.py --device P:D [--baseline P:D] [--shape cpu|gpu|both] [--quick] [--json]

Each device runs the same small cases (``_second_device_cases.py``: CSM builds of
primitives and bundled meshes, Scene.visible, AO, instances, G-buffer and
render, shadow map, cube-map AO, SSAO, filters) in a child process of its own
with ``PYSHADOW_DEVICE`` set there; the baseline runs first and leaves the query
cases' CSMs for the other, so both query the same maps. ``--shape gpu`` launches
with the GPU branch of ``pyshadow._cl.launch`` (one query per work-item at 1 lane,
groups of up to 128, the raster's group left to the driver) whatever the device
says it is, through ``launch.override``.

Per case it reports: CSM file bytes equal or not; how many bool/int arrays are
equal; float arrays equal, or their largest difference in ulps and in absolute
value; Oclgrind's findings on stderr where a device is Oclgrind (invalid reads and
writes, uninitialized values, data races, barrier divergence, API errors); each
device's seconds. Exit status 1 where a CSM, bool or int result differs, an
array is on one side only, a case fails, a child dies, or a finding other than
the known benign ones (:data:`BENIGN`) appears; 2 for a device that does
not exist (the message lists those that do); 0 otherwise. Float differences are
reported, never fatal: devices may round differently.

OpenCL devices are listed as pyopencl lists them, so an ``OCL_ICD_VENDORS`` you
set (for an Oclgrind .icd file, benchmarks/README.md) is honoured.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
# Oclgrind's finding kinds, as the first line of each of its reports starts
FINDINGS = {"Invalid read": "invalid read", "Invalid write": "invalid write", "Uninitialized": "uninitialized",
            "Read-write data race": "race", "Write-write data race": "race", "divergence": "divergence",
            "OpenCL runtime error": "api"}
# sm_raster reads a texel before its atomic_min (kernels/shadow_map.cl, "most overdraw skips the atomic"):
# depths only decrease, so a stale read is never below the stored value and can only cost an extra atomic_min;
# pyopencl asks clGetDeviceInfo for parameters newer than Oclgrind's OpenCL 1.2 (OCLGRIND_CHECK_API: CL_INVALID_VALUE)
BENIGN = {("race", "sm_raster"), ("api", "clGetDeviceInfo")}


# ------------------------------------------------------------------ comparison
def ordered_bits(x: np.ndarray) -> np.ndarray:
    """Float32/64 values as integers ordered like the floats (adjacent floats differ by 1), as float64."""
    i = x.view(np.int32 if x.dtype == np.float32 else np.int64).astype(np.int64)
    sign = np.int64(-2 ** 31) if x.dtype == np.float32 else np.int64(-2 ** 63)
    return np.where(i < 0, sign - i, i).astype(np.float64)


def compare_array(key: str, a: np.ndarray, b: np.ndarray) -> dict:
    """One array of the baseline (``a``) against the device's (``b``).

    Returns a dict: ``key``, ``kind`` ('csm', 'exact' for bool/int, 'float'), ``size``, ``differ`` (elements
    that differ), and for floats ``max_ulp`` (floats between the two values), ``max_abs`` and ``scale_ulp``
    (``max_abs`` in ulps of the baseline array's largest finite magnitude) over the differing elements (NaNs
    at the same places are equal).
    """
    a, b = np.asarray(a), np.asarray(b)
    kind = "csm" if key.endswith("/csm") else ("float" if a.dtype.kind == "f" else "exact")
    out = {"key": key, "kind": kind, "size": int(a.size), "differ": 0}
    if a.shape != b.shape or a.dtype != b.dtype:
        out.update(differ=max(a.size, b.size, 1), note=f"shape/dtype {a.shape} {a.dtype} vs {b.shape} {b.dtype}")
        return out
    if kind != "float":
        out["differ"] = int(np.count_nonzero(a != b))
        return out
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    out["differ"] = int(np.count_nonzero(~same))
    if out["differ"]:
        x, y = a[~same], b[~same]
        out["max_ulp"] = int(np.max(np.abs(ordered_bits(x) - ordered_bits(y))))
        with np.errstate(invalid="ignore"):
            d = np.abs(x.astype(np.float64) - y.astype(np.float64))
        out["max_abs"] = float(np.nanmax(d)) if np.any(~np.isnan(d)) else float("nan")
        # near 0 (a coordinate of a point on an axis) the ulp count is large for a tiny change: the difference
        # in ulps of the array's largest finite value says how large it is at the array's scale
        fin = np.abs(a[np.isfinite(a)])
        spacing = float(np.spacing(fin.max() if fin.size else a.dtype.type(1)))
        out["scale_ulp"] = int(np.ceil(out["max_abs"] / spacing)) if np.isfinite(out["max_abs"]) else -1
    return out


def compare(base: dict, dev: dict) -> dict:
    """Per case: the comparisons of its arrays, and the arrays only one side has."""
    cases: dict = {}
    for key in sorted(set(base) | set(dev)):
        case = key.split("/", 1)[0]
        row = cases.setdefault(case, {"arrays": [], "missing": []})
        if key in base and key in dev:
            row["arrays"].append(compare_array(key, base[key], dev[key]))
        else:
            row["missing"].append(key)
    return cases


def parse_findings(text: str) -> dict:
    """Oclgrind's findings in a child's stderr, by case: ``{case: {(kind, kernel, line): count}}``.

    The child writes ``=== CASE name`` before each case; a report is a line starting with one of
    :data:`FINDINGS` followed by indented lines naming the kernel (``Kernel: k``) and source line
    (``At line N``, of the kernel's source with its headers expanded); an API error (OCLGRIND_CHECK_API) names
    the function and the error code instead.
    """
    out: dict = {}
    case, lines, i = "(setup)", text.splitlines(), 0
    while i < len(lines):
        ln = lines[i]
        i += 1
        if ln.startswith("=== CASE "):
            case = ln[9:].strip()
            continue
        kind = next((v for k, v in FINDINGS.items() if k in ln), None)
        if kind is None or ln.startswith((" ", "\t")):
            continue
        kernel = where = ""
        while i < len(lines) and lines[i].startswith((" ", "\t")):
            s = lines[i].strip()
            kernel = s.split(":", 1)[1].strip() if s.startswith(("Kernel:", "Function:")) and not kernel else kernel
            m = re.match(r"At line (\d+)|Error:\s*(\w+)", s)
            where = (m.group(1) or m.group(2)) if m and not where else where
            i += 1
        k = (kind, kernel, where)
        out.setdefault(case, {})[k] = out.setdefault(case, {}).get(k, 0) + 1
    return out


def fatal_findings(found: dict) -> int:
    """How many findings are not known to be benign (:data:`BENIGN`)."""
    return sum(n for per in found.values() for (kind, kernel, _), n in per.items() if (kind, kernel) not in BENIGN)


def summarize(base: dict, dev: dict, base_err: dict | None = None, dev_err: dict | None = None,
              findings: dict | None = None) -> tuple[list[dict], int]:
    """Rows per case and the exit status (1 where a CSM/bool/int result differs, an array or a case is on
    one side only, a case failed, or a non-benign finding appears; else 0)."""
    base_err, dev_err, findings = base_err or {}, dev_err or {}, findings or {}
    rows, status = [], 0
    cmp = compare(base, dev)
    for case in sorted(set(cmp) | set(base_err) | set(dev_err) | (set(findings) - {"(setup)"}),
                       key=lambda c: (not c.startswith("build_"), c)):
        c = cmp.get(case, {"arrays": [], "missing": []})
        exact = [a for a in c["arrays"] if a["kind"] != "float"]
        floats = [a for a in c["arrays"] if a["kind"] == "float"]
        csm = [a for a in exact if a["kind"] == "csm"]
        row = {"case": case, "csm": None if not csm else ("equal" if not csm[0]["differ"] else "DIFFER"),
               "exact_equal": sum(not a["differ"] for a in exact), "exact": len(exact),
               "float_equal": sum(not a["differ"] for a in floats), "float": len(floats),
               "max_ulp": max([a.get("max_ulp", 0) for a in floats], default=0),
               "max_abs": max([a.get("max_abs", 0.0) for a in floats], default=0.0),
               "scale_ulp": max([a.get("scale_ulp", 0) for a in floats], default=0),
               "missing": c["missing"], "arrays": c["arrays"], "errors": [base_err.get(case), dev_err.get(case)],
               "findings": {f"{k}:{kern}:{line}": n for (k, kern, line), n in findings.get(case, {}).items()}}
        bad = (row["exact_equal"] < row["exact"] or c["missing"] or case in base_err or case in dev_err
               or fatal_findings({case: findings.get(case, {})}))
        row["ok"] = not bad
        status |= int(bool(bad))
        rows.append(row)
    if fatal_findings({"(setup)": findings.get("(setup)", {})}):
        status = 1
    return rows, status


# ------------------------------------------------------------------ devices
def resolve_device(spec: str | None):
    """(P:D string, description) of the device ``spec`` names ('P:D', 'cpu', 'gpu'; None: pyshadow's default).

    Raises pyshadow's DeviceNotFoundError, naming every device found, where ``spec`` names none.
    """
    from pyshadow._cl import _choose_device
    pi, di, plat, dev = _choose_device(spec or "")
    return f"{pi}:{di}", f"{plat.name.strip()} / {dev.name.strip()}"


def run_child(device: str, shape: str, work: Path, quick: bool, tag: str, timeout: float) -> dict:
    """Run the cases on ``device`` in a child process; its arrays, seconds, errors, stderr and exit code."""
    out = work / tag
    out.mkdir(parents=True, exist_ok=True)
    for stale in ("arrays.npz", "meta.json"):       # a child that dies must not leave an earlier run's answers
        (out / stale).unlink(missing_ok=True)
    env = dict(os.environ, PYSHADOW_DEVICE=device)
    env.setdefault("OCLGRIND_MAX_ERRORS", "1000")
    env.setdefault("OCLGRIND_CHECK_API", "1")
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", str(out), "--shape", shape,
           "--work", str(work)] + (["--quick"] if quick else [])
    t = time.perf_counter()
    with open(out / "stderr.txt", "w") as err:
        try:
            rc = subprocess.run(cmd, env=env, stdout=subprocess.DEVNULL, stderr=err, timeout=timeout).returncode
        except subprocess.TimeoutExpired:
            rc = "timeout"
    res = {"rc": rc, "wall": time.perf_counter() - t, "stderr": (out / "stderr.txt").read_text(errors="replace")}
    meta = out / "meta.json"
    res.update(json.loads(meta.read_text()) if meta.is_file() else {"seconds": {}, "errors": {}, "shape": None})
    res["arrays"] = dict(np.load(out / "arrays.npz")) if (out / "arrays.npz").is_file() else {}
    return res


def child_main(out: Path, shape: str, work: Path, quick: bool) -> int:
    import warnings

    warnings.simplefilter("ignore")
    import pyshadow._cl as pcl
    from _second_device_cases import run_cases
    from pyshadow._cl import launch
    kw = {}
    if shape == "gpu":
        dev = pcl.device()
        wg = max(1, min(int(dev.max_work_group_size), int(dev.max_work_item_sizes[0])))
        kw = dict(kind="GPU", query_batch=pcl.lanes(), query_group=min(128, wg), raster_group=None)
    with launch.override(**kw):
        s = launch.shape()
        arrays, seconds, errors = run_cases(out, quick, csm_dir=work / "query_csm", log=sys.stderr)
    if "oclgrind" in pcl.device_info()["platform"].lower():
        _control(pcl)
    np.savez(out / "arrays.npz", **arrays)
    (out / "meta.json").write_text(json.dumps({"seconds": seconds, "errors": errors, "shape": s.as_dict(),
                                               "device": "{platform} / {name}".format(**pcl.device_info())}))
    return 0


#: a kernel that reads one float past its buffer: Oclgrind must report it after the cases, else it has stopped
#: reporting (OCLGRIND_MAX_ERRORS counts per process) and the cases' silence means nothing
CONTROL = "__kernel void control_oob(__global const float *a, __global float *b) { b[0] = a[4]; }"


def _control(pcl) -> None:
    import pyopencl as cl

    print("=== CASE (control)", file=sys.stderr, flush=True)
    ctx, q = pcl.context(), pcl.queue()
    a = cl.Buffer(ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=np.zeros(4, np.float32))
    b = cl.Buffer(ctx, cl.mem_flags.WRITE_ONLY, 4)
    cl.Program(ctx, CONTROL).build().control_oob(q, (1,), None, a, b)
    q.finish()
    sys.stderr.flush()


# ------------------------------------------------------------------ report
def _fmt_row(r: dict, tb: float | None, td: float | None) -> str:
    parts = []
    if r["csm"]:
        parts.append(f"CSM bytes {r['csm']}")
    n_exact = r["exact"] - (1 if r["csm"] else 0)
    if n_exact:
        eq = r["exact_equal"] - (1 if r["csm"] == "equal" else 0)
        parts.append(f"bool/int {eq} of {n_exact} equal")
    if r["float"]:
        f = f"float {r['float_equal']} of {r['float']} equal"
        if r["float_equal"] < r["float"]:
            f += f": max {r['max_ulp']} ulp ({r['scale_ulp']} at scale), abs {r['max_abs']:.2g}"
        parts.append(f)
    if r["missing"]:
        parts.append("ONE SIDE ONLY: " + ", ".join(k.split("/", 1)[1] for k in r["missing"]))
    for who, e in zip(("baseline", "device"), r["errors"]):
        if e:
            parts.append(f"{who} error: {e[:80]}")
    found = "; ".join(f"{k} x{n}" + (" (benign)" if tuple(k.split(":")[:2]) in BENIGN else "")
                      for k, n in r["findings"].items() if not k.startswith("api:clGetDeviceInfo")) or "-"
    t = " / ".join("-" if x is None else f"{x:.2f}" for x in (tb, td))
    return f"| {r['case']} | {'; '.join(parts) or 'no arrays'} | {found} | {t} | {'ok' if r['ok'] else 'DIFFERS'} |"


def report(shape: str, base: dict, dev: dict, names: tuple[str, str]) -> tuple[str, list[dict], int]:
    """The Markdown table of one shape, its rows and its exit status."""
    findings: dict = {}
    for name, res in zip(names, (base, dev)):       # Oclgrind's reports, on whichever side it is
        if "oclgrind" in name.lower():
            for case, per in parse_findings(res["stderr"]).items():
                for k, n in per.items():
                    findings.setdefault(case, {})[k] = findings.setdefault(case, {}).get(k, 0) + n
    control = {k[1] for k in findings.pop("(control)", {}) if k[0] == "invalid read"}
    rows, status = summarize(base["arrays"], dev["arrays"], base["errors"], dev["errors"], findings)
    lines = [f"### shape {shape}: device {names[1]} against baseline {names[0]}", "",
             f"device launch shape: {dev.get('shape')}", "",
             "| case | result | device findings | seconds baseline / device | |", "|---|---|---|---|---|"]
    for r in rows:
        lines.append(_fmt_row(r, base["seconds"].get(r["case"]), dev["seconds"].get(r["case"])))
    for who, res in (("baseline", base), ("device", dev)):
        if res["rc"] != 0:
            status = 1
            tail = "\n".join(res["stderr"].strip().splitlines()[-5:])
            last = re.findall(r"^=== CASE (\S+)", res["stderr"], re.M)
            lines.append(f"\n{who} child exit status {res['rc']}, " + (f"in case {last[-1]}" if last else
                                                                          "before its first case") + f":\n{tail}")
    for name, res in zip(names, (base, dev)):
        if "oclgrind" in name.lower() and res["rc"] == 0 and "control_oob" not in control:
            status = 1
            lines.append(f"\n{name}: Oclgrind did not report the control kernel's out-of-bounds read after the cases: "
                         "it had stopped reporting (raise OCLGRIND_MAX_ERRORS), so their silence means nothing")
    setup = findings.get("(setup)", {})
    if setup:
        lines.append(f"\nfindings outside the cases: {setup}")
    tot = lambda res: sum(res["seconds"].values())      # noqa: E731
    n_ok = sum(r["ok"] for r in rows)
    lines.append(f"\n{n_ok} of {len(rows)} cases without a CSM/bool/int difference or finding; "
                 f"case seconds {tot(base):.1f} (baseline) / {tot(dev):.1f} (device), "
                 f"child wall {base['wall']:.1f} / {dev['wall']:.1f} s")
    return "\n".join(lines), rows, status


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--device", required=False, help="the device to check, as PYSHADOW_DEVICE takes it (P:D)")
    ap.add_argument("--baseline", default=None, help="the device to compare with (default: pyshadow's choice)")
    ap.add_argument("--shape", choices=("cpu", "gpu", "both"), default="cpu",
                    help="launch shape: cpu = each device's own, gpu = the GPU branch forced (default: %(default)s)")
    ap.add_argument("--quick", action="store_true", help="a few cases only")
    ap.add_argument("--json", action="store_true", help="print the rows as JSON instead of tables")
    ap.add_argument("--work", type=Path, default=None, help="folder for the children's files (default: a temporary)")
    ap.add_argument("--timeout", type=float, default=1800.0, help="seconds per child (default: %(default)s)")
    ap.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        return child_main(a.child, a.shape, a.work, a.quick)
    if not a.device:
        ap.error("--device P:D is required")
    from pyshadow._cl import DeviceNotFoundError
    try:
        dev, dev_name = resolve_device(a.device)
        base, base_name = resolve_device(a.baseline)
    except DeviceNotFoundError as exc:
        print(f"second_device.py: --device {a.device!r} / --baseline {a.baseline!r}: {exc}", file=sys.stderr)
        return 2
    if dev == base:
        print(f"second_device.py: the baseline is the device itself ({dev} {dev_name}); name another with "
              "--baseline P:D", file=sys.stderr)
        return 2
    shapes = ("cpu", "gpu") if a.shape == "both" else (a.shape,)
    tmp = None if a.work else tempfile.TemporaryDirectory(prefix="second_device_")
    work = Path(a.work or tmp.name)
    status, out = 0, {"device": f"{dev} {dev_name}", "baseline": f"{base} {base_name}", "shapes": {}}
    try:
        for shape in shapes:
            rb = run_child(base, shape, work, a.quick, f"baseline_{shape}", a.timeout)
            rd = run_child(dev, shape, work, a.quick, f"device_{shape}", a.timeout)
            text, rows, st = report(shape, rb, rd, (f"{base} {base_name}", f"{dev} {dev_name}"))
            status |= st
            out["shapes"][shape] = {"rows": rows, "status": st, "seconds": [rb["seconds"], rd["seconds"]],
                                    "launch": [rb.get("shape"), rd.get("shape")], "rc": [rb["rc"], rd["rc"]]}
            if not a.json:
                print(text + "\n", flush=True)
    finally:
        if tmp is not None:
            tmp.cleanup()
    if a.json:
        print(json.dumps(out, indent=1, default=str))
    else:
        print("exit status", status)
    return status


if __name__ == "__main__":
    sys.path.insert(0, str(HERE))
    sys.exit(main())

"""Child process of the lane-width probe (run as a script, not imported).

Usage: ``python probe_child.py PLATFORM DEVICE LANES JOB`` with JOB a JSON
file: ``{"probe": source of kernels/probe.cl, "builds": [{"label", "source",
"options"}, ...]}`` (headers inlined). Builds the probe kernel with
``-DLANES``, runs it and compares every answer with NumPy; then builds each
of the lane kernels (as pyshadow would, at this width) and creates all their
kernels. A build whose log warns that a vector argument changes the ABI
fails the width. Prints one JSON
line ``{"ok": bool, "why": str}`` and exits 0; a compiler that crashes or
hangs takes only this process down (the parent sees the signal or its
timeout). Imports nothing from pyshadow, so a broken device cannot break the
import either (it loads ``pocl_cpu.py`` by its path: the standard library only).
"""
import importlib.util
import json
import os
import sys

import numpy as np
import pyopencl as cl

# clang's warning when a vector type does not match the target's registers:
# the build "succeeds" but calls between the kernel and PoCL's builtin library
# disagree on the ABI (seen on AMD Zen 4 with LLVM 14: crashes, hangs, wrong
# kernels), so the width is refused even if this run happened to work
ABI_WARNING = "changes the ABI"


# the rows of lane_probe's outputs (kernels/probe.cl), named in a refusal's reason
FLOAT_ROWS = ("ceil/floor/fmin/fmax", "select/sqrt/VSEL", "CONVERT/VSEL", "VANY/MASK", "VABS", "VSQRT",
              "VMIN/unaligned VLOAD", "VMAX/unaligned VLOAD", "VSEL of -0", "DEINTERLEAVE3 X", "DEINTERLEAVE3 Y",
              "DEINTERLEAVE3 Z", "LANE_GATHER", "LANE_LOAD/LANE_STORE (float)", "CONVERT int -> float")
INT_ROWS = ("CONVERT float -> int", "LANE_BITS", "BIT_LOW", "VANY/VALL", "LANE_LOAD/LANE_STORE/IMIN (int)",
            "VMIN/VMAX/LANE_IDS (int)", "CONVERT int -> uchar", "MASK/&/~/| (int)", "VSEL (int)")
# float rows compared within 4e-7 relative (sqrt may be 3 ulp off the correctly rounded value on some devices);
# the rest bit for bit (negative zero included)
SQRT_ROWS = (1, 5)


def inputs(n, lanes):
    """x (n + 16 float32: values of both signs, negative zero beside zero, values at and past 2^24), the lane
    masks (n int32: per group of lanes none, all, the last lane only, the first only, the middle one only, or
    mixed) and the (n, 3) float32 rows to deinterleave."""
    x = np.linspace(-3.0, 3.0, n + 16, dtype=np.float32)
    x[::7] *= -1.0
    special = [-0.0, 0.0, -0.0, -0.0, 0.0, 2.0 ** 24, -2.0 ** 24, 2.0 ** 24 + 2, 5592405.0, -5592406.0, 1e7,
               -1.5, 0.5, -0.3, -2.5, 1.5]
    x[9:9 + len(special)] = special
    groups = n // lanes
    rng = np.random.default_rng(7)
    masks = np.zeros((groups, lanes), np.int32)
    for g in range(groups):
        kind = g % 6
        if kind == 1:
            masks[g] = 1
        elif kind in (2, 3, 4):
            masks[g, (lanes - 1, 0, lanes // 2)[kind - 2]] = -1 if kind == 2 else 7
        elif kind == 5:
            masks[g] = rng.integers(0, 2, lanes) * 3
    t = (np.arange(3 * n) * np.float32(0.75) - np.float32(200)).astype(np.float32).reshape(n, 3)
    return x, masks.reshape(-1), t


def expected(x, mi, t, n, lanes):
    """The float32 (15, n) and int32 (9, n) rows lane_probe writes."""
    v, w = x[:n], x[1:n + 1]
    lane = np.arange(n) % lanes
    group = np.arange(n) - lane
    m = mi != 0
    a = np.ceil(np.minimum(v, np.float32(2))) + np.floor(np.maximum(v, np.float32(-2)))
    b = np.where(v > 0, np.sqrt(np.abs(v)), -v).astype(np.float32)
    ci = np.trunc(v * np.float32(3)).astype(np.int32)
    d = np.repeat((v.reshape(-1, lanes) > 1.5).any(axis=1), lanes).astype(np.float32)
    lanes_v = w.copy()
    lanes_v[lane == lanes - 1] = v[lane == 0]
    fl = [a, b, ci.astype(np.float32), d, np.abs(v), np.sqrt(np.abs(v)), np.where(w < v, w, v),
          np.where(w > v, w, v), np.where(m, np.float32(-0.0), v), t[:, 0], t[:, 1], t[:, 2],
          x[group + (5 * lane + 3) % lanes], lanes_v, (3 * ci + 1).astype(np.float32)]
    mg = m.reshape(-1, lanes)
    bits = (mg * (1 << np.arange(lanes))).sum(axis=1)
    seen = np.zeros(len(mg), np.int64)
    for lo in range(lanes):
        seen = np.where(mg[:, lo], 3 * seen + lo + 1, seen)
    anyall = mg.any(1) + 2 * mg.all(1) + 4 * (~mg).any(1) + 8 * (~mg).all(1)
    ints = [ci, np.repeat(bits, lanes), np.repeat(seen, lanes), np.repeat(anyall, lanes), np.minimum(ci, 2 - ci),
            np.clip(ci + lane, -5, 5), (37 * ci) & 0xFF, -((m & ~(v > 1)) | (ci == 0)).astype(np.int32),
            np.where(v > 0.5, 1, np.where(v < 0, 0, ci))]
    return np.stack(fl).astype(np.float32), np.stack(ints).astype(np.int32)


def compare(x, out, iout, want, iwant):
    """None where lane_probe's answers (``out`` float32 (15, n), ``iout`` int32 (9, n)) are NumPy's
    (``want``, ``iwant``), else the first wrong one in a line, named by its construct."""
    exact = np.ones(out.shape, bool)
    exact[list(SQRT_ROWS)] = False
    ok = np.where(exact, out.view(np.int32) == want.view(np.int32),
                  np.isclose(out, want, rtol=4e-7, atol=0))
    for good, got, wants, names in ((ok, out, want, FLOAT_ROWS), (iout == iwant, iout, iwant, INT_ROWS)):
        bad = np.argwhere(~good)
        if len(bad):
            r, k = (int(j) for j in bad[0])
            return (f"wrong answers ({names[r]}, first at x={float(x[k])!r}, value {k}: got {got[r, k].item()!r}, "
                    f"expected {wants[r, k].item()!r})")
    return None


def _failure(exc, prg, dev) -> str:
    """A failed build in a line: the status's name and the compiler's own log (pyopencl's message repeats the
    status and names the device by its address)."""
    try:
        status = cl.status_code.to_string(exc.code)
    except Exception:
        status = type(exc).__name__
    try:
        log = " ".join((prg.get_build_info(dev, cl.program_build_info.LOG) or "").split())
    except cl.Error:
        log = ""
    return f"{status}: {log[:300]}" if log else f"{status} ({' '.join(str(exc).split())[:300]})"


def _build(ctx, dev, src, options, label):
    """None on success, else why not."""
    prg = cl.Program(ctx, src)
    try:
        prg.build(options=options)
    except cl.Error as exc:
        return f"building {label} failed: {_failure(exc, prg, dev)}"
    log = prg.get_build_info(dev, cl.program_build_info.LOG) or ""
    if ABI_WARNING in log:
        return (f"building {label}, the compiler warns that a vector argument of this width "
                f"{ABI_WARNING} (its target lacks the registers that its builtin library "
                "assumes)")
    try:
        prg.all_kernels()
    except cl.Error as exc:
        return f"creating the kernels of {label} failed: {str(exc).strip()[:300]}"
    return prg


def main():
    pi, di, lanes = (int(a) for a in sys.argv[1:4])
    with open(sys.argv[4]) as f:
        job = json.load(f)
    # the CPU name the parent gave PoCL (pocl_cpu.py, a file of the standard library only)
    spec = importlib.util.spec_from_file_location("pocl_cpu", os.path.join(os.path.dirname(__file__), "pocl_cpu.py"))
    pocl_cpu = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(pocl_cpu)
    pocl_cpu.apply()
    dev = cl.get_platforms()[pi].get_devices()[di]
    ctx = cl.Context([dev])
    q = cl.CommandQueue(ctx)
    prg = _build(ctx, dev, job["probe"], ["-cl-std=CL1.2", f"-DLANES={lanes}"], "probe.cl")
    if isinstance(prg, str):
        return {"ok": False, "why": prg}
    n = 256
    x, mi, t = inputs(n, lanes)
    mf = cl.mem_flags
    bufs = [cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a) for a in (x, mi, t)]
    ob, iob = cl.Buffer(ctx, mf.WRITE_ONLY, 4 * 15 * n), cl.Buffer(ctx, mf.WRITE_ONLY, 4 * 9 * n)
    prg.lane_probe(q, (n // lanes,), None, *bufs, np.int32(n), ob, iob)
    out, iout = np.empty((15, n), np.float32), np.empty((9, n), np.int32)
    cl.enqueue_copy(q, out, ob)
    cl.enqueue_copy(q, iout, iob)
    q.finish()
    why = compare(x, out, iout, *expected(x, mi, t, n, lanes))
    if why:
        return {"ok": False, "why": why}
    for b in job["builds"]:
        r = _build(ctx, dev, b["source"], list(b["options"]) + [f"-DLANES={lanes}"], b["label"])
        if isinstance(r, str):
            return {"ok": False, "why": r}
    return {"ok": True, "why": "built and computed correctly"}


if __name__ == "__main__":
    print(json.dumps(main()), flush=True)

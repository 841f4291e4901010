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


def expected(x, lanes):
    a = np.ceil(np.minimum(x, np.float32(2))) + np.floor(np.maximum(x, np.float32(-2)))
    b = np.where(x > 0, np.sqrt(np.abs(x)), -x).astype(np.float32)
    c = np.trunc(x * np.float32(3)).astype(np.float32)
    d = np.repeat((x.reshape(-1, lanes) > 1.5).any(axis=1), lanes).astype(np.float32)
    return np.stack([a, b, c, d]).astype(np.float32)


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
    x = np.linspace(-3.0, 3.0, n, dtype=np.float32)
    x[::7] *= -1.0
    mf = cl.mem_flags
    xb = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=x)
    ob = cl.Buffer(ctx, mf.WRITE_ONLY, 4 * 4 * n)
    prg.lane_probe(q, (n // lanes,), None, xb, np.int32(n), ob)
    out = np.empty((4, n), np.float32)
    cl.enqueue_copy(q, out, ob)
    q.finish()
    want = expected(x, lanes)
    exact = np.array_equal(out[[0, 2, 3]], want[[0, 2, 3]])
    # sqrt may be 3 ulp off the correctly rounded value on some devices
    close = np.allclose(out[1], want[1], rtol=4e-7, atol=0)
    if not (exact and close):
        bad = int(np.argmax(np.any(out != want, axis=0)))
        return {"ok": False, "why": f"wrong answers (first at x={x[bad]!r}: got "
                                    f"{out[:, bad].tolist()}, expected {want[:, bad].tolist()})"}
    for b in job["builds"]:
        r = _build(ctx, dev, b["source"], list(b["options"]) + [f"-DLANES={lanes}"], b["label"])
        if isinstance(r, str):
            return {"ok": False, "why": r}
    return {"ok": True, "why": "built and computed correctly"}


if __name__ == "__main__":
    print(json.dumps(main()), flush=True)

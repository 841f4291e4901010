"""The lane probe (kernels/probe.cl) exercises every construct of lanes.h that the lane kernels use.

A device whose compiler gets one of them wrong at a width must have that width refused, not answer wrong in the
lane kernels (Oclgrind 21.10's vector ?: in VSEL passed a probe that did not use it). Here PoCL is given such a
defect by a broken macro, defined over lanes.h's own in the probe's source: the probe must refuse the width, and
pass it with the true macros, in either of lanes.h's forms (CPU_CLANG 1: PoCL's inline forms; 0: the standard
builtins, as GPU drivers compile them).
"""
import pytest

from pyshadow import _cl
from pyshadow._cl import probe as probe_mod

END = "/* ---- end lanes.h ---- */"
# each construct broken as a compiler might break it (4 lanes)
BROKEN = {
    "VALL": "#undef VALL\n#define VALL(m) VANY(m)",
    # the highest set bit instead of the lowest (equal for a mask of one lane)
    "BIT_LOW": "#undef BIT_LOW\n#define BIT_LOW(b) (31 - clz(b))",
    # the lanes' bits in reverse order
    "LANE_BITS": "#undef LANE_BITS\n#define LANE_BITS(m) lane_or((m) & ((iv)(1) << (3 - LANE_IDS)))",
    "DEINTERLEAVE3": ("#undef DEINTERLEAVE3\n#define DEINTERLEAVE3(T, a0, a1, a2, X, Y, Z) "
                      "X = (T)(a0.s0, a0.s3, a1.s2, a2.s1); Y = (T)(a0.s1, a1.s3, a1.s0, a2.s2); "
                      "Z = (T)(a0.s2, a1.s1, a2.s0, a2.s3)"),
    "LANE_GATHER": "#undef LANE_GATHER\n#define LANE_GATHER(V, F, f) ((V)(F(0, f), F(1, f), F(3, f), F(2, f)))",
    # int -> float rounded toward zero (differs past 2^24 only)
    "CONVERT int->float": ("#undef CONVERT\n#define CONVERT(T, x) LANE_CAT(PROBE_BAD_, T)(x)\n"
                           "#define PROBE_BAD_float(x) convert_float4_rtz(x)\n"
                           "#define PROBE_BAD_int(x) convert_int4(x)\n#define PROBE_BAD_uchar(x) convert_uchar4(x)"),
    # int -> uchar saturated rather than its low bits
    "CONVERT int->uchar": ("#undef CONVERT\n#define CONVERT(T, x) LANE_CAT(PROBE_BAD_, T)(x)\n"
                           "#define PROBE_BAD_float(x) convert_float4(x)\n"
                           "#define PROBE_BAD_int(x) convert_int4(x)\n"
                           "#define PROBE_BAD_uchar(x) convert_uchar4_sat(x)"),
    # |x| as max(x, -x): -0 keeps its sign
    "VABS": "#undef VABS\n#define VABS(x) VMAX((x), -(x))",
    # an unsigned comparison
    "IMIN": "#undef IMIN\n#define IMIN(a, b) ((uint)(a) < (uint)(b) ? (a) : (b))",
}


def _verdicts(source: str, widths=(4,)) -> dict:
    pi, di = _cl._init()["index"]
    return probe_mod.run_probe(pi, di, {"probe": source, "builds": []}, widths=widths)


@pytest.fixture(scope="module")
def source():
    src = _cl.kernel_source("probe.cl")
    assert src.count(END) == 1
    assert _verdicts(src)[4]["ok"], "the probe fails on this device with the true lanes.h"
    return src


@pytest.mark.parametrize("construct", sorted(BROKEN))
def test_the_probe_refuses_a_width_whose_construct_is_wrong(source, construct):
    """Was: the probe did not use VALL, BIT_LOW, LANE_BITS, DEINTERLEAVE3, LANE_GATHER, IMIN, VABS (on -0) or
    conversions past 2^24 and to uchar, so a device that got one wrong passed it."""
    found = _verdicts(source.replace(END, END + "\n" + BROKEN[construct] + "\n"))[4]
    assert not found["ok"] and found["why"].startswith("wrong answers"), found


@pytest.mark.parametrize("cpu_clang", [0, 1])
def test_the_probe_passes_every_width_in_both_forms_of_lanes_h(cpu_clang):
    """Widths 1 and 4 pass, and so does every width up to the widest that passes. A wider one may be refused,
    and only because the compiler warns that its vector arguments change the ABI (no registers that wide).
    Was: every width had to pass, which failed on an AVX2 CPU (an AMD EPYC): PoCL's 16 lanes are refused there."""
    found = _verdicts(f"#define CPU_CLANG {cpu_clang}\n" + _cl.kernel_source("probe.cl"), probe_mod.LANE_WIDTHS)
    passed = [w for w, v in found.items() if v["ok"]]
    assert 1 in passed and 4 in passed, found
    for w, v in found.items():
        if not v["ok"]:
            assert _cl.ABI_WARNING in v["why"] and w > max(passed), (w, found)

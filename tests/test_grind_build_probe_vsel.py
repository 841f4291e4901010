"""The lane probe checks the vector ?: of VSEL (lanes.h), which the lane kernels use throughout.

Oclgrind 21.10 (an OpenCL 1.2 implementation) gets two vector ?: that share one mask wrong at every width above 1
(the lanes not selected come out as their operand's bits AND 1), select() right: its 4-, 8- and 16-lane probe passed,
and with PYSHADOW_LANES=4 the zigzag lookup of views_zigzag.h picked wrong maps (6 of 40 visibility rays of a box
answered otherwise than at 1 lane and on PoCL). Here PoCL is given that defect by a VSEL that zeroes the unselected
operand: the probe must refuse the width, and pass it with the true VSEL.
"""
from pyshadow import _cl
from pyshadow._cl import probe as probe_mod

TRUE_VSEL = "#define VSEL(a, b, c) ((c) ? (b) : (a))"
# the unselected lanes about as Oclgrind gives them (the operand's bits AND 1: 0 or 1e-45 for floats): zero, for
# the int and the float vectors the probe selects alike
BROKEN_VSEL = "#define VSEL(a, b, c) ((c) ? (b) : (a) * 0)"


def _verdict(source: str, width: int = 4) -> dict:
    pi, di = _cl._init()["index"]
    return probe_mod.run_probe(pi, di, {"probe": source, "builds": []}, widths=(width,))[width]


def test_the_probe_refuses_a_width_whose_vector_selection_is_wrong():
    """Was: the probe used select() and scalar ?: only, so a device whose VSEL is wrong passed it (Oclgrind at
    4, 8 and 16 lanes), and the lane kernels then answered wrong at that width."""
    src = _cl.kernel_source("probe.cl")
    assert src.count(TRUE_VSEL) == 1
    assert _verdict(src)["ok"], "the probe fails on this device with the true VSEL"
    found = _verdict(src.replace(TRUE_VSEL, BROKEN_VSEL))
    assert not found["ok"] and found["why"].startswith("wrong answers"), found


def test_the_probe_checks_the_int_selection_row():
    """The int VSEL row (nested selections of an int vector, as grid.h's steps) is compared with NumPy: an
    altered selection in it is refused and named."""
    src = _cl.kernel_source("probe.cl")
    nested = "VSEL(VSEL(ci, (iv)(0), MASK(v < 0.0f))"
    assert src.count(nested) == 1
    found = _verdict(src.replace(nested, "VSEL(VSEL(ci, (iv)(2), MASK(v < 0.0f))"))
    assert not found["ok"] and found["why"].startswith("wrong answers (VSEL (int)"), found

"""A kernel build whose compiler log warns that a vector argument "changes the ABI" is refused."""
import pyopencl as cl
import pytest

from pyshadow import _cl


def test_a_build_warning_of_an_abi_change_is_a_build_error(monkeypatch):
    """Was: such a build was used. With PoCL told ``x86-64`` (SSE2), the query kernels' standard-OpenCL form
    at 4 lanes (double4 loads of float64 points) built with that warning and answered 5,249 of 16,016 bunny
    rays wrongly (the inline CPU form and the NumPy mirror: 0). Now the build raises KernelBuildError naming
    the warning (the lane probe already refused widths whose lane kernels warned so)."""
    real = cl.Program.get_build_info
    warned = "k.cl:3:9: warning: AVX vector return of type 'double4' without 'avx' enabled changes the ABI"
    monkeypatch.setattr(cl.Program, "get_build_info", lambda self, dev, param:
                        warned if param == cl.program_build_info.LOG else real(self, dev, param))
    src = "__kernel void k(__global float *a) { a[get_global_id(0)] = 1.0f; }"
    with pytest.raises(_cl.KernelBuildError, match=r"building tiny\.cl failed (.|\n)*vector argument changes the ABI"
                       r"(.|\n)*AVX vector return of type 'double4'"):
        _cl.build_source(src, "tiny.cl")
    monkeypatch.setattr(cl.Program, "get_build_info", real)
    prg = _cl.build_source(src, "tiny.cl")          # the same source, without the warning: built
    assert prg.get_info(cl.program_info.KERNEL_NAMES) == "k"

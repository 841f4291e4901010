"""kernels/vec3.h: its inline float3 helpers give the OpenCL builtins' values bit for bit.

On CPU targets of clang (PoCL) ``dot3``, ``cross3``, ``normalize3`` and
``length3`` spell out the operations of PoCL's ``dot``, ``cross``,
``normalize`` and ``length`` (which PoCL compiles as library calls); the
G-buffer's resolve and the AO kernel use them, and their answers must not
move. Each is compared with its builtin on vectors of every magnitude: the
normal range, squared lengths that underflow or overflow float32 (where the
builtins rescale), zeros, subnormal and infinite components. With
``CPU_CLANG=0`` the helpers are the builtins themselves.
"""
import numpy as np
import pyopencl as cl
import pytest

from pyshadow import _cl

KERNEL = """
__kernel void vec3_pairs(__global const float *a, __global const float *b, __global float *out)
{
    const size_t i = get_global_id(0);
    const float3 u = row3(a, i), v = row3(b, i);
    __global float *o = out + 16 * i;
    store_row3(normalize3(u), o, 0);
    store_row3(normalize(u), o, 1);
    store_row3(cross3(u, v), o, 2);
    store_row3(cross(u, v), o, 3);
    o[12] = dot3(u, v);
    o[13] = dot(u, v);
    o[14] = length3(u);
    o[15] = length(u);
}
"""


def _source():
    kdir = _cl.kernel_dir()
    head = (kdir / "cpu_clang.h").read_text()
    vec3 = (kdir / "vec3.h").read_text().replace('#include "cpu_clang.h"', head)
    assert "#include" not in vec3
    return vec3 + KERNEL


def _vectors(rng, n):
    """Rows of every magnitude: random directions times 10^e, e in [-46, 39], plus special rows."""
    d = rng.normal(size=(n, 3))
    e = rng.uniform(-46.0, 39.0, size=(n, 1))
    v = d * 10.0 ** e
    v[rng.random(n) < 0.1, rng.integers(0, 3)] = 0.0             # a zero component
    special = np.array([[0.0, 0.0, 0.0], [1e-45, 0.0, 0.0], [1e-40, 2e-41, -3e-42], [np.inf, 1.0, 0.0],
                        [3e38, 3e38, 3e38], [1.0, 1e-30, 1e30], [-0.0, 0.0, -0.0], [1.1e-19, 0.0, 0.0],
                        [1.0842e-19, 1e-20, 0.0], [1.8e19, 0.0, 0.0], [2e19, 1.0, 1.0]])
    with np.errstate(over="ignore", under="ignore"):
        return np.concatenate([special, v]).astype(np.float32)


@pytest.mark.parametrize("cpu_clang", [None, 0])
def test_vec3_helpers_equal_the_builtins_bit_for_bit(cpu_clang):
    rng = np.random.default_rng(3)
    a, b = _vectors(rng, 20000), _vectors(rng, 20000)
    n = min(len(a), len(b))
    a, b = a[:n], b[:n]
    defines = {} if cpu_clang is None else {"CPU_CLANG": cpu_clang}
    prg = _cl.build_source(_source(), "vec3_test.cl", defines)
    q = _cl.queue()
    out = np.zeros((n, 16), np.float32)
    ob = _cl.empty(out.nbytes)
    prg.vec3_pairs(q, (n,), None, _cl.to_device(a), _cl.to_device(b), ob)
    cl.enqueue_copy(q, out, ob)
    bits = out.view(np.uint32)
    for name, mine, builtin in (("normalize", slice(0, 3), slice(3, 6)), ("cross", slice(6, 9), slice(9, 12)),
                                ("dot", slice(12, 13), slice(13, 14)), ("length", slice(14, 15), slice(15, 16))):
        differ = np.flatnonzero((bits[:, mine] != bits[:, builtin]).any(axis=1))
        assert len(differ) == 0, (f"{name}: {len(differ)} of {n} rows differ from the builtin, e.g. "
                                  f"{a[differ[0]]} -> {out[differ[0], mine]} against {out[differ[0], builtin]}")
    # the rows cover the builtins' rescaled ranges and the normal one
    with np.errstate(over="ignore", under="ignore"):
        l2 = (a.astype(np.float32) ** 2).sum(axis=1, dtype=np.float32)
    assert (l2 < np.finfo(np.float32).tiny).sum() > 1000 and np.isinf(l2).sum() > 1000
    assert ((l2 >= np.finfo(np.float32).tiny) & np.isfinite(l2)).sum() > 5000
    # and the normal range's unit vectors are unit vectors
    ok = (l2 >= 1e-30) & (l2 <= 1e30)
    np.testing.assert_allclose(np.linalg.norm(out[ok, 0:3].astype(np.float64), axis=1), 1.0, atol=2e-7)

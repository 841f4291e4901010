/* probe.cl -- can this device build and run lane vectors of LANES?
 *
 * Kernel lane_probe: one work-item per LANES values of x. It exercises what
 * the lane kernels use on vectors -- vloadN/vstoreN, comparisons as masks,
 * select, any, fmin/fmax, floor/ceil, sqrt, convert_int/convert_float,
 * ternary selection, the vector ?: of VSEL (two selections sharing one mask,
 * as in views_zigzag.h: Oclgrind 21.10 computes that wrong at every width
 * above 1, select() right) -- and writes per value the results the host checks
 * against NumPy (pyshadow._cl probes each width in a child process, since a
 * broken compiler can crash or hang instead of failing).
 *
 * Buffers
 *   x    float (n)      inputs, n a multiple of LANES; read
 *   out  float (4, n)   rows: ceil(fmin(x, 2)) + floor(fmax(x, -2)),
 *                       sqrt(|x|) where x > 0 else -x (select, then VSEL),
 *                       (float)(int)(x * 3) (then VSEL), 1 if any lane of the vector
 *                       exceeds 1.5 else 0; written
 * Macros: LANES.
 */
#include "lanes.h"

__kernel void lane_probe(__global const float *x, const int n, __global float *out)
{
    const int i = get_global_id(0) * LANES;
    if (i >= n) return;
    const fv v = VLOAD(0, x + i);
    const fv a = ceil(fmin(v, (fv)(2.0f))) + floor(fmax(v, (fv)(-2.0f)));
    const iv pos = MASK(v > 0.0f);
    const fv b = select(-v, sqrt(fabs(v)), pos);
    const fv c = CONVERT(float, CONVERT(int, v * 3.0f));
    const fv d = (fv)(VANY(MASK(v > 1.5f) & ~MASK(v != v)) ? 1.0f : 0.0f);
    /* b and c again through VSEL, two selections sharing one mask (no input is NaN: b and c) */
    const iv nans = MASK(v != v);
    const fv bs = VSEL(b, (fv)(1.0f), nans), cs = VSEL(c, (fv)(0.0f), nans);
    VSTORE(a, 0, out + i);
    VSTORE(bs, 0, out + n + i);
    VSTORE(cs, 0, out + 2 * n + i);
    VSTORE(d, 0, out + 3 * n + i);
}

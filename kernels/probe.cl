/* probe.cl -- can this device build and run lane vectors of LANES?
 *
 * Kernel lane_probe: one work-item per LANES values of x. It exercises every
 * construct of lanes.h the lane kernels use, in the forms this device
 * compiles (CPU_CLANG's inline forms or the standard builtins) -- MASK, VSEL
 * (two selections sharing one mask, as in views_zigzag.h: Oclgrind 21.10
 * computes the vector ?: wrong at every width above 1, select() right), VMIN,
 * VMAX, VABS, VSQRT, IMIN, CONVERT (int <-> float, int -> uchar), VANY, VALL,
 * LANE_BITS, BIT_LOW, LANE_IDS, LANE_GATHER, VLOAD (aligned and not), VSTORE,
 * LANE_ARRAY with LANE_LOAD / LANE_STORE mixed with scalar accesses,
 * DEINTERLEAVE3 and PREFETCH -- on values that expose the usual mistakes
 * (negative zero, values past 2^24, negative conversions, masks of one lane),
 * and writes per value the results the host checks against NumPy
 * (pyshadow._cl probes each width in a child process, since a broken compiler
 * can crash or hang instead of failing).
 *
 * Buffers
 *   x     float (n + 16)  inputs, n a multiple of LANES; read (x[i + 1] too:
 *                         an unaligned load)
 *   mi    int (n)         lane masks (non-zero: set); read
 *   t     float (n, 3)    rows to deinterleave; read
 *   out   float (15, n)   written; rows: ceil(fmin(x, 2)) + floor(fmax(x, -2)),
 *                         sqrt(|x|) where x > 0 else -x (select, then VSEL),
 *                         (float)(int)(x * 3) (then VSEL), any lane > 1.5,
 *                         VABS(x), VSQRT(VABS(x)), VMIN and VMAX of x and
 *                         x[+1], VSEL(x, -0, mask), t's columns X, Y, Z,
 *                         x gathered at lane (5 l + 3) % LANES, x[+1] with
 *                         its last lane x[0] (private arrays), the float of
 *                         3 (int)(3 x) + 1
 *   iout  int (9, n)      written; rows: (int)(3 x), LANE_BITS(mask), the
 *                         set lanes visited by BIT_LOW (c = 3 c + l + 1),
 *                         VANY + 2 VALL of mask, + 4 / + 8 of ~mask,
 *                         IMIN(c, 2 - c) (private array), clamp(c + lane,
 *                         -5, 5) (VMIN / VMAX), (uchar)(37 c), the mask
 *                         (mask & ~(x > 1)) | (c == 0) (-1 where set),
 *                         VSEL(VSEL(c, 0, x < 0), 1, x > 0.5) (int, nested)
 * Macros: LANES; CPU_CLANG (optional, lanes.h).
 */
#include "lanes.h"

/* lane l of LANE_GATHER: x at a permuted lane of this work-item's values */
#define PROBE_PERM(l, f) x[i + (5 * (l) + (f)) % LANES]

__kernel void lane_probe(__global const float *x, __global const int *mi, __global const float *t,
                         const int n, __global float *out, __global int *iout)
{
    const int i = get_global_id(0) * LANES;
    if (i >= n) return;
    PREFETCH((__global const uchar *)(x + i + LANES));
    const fv v = VLOAD(0, x + i), w = VLOAD(0, x + i + 1);
    const fv a = ceil(fmin(v, (fv)(2.0f))) + floor(fmax(v, (fv)(-2.0f)));
    const iv pos = MASK(v > 0.0f);
    const fv b = select(-v, sqrt(fabs(v)), pos);
    const iv ci = CONVERT(int, v * 3.0f);
    const fv c = CONVERT(float, ci);
    const fv d = (fv)(VANY(MASK(v > 1.5f) & ~MASK(v != v)) ? 1.0f : 0.0f);
    /* b and c again through VSEL, two selections sharing one mask (no input is NaN: b and c) */
    const iv nans = MASK(v != v);
    const fv bs = VSEL(b, (fv)(1.0f), nans), cs = VSEL(c, (fv)(0.0f), nans);
    const iv mk = MASK(VLOAD(0, mi + i) != 0);
    fv X, Y, Z;
    {
        const fv a0 = VLOAD(0, t + 3 * i), a1 = VLOAD(1, t + 3 * i), a2 = VLOAD(2, t + 3 * i);
        DEINTERLEAVE3(fv, a0, a1, a2, X, Y, Z);
    }
    LANE_ARRAY float fb[2 * LANES];
    LANE_ARRAY int ib[LANES];
    LANE_STORE(v, fb);
    LANE_STORE(w, fb + LANES);
    fb[2 * LANES - 1] = fb[0];
    LANE_STORE(ci, ib);
    for (int l = 0; l < LANES; ++l) ib[l] = IMIN(ib[l], 2 - ib[l]);
    const int bits = LANE_BITS(mk);
    int seen = 0;
    for (int s = bits; s; s &= s - 1) seen = 3 * seen + BIT_LOW(s) + 1;
    const int anyall = VANY(mk) + 2 * VALL(mk) + 4 * VANY(~mk) + 8 * VALL(~mk);
    const fv rows[15] = {a, bs, cs, d, VABS(v), VSQRT(VABS(v)), VMIN(v, w), VMAX(v, w), VSEL(v, (fv)(-0.0f), mk),
                         X, Y, Z, LANE_GATHER(fv, PROBE_PERM, 3), LANE_LOAD(fb + LANES), CONVERT(float, 3 * ci + 1)};
    const iv irows[9] = {ci, (iv)(bits), (iv)(seen), (iv)(anyall), LANE_LOAD(ib),
                         VMIN(VMAX(ci + LANE_IDS, (iv)(-5)), (iv)(5)), CONVERT(int, CONVERT(uchar, 37 * ci)),
                         (mk & ~MASK(v > 1.0f)) | MASK(ci == 0),
                         VSEL(VSEL(ci, (iv)(0), MASK(v < 0.0f)), (iv)(1), MASK(v > 0.5f))};
    for (int r = 0; r < 15; ++r) VSTORE(rows[r], 0, out + r * n + i);
    for (int r = 0; r < 9; ++r) VSTORE(irows[r], 0, iout + r * n + i);
}

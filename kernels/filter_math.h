/* filter_math.h -- the tap weight of filters.cl on lane vectors (lanes.h),
 * bit for bit the value of the scalar code for each lane.
 *
 *   EXP_V(x)        exp of each lane: the builtin exp(float), lane by lane
 *   fv3             three lane vectors x, y, z (the lanes' normals)
 *   DOT_V(p, q)     dot((float3)(p.x, p.y, p.z), (float3)(q.x, ...)) of each
 *                   lane (p, q fv3), as the builtin dot
 *   FABS_V(x)       fabs of each lane
 *   TO_INT, TO_FLOAT  convert_int / convert_float of lanes (casts at LANES = 1)
 *   tap_weight_v    the tap weight (same operations, same order)
 *
 * Why exp lane by lane: PoCL's exp(floatN) is another algorithm than its
 * exp(float) (fused multiply-adds, round-to-nearest reduction): 1 ulp apart
 * for 971,055 of the 1.12e9 floats in [-104, 0] (all of them measured, at 4
 * and 8 lanes), so vector filters calling it would not reproduce the scalar
 * ones. EXP_V therefore calls the scalar exp(float) of each lane: the old
 * values bit for bit at every width. (A vector exp of our own would be
 * faster still -- about 3x on the bilateral filter -- but changes answers by
 * an ulp here and there; not done.) PoCL's dot(float3) is the three
 * products, then (x + y) + z, unfused (vec3.h);
 * its fmax(0, c) is c unless 0 > c or c is NaN. CPU_CLANG targets use these
 * inline forms at every width, LANES = 1 too (PoCL does not inline its
 * builtins into kernels as large as these, and each call saves the live
 * registers). Elsewhere (GPU drivers) LANES = 1 calls the builtins, as the
 * scalar code did, and wider lanes call them lane by lane: the same values
 * by construction. tests/test_filters_lanes.py checks every width against
 * LANES = 1 and EXP_V, DOT_V against the builtins.
 * Macros: LANES, CPU_CLANG (lanes.h).
 */
#ifndef PYSHADOW_FILTER_MATH_H
#define PYSHADOW_FILTER_MATH_H

#include "lanes.h"

/* (no private arrays: PoCL keeps those in memory, per work-item) */
typedef struct { fv x, y, z; } fv3;

#if LANES == 1
#define TO_INT(x) ((int)(x))
#define TO_FLOAT(x) ((float)(x))
#else
#define TO_INT(x) CONVERT(int, x)
#define TO_FLOAT(x) CONVERT(float, x)
#endif

#if CPU_CLANG
/* inline forms (PoCL calls its builtins, and in kernels this large does not
 * inline them; each call saves the live registers around it) */
#if LANES == 1
#define FABS_V(x) __builtin_fabsf(x)
#else
#define FABS_V(x) VABS(x)
#endif
__attribute__((always_inline)) inline fv dot_v(const fv3 p, const fv3 q)
{
    const fv x = p.x * q.x;
    const fv y = p.y * q.y;
    const fv z = p.z * q.z;
    return (x + y) + z;
}
#define DOT_V(p, q) dot_v((p), (q))
#elif LANES == 1
#define FABS_V(x) fabs(x)
#define DOT_V(p, q) dot((float3)((p).x, (p).y, (p).z), (float3)((q).x, (q).y, (q).z))
#else
#define FABS_V(x) VABS(x)
#define DOT_LANE(l, u) dot((float3)(p.x[l], p.y[l], p.z[l]), (float3)(q.x[l], q.y[l], q.z[l]))
__attribute__((always_inline)) inline fv dot_v(const fv3 p, const fv3 q)
{
    return LANE_GATHER(fv, DOT_LANE, 0);
}
#define DOT_V(p, q) dot_v((p), (q))
#endif

#if LANES == 1
#define EXP_V(x) exp(x)
#else
#define EXP_LANE(l, x) exp((x)[l])
__attribute__((always_inline)) inline fv exp_v(const fv x)
{
    return LANE_GATHER(fv, EXP_LANE, x);
}
#define EXP_V(x) exp_v(x)
#endif

/* tap_weight (filters.cl) of lanes: dist2 the squared pixel distance (the
 * same for every lane), zp/zq depths, p/q normals (x, y, z lane vectors) */
__attribute__((always_inline)) inline fv tap_weight_v(const float dist2, const fv zp, const fv zq,
                                                      const fv3 p, const fv3 q, const float inv_s,
                                                      const float inv_z, const float inv_n)
{
    const float a2 = dist2 * inv_s * inv_s;
    const fv r = FABS_V(zq - zp) / zp * inv_z;
    const fv c = 1.0f - DOT_V(p, q);
#if LANES == 1 && !CPU_CLANG
    const fv m = fmax(0.0f, c) * inv_n;
#else
    /* fmax(0, c) as PoCL has it: c unless 0 > c or c is NaN (elsewhere the
     * two may differ in the sign of a zero m, which m * m drops) */
    const fv m = VSEL((fv)(0.0f), c, MASK(c >= 0.0f)) * inv_n;
#endif
    return EXP_V(-0.5f * (a2 + r * r + m * m));
}

#endif

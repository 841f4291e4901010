/* vec3.h -- float3 rows and arithmetic without the calls into PoCL's
 * library that the builtins compile to there (not inlined; on CPUs each
 * call also saves the live vector registers around it):
 *
 *   row3(a, k), store_row3(v, a, k)  row k of an (n, 3) float array, element
 *                   by element: the values of vload3 / vstore3, everywhere
 *   dot3, cross3, normalize3, length3  on CPU targets of clang (cpu_clang.h)
 *                   the operations of PoCL's dot, cross, normalize and
 *                   length in the same order, so the same values bit for
 *                   bit (tests/test_vec3.py compares them):
 *                     dot: the three products, then (x + y) + z, no fused
 *                     multiply-add (each product its own statement, so the
 *                     compiler cannot fuse it);
 *                     cross: products, then differences;
 *                     normalize: v times 1 / sqrt of the squared length (dot3
 *                     of v with itself); length: that sqrt. Outside
 *                     [FLT_MIN, inf) the builtins rescale v first, and there
 *                     they are called.
 *                   Elsewhere (GPU drivers) the builtins themselves.
 * Macros: CPU_CLANG (optional, cpu_clang.h).
 */
#ifndef PYSHADOW_VEC3_H
#define PYSHADOW_VEC3_H

#include "cpu_clang.h"

inline float3 row3(__global const float *a, size_t k)
{
    return (float3)(a[3 * k], a[3 * k + 1], a[3 * k + 2]);
}

inline void store_row3(float3 v, __global float *a, size_t k)
{
    a[3 * k] = v.x;
    a[3 * k + 1] = v.y;
    a[3 * k + 2] = v.z;
}

#if CPU_CLANG
/* sqrt of one float: the CPU's square root instruction (correctly rounded,
 * as PoCL's sqrt there) */
#if defined(__has_builtin)
#if __has_builtin(__builtin_sqrtf)
#define SQRT1(x) __builtin_sqrtf(x)
#endif
#endif
#ifndef SQRT1
#define SQRT1(x) sqrt(x)
#endif

inline float dot3(float3 a, float3 b)
{
    const float x = a.x * b.x;
    const float y = a.y * b.y;
    const float z = a.z * b.z;
    return (x + y) + z;
}

inline float3 cross3(float3 a, float3 b)
{
    const float p = a.y * b.z, q = a.z * b.y;
    const float r = a.z * b.x, s = a.x * b.z;
    const float t = a.x * b.y, u = a.y * b.x;
    return (float3)(p - q, r - s, t - u);
}

inline float3 normalize3(float3 v)
{
    const float l2 = dot3(v, v);
    if (!(l2 >= FLT_MIN && l2 < INFINITY))
        return normalize(v);
    return v * (1.0f / SQRT1(l2));
}

inline float length3(float3 v)
{
    const float l2 = dot3(v, v);
    if (!(l2 >= FLT_MIN && l2 < INFINITY))
        return length(v);
    return SQRT1(l2);
}
#else
#define dot3(a, b) dot((a), (b))
#define cross3(a, b) cross((a), (b))
#define normalize3(v) normalize(v)
#define length3(v) length(v)
#endif

#endif

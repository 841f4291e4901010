/* csm_common.h -- depth keys of a Coherent Shadow Map, shared by the
 * compression and query kernels.
 *
 * Depth is handled as unsigned integer keys whose order is the order of the
 * depths, so run intersections are exact integer min/max:
 *   DEPTH_BITS 16: key k in 0..DEPTH_Q is the depth k / DEPTH_Q (fixed
 *                  point, DEPTH_Q = 65534); KEY_MISS = 65535 is +inf.
 *   DEPTH_BITS 32: the key is the bit pattern of the (non-negative) float
 *                  depth; KEY_MISS is the pattern of +inf.
 *
 * Macros: DEPTH_BITS (16 or 32).
 */
#ifndef PYSHADOW_CSM_COMMON_H
#define PYSHADOW_CSM_COMMON_H

#pragma OPENCL FP_CONTRACT OFF

/* STORED_MAX_DEPTH: no finite stored depth is larger (16 bits: k / DEPTH_Q
 * with k <= DEPTH_Q; 32 bits: the host refuses depths beyond 2,
 * csm.file_checks.check_arrays) */
#if DEPTH_BITS == 16
#define DEPTH_Q 65534.0f
#define KEY_MISS 65535u
#define STORED_MAX_DEPTH 1.0f
typedef ushort depth_t;
#elif DEPTH_BITS == 32
#define KEY_MISS 0x7f800000u
#define STORED_MAX_DEPTH 2.0f
typedef float depth_t;
#else
#error "DEPTH_BITS must be 16 or 32"
#endif

/* smallest key whose depth is >= z (z >= 0 finite) */
inline uint key_at_or_above(float z)
{
#if DEPTH_BITS == 16
    z = fmin(z, 1.0f);
    float k = ceil(z * DEPTH_Q);
    /* make k the exact ceiling of z*Q: the sign of fma(-z, Q, k) is exact */
    if (fma(-z, DEPTH_Q, k) < 0.0f) k += 1.0f;
    if (k >= 1.0f && fma(-z, DEPTH_Q, k - 1.0f) >= 0.0f) k -= 1.0f;
    return (uint)fmin(k, DEPTH_Q);
#else
    return as_uint(fmax(z, 0.0f));
#endif
}

/* largest key whose depth is < z, or (uint)-1 when there is none */
inline uint key_below(float z)
{
#if DEPTH_BITS == 16
    if (z > 1.0f) return (uint)DEPTH_Q;
    return key_at_or_above(z) - 1u;
#else
    return as_uint(fmax(z, 0.0f)) - 1u;
#endif
}

/* stored value -> depth (+inf for a miss) */
inline float stored_depth(depth_t s)
{
#if DEPTH_BITS == 16
    return (s == (depth_t)KEY_MISS) ? INFINITY : (float)s / DEPTH_Q;
#else
    return s;
#endif
}

#endif

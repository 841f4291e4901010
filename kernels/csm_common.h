/* csm_common.h -- depth keys and the segment-list search of a Coherent
 * Shadow Map, shared by the compression and query kernels.
 *
 * Depth is handled as unsigned integer keys whose order is the order of the
 * depths, so run intersections are exact integer min/max:
 *   DEPTH_BITS 16: key k in 0..DEPTH_Q is the depth k / DEPTH_Q (fixed
 *                  point, DEPTH_Q = 65534); KEY_MISS = 65535 is +inf.
 *   DEPTH_BITS 32: the key is the bit pattern of the (non-negative) float
 *                  depth; KEY_MISS is the pattern of +inf.
 *
 * Macros: DEPTH_BITS (16 or 32), IEND_T (ushort or uint), PAIR_WIDE (0 or 1).
 */
#ifndef PYSHADOW_CSM_COMMON_H
#define PYSHADOW_CSM_COMMON_H

#pragma OPENCL FP_CONTRACT OFF

#if DEPTH_BITS == 16
#define DEPTH_Q 65534.0f
#define KEY_MISS 65535u
typedef ushort depth_t;
#elif DEPTH_BITS == 32
#define KEY_MISS 0x7f800000u
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

/* Device layout of the segments (built on the host from the validated
 * file arrays, CoherentShadowMap.search_arrays):
 *   pairs    per segment, i_end and stored depth side by side, so the search
 *            finds the depth in the cache line it already read:
 *            PAIR_WIDE 0: uint, i_end in the low and depth in the high 16
 *            bits; PAIR_WIDE 1: uint2 (i_end, depth bits)
 *   summary  IEND_T, for every block of SEARCH_BLOCK segments of a list the
 *            i_end of its last segment (the list's last: D - 1)
 *   offsets  uint (texels + 1): texel t owns pairs [offsets[t], offsets[t+1])
 *   soff     uint (texels + 1): and summary entries [soff[t], soff[t+1])
 */
#define SEARCH_BLOCK 16
#if PAIR_WIDE
typedef uint2 pair_t;
#define PAIR_IEND(p) ((p).x)
#if DEPTH_BITS == 16
#define PAIR_STORED(p) ((depth_t)(p).y)
#else
#define PAIR_STORED(p) (as_float((p).y))
#endif
#else
typedef uint pair_t;
#define PAIR_IEND(p) ((p) & 0xffffu)
#define PAIR_STORED(p) ((depth_t)((p) >> 16))
#endif

/* Index of the first segment of texel t's list with i_end >= map: binary
 * search of the list's block summary (one cache line for a typical list),
 * then of the one block of at most SEARCH_BLOCK pairs that holds the answer.
 * The lists are validated to be non-empty, strictly increasing and to end at
 * D - 1, so for 0 <= map < D the answer lies in the list; every read stays in
 * [offsets[t], offsets[t+1]) and [soff[t], soff[t+1]) whatever `map` is
 * (past the end it returns the list's last segment). */
inline uint csm_find(__global const uint *offsets, __global const uint *soff,
                     __global const IEND_T *summary, __global const pair_t *pairs,
                     uint t, uint map)
{
    const uint a = offsets[t], b = offsets[t + 1];
    const uint sa = soff[t];
    uint lo = sa, hi = soff[t + 1] - 1u;
    while (lo < hi) {
        const uint mid = lo + ((hi - lo) >> 1);
        if ((uint)summary[mid] < map) lo = mid + 1u; else hi = mid;
    }
    const uint ba = a + SEARCH_BLOCK * (lo - sa);
    lo = ba;
    hi = min(ba + SEARCH_BLOCK, b) - 1u;
    while (lo < hi) {
        const uint mid = lo + ((hi - lo) >> 1);
        if ((uint)PAIR_IEND(pairs[mid]) < map) lo = mid + 1u; else hi = mid;
    }
    return lo;
}

#endif

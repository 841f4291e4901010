/* lanes.h -- lane vectors: LANES queries (or triangles) side by side.
 *
 * The vector width is a property of the device, not of the source: the host
 * (pyshadow._cl.lanes(), probed per device) passes LANES = 1, 4, 8 or 16 and
 * every kernel that works on lanes is written against the names below.
 * LANES = 1 is one query per work-item, the natural shape for GPUs; 4, 8 and
 * 16 suit CPUs whose compilers map them onto SSE/AVX/AVX-512 registers.
 *
 *   fv, iv              float and int lanes
 *   MASK(c)             a comparison as a lane mask: every bit set (-1) where
 *                       true, 0 where false -- what vector comparisons give;
 *                       a scalar comparison gives 1, so LANES = 1 negates it.
 *                       Every comparison that is stored in an iv, or meets
 *                       ~, & or |, goes through MASK.
 *   VANY(m), VALL(m)    any / all lanes of a mask (inline forms with
 *                       CPU_CLANG)
 *   VSEL(a, b, c)       b where mask c is set, else a (no NaN operands)
 *   VMIN, VMAX          min / max as operators (PoCL calls its vector
 *                       builtins rather than inlining them)
 *   VABS, VSQRT         fabs / sqrt of lane vectors, inline on CPU_CLANG
 *                       targets that have them (below)
 *   IMIN(a, b)          the smaller int (PoCL calls min(int, int))
 *   VLOAD(i, p), VSTORE(v, i, p)   vloadN / vstoreN (plain element access
 *                       for LANES = 1)
 *   CONVERT(T, x)       convert_TN(x) (convert_int16, convert_float8, ...) with
 *                       its default rounding
 *   VTYPE(T)            the lane vector of scalar type T (double16, uchar8)
 *   LANE_IDS            (0, 1, ..., LANES - 1)
 *   LANE_GATHER(V, F, f)  the lane vector of type V (fv, iv) of F(l, f) for
 *                       l = 0 .. LANES - 1 (F a macro reading lane l's value
 *                       f, as I[l]->f): built in registers -- not stored lane
 *                       by lane and read back as a vector, which stalls the
 *                       read until the stores retire
 * Lane memory (private arrays of queries, moved a lane vector at a time):
 *   LANE_ARRAY          alignment of a private array to a whole lane vector
 *   LANE_LOAD(a), LANE_STORE(v, a)  the lane vector at a: a LANE_ARRAY, or
 *                       one offset by a multiple of LANES (the vector type
 *                       follows a's element type: float, int or uint)
 *   PREFETCH(p)         start fetching p's cache line, without waiting
 *   DEINTERLEAVE3(T, a0, a1, a2, X, Y, Z)  rows 0..LANES-1 of an (N, 3)
 *                       array, loaded as three T vectors a0, a1, a2, into
 *                       the columns X, Y, Z
 *   CPU_CLANG           1 on CPU targets of clang (PoCL): LANE_LOAD, LANE_STORE
 *                       and PREFETCH take inline forms there; the host may
 *                       set it (0: the standard OpenCL forms, as on GPUs)
 * Macros: LANES (1, 4, 8 or 16); CPU_CLANG (optional, see above).
 */
#ifndef PYSHADOW_LANES_H
#define PYSHADOW_LANES_H

#ifndef LANES
#error "LANES (1, 4, 8 or 16) must be defined by the host"
#endif

#define LANE_CAT_(a, b) a##b
#define LANE_CAT(a, b) LANE_CAT_(a, b)

#if LANES == 16
#define LANE_SFX 16
#define LANE_IDS ((iv)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15))
#elif LANES == 8
#define LANE_SFX 8
#define LANE_IDS ((iv)(0, 1, 2, 3, 4, 5, 6, 7))
#elif LANES == 4
#define LANE_SFX 4
#define LANE_IDS ((iv)(0, 1, 2, 3))
#elif LANES == 1
#define LANE_SFX
#define LANE_IDS ((iv)(0))
#else
#error "LANES must be 1, 4, 8 or 16"
#endif

#if LANES == 16
#define LANE_GATHER(V, F, f) ((V)(F(0, f), F(1, f), F(2, f), F(3, f), F(4, f), F(5, f), F(6, f), F(7, f), \
                                  F(8, f), F(9, f), F(10, f), F(11, f), F(12, f), F(13, f), F(14, f), F(15, f)))
#elif LANES == 8
#define LANE_GATHER(V, F, f) ((V)(F(0, f), F(1, f), F(2, f), F(3, f), F(4, f), F(5, f), F(6, f), F(7, f)))
#elif LANES == 4
#define LANE_GATHER(V, F, f) ((V)(F(0, f), F(1, f), F(2, f), F(3, f)))
#else
#define LANE_GATHER(V, F, f) (F(0, f))
#endif

#define VTYPE(T) LANE_CAT(T, LANE_SFX)
#if LANES > 1 && defined(__clang__)
/* clang converts vectors inline; a call of convert_double8() and the like
 * passes a vector wider than some targets' registers to the builtin library,
 * where the calling conventions of compiler and library can disagree (PoCL 3.0
 * with LLVM 14 on AMD Zen 4). Same roundings as convert_TN's defaults. */
#define CONVERT(T, x) __builtin_convertvector((x), VTYPE(T))
#else
#define CONVERT(T, x) LANE_CAT(LANE_CAT(convert_, T), LANE_SFX)(x)
#endif
typedef VTYPE(float) fv;
typedef VTYPE(int) iv;

#if LANES == 1
#define MASK(c) (-(int)(c))
#define VANY(m) ((m) != 0)
#define VALL(m) ((m) != 0)
#define VLOAD(i, p) ((p)[(i)])
#define VSTORE(v, i, p) ((p)[(i)] = (v))
#else
#define MASK(c) (c)
#define VANY(m) any(m)
#define VALL(m) all(m)
#define VLOAD(i, p) LANE_CAT(vload, LANE_SFX)((i), (p))
#define VSTORE(v, i, p) LANE_CAT(vstore, LANE_SFX)((v), (i), (p))
#endif

#define VSEL(a, b, c) ((c) ? (b) : (a))
#define VMIN(a, b) (((b) < (a)) ? (b) : (a))
#define VMAX(a, b) (((b) > (a)) ? (b) : (a))

/* CPU targets of clang (PoCL, cpu_clang.h): builtins PoCL would call rather
 * than inline get inline forms below; other compilers use the standard
 * builtins */
#include "cpu_clang.h"
#if LANES > 1
/* the OR of a lane vector's lanes, by halving ORs */
__attribute__((always_inline)) inline int lane_or(iv m)
{
#if LANES == 16
    const int8 a = m.lo | m.hi;
    const int4 b = a.lo | a.hi;
#elif LANES == 8
    const int4 b = m.lo | m.hi;
#else
    const int4 b = m;
#endif
    const int2 c = b.lo | b.hi;
    return c.x | c.y;
}
#endif
#if CPU_CLANG && LANES > 1
/* any() / all() of a mask by halving ORs / ANDs down to one lane's sign bit
 * (the bit any() and all() test): PoCL calls its library's any() for every
 * use, and the tree's traversal asks it per node and lane group (19 % of
 * the time of a query among 10,000 casters went to the calls alone) */
inline int lane_any(iv m)
{
    return lane_or(m) < 0;
}
inline int lane_all(iv m)
{
#if LANES == 16
    const int8 a = m.lo & m.hi;
    const int4 b = a.lo & a.hi;
#elif LANES == 8
    const int4 b = m.lo & m.hi;
#else
    const int4 b = m;
#endif
    const int2 c = b.lo & b.hi;
    return (c.x & c.y) < 0;
}
#undef VANY
#undef VALL
#define VANY(m) lane_any(m)
#define VALL(m) lane_all(m)
#endif
/* |x| and sqrt(x) of lane vectors, and the smaller of two ints: PoCL calls
 * its builtins fabs, sqrt and min, and a call in the lookup's arithmetic
 * makes the compiler save every live vector register around it (all are
 * caller-saved), so CPU targets of clang take the compiler's own forms where
 * it has them -- the same values (|x| clears the sign; vsqrtps and sqrtps
 * round correctly, as PoCL's sqrt does with them) */
#if CPU_CLANG && LANES > 1 && defined(__has_builtin)
#if __has_builtin(__builtin_elementwise_abs)
#define VABS(x) __builtin_elementwise_abs(x)
#endif
#if LANES == 8 && defined(__AVX__) && __has_builtin(__builtin_ia32_sqrtps256)
#define VSQRT(x) __builtin_ia32_sqrtps256(x)
#elif LANES == 4 && defined(__SSE__) && __has_builtin(__builtin_ia32_sqrtps)
#define VSQRT(x) __builtin_ia32_sqrtps(x)
#endif
#endif
#ifndef VABS
#define VABS(x) fabs(x)
#endif
#ifndef VSQRT
#define VSQRT(x) sqrt(x)
#endif
#define IMIN(a, b) ((a) < (b) ? (a) : (b))
/* LANE_BITS(m): the lanes of mask m as the bits of an int (bit l: lane l);
 * BIT_LOW(b): the number of b's lowest set bit (b != 0) -- to visit the set
 * lanes of a sparse mask one after another, without a branch per lane;
 * BIT_COUNT(b): the number of b's set bits; LANE_ALL: every lane's bit;
 * MASK4_BITS(m): the elements of an int4 mask as the bits of an int (their
 * sign bits: movmskps on x86 CPU_CLANG targets) */
#if LANES > 1
#define LANE_BITS(m) lane_or((m) & ((iv)(1) << LANE_IDS))
#else
#define LANE_BITS(m) ((m) != 0)
#endif
#define LANE_ALL ((1 << LANES) - 1)
#if CPU_CLANG
#define BIT_LOW(b) __builtin_ctz((uint)(b))
#define BIT_COUNT(b) __builtin_popcount((uint)(b))
#else
#define BIT_LOW(b) (31 - clz((b) & -(b)))
#define BIT_COUNT(b) ((int)popcount((uint)(b)))
#endif
#if CPU_CLANG && defined(__SSE__) && defined(__has_builtin)
#if __has_builtin(__builtin_ia32_movmskps)
#define MASK4_BITS(m) __builtin_ia32_movmskps(as_float4(m))
#endif
#endif
#ifndef MASK4_BITS
__attribute__((always_inline)) inline int mask4_bits(int4 m)
{
    const int4 b = m & (int4)(1, 2, 4, 8);
    return b.x | b.y | b.z | b.w;
}
#define MASK4_BITS(m) mask4_bits(m)
#endif
/* private lane arrays: aligned to a whole lane vector, moved as whole
 * vectors (the type follows the array, so one macro serves float, int and
 * uint arrays) */
#define LANE_ARRAY __attribute__((aligned(4 * LANES)))
#if CPU_CLANG
#define LANE_LOAD(a) (*(__typeof__(VLOAD(0, (a))) *)(a))
#define LANE_STORE(v, a) (*(__typeof__(VLOAD(0, (a))) *)(a) = (v))
/* a cache-line prefetch that does not hold up the lane loop (PoCL's
 * prefetch() is a no-op; clang's builtin becomes the CPU's prefetch
 * instruction; memory is flat on CPUs) */
#define PREFETCH(p) __builtin_prefetch((const void *)(ulong)(p))
#else
#define LANE_LOAD(a) VLOAD(0, (a))
#define LANE_STORE(v, a) VSTORE((v), 0, (a))
#define PREFETCH(p) prefetch((p), 1)
#endif
/* rows 0..LANES-1 of an (N, 3) array from its 3 LANES values in a0, a1, a2 */
#if LANES == 16
#define DEINTERLEAVE3(T, a0, a1, a2, X, Y, Z)                                               \
    X = (T)(a0.s0, a0.s3, a0.s6, a0.s9, a0.sc, a0.sf, a1.s2, a1.s5, a1.s8, a1.sb, a1.se,  \
            a2.s1, a2.s4, a2.s7, a2.sa, a2.sd);                                            \
    Y = (T)(a0.s1, a0.s4, a0.s7, a0.sa, a0.sd, a1.s0, a1.s3, a1.s6, a1.s9, a1.sc, a1.sf,  \
            a2.s2, a2.s5, a2.s8, a2.sb, a2.se);                                            \
    Z = (T)(a0.s2, a0.s5, a0.s8, a0.sb, a0.se, a1.s1, a1.s4, a1.s7, a1.sa, a1.sd, a2.s0,  \
            a2.s3, a2.s6, a2.s9, a2.sc, a2.sf)
#elif LANES == 8
#define DEINTERLEAVE3(T, a0, a1, a2, X, Y, Z)                                               \
    X = (T)(a0.s0, a0.s3, a0.s6, a1.s1, a1.s4, a1.s7, a2.s2, a2.s5);                       \
    Y = (T)(a0.s1, a0.s4, a0.s7, a1.s2, a1.s5, a2.s0, a2.s3, a2.s6);                       \
    Z = (T)(a0.s2, a0.s5, a1.s0, a1.s3, a1.s6, a2.s1, a2.s4, a2.s7)
#elif LANES == 4
#define DEINTERLEAVE3(T, a0, a1, a2, X, Y, Z)                                               \
    X = (T)(a0.s0, a0.s3, a1.s2, a2.s1);                                                   \
    Y = (T)(a0.s1, a1.s0, a1.s3, a2.s2);                                                   \
    Z = (T)(a0.s2, a1.s1, a2.s0, a2.s3)
#else
#define DEINTERLEAVE3(T, a0, a1, a2, X, Y, Z) X = (a0); Y = (a1); Z = (a2)
#endif

#endif

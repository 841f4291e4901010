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
 *   VANY(m), VALL(m)    any / all lanes of a mask
 *   VSEL(a, b, c)       b where mask c is set, else a (no NaN operands)
 *   VMIN, VMAX          min / max as operators (PoCL calls its vector
 *                       builtins rather than inlining them)
 *   VLOAD(i, p), VSTORE(v, i, p)   vloadN / vstoreN (plain element access
 *                       for LANES = 1)
 *   CONVERT(T, x)       convert_TN(x) (convert_int16, convert_float8, ...) with
 *                       its default rounding
 *   VTYPE(T)            the lane vector of scalar type T (double16, uchar8)
 *   LANE_IDS            (0, 1, ..., LANES - 1)
 * Macros: LANES (1, 4, 8 or 16).
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

#endif

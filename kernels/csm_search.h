/* csm_search.h -- the segment search of the query kernels.
 *
 * Device layout of the segments (built on the host from the validated file
 * arrays by CoherentShadowMap.search_arrays):
 *   pairs    per segment, i_end and stored depth side by side, so the search
 *            finds the depth in the cache line it already read:
 *            PAIR_WIDE 0: uint, i_end in the low and depth in the high 16
 *            bits; PAIR_WIDE 1: uint2 (i_end, depth bits)
 *   summary  IEND_T, for every block of SEARCH_BLOCK segments of a list the
 *            i_end of its last segment (the list's last: D - 1)
 *   offsets  uint (texels + 1): texel t owns pairs [offsets[t], offsets[t+1])
 *   soff     uint (texels + 1): and summary entries [soff[t], soff[t+1])
 * Macros: DEPTH_BITS, IEND_T (ushort or uint), PAIR_WIDE (0 or 1),
 * SEARCH_BLOCK (segments per summary block: pyshadow.csm.SEARCH_BLOCK).
 */
#ifndef PYSHADOW_CSM_SEARCH_H
#define PYSHADOW_CSM_SEARCH_H

#include "csm_common.h"

#ifndef SEARCH_BLOCK
#error "SEARCH_BLOCK (segments per summary block) must be defined by the host"
#endif
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

/* Index of the first segment of texel t's list with i_end >= map: count the
 * list's block-summary entries below map (that is the block holding the
 * answer), then the i_end values below map in that block of at most
 * SEARCH_BLOCK pairs. Branch-free counting over one or two cache lines each
 * (faster than a binary search on PoCL for one lane: no mispredicted
 * jumps; stored_v() in csm_stored.h searches the summary of LANES lanes side
 * by side by a binary search instead).
 * The lists are validated to be non-empty, strictly increasing and to end at
 * D - 1, so for 0 <= map < D the answer lies in the list; the scans never
 * leave [soff[t], soff[t+1]) and [offsets[t], offsets[t+1]) whatever `map`
 * is (past the end the list's last segment is returned). */
inline uint csm_find(__global const uint *offsets, __global const uint *soff,
                     __global const IEND_T *summary, __global const pair_t *pairs,
                     uint t, uint map)
{
    const uint a = offsets[t], b = offsets[t + 1];
    const uint sa = soff[t], sb = soff[t + 1];
    uint c = 0u;
    for (uint j = sa; j + 1u < sb; ++j) c += ((uint)summary[j] < map);
    const uint b0 = a + SEARCH_BLOCK * c;
    const uint e0 = min(b0 + SEARCH_BLOCK, b) - 1u;
    uint c2 = 0u;
    for (uint j = b0; j < e0; ++j) c2 += ((uint)PAIR_IEND(pairs[j]) < map);
    return b0 + c2;
}

#endif

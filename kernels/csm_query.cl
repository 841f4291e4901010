/* csm_query.cl -- segment lookup in a Coherent Shadow Map.
 *
 * csm_lookup  one work-item per query (map, texel): index of the segment
 *             that holds the texel's stored depth for that map, found by
 *             csm_find() of csm_common.h, the search the visibility kernel
 *             runs.
 *
 * Buffers (layout in csm_common.h; built from validated arrays)
 *   offsets, soff uint (RES*RES + 1); summary IEND_T; pairs pair_t   read
 *   maps, texels int (N)  read; validated on the host (0 <= map < D,
 *                         0 <= texel < RES*RES)
 *   out uint (N)  written
 * Macros: RES, DEPTH_BITS (16 or 32), IEND_T (ushort or uint), PAIR_WIDE
 */
#include "csm_search.h"

__kernel void csm_lookup(__global const uint *offsets, __global const uint *soff,
                         __global const IEND_T *summary, __global const pair_t *pairs,
                         const int n_queries, __global const int *maps,
                         __global const int *texels, __global uint *out)
{
    const int q = get_global_id(0);
    if (q >= n_queries) return;
    out[q] = csm_find(offsets, soff, summary, pairs, (uint)texels[q], (uint)maps[q]);
}

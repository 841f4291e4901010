/* csm_query.cl -- segment lookup in a Coherent Shadow Map.
 *
 * csm_lookup  one work-item per query (map, texel): index of the segment
 *             that holds the texel's stored depth for that map, found by the
 *             binary search of csm_common.h (the one the visibility kernel
 *             uses).
 *
 * Buffers
 *   offsets uint (RES*RES + 1), iend IEND_T (S)  read; validated on the host
 *   maps, texels int (N)  read; validated on the host (0 <= map < D,
 *                         0 <= texel < RES*RES)
 *   out uint (N)  written
 * Macros: RES, DEPTH_BITS (16 or 32), IEND_T (ushort or uint)
 */
#include "csm_common.h"

__kernel void csm_lookup(__global const uint *offsets, __global const IEND_T *iend,
                         const int n_maps, const int n_queries, __global const int *maps,
                         __global const int *texels, __global uint *out)
{
    const int q = get_global_id(0);
    if (q >= n_queries) return;
    const uint t = (uint)texels[q];
    out[q] = csm_find(iend, offsets[t], offsets[t + 1], (uint)maps[q], (uint)n_maps);
}

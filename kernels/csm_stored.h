/* csm_stored.h -- stored_v(): the stored depth of (map, texel) for every
 * lane of a scene kernel's CSM lookup (csm_lookup.h), by the counting search
 * of csm_search.h over the padded lists of the scene's atlas.
 *
 * Expects: LANES (lanes.h), the scene tables (scene_tables.h), DEPTH_BITS,
 * IEND_T, PAIR_WIDE, SEARCH_BLOCK (csm_search.h); NTYPES > 0.
 */
#ifndef PYSHADOW_CSM_STORED_H
#define PYSHADOW_CSM_STORED_H

#include "csm_search.h"
#include "lanes.h"
#include "scene_tables.h"

#if NTYPES
#ifndef BATCH
#error "BATCH (queries per work-item, a multiple of LANES) must be defined by the host"
#endif
/* the most lanes one stored_v() asks: a batch's queue (batch.h) */
#define STORED_MAX (BATCH + LANES)

/* za[l]: the stored depth of (map ka[l], texel ta[l]) of CSM type T for
 * every lane l < n (a multiple of LANES, at most STORED_MAX) with va[l] !=
 * 0, +inf for the others. The search of csm_find() (csm_search.h) for every
 * lane: first the list's block summary, then the block. */
__attribute__((always_inline))
inline void stored_v(const scene_t *S, __global const csm_type_t *T, const int *ka, const int *ta,
                     const int *va, float *za, const int n)
{
    __global const uint *off = S->offsets + T->texel_base;
    __global const uint *sof = S->soff + T->texel_base;
    LANE_ARRAY uint lo[STORED_MAX], hi[STORED_MAX], base[STORED_MAX];
    for (int l = 0; l < n; ++l) {
        const uint t = va[l] ? (uint)ta[l] : 0u;
        base[l] = off[t];
        lo[l] = sof[t];
        hi[l] = va[l] ? sof[t + 1] - 1u : lo[l];
        PREFETCH(S->summary + lo[l]);
#if PROFILE_SKIP_SEARCH
        hi[l] = lo[l];
#endif
    }
    /* counting scans: the number of summary entries below the map is the
     * block, the number of i_end below it in that block the segment --
     * branch-free, sequential reads, no mispredicted jumps. The lists are
     * padded to whole blocks (search_arrays(padded=True)) with copies of
     * their last pair (i_end = D - 1, never below the map), so every block is
     * SEARCH_BLOCK pairs at an aligned start. First every lane's block is
     * found and prefetched (the lanes' cache misses are in flight together),
     * then the blocks are counted and the segment's depth read. */
    LANE_ARRAY uint b0a[STORED_MAX];
    for (int l = 0; l < n; ++l) {
        const uint k = (uint)ka[l];
        uint c = 0u;
        for (uint j = lo[l]; j < hi[l]; ++j) c += ((uint)S->summary[j] < k);
        b0a[l] = base[l] + SEARCH_BLOCK * c;
        PREFETCH(S->pairs + b0a[l]);
    }
    for (int l = 0; l < n; ++l) {
        const uint k = (uint)ka[l], b0 = b0a[l];
        uint c2 = 0u;
        for (uint j = 0; j < SEARCH_BLOCK; ++j) c2 += ((uint)PAIR_IEND(S->pairs[b0 + j]) < k);
        za[l] = va[l] ? stored_depth(PAIR_STORED(S->pairs[b0 + c2])) : INFINITY;
    }
}

#endif  /* NTYPES */
#endif

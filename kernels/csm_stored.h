/* csm_stored.h -- stored_v(): the stored depth of (map, texel) for every
 * lane of a scene kernel's CSM lookup (csm_lookup.h), by the search of
 * csm_search.h over the padded lists of the scene's atlas: the block by a
 * binary search of the summary, LANES lanes side by side, the segment by
 * counting in the block (the same segment as csm_find()).
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
/* the most lanes one stored_v() asks: a batch's queue (batch.h), or with
 * FILTERED a round of the votes or a lane group's 16 taps (csm_vote.h,
 * included first) */
#if FILTERED
#ifndef VOTE_LANES
#error "csm_vote.h must be included before csm_stored.h"
#endif
#define STORED_MAX (16 * LANES > VOTE_ROUND * VOTE_LANES ? 16 * LANES : VOTE_ROUND * VOTE_LANES)
#else
#define STORED_MAX (BATCH + LANES)
#endif

/* za[l]: the stored depth of (map ka[l], texel ta[l]) of CSM type T for
 * every lane l < n (a multiple of LANES, at most STORED_MAX; ka a LANE_ARRAY
 * or one offset by a multiple of LANES) with va[l] != 0, +inf for the
 * others. The search of csm_find() (csm_search.h) for every lane: first the
 * list's block summary, then the block. */
__attribute__((always_inline))
inline void stored_v(const scene_t *S, __global const csm_type_t *T, const int *ka, const int *ta,
                     const int *va, float *za, const int n)
{
    __global const uint *off = S->offsets + T->texel_base;
    __global const uint *sof = S->soff + T->texel_base;
    LANE_ARRAY int lo[STORED_MAX], hi[STORED_MAX];
    LANE_ARRAY uint base[STORED_MAX];
    for (int l = 0; l < n; ++l) {
        const uint t = va[l] ? (uint)ta[l] : 0u;
        base[l] = off[t];
        lo[l] = (int)sof[t];
        hi[l] = va[l] ? (int)sof[t + 1] - 1 : lo[l];
        PREFETCH(S->summary + lo[l]);
#if PROFILE_SKIP_SEARCH
        hi[l] = lo[l];
#endif
    }
    /* the block: the number of summary entries below the map, by a binary
     * search of LANES lanes side by side (the entry at hi, the list's last,
     * is read but not counted: every index read lies in the list), no
     * branch per lane; then the block is prefetched. The lists are padded
     * to whole blocks (search_arrays(padded=True)) with copies of their last
     * pair (i_end = D - 1, never below the map), so every block is
     * SEARCH_BLOCK pairs at an aligned start. First every lane's block is
     * found and prefetched (the lanes' cache misses are in flight together),
     * then the blocks are counted and the segment's depth read. */
    LANE_ARRAY uint b0a[STORED_MAX];
    for (int c0 = 0; c0 < n; c0 += LANES) {
        const iv k = LANE_LOAD(ka + c0), a = LANE_LOAD(lo + c0);
        iv b = a, len = LANE_LOAD(hi + c0) - a;
        LANE_ARRAY int mid[LANES];
#define SUMMARY_AT(l, v) (int)S->summary[v[l]]
        while (VANY(MASK(len > 0))) {
            const iv h = len >> 1, m = b + h;
            LANE_STORE(m, mid);
            const iv below = MASK(LANE_GATHER(iv, SUMMARY_AT, mid) < k) & MASK(len > 0);
            b = VSEL(b, m + 1, below);
            len = VSEL(h, len - h - 1, below);
        }
#undef SUMMARY_AT
        LANE_STORE(b - a, mid);
        for (int l = 0; l < LANES; ++l) {
            b0a[c0 + l] = base[c0 + l] + SEARCH_BLOCK * (uint)mid[l];
            PREFETCH(S->pairs + b0a[c0 + l]);
        }
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

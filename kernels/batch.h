/* batch.h -- batch_occluded(): a work-item's batch of queries against the
 * whole scene -- the ground plane, then per caster instance the bounding
 * sphere and the CSM lookup (csm_lookup.h) of the queries still open.
 * Expects: LANES (lanes.h), BATCH (queries per work-item, a multiple of
 * LANES), GROUND, SURFACE_NORMALS (0/1: each query's surface normal in
 * nx, ny, nz, for the surface rule of csm_lookup.h), INSTANCE_BVH (0/1:
 * find the casters through the tree over their boxes, BVH_STACK deep;
 * pyshadow.visibility.bvh), INSTANCE_GRID (0/1: through the grid over their
 * spheres, grid.h; pyshadow.visibility.grid; at most one of the two),
 * FINITE_RAYS (0/1: each query's length in tm, scene_tables.h), NTYPES (0:
 * the scene has no caster; only the ground test is compiled -- no sphere
 * test, tree, grid or lookup), and what csm_lookup.h expects. The grid's
 * walk (batch_grid()) is in batch_grid.h.
 */
#ifndef PYSHADOW_BATCH_H
#define PYSHADOW_BATCH_H

#include "lanes.h"
#include "scene_tables.h"
#include "csm_lookup.h"
#include "grid.h"

/* ---------------------------------------------------------------------
 * A batch of nb <= BATCH queries (private arrays; nb a multiple of LANES):
 * occ[i] != 0 on entry marks queries already decided (padding), on exit
 * the occluded ones. The ground plane is tested for all; then, per caster,
 * only the undecided queries whose ray can meet its bounding sphere join a
 * queue of (query, caster) pairs that the CSM lookup answers LANES at a
 * time -- rays stopped by the ground or missing a body cost no search.
 * Which casters a query meets:
 *   - every caster, one after another (neither define);
 *   - INSTANCE_BVH: those of the tree's leaves its ray reaches: a node is
 *     entered by the lane groups of the batch that have a ray meeting the
 *     boxes on the way to it, and its box is tested for those groups only;
 *   - INSTANCE_GRID: those listed in the grid cells its ray crosses (the
 *     rays of a lane group walked side by side), and the few casters wider
 *     than a cell.
 * Each caster is asked exactly as without tree or grid (the same sphere
 * test and lookup; the OR over casters does not depend on their order), so
 * answers are the same bit for bit.
 * ------------------------------------------------------------------- */
#ifndef BATCH
#error "BATCH (queries per work-item, a multiple of LANES) must be defined by the host"
#endif
/* words of a bit set over the batch's lane groups (the tree's traversal) */
#define BVH_WORDS ((BATCH / LANES + 31) / 32)
#if SURFACE_NORMALS
#define BATCH_NORMAL_PARAMS , const float *nx, const float *ny, const float *nz
#define BATCH_NORMAL_ARGS , nx, ny, nz
#else
#define BATCH_NORMAL_PARAMS
#define BATCH_NORMAL_ARGS
#endif
/* a batch's queries as its functions pass them on: points, unit directions,
 * owners, the decided mask (and normals) */
#define QUERY_PARAMS const float *px, const float *py, const float *pz, const float *wx, const float *wy, \
                     const float *wz, const int *own, int *occ BATCH_NORMAL_PARAMS
#define QUERY_ARGS px, py, pz, wx, wy, wz, own, occ BATCH_NORMAL_ARGS
#if FINITE_RAYS         /* each query's length tm (world units; scene_tables.h) */
#define BATCH_TMAX_PARAMS , const float *tm
#define BATCH_TMAX_ARGS , tm
#define TMAX_LANES(c) , LANE_LOAD(tm + (c))
#else
#define BATCH_TMAX_PARAMS
#define BATCH_TMAX_ARGS
#define TMAX_LANES(c)
#endif

#if NTYPES
/* The (query, caster) pairs a batch still has to ask, LANES to a lookup:
 * the sphere tests of every caster append to one queue, whose full lane
 * groups are asked (after each caster with the tree; when the queue is full
 * and after the walks with the grid), whichever casters the pairs belong to
 * (each lane reads its own instance; instance_v), so that a batch among many
 * casters, each met by a few of its rays, fills its lanes instead of asking
 * each caster with mostly empty ones. The pairs of one lookup share a CSM
 * type: with several types a change of type first asks what waits. A query
 * stays open until its pairs are asked, and may meet more casters meanwhile;
 * the answer, an OR over the casters its ray meets, is the same. */
typedef struct {
    int n, type;                        /* pairs waiting, their CSM type */
    int q[BATCH + LANES], j[BATCH + LANES];
} pending_t;

/* ask the first cnt pairs of P, LANES at a time, passing over the pairs of
 * queries an earlier group (or the ground) has found occluded: a query's
 * answer is the OR over its pairs. The one-texel lookup runs in two halves:
 * every group's maps, texels and depths first (instance_v), then the
 * searches of all of them together (stored_v), so that the cache misses of
 * all the groups are in flight at once, not one group's after another's.
 * So does the vote: VOTE_GROUPS groups' votes planned (instance_v), then
 * read together, round by round (vote_occluded(), csm_vote.h). */
inline void batch_ask(const scene_t *S, const pending_t *P, const int cnt, QUERY_PARAMS)
{
#if FILTERED
    vote_t V;
    int qv[VOTE_LANES], g = 0;  /* each planned lane's query; the lanes planned */
#else
    LANE_ARRAY int ka[STORED_MAX], ta[STORED_MAX], va[STORED_MAX], qa[STORED_MAX];
    LANE_ARRAY float dz[STORED_MAX], bz[STORED_MAX], za[STORED_MAX];
#if EMPTY_RUNS
    int searched = 0;   /* lanes that search (instance_v: inside the map, not on an empty run) */
#endif
    int m = 0;      /* lanes asked, whole groups: every group but the last is full, so m is at most cnt
                     * (a queue's length, <= BATCH + LANES) rounded up to LANES: STORED_MAX */
#endif
    for (int k = 0; k < cnt;) {
        int gi[LANES], ja[LANES], n = 0;
        for (; k < cnt && n < LANES; ++k) {     /* the next pairs whose query is open, without branches */
            gi[n] = P->q[k];
            ja[n] = P->j[k];
            n += occ[gi[n]] == 0;
        }
        if (n == 0)
            break;
        for (int l = n; l < LANES; ++l)         /* padding: the last pair again, masked off */
            gi[l] = gi[n - 1], ja[l] = ja[n - 1];
#define PAIR_Q(l, a) a[gi[l]]                   /* pair l's query's value in array a */
#define PAIR_J(l, u) ja[l]
        const iv act = MASK(LANE_IDS < n);
#if !FILTERED
        iv known;               /* lanes answered occluded without a search (instance_v, EMPTY_RUNS) */
#endif
        const iv r = instance_v(S, P->type, LANE_GATHER(iv, PAIR_J, 0), ja[0], LANE_GATHER(fv, PAIR_Q, px),
                                LANE_GATHER(fv, PAIR_Q, py), LANE_GATHER(fv, PAIR_Q, pz), LANE_GATHER(fv, PAIR_Q, wx),
                                LANE_GATHER(fv, PAIR_Q, wy), LANE_GATHER(fv, PAIR_Q, wz), LANE_GATHER(iv, PAIR_Q, own),
                                act
#if SURFACE_NORMALS
                                , LANE_GATHER(fv, PAIR_Q, nx), LANE_GATHER(fv, PAIR_Q, ny), LANE_GATHER(fv, PAIR_Q, nz)
#endif
#if !FILTERED
                                , ka + m, ta + m, dz + m, bz + m, &known
#else
                                , &V, g
#endif
                                );
#undef PAIR_Q
#undef PAIR_J
#if FILTERED
        (void)r;
        for (int l = 0; l < LANES; ++l)
            qv[g + l] = gi[l];
        g += LANES;
        if (g == VOTE_LANES) {
            vote_occluded(S, S->types + P->type, &V, g / LANES, qv, occ);
            g = 0;
        }
#else
        LANE_STORE(r, va + m);
        for (int l = 0; l < LANES; ++l)
            qa[m + l] = gi[l];
#if EMPTY_RUNS
        if (VANY(known)) {      /* their queries' later pairs are passed over, as after a search */
            LANE_ARRAY int kn[LANES];
            LANE_STORE(known, kn);
            for (int l = 0; l < LANES; ++l)
                occ[gi[l]] |= kn[l];
        }
#endif
        m += LANES;
#if EMPTY_RUNS
        searched += BIT_COUNT(LANE_BITS(r));
#endif
#endif
    }
#if FILTERED
    if (g)
        vote_occluded(S, S->types + P->type, &V, g / LANES, qv, occ);
#else
#if EMPTY_RUNS
    /* where that spares a lane group, the lanes that still search moved to
     * the front (va 0: outside the map, or on an empty run of maps, answered
     * open by instance_v), without branches, in whole groups: the last padded
     * with lanes that ask nothing */
    if (m - searched >= LANES) {
        int w = 0;
        for (int l = 0; l < m; ++l) {
            ka[w] = ka[l]; ta[w] = ta[l]; va[w] = va[l]; qa[w] = qa[l]; dz[w] = dz[l]; bz[w] = bz[l];
            w += va[l] != 0;
        }
        m = (w + LANES - 1) / LANES * LANES;
        for (int l = w; l < m; ++l) {
            ka[l] = 0; ta[l] = 0; va[l] = 0; qa[l] = qa[0]; dz[l] = 0.0f; bz[l] = 0.0f;
        }
    }
#endif
    if (m == 0)
        return;
    stored_v(S, S->types + P->type, ka, ta, va, za, m);
    for (int c = 0; c < m; c += LANES) {        /* the lookup's end (padding lanes: va 0) */
        LANE_ARRAY int ra[LANES];
        LANE_STORE(LANE_LOAD(va + c) & MASK(LANE_LOAD(dz + c) > LANE_LOAD(za + c) + LANE_LOAD(bz + c)), ra);
        for (int l = 0; l < LANES; ++l)
            occ[qa[c + l]] |= ra[l];
    }
#endif
}

/* the queue holds pairs of one CSM type: before a pair of caster j joins,
 * what waits of another type is asked */
inline void pending_type(const scene_t *S, pending_t *P, const int j, QUERY_PARAMS)
{
#if NTYPES > 1
    const int t = S->itype[j];
    if (P->n && t != P->type) {
        batch_ask(S, P, P->n, QUERY_ARGS);
        P->n = 0;
    }
    P->type = t;
#endif
}

#if INSTANCE_BVH || INSTANCE_GRID
/* ask the full lane groups of the first cnt pairs; the rest (fewer than
 * LANES) waits at the front of the queue */
inline void pending_drain(const scene_t *S, pending_t *P, const int cnt, QUERY_PARAMS)
{
    const int full = cnt - cnt % LANES;
    batch_ask(S, P, full, QUERY_ARGS);
    for (int k = full; k < cnt; ++k)
        P->q[k - full] = P->q[k], P->j[k - full] = P->j[k];
    P->n = cnt - full;
}
#endif

/* the open queries of the lane groups gl[0 .. ng) (offsets into the batch)
 * against caster j, of those the lanes of lm: those whose ray can meet its
 * bounding sphere join the queue, and its full groups are asked */
inline void batch_instance(const scene_t *S, const int j, pending_t *P, const int *gl, const int ng,
                           const int *lm, QUERY_PARAMS BATCH_TMAX_PARAMS)
{
    pending_type(S, P, j, QUERY_ARGS);
    int cnt = P->n;
    for (int e = 0; e < ng; ++e) {
        const int c = gl[e];
        const iv act = LANE_LOAD(lm + c) & ~LANE_LOAD(occ + c)
                       & sphere_v(S, j, LANE_LOAD(px + c), LANE_LOAD(py + c), LANE_LOAD(pz + c),
                                  LANE_LOAD(wx + c), LANE_LOAD(wy + c), LANE_LOAD(wz + c) TMAX_LANES(c));
        if (!VANY(act))
            continue;                           /* no ray of the group meets the sphere */
        LANE_ARRAY int am[LANES];
        LANE_STORE(act, am);
        for (int l = 0; l < LANES; ++l) {       /* branch-free packing; cnt < LANES + e LANES + l here */
            P->q[cnt] = c + l;
            P->j[cnt] = j;
            cnt += (am[l] != 0);
        }
    }
#if INSTANCE_BVH || INSTANCE_GRID
    pending_drain(S, P, cnt, QUERY_ARGS);
#else
    batch_ask(S, P, cnt, QUERY_ARGS);   /* few casters: each asked at once */
    P->n = 0;
#endif
}
#endif

#include "batch_grid.h"

inline void batch_occluded(const scene_t *S, const float *px, const float *py, const float *pz,
                           const float *wx, const float *wy, const float *wz, const int *own,
                           int *occ, const int nb BATCH_NORMAL_PARAMS BATCH_TMAX_PARAMS)
{
#if GROUND
    for (int c = 0; c < nb; c += LANES)
        LANE_STORE(LANE_LOAD(occ + c) | ground_v(S, LANE_LOAD(py + c), LANE_LOAD(wy + c) TMAX_LANES(c)),
                   occ + c);
#endif
#if NTYPES
    pending_t P;
    P.n = 0;
    P.type = 0;
    LANE_ARRAY int lm[BATCH];                   /* lanes that may meet the casters asked next */
    int gl[BATCH / LANES], ng = 0;              /* their lane groups (offsets into the batch) */
#endif
#if NTYPES && INSTANCE_BVH
    LANE_ARRAY float ix[BATCH], iy[BATCH], iz[BATCH];
    for (int c = 0; c < nb; c += LANES) {
        LANE_STORE((fv)(1.0f) / LANE_LOAD(wx + c), ix + c);
        LANE_STORE((fv)(1.0f) / LANE_LOAD(wy + c), iy + c);
        LANE_STORE((fv)(1.0f) / LANE_LOAD(wz + c), iz + c);
    }
    /* gm: the lane groups with a ray that met every box on the way to the
     * node (bit g: lanes g LANES ...); each stack entry keeps its own */
    uint gm[BVH_WORDS], held[BVH_STACK][BVH_WORDS];
    int stack[BVH_STACK];
    for (int w = 0; w < BVH_WORDS; ++w)
        gm[w] = 0u;
    for (int g = 0; g < nb / LANES; ++g)
        gm[g >> 5] |= 1u << (g & 31);
    int sp = 0, node = 0;
    for (;;) {
        __global const bvh_node_t *B = S->nodes + node;
        uint hm[BVH_WORDS];
        for (int w = 0; w < BVH_WORDS; ++w)
            hm[w] = 0u;
        ng = 0;
        for (int g = 0; g < nb / LANES; ++g) {
            if (!((gm[g >> 5] >> (g & 31)) & 1u))
                continue;
            const int c = g * LANES;
            const iv h = ~LANE_LOAD(occ + c) & box_v(S, B, LANE_LOAD(px + c), LANE_LOAD(py + c),
                                                     LANE_LOAD(pz + c), LANE_LOAD(ix + c), LANE_LOAD(iy + c),
                                                     LANE_LOAD(iz + c) TMAX_LANES(c));
            if (VANY(h)) {
                hm[g >> 5] |= 1u << (g & 31);
                LANE_STORE(h, lm + c);
                gl[ng++] = c;
            }
        }
        if (ng) {
            const int a = B->a, b = B->b;
            if (b >= 0) {                       /* inner node: the left child next, the right one later */
                if (b != a) {
                    for (int w = 0; w < BVH_WORDS; ++w)
                        held[sp][w] = hm[w];
                    stack[sp++] = b;
                }
                for (int w = 0; w < BVH_WORDS; ++w)
                    gm[w] = hm[w];
                node = a;
                continue;
            }
            for (int k = a; k < a - b; ++k)     /* leaf: its casters, for the rays that met its box */
                batch_instance(S, S->order[k], &P, gl, ng, lm, px, py, pz, wx, wy, wz, own, occ
                               BATCH_NORMAL_ARGS BATCH_TMAX_ARGS);
        }
        if (sp == 0)
            break;
        node = stack[--sp];
        for (int w = 0; w < BVH_WORDS; ++w)
            gm[w] = held[sp][w];
    }
#elif NTYPES
    for (int c = 0; c < nb; c += LANES) {
        LANE_STORE((iv)(-1), lm + c);
        gl[ng++] = c;
    }
#if INSTANCE_GRID
    batch_grid(S, &P, gl, ng, lm, QUERY_ARGS BATCH_TMAX_ARGS);
#else
    for (int j = 0; j < S->ninst; ++j)
        batch_instance(S, j, &P, gl, ng, lm, QUERY_ARGS
                       BATCH_TMAX_ARGS);
#endif
#endif
#if NTYPES
    batch_ask(S, &P, P.n, QUERY_ARGS);   /* what still waits */
#endif
}

#endif

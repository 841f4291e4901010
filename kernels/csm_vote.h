/* csm_vote.h -- the vote of the FILTERED lookup (csm_lookup.h) for several
 * lane groups at once: instance_v() plans each group's vote (its four maps,
 * their taps and depths) into a vote_t; vote_occluded() then reads the taps
 * of all the planned groups round by round, each round's taps of all the
 * groups packed into one search (stored_v(): their cache misses in flight
 * together; lanes with nothing to read take no part), and ORs the groups'
 * answers into the batch. Each lane reads its taps in the same order and
 * decides exactly as when the groups voted one after another, one tap after
 * another: the answers are the same bit for bit.
 *
 * Expects: LANES (lanes.h), the scene tables (scene_tables.h), BATCH, NTYPES,
 * FILTERED; optional VOTE_FIRST, VOTE_NEXT (the taps of the first and later
 * rounds), VOTE_MARGIN (the margin of a decided vote), VOTE_GROUPS (lane
 * groups voting together); the answers do not depend on them. Included by
 * csm_lookup.h before csm_stored.h, whose STORED_MAX counts these rounds.
 */
#ifndef PYSHADOW_CSM_VOTE_H
#define PYSHADOW_CSM_VOTE_H

#include "lanes.h"
#include "scene_tables.h"

#if NTYPES && FILTERED
#ifndef VOTE_FIRST
#define VOTE_FIRST 4
#endif
#ifndef VOTE_NEXT
#define VOTE_NEXT 1
#endif
#if VOTE_FIRST < 1 || VOTE_FIRST > 16 || VOTE_NEXT < 1 || VOTE_NEXT > 16
#error "VOTE_FIRST and VOTE_NEXT must lie in 1 .. 16"
#endif
#ifndef VOTE_MARGIN
#define VOTE_MARGIN 1e-4f
#endif
/* lane groups planned before their rounds: 128 lanes, at most a batch's queue (batch.h) */
#ifndef VOTE_GROUPS
#define VOTE_GROUPS (128 / LANES < (BATCH + LANES) / LANES ? 128 / LANES : (BATCH + LANES) / LANES)
#endif
#if VOTE_GROUPS < 1
#error "VOTE_GROUPS must be at least 1"
#endif
#define VOTE_LANES (VOTE_GROUPS * LANES)
/* the most taps a lane reads in one round */
#define VOTE_ROUND (VOTE_FIRST > VOTE_NEXT ? VOTE_FIRST : VOTE_NEXT)
#endif

#include "csm_stored.h"

#if NTYPES && FILTERED
/* The planned votes of VOTE_GROUPS lane groups, lane c of group g at
 * g LANES + c of every array: per map m (heaviest first) its map kw, whether
 * the point lies in its square (ins, a mask) and the point's depth dq; per
 * tap i = 4 m + c (each map's taps heaviest first) its texel tq, weight tw
 * and bias tb; the running vote: the weights read shadowing (ws) and lit
 * (wl), the lanes still reading (open) or out of taps undecided (exh), and
 * each map's next tap (head). Every array is a whole number of lane vectors:
 * the first one's alignment (LANE_ARRAY) holds for all. */
typedef struct {
    LANE_ARRAY float tw[16][VOTE_LANES];
    float tb[16][VOTE_LANES], dq[4][VOTE_LANES], ws[VOTE_LANES], wl[VOTE_LANES];
    int tq[16][VOTE_LANES], kw[4][VOTE_LANES], ins[4][VOTE_LANES], head[4][VOTE_LANES];
    int open[VOTE_LANES], exh[VOTE_LANES];
} vote_t;

/* The rounds of the votes of V's first ng groups, and the rule replayed on
 * the lanes that read all of their taps undecided; the lanes occluded are
 * ORed into occ[qa[l]] (qa: each lane's query; padding lanes are not
 * open). The rule (scene.visible_reference(filtered=True)): maps heaviest
 * first, each map's taps heaviest first, a lane asking no more once its
 * shadowing votes exceed one half or the weight still to come cannot take
 * them there (a margin of 1e-5 for the rounding of the running sums); the
 * answer: the votes exceed one half. That answer is known as soon as the
 * taps read, in whatever order, weigh more than one half plus VOTE_MARGIN
 * on one side (the weights sum to 1, the rounding of these sums is below
 * 1e-5): so each lane reads its taps heaviest first over all four maps (a
 * merge of the maps' sorted taps), fewer than in the rule's order, in
 * rounds for the lanes still open: in a round a lane reads its next tap,
 * and the ones after it as long as the weight known before each (its taps
 * read, either side, and the maps not holding the point) is at most
 * 0.5 + VOTE_MARGIN -- the vote cannot be decided before them (the running
 * sums are at most that weight), so no tap is read in vain -- VOTE_FIRST
 * at most in the first round, VOTE_NEXT in later ones. A lane that has read
 * all of its taps undecided (a vote within VOTE_MARGIN of one half) replays
 * the rule on them, read again. */
inline void vote_occluded(const scene_t *S, __global const csm_type_t *T, vote_t *V, const int ng,
                          const int *qa, int *occ)
{
    const float decisive = 0.5f + VOTE_MARGIN;
    for (int r = 0; r <= 16; ++r) {            /* an open lane reads at least one tap a round */
        const int nb = r ? VOTE_NEXT : VOTE_FIRST;
        int gs[VOTE_GROUPS], np = 0;            /* the groups with an open lane */
        for (int g = 0; g < ng; ++g) {
            gs[np] = g;
            np += VANY(LANE_LOAD(V->open + g * LANES)) ? 1 : 0;
        }
        if (np == 0)
            break;
        LANE_ARRAY int ia[VOTE_ROUND][VOTE_LANES], fa[VOTE_ROUND][VOTE_LANES], pa[VOTE_ROUND][VOTE_LANES];
        LANE_ARRAY int ka[VOTE_ROUND * VOTE_LANES], ta[VOTE_ROUND * VOTE_LANES], va[VOTE_ROUND * VOTE_LANES];
        LANE_ARRAY float bw[VOTE_ROUND][VOTE_LANES], za[VOTE_ROUND * VOTE_LANES];
        int nf = 0;                             /* the taps read, listed in ka, ta */
        for (int e = 0; e < np; ++e) {          /* each lane's next nb taps: the heaviest of the maps' next ones */
            const int g = gs[e] * LANES, o = e * LANES;
            const iv open = LANE_LOAD(V->open + g);
            fv sum = LANE_LOAD(V->ws + g) + LANE_LOAD(V->wl + g);
            iv f = open;
            iv head[4], ins[4];
            for (int m = 0; m < 4; ++m)
                head[m] = LANE_LOAD(V->head[m] + g), ins[m] = LANE_LOAD(V->ins[m] + g);
            for (int b = 0; b < nb; ++b) {
                fv w = (fv)(-1.0f);
                iv bi = (iv)(0), bm = (iv)(-1);
                for (int m = 0; m < 4; ++m) {
                    fv h = (fv)(-1.0f);
                    for (int c = 0; c < 4; ++c)
                        h = VSEL(h, LANE_LOAD(V->tw[4 * m + c] + g), MASK(head[m] == c) & ins[m]);
                    const iv take = MASK(h > w);
                    w = VSEL(w, h, take);
                    bm = VSEL(bm, (iv)(m), take);
                    bi = VSEL(bi, 4 * m + head[m], take);
                }
                for (int m = 0; m < 4; ++m)
                    head[m] -= MASK(bm == m) & f;
                LANE_STORE(w, bw[b] + o);
                LANE_STORE(bi, ia[b] + o);
                LANE_STORE(f, fa[b] + o);
                LANE_STORE(f & MASK(bm >= 0), pa[b] + o);
                sum += VSEL((fv)(0.0f), w, f & MASK(bm >= 0));
                f &= MASK(bm >= 0) & MASK(sum <= decisive);
                for (int l = 0; l < LANES; ++l) {       /* the taps read, packed without branches */
                    const int i = ia[b][o + l], rd = pa[b][o + l] != 0;
                    ka[nf] = V->kw[i >> 2][g + l];
                    ta[nf] = V->tq[i][g + l];
                    va[nf] = 1;
                    pa[b][o + l] = rd ? nf : 0;
                    nf += rd;
                }
            }
            for (int m = 0; m < 4; ++m)
                LANE_STORE(head[m], V->head[m] + g);
        }
        for (; nf % LANES || nf == 0; ++nf)     /* whole lane groups, at least one (za[0] is read) */
            ka[nf] = 0, ta[nf] = 0, va[nf] = 0;
        stored_v(S, T, ka, ta, va, za, nf);
        for (int e = 0; e < np; ++e) {
            const int g = gs[e] * LANES, o = e * LANES;
            fv ws = LANE_LOAD(V->ws + g), wl = LANE_LOAD(V->wl + g);
            iv open = LANE_LOAD(V->open + g), exh = LANE_LOAD(V->exh + g);
            for (int b = 0; b < nb; ++b) {
                LANE_ARRAY float zb[LANES], db[LANES];
                for (int l = 0; l < LANES; ++l) {
                    const int i = ia[b][o + l];
                    zb[l] = za[pa[b][o + l]] + V->tb[i][g + l];
                    db[l] = V->dq[i >> 2][g + l];
                }
                const fv w = LANE_LOAD(bw[b] + o);
                const iv live = open & LANE_LOAD(fa[b] + o), has = live & MASK(w >= 0.0f);
                const iv sh = MASK(LANE_LOAD(db) > LANE_LOAD(zb));
                ws += VSEL((fv)(0.0f), w, has & sh);
                wl += VSEL((fv)(0.0f), w, has & ~sh);
                exh |= live & ~has;
                open = (open & ~live) | (has & MASK(ws <= decisive) & MASK(wl <= decisive));
            }
            LANE_STORE(ws, V->ws + g);
            LANE_STORE(wl, V->wl + g);
            LANE_STORE(open, V->open + g);
            LANE_STORE(exh, V->exh + g);
        }
    }
    for (int g = 0; g < ng * LANES; g += LANES) {
        const iv exh = LANE_LOAD(V->exh + g) | LANE_LOAD(V->open + g);
        iv shadow = MASK(LANE_LOAD(V->ws + g) > decisive);
        if (VANY(exh)) {        /* the rule itself, on every tap of the maps holding the point */
            LANE_ARRAY int ka[16 * LANES], ta[16 * LANES], va[16 * LANES];
            LANE_ARRAY float za[16 * LANES];
            for (int i = 0; i < 16; ++i) {
                LANE_STORE(exh & LANE_LOAD(V->ins[i >> 2] + g), va + i * LANES);
                for (int l = 0; l < LANES; ++l) {
                    ka[i * LANES + l] = V->kw[i >> 2][g + l];
                    ta[i * LANES + l] = V->tq[i][g + l];
                }
            }
            stored_v(S, T, ka, ta, va, za, 16 * LANES);
            fv v = (fv)(0.0f), rest = (fv)(1.0f);
            iv o = exh;
            for (int i = 0; i < 16; ++i) {
                const int m = i >> 2;
                const fv tw = LANE_LOAD(V->tw[i] + g);
                v += VSEL((fv)(0.0f), tw, o & LANE_LOAD(V->ins[m] + g)
                          & MASK(LANE_LOAD(V->dq[m] + g) > LANE_LOAD(za + i * LANES) + LANE_LOAD(V->tb[i] + g)));
                rest -= tw;
                o &= MASK(v <= 0.5f) & MASK(v + rest > 0.5f - 1e-5f);
            }
            shadow = VSEL(shadow, MASK(v > 0.5f), exh);
        }
        LANE_ARRAY int ra[LANES];
        LANE_STORE(shadow, ra);
        for (int l = 0; l < LANES; ++l)
            occ[qa[g + l]] |= ra[l];
    }
}
#endif
#endif

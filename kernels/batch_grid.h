/* batch_grid.h -- batch_grid(): a batch's queries against the casters listed
 * in the cells of the instance grid (grid.h; pyshadow.visibility.grid) that
 * their rays cross, queued for the lookups of batch.h. Part of batch.h,
 * which includes it after batch_instance(); expects what batch.h expects.
 */
#ifndef PYSHADOW_BATCH_GRID_H
#define PYSHADOW_BATCH_GRID_H

#if NTYPES && INSTANCE_GRID
#if FINITE_RAYS
#define TMAX1_ARG(i) , tm[i]
#else
#define TMAX1_ARG(i)
#endif
/* queue the pair (query i, caster j); the queue is asked when it is full
 * (BATCH pairs), and at the end of the walks (batch_grid): the walks run
 * without lookups in between, and the lookups run LANES pairs at a time */
__attribute__((always_inline)) inline void pending_push(const scene_t *S, pending_t *P, const int i, const int j,
                                                        QUERY_PARAMS)
{
#if NTYPES > 1
    if (S->itype[j] != P->type)
        pending_type(S, P, j, QUERY_ARGS);
#endif
    P->q[P->n] = i;
    P->j[P->n] = j;
    if (++P->n == BATCH) {
        batch_ask(S, P, BATCH, QUERY_ARGS);
        P->n = 0;
    }
}

/* A sphere lies in up to 8 cells, which a ray crosses one after another:
 * one the ray meets that is among the last GRID_SEEN it met (sn, per lane)
 * is not queued again (one met again after more is asked twice, with the
 * same answer) */
#define GRID_SEEN 4
__attribute__((always_inline)) inline void grid_met(const scene_t *S, pending_t *P, int *sn, const int i,
                                                    const int j, QUERY_PARAMS)
{
    if (j == sn[0] || j == sn[1] || j == sn[2] || j == sn[3])
        return;
    sn[3] = sn[2]; sn[2] = sn[1]; sn[1] = sn[0]; sn[0] = j;
    pending_push(S, P, i, j, QUERY_ARGS);
}

/* the walking lanes of group c all in the cell of packet K (rays from one
 * point, as AO's): its spheres against the lane vector, one at a time */
__attribute__((always_inline)) inline void grid_cell_shared(const scene_t *S, pending_t *P,
                                                            __global const grid_packet_t *K, const int c,
                                                            const fv *p, const fv *w, const iv walking,
                                                            int (*seen)[GRID_SEEN], QUERY_PARAMS BATCH_TMAX_PARAMS)
{
    for (;; K = S->gpackets + (-2 - K->instance[3])) {
        for (int q = 0; q < 4; ++q) {
            const int j = K->instance[q];
            if (j == -1)
                break;                          /* unused slots: the rest of the list's last packet */
            const iv met = (j >= 0 ? walking : (iv)(0)) & sphere_slot_v(K, q, p, w TMAX_LANES(c));
            if (!VANY(met))
                continue;                       /* missed, or the link */
            LANE_ARRAY int ma[LANES];
            LANE_STORE(met, ma);
            for (int l = 0; l < LANES; ++l)
                if (ma[l])
                    grid_met(S, P, seen[l], c + l, j, QUERY_ARGS);
        }
        if (K->instance[3] >= -1)               /* < -1: the list goes on in packet -2 - link */
            break;
    }
}

/* query i's ray against the list of its cell, from packet K, four spheres at a time */
__attribute__((always_inline)) inline void grid_cell_one(const scene_t *S, pending_t *P,
                                                         __global const grid_packet_t *K, const int i, int *sn,
                                                         QUERY_PARAMS BATCH_TMAX_PARAMS)
{
    for (;; K = S->gpackets + (-2 - K->instance[3])) {
        const int4 met = sphere_4(K, px[i], py[i], pz[i], wx[i], wy[i], wz[i] TMAX1_ARG(i));
        if (met.x | met.y | met.z | met.w) {
            const int hit[4] = {met.x, met.y, met.z, met.w};
            for (int q = 0; q < 4; ++q)
                if (hit[q])
                    grid_met(S, P, sn, i, K->instance[q], QUERY_ARGS);
        }
        if (K->instance[3] >= -1)
            break;
    }
}

/* the open queries of the batch against the casters listed in the cells
 * their rays cross (grid.h; the lanes of a group walk side by side), then
 * the casters wider than a cell, asked of every ray */
inline void batch_grid(const scene_t *S, pending_t *P, const int *gl, const int ng, const int *lm,
                       QUERY_PARAMS BATCH_TMAX_PARAMS)
{
    __global const grid_t *G = S->grid;
    for (int e = 0; e < ng; ++e) {
        const int c = gl[e];
        const fv p[3] = {LANE_LOAD(px + c), LANE_LOAD(py + c), LANE_LOAD(pz + c)};
        const fv w[3] = {LANE_LOAD(wx + c), LANE_LOAD(wy + c), LANE_LOAD(wz + c)};
        const fv inv[3] = {(fv)(1.0f) / w[0], (fv)(1.0f) / w[1], (fv)(1.0f) / w[2]};
        walk_v_t W;
        grid_start_v(G, &W, p, w, inv, MASK(LANE_LOAD(occ + c) == 0));
        int seen[LANES][GRID_SEEN];
        for (int l = 0; l < LANES; ++l)
            for (int q = 0; q < GRID_SEEN; ++q)
                seen[l][q] = -1;
        while (VANY(W.walking)) {
            LANE_ARRAY int ca[LANES], wa[LANES];
            LANE_STORE(W.cid, ca);
            LANE_STORE(W.walking, wa);
            int f = 0;
            while (!wa[f])                      /* the first walking lane */
                ++f;
            if (VALL(~W.walking | MASK(W.cid == ca[f]))) {
                grid_cell_shared(S, P, S->gpackets + ca[f], c, p, w, W.walking, seen, QUERY_ARGS BATCH_TMAX_ARGS);
            } else {
                int act[LANES], na = 0;         /* the walking lanes, packed without branches */
                for (int l = 0; l < LANES; ++l) {
                    act[na] = l;
                    na += wa[l] != 0;
                }
                for (int m = 0; m < na; ++m)
                    grid_cell_one(S, P, S->gpackets + ca[act[m]], c + act[m], seen[act[m]], QUERY_ARGS
                                  BATCH_TMAX_ARGS);
            }
            grid_next_v(G, &W, p, inv);
            W.walking &= MASK(LANE_LOAD(occ + c) == 0);
        }
    }
    pending_drain(S, P, P->n, QUERY_ARGS);       /* batch_instance: fewer than LANES wait */
    const int big = G->dims[0] * G->dims[1] * G->dims[2];       /* the big casters' packets follow the cells' */
    for (int k = 0; k < G->big; ++k)
        batch_instance(S, S->gpackets[big + k / 4].instance[k % 4], P, gl, ng, lm, px, py, pz, wx, wy, wz, own, occ
                       BATCH_NORMAL_ARGS BATCH_TMAX_ARGS);
}
#endif

#endif

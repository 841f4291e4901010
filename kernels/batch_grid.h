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
 * same answer). With one CSM type, without a branch on the seen list: the
 * pair is written whatever, and counted when it is new */
#define GRID_SEEN 4
__attribute__((always_inline)) inline void grid_met(const scene_t *S, pending_t *P, int *sn, const int i,
                                                    const int j, QUERY_PARAMS)
{
#if NTYPES > 1
    if (j == sn[0] || j == sn[1] || j == sn[2] || j == sn[3])
        return;
    sn[3] = sn[2]; sn[2] = sn[1]; sn[1] = sn[0]; sn[0] = j;
    pending_push(S, P, i, j, QUERY_ARGS);
#else
    const int fresh = (j != sn[0]) & (j != sn[1]) & (j != sn[2]) & (j != sn[3]);
    sn[3] = fresh ? sn[2] : sn[3];
    sn[2] = fresh ? sn[1] : sn[2];
    sn[1] = fresh ? sn[0] : sn[1];
    sn[0] = fresh ? j : sn[0];
    P->q[P->n] = i;
    P->j[P->n] = j;
    P->n += fresh;
    if (P->n == BATCH) {
        batch_ask(S, P, BATCH, QUERY_ARGS);
        P->n = 0;
    }
#endif
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
            for (int bits = LANE_BITS(met); bits; bits &= bits - 1) {  /* the lanes met, in order */
                const int l = BIT_LOW(bits);
                grid_met(S, P, seen[l], c + l, j, QUERY_ARGS);
            }
        }
        if (K->instance[3] >= -1)               /* < -1: the list goes on in packet -2 - link */
            break;
    }
}

/* query i's ray against the list of its cell, from packet K, four spheres at a
 * time (grid_cells_apart: the packets after a list's first) */
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

/* the walking lanes of a group (the bits of walk), lane l in its own cell
 * ca[l], its query c + lq[l]: the first packet of every lane's list tested without
 * a branch on the result, the (lane, sphere) pairs met kept as bits (4 a
 * lane: 64 bits hold LANES <= 16), then queued lane by lane in slot order;
 * a list that goes on (a link) is tested on by grid_cell_one after. Each
 * lane makes the same tests and queues its casters in the same order as
 * grid_cell_one alone would */
#if CPU_CLANG
#define BIT_LOW64(b) __builtin_ctzl((ulong)(b))
#else
#define BIT_LOW64(b) (63 - (int)clz((b) & -(b)))
#endif
__attribute__((always_inline)) inline void grid_cells_apart(const scene_t *S, pending_t *P, int walk,
                                                            const int *ca, const int c,
                                                            const int *lq, int (*seen)[GRID_SEEN],
                                                            QUERY_PARAMS BATCH_TMAX_PARAMS)
{
    ulong bits = 0, links = 0;
    int lw[LANES];
    for (int m = 0; walk; walk &= walk - 1, ++m) {
        const int l = BIT_LOW(walk), i = c + lq[l];
        lw[m] = l;
        __global const grid_packet_t *K = S->gpackets + ca[l];
        const int4 met = sphere_4(K, px[i], py[i], pz[i], wx[i], wy[i], wz[i] TMAX1_ARG(i));
        bits |= (ulong)(uint)MASK4_BITS(met) << (4 * m);
        links |= (ulong)(K->instance[3] < -1) << m;
    }
    for (; bits; bits &= bits - 1) {
        const int b = BIT_LOW64(bits), l = lw[b >> 2];
        grid_met(S, P, seen[l], c + lq[l], S->gpackets[ca[l]].instance[b & 3], QUERY_ARGS);
    }
    for (; links; links &= links - 1) {
        const int l = lw[BIT_LOW64(links)];
        grid_cell_one(S, P, S->gpackets + (-2 - S->gpackets[ca[l]].instance[3]), c + lq[l], seen[l], QUERY_ARGS
                      BATCH_TMAX_ARGS);
    }
}

/* Walks set down (LANES > 1). The lanes of a group walk side by side until
 * the last has left the grid; rays from one point (AO's) share their first
 * cell, then part: most leave within two or three cells, a few low ones
 * walk tens, and the group's steps with one or two lanes walking cost a
 * whole step each. A group whose walking lanes are GRID_SPILL_LANES or fewer
 * sets their walks down (query, cells, seen list), and after the groups the
 * walks set down are taken up LANES at a time, a lane that leaves taking
 * the next: every walk visits the same cells in the same order with the
 * same tests as it would have, so the queries meet the same casters, or
 * ends early where its query is found occluded (the answer is then made) */
#if LANES > 1
#define GRID_SPILL_LANES (LANES / 4)        /* LANES / 2 and 3 LANES / 4 measured no faster */
#define GRID_DRAIN 16                       /* pairs waiting that the walks set down ask (32: slower) */
typedef struct {
    int n;
    int q[BATCH], cell[3][BATCH], seen[BATCH][GRID_SEEN];
} spill_t;

/* set down the walking lanes of group c (the bits of walk; walk W, seen lists seen) */
__attribute__((always_inline)) inline void grid_spill(spill_t *R, const walk_v_t *W, int walk, const int c,
                                                      int (*seen)[GRID_SEEN])
{
    LANE_ARRAY int k[3][LANES];
    for (int a = 0; a < 3; ++a)
        LANE_STORE(W->cell[a], k[a]);
    int r = R->n;
    for (; walk; walk &= walk - 1, ++r) {
        const int l = BIT_LOW(walk);
        R->q[r] = c + l;
        for (int a = 0; a < 3; ++a)
            R->cell[a][r] = k[a][l];
        for (int u = 0; u < GRID_SEEN; ++u)
            R->seen[r][u] = seen[l][u];
    }
    R->n = r;
}

/* the walks set down, LANES at a time: a lane whose walk ends takes up the
 * next whose query is still open. The pairs they queue are asked when
 * GRID_DRAIN wait (whole lane groups; pending_drain), and walks whose query
 * that finds occluded end there: the long walks (rays low over the casters)
 * mostly meet a caster that occludes them in their first few cells. */
inline void grid_spilled(const scene_t *S, pending_t *P, const spill_t *R, QUERY_PARAMS BATCH_TMAX_PARAMS)
{
    __global const grid_t *G = S->grid;
    LANE_ARRAY int lq[LANES], ca[LANES], k[3][LANES];
    int seen[LANES][GRID_SEEN];
    walk_v_t W;
    fv p[3], w[3], inv[3];
    for (int a = 0; a < 3; ++a)
        W.cell[a] = (iv)(0);
    W.walking = (iv)(0);
    for (int l = 0; l < LANES; ++l)
        lq[l] = 0;                              /* lanes never taken: query 0, not walking */
#define LANE_Q(l, a) a[lq[l]]                   /* lane l's query's value in array a */
    for (int h = 0;;) {
        int idle = ~LANE_BITS(W.walking) & LANE_ALL;
        if (h < R->n && idle) {                 /* the lanes whose walk has ended take up the next */
            for (int a = 0; a < 3; ++a)
                LANE_STORE(W.cell[a], k[a]);
            int took = 0;
            for (; idle; idle &= idle - 1) {
                while (h < R->n && occ[R->q[h]])
                    ++h;                        /* found occluded meanwhile: not walked on */
                if (h == R->n)
                    break;
                const int l = BIT_LOW(idle);
                lq[l] = R->q[h];
                for (int a = 0; a < 3; ++a)
                    k[a][l] = R->cell[a][h];
                for (int u = 0; u < GRID_SEEN; ++u)
                    seen[l][u] = R->seen[h][u];
                took |= 1 << l;
                ++h;
            }
            if (took) {
                p[0] = LANE_GATHER(fv, LANE_Q, px); p[1] = LANE_GATHER(fv, LANE_Q, py);
                p[2] = LANE_GATHER(fv, LANE_Q, pz);
                w[0] = LANE_GATHER(fv, LANE_Q, wx); w[1] = LANE_GATHER(fv, LANE_Q, wy);
                w[2] = LANE_GATHER(fv, LANE_Q, wz);
                for (int a = 0; a < 3; ++a) {
                    inv[a] = (fv)(1.0f) / w[a];
                    W.cell[a] = LANE_LOAD(k[a]);
                }
                W.walking |= MASK((((iv)(took) >> LANE_IDS) & 1) != 0);
                grid_at_v(G, &W, p, w, inv);
            }
        }
        const int walk = LANE_BITS(W.walking);
        if (!walk)
            break;
        LANE_STORE(W.cid, ca);
        grid_cells_apart(S, P, walk, ca, 0, lq, seen, QUERY_ARGS BATCH_TMAX_ARGS);
        const int ask = P->n >= GRID_DRAIN;
        if (ask)
            pending_drain(S, P, P->n, QUERY_ARGS);
        grid_next_v(G, &W, p, inv);
        if (ask)                                /* occ changes where pairs are asked */
            W.walking &= MASK(LANE_GATHER(iv, LANE_Q, occ) == 0);
    }
#undef LANE_Q
}
#endif

/* the open queries of the batch against the casters listed in the cells
 * their rays cross (grid.h; the lanes of a group walk side by side, then
 * the walks set down), then the casters wider than a cell, asked of every ray */
inline void batch_grid(const scene_t *S, pending_t *P, const int *gl, const int ng, const int *lm,
                       QUERY_PARAMS BATCH_TMAX_PARAMS)
{
    __global const grid_t *G = S->grid;
#if LANES > 1
    spill_t R;
    R.n = 0;
#endif
    int lane_id[LANES];
    for (int l = 0; l < LANES; ++l)
        lane_id[l] = l;
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
        for (int walk; (walk = LANE_BITS(W.walking));) {      /* the walking lanes as bits */
#if LANES > 1
            if (BIT_COUNT(walk) <= GRID_SPILL_LANES) {
                grid_spill(&R, &W, walk, c, seen);
                break;
            }
#endif
            LANE_ARRAY int ca[LANES];
            LANE_STORE(W.cid, ca);
            if (VALL(~W.walking | MASK(W.cid == ca[BIT_LOW(walk)]))) {
                grid_cell_shared(S, P, S->gpackets + ca[BIT_LOW(walk)], c, p, w, W.walking, seen, QUERY_ARGS
                                 BATCH_TMAX_ARGS);
            } else {
                grid_cells_apart(S, P, walk, ca, c, lane_id, seen, QUERY_ARGS BATCH_TMAX_ARGS);
            }
            grid_next_v(G, &W, p, inv);
            W.walking &= MASK(LANE_LOAD(occ + c) == 0);
        }
    }
#if LANES > 1
    pending_drain(S, P, P->n, QUERY_ARGS);      /* the walks of queries this finds occluded are not taken up */
    grid_spilled(S, P, &R, QUERY_ARGS BATCH_TMAX_ARGS);
#endif
    pending_drain(S, P, P->n, QUERY_ARGS);       /* batch_instance: fewer than LANES wait */
    const int big = G->dims[0] * G->dims[1] * G->dims[2];       /* the big casters' packets follow the cells' */
    for (int k = 0; k < G->big; ++k)
        batch_instance(S, S->gpackets[big + k / 4].instance[k % 4], P, gl, ng, lm, px, py, pz, wx, wy, wz, own, occ
                       BATCH_NORMAL_ARGS BATCH_TMAX_ARGS);
}
#endif

#endif

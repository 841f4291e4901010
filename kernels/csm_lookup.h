/* csm_lookup.h -- the CSM lookup of the scene kernels: is a query (point,
 * direction) shadowed by one caster instance? (thesis 000, sections 5.3.2,
 * 5.3.3; the rule in visibility.cl's opening comment)
 *
 *   stored_v()      (csm_stored.h) the stored depth of (map, texel) for
 *                   every lane: the block by a binary search of the summary,
 *                   the segment by counting in the block
 *   map_frame_v(), bias_v(), surface_rule_v()  (csm_map.h) a point seen
 *                   from a map, its depth tolerance, the surface rule
 *   instance_v()    the lookup: the nearest map (views_zigzag.h,
 *                   views_hilbert.h) and its texel, the stored depth asked
 *                   afterwards by the caller (batch.h's batch_ask, for
 *                   several lane groups at once), or with FILTERED the
 *                   plan of the vote of four maps times four texels, whose
 *                   taps vote_occluded() (csm_vote.h) reads afterwards
 *
 * Queries are answered LANES at a time (lanes.h; the host picks LANES per
 * device): the arithmetic runs on lane vectors (one lane per query), the
 * table reads (map bases, list offsets, the searches, stored
 * depths) run lane by lane, each phase for all lanes before the next, with
 * the block summaries and the blocks prefetched as soon as their addresses
 * are known -- so the lanes' cache misses overlap instead of queueing
 * (memory latency is what limits these kernels on CPUs). With LANES = 1
 * each work-item answers its queries one by one (GPUs).
 *
 * NTYPES 0 (no casters): nothing of this file is compiled (batch.h asks none).
 *
 * Expects: LANES (lanes.h); NTYPES; DEPTH_BITS, IEND_T, PAIR_WIDE, SEARCH_BLOCK
 * (csm_search.h); LAYOUT_ZIGZAG, LAYOUT_HILBERT, FILTERED, FILTER_ANGLE_EPS
 * (FILTERED only); SURFACE_NORMALS (0/1) and SURFACE_LIFT_TEXELS (float,
 * SURFACE_NORMALS only: the surface rule); optional PROFILE_SKIP_NEAREST, PROFILE_SKIP_SEARCH
 * (visibility.cl); optional VOTE_FIRST, VOTE_NEXT, VOTE_MARGIN, VOTE_GROUPS (FILTERED: csm_vote.h).
 */
#ifndef PYSHADOW_CSM_LOOKUP_H
#define PYSHADOW_CSM_LOOKUP_H

#include "csm_search.h"
#include "csm_vote.h"
#include "csm_stored.h"
#include "lanes.h"
#include "scene_tables.h"
#include "views_hilbert.h"
#include "views_zigzag.h"

#ifndef NTYPES
#error "NTYPES (number of CSM types of the scene, 0: no caster) must be defined by the host"
#endif
#ifndef SURFACE_NORMALS
#error "SURFACE_NORMALS (0/1: queries carry their surface normal) must be defined by the host"
#endif
#include "csm_map.h"
#if NTYPES
/* The CSM lookup of the lanes act against caster instance j, each lane its
 * own instance j[l] (j0: one of them), all of CSM type t; with
 * SURFACE_NORMALS each lane's unit surface normal (mx, my, mz), world frame.
 * FILTERED: the plan of the lanes' votes, written to group g (its first
 * lane's offset) of V, for vote_occluded(); returns act. Otherwise its first half: the lanes
 * (-1) whose point lies in the square of its map, with that map ka[l], the
 * texel ta[l], the point's depth dz_out[l] and its bias bz_out[l] (lane
 * arrays) -- the lane is occluded when depth > stored + bias, the stored
 * depth of stored_v(), which the caller asks for many lane groups at once
 * (batch_ask): their cache misses overlap. Lanes whose answer is known
 * without the search (EMPTY_RUNS: occluded) are not among them, but in
 * *known. */
#if FILTERED
#define LOOKUP_OUT_PARAMS , vote_t *V, const int g
#else
#define LOOKUP_OUT_PARAMS , int *ka, int *ta, float *dz_out, float *bz_out, iv *known
#endif
inline iv instance_v(const scene_t *S, int t, iv j, int j0, fv px, fv py, fv pz, fv wx, fv wy, fv wz, iv own,
                     iv act NORMAL_PARAMS LOOKUP_OUT_PARAMS)
{
    __global const csm_type_t *T = S->types + t;
    const int R = T->resolution, layout = T->layout, vbase = T->view_base;
    /* the lanes' frames: point q = A p + offset, direction v = Rw w (and the
     * normal o = Rw m), from each lane's instance record (to_object A,
     * offset, rotation Rw, horizon), its fields gathered into lane vectors */
    fv qx, qy, qz, vx, vy, vz;
#if SURFACE_NORMALS
    fv ox, oy, oz, hs;
#define NORMAL_FRAME(Rw, H)                                                     \
    ox = Rw(0) * mx + Rw(1) * my + Rw(2) * mz;                                  \
    oy = Rw(3) * mx + Rw(4) * my + Rw(5) * mz;                                  \
    oz = Rw(6) * mx + Rw(7) * my + Rw(8) * mz;                                  \
    hs = H
#else
#define NORMAL_FRAME(Rw, H)
#endif
#define INSTANCE_FRAME(A, O, Rw, H)                                             \
    qx = A(0) * px + A(1) * py + A(2) * pz + O(0);                              \
    qy = A(3) * px + A(4) * py + A(5) * pz + O(1);                              \
    qz = A(6) * px + A(7) * py + A(8) * pz + O(2);                              \
    vx = Rw(0) * wx + Rw(1) * wy + Rw(2) * wz;                                  \
    vy = Rw(3) * wx + Rw(4) * wy + Rw(5) * wz;                                  \
    vz = Rw(6) * wx + Rw(7) * wy + Rw(8) * wz;                                  \
    NORMAL_FRAME(Rw, H)
    if (VALL(MASK(j == (iv)(j0)))) {           /* one instance (most lookups): its scalars */
        __global const instance_t *I = S->inst + j0;
#define ONE_A(c) I->to_object[c]
#define ONE_O(c) I->offset[c]
#define ONE_R(c) I->rotation[c]
        INSTANCE_FRAME(ONE_A, ONE_O, ONE_R, (fv)(I->horizon));
    } else {
        /* each lane's record I[l], its fields gathered into lane vectors (LANE_GATHER, lanes.h) */
        LANE_ARRAY int ja[LANES];
        LANE_STORE(j, ja);
        __global const instance_t *I[LANES];
        for (int l = 0; l < LANES; ++l)
            I[l] = S->inst + ja[l];
#define LANE_FIELD(l, f) I[l]->f
#define LANE_A(c) LANE_GATHER(fv, LANE_FIELD, to_object[c])
#define LANE_O(c) LANE_GATHER(fv, LANE_FIELD, offset[c])
        fv rw[9];
        for (int c = 0; c < 9; ++c)
            rw[c] = LANE_GATHER(fv, LANE_FIELD, rotation[c]);
#define LANE_R(c) rw[c]
        INSTANCE_FRAME(LANE_A, LANE_O, LANE_R, LANE_GATHER(fv, LANE_FIELD, horizon));
    }
#undef NORMAL_FRAME
#undef INSTANCE_FRAME
#undef ONE_A
#undef ONE_O
#undef ONE_R
#undef LANE_FIELD
#undef LANE_A
#undef LANE_O
#undef LANE_R
    const fv inv = 1.0f / VSQRT(vx * vx + vy * vy + vz * vz);
    vx *= inv; vy *= inv; vz *= inv;
    /* the ray's chord through the caster, inside the bounding sphere (radius
     * 1 here) and the mesh's box (T->box_lo, box_hi): u in [u0, u1] along v
     * from q_perp = q - (q.v) v, q at u = q.v. A point before its chord takes
     * its texel at the chord's midpoint (the map's axis and the ray part by
     * their angle times the distance from there: at most half the chord) and,
     * from outside the sphere, its depth where the ray enters the sphere
     * (well behind the mesh). A chord empty or behind the point: a miss.
     * Such a point farther outside the sphere than two texels, or on another
     * body, lies on none of this caster's surfaces, and every surface of its
     * chord is ahead of it: it asks as a point of another body (own -2) with
     * a depth behind every stored one (2; the sphere's back is 1). At the
     * entry's depth a surface lying on the sphere (a bowl, a dome's shell)
     * tied with the point and let the ray through. */
    fv cqx = qx, cqy = qy, cqz = qz;
    iv beyond;
    {
        const fv b = qx * vx + qy * vy + qz * vz;
        const fv sx = qx - b * vx, sy = qy - b * vy, sz = qz - b * vz;
        const fv h2 = 1.0f - (sx * sx + sy * sy + sz * sz), e = VSQRT(VMAX(h2, (fv)(0.0f)));
        fv u0 = -e, u1 = e;
        const fv sv[3] = {sx, sy, sz}, vv[3] = {vx, vy, vz};
        for (int a = 0; a < 3; ++a) {
            const fv r = 1.0f / VSEL(vv[a], (fv)(1e-30f), MASK(VABS(vv[a]) < 1e-30f));
            const fv ua = (T->box_lo[a] - sv[a]) * r, ub = (T->box_hi[a] - sv[a]) * r;
            u0 = VMAX(u0, VMIN(ua, ub));
            u1 = VMIN(u1, VMAX(ua, ub));
        }
        act &= ~(MASK(h2 < 0.0f) | MASK(u0 > u1) | MASK(u1 < b));
        const iv far = MASK(b < u0), out = far & MASK(b < -e);
        beyond = out & ((MASK(own != -1) & MASK(own != j)) | MASK(b * b - h2 > (8.0f + 16.0f / (float)R) / (float)R));
        own = VSEL(own, (iv)(-2), beyond);
        const fv um = 0.5f * (u0 + u1);
        qx = VSEL(qx, sx - e * vx, out);
        qy = VSEL(qy, sy - e * vy, out);
        qz = VSEL(qz, sz - e * vz, out);
        cqx = VSEL(qx, sx + um * vx, far);
        cqy = VSEL(qy, sy + um * vy, far);
        cqz = VSEL(qz, sz + um * vz, far);
    }
#if SURFACE_NORMALS
    const iv up = surface_rule_v(hs, j, own, &ox, &oy, &oz, &vx, &vy, &vz);
#endif
    LANE_ARRAY int am[LANES];
    LANE_STORE(act, am);

#if FILTERED
    /* the four maps of ViewSet.filter_window, each asked by a bilinear vote
     * of the four texels around the point (texel centres; border texels
     * repeated); the instance shadows a lane when the weighted votes exceed
     * one half (scene.visible_reference(filtered=True)); the maps (kw) in V */
    int *kw[4] = {V->kw[0] + g, V->kw[1] + g, V->kw[2] + g, V->kw[3] + g};
    LANE_ARRAY float mw[4][LANES];
#if LAYOUT_ZIGZAG
    if (layout == 0) {
        iv k[4];
        fv cx[4], cy[4], cz[4];
        zigzag_window_v(T->p1, T->p2, T->zigzag_offset, T->zigzag_steps[0], T->zigzag_steps[1],
                        T->zigzag_steps[2], T->zigzag_steps[3], vx, vy, vz, 1, k, cx, cy, cz);
        fv wsum = (fv)(0.0f), wt[4];
        for (int m = 0; m < 4; ++m) {
            const fv ex = vx - cx[m], ey = vy - cy[m], ez = vz - cz[m];
            const fv chord = VSQRT(ex * ex + ey * ey + ez * ez);
            wt[m] = 1.0f / (2.0f * asin(VMIN(0.5f * chord, (fv)(1.0f))) + FILTER_ANGLE_EPS);
            wsum += wt[m];
        }
        /* heaviest map first (a sorting network of the four), so that the
         * vote below is decided early */
        sort4_heaviest_first(wt, k, 0);
        for (int m = 0; m < 4; ++m) {
            LANE_STORE(k[m], kw[m]);
            LANE_STORE(wt[m] / wsum, mw[m]);
        }
    }
#endif
#if LAYOUT_HILBERT
    if (layout != 0) {
        LANE_ARRAY float ax[LANES], ay[LANES], az[LANES];
        LANE_STORE(vx, ax); LANE_STORE(vy, ay); LANE_STORE(vz, az);
        for (int l = 0; l < LANES; ++l) {
            int k4[4] = {0, 0, 0, 0};
            float w4[4] = {0.25f, 0.25f, 0.25f, 0.25f};
            if (am[l])
                window_hilbert(S->bases, vbase, S->cells, T->cell_base, T->p1, layout == 2,
                               (float3)(ax[l], ay[l], az[l]), k4, w4);
            const float sum = w4[0] + w4[1] + w4[2] + w4[3];
            for (int m = 0; m < 4; ++m) { kw[m][l] = k4[m]; mw[m][l] = w4[m] / sum; }
        }
    }
#endif
    /* each map's point, depth, bias and its four taps: the texels around
     * the point (texel centres; border texels repeated) with their bilinear
     * weights, heaviest first (tap i = 4 m + c); the vote's rounds:
     * vote_occluded() (csm_vote.h) */
    iv ins[4];
    for (int n = 0; n < 4; ++n) {
        fv dx, dy, dz, depth, fx, fy, tw[4], tb[4];
        NORMAL_PLANE_DECL
        const iv inside = act & map_frame_v(S->bases + 9 * vbase, kw[n], R, qx, qy, qz, cqx, cqy, cqz,
                                            &dx, &dy, &dz, &depth, &fx, &fy NORMAL_LIFT_ARGS);
        ins[n] = inside;
        LANE_STORE(inside, V->ins[n] + g);
        LANE_STORE(VSEL(depth, (fv)(2.0f), beyond), V->dq[n] + g);
        const fv wm = LANE_LOAD(mw[n]);
        const fv bias = bias_v(S, R, j, own, vx, vy, vz, dx, dy, dz NORMAL_BIAS_ARGS);
        const fv gx = VSEL((fv)(0.0f), fx - 0.5f, inside), gy = VSEL((fv)(0.0f), fy - 0.5f, inside);
        const fv x0f = floor_texel_v(gx), y0f = floor_texel_v(gy);
        const fv tx = gx - x0f, ty = gy - y0f;
        const iv x0 = CONVERT(int, x0f), y0 = CONVERT(int, y0f);
        iv tt[4];
        for (int c = 0; c < 4; ++c) {
            const int ddy = c >> 1, ddx = c & 1;
            tt[c] = VMIN(VMAX(y0 + ddy, (iv)(0)), (iv)(R - 1)) * R + VMIN(VMAX(x0 + ddx, (iv)(0)), (iv)(R - 1));
            tw[c] = wm * (ddy ? ty : 1.0f - ty) * (ddx ? tx : 1.0f - tx);
#if SURFACE_NORMALS && PLANE_BIAS       /* the tap's centre lies (ddx - tx, ddy - ty) texels from the point */
            tb[c] = tap_bias_v(S, R, bias, pu, pv, pe, (float)ddx - tx, (float)ddy - ty);
#else
            tb[c] = bias;
#endif
        }
#if SURFACE_NORMALS && PLANE_BIAS
        sort4_heaviest_first(tw, tt, tb);       /* texels heaviest first, too */
#else
        sort4_heaviest_first(tw, tt, 0);
#endif
        for (int c = 0; c < 4; ++c) {
            LANE_STORE(tt[c], V->tq[4 * n + c] + g);
            LANE_STORE(tw[c], V->tw[4 * n + c] + g);
            LANE_STORE(tb[c], V->tb[4 * n + c] + g);
        }
    }
    fv wl = (fv)(0.0f);         /* the weight of the maps not holding the point: lit */
    for (int m = 0; m < 4; ++m)
        wl += VSEL(LANE_LOAD(mw[m]), (fv)(0.0f), ins[m]);
    LANE_STORE(wl, V->wl + g);
    LANE_STORE((fv)(0.0f), V->ws + g);
    LANE_STORE(act & MASK(wl <= 0.5f + VOTE_MARGIN), V->open + g);
    LANE_STORE((iv)(0), V->exh + g);
    for (int m = 0; m < 4; ++m)
        LANE_STORE((iv)(0), V->head[m] + g);
    return act;
#else
    iv k = (iv)(0);
#if LAYOUT_ZIGZAG
#if PROFILE_SKIP_NEAREST
    if (layout == 0) k = clamp(CONVERT(int, VABS(vx) * (float)(T->maps - 1)), 0, T->maps - 1);
#else
    if (layout == 0) k = nearest_zigzag_v(T->p1, T->p2, T->zigzag_offset, T->zigzag_steps[0],
                                          T->zigzag_steps[1], T->zigzag_steps[2], T->zigzag_steps[3],
                                          vx, vy, vz);
#endif
#endif
#if LAYOUT_HILBERT
    if (layout != 0) {
        LANE_ARRAY float ax[LANES], ay[LANES], az[LANES];
        LANE_STORE(vx, ax); LANE_STORE(vy, ay); LANE_STORE(vz, az);
        for (int l = 0; l < LANES; ++l)
            ka[l] = am[l] ? nearest_hilbert(S->bases, vbase, S->cells, T->cell_base, T->p1, layout == 2,
                                            (float3)(ax[l], ay[l], az[l])) : 0;
    } else
#endif
    {
        LANE_STORE(k, ka);
    }
    fv dx, dy, dz, depth, fx, fy;
    NORMAL_PLANE_DECL
    const iv valid = act & map_frame_v(S->bases + 9 * vbase, ka, R, qx, qy, qz, cqx, cqy, cqz,
                                       &dx, &dy, &dz, &depth, &fx, &fy NORMAL_LIFT_ARGS);
    depth = VSEL(depth, (fv)(2.0f), beyond);
    *known = (iv)(0);
    if (!VANY(valid)) {
        LANE_STORE((iv)(0), ta);
        LANE_STORE((fv)(0.0f), dz_out);
        LANE_STORE((fv)(0.0f), bz_out);
        return valid;
    }
    const iv tex = VMIN(CONVERT(int, fy), (iv)(R - 1)) * R + VMIN(CONVERT(int, fx), (iv)(R - 1));
    LANE_STORE(tex, ta);
    LANE_STORE(depth, dz_out);
#if EMPTY_RUNS
    /* a lane whose run of maps is empty at its texel (every map of it a miss:
     * stored depth +inf, never below depth + bias; csm.device.empty_bits) is
     * answered open here, as the search would answer it, and asks none
     * (batch_ask). Index of a lane outside the map: the type's first word */
    const iv run = LANE_LOAD(ka) >> T->empty_shift;
    LANE_ARRAY int wi[LANES];
    LANE_STORE(VSEL((iv)(T->empty_base), T->empty_base + tex * T->empty_words + (run >> 5), valid), wi);
#define EMPTY_WORD(l, a) (int)S->empty[a[l]]
    const iv word = LANE_GATHER(iv, EMPTY_WORD, wi);
#undef EMPTY_WORD
    const iv found = valid & MASK(((word >> (run & 31)) & 1) == 0);
#else
    const iv found = valid;
#endif
    const fv bias = bias_v(S, R, j, own, vx, vy, vz, dx, dy, dz NORMAL_BIAS_ARGS);
#if SURFACE_NORMALS && PLANE_BIAS           /* the texel's centre lies (floor(f) + 1/2 - f) texels from the point */
    const fv bz = tap_bias_v(S, R, bias, pu, pv, pe, floor(fx) + 0.5f - fx, floor(fy) + 0.5f - fy);
#else
    const fv bz = bias;
#endif
    LANE_STORE(bz, bz_out);
#if EMPTY_RUNS
    /* With a bit for every map (shift 0), a clear bit says that the lane's
     * own map stores a surface at its texel: a finite stored depth, at most
     * STORED_MAX_DEPTH. A lane behind every surface of the caster (beyond:
     * depth 2) is then occluded, as the search would answer it, wherever
     * STORED_MAX_DEPTH + bias < 2 (so any stored depth + bias is below 2:
     * float addition is monotone), and asks none */
    if (T->empty_shift == 0) {
        *known = found & beyond & MASK(STORED_MAX_DEPTH + bz < 2.0f);
        return found & ~*known;
    }
#endif
    return found;
#endif
}

#endif  /* NTYPES */
#endif

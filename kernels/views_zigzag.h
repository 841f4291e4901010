/* views_zigzag.h -- the maps nearest a direction on a zigzag view set
 * (layout 0: views.ViewSet.zigzag, T rows of theta by P columns of phi, odd
 * rows reversed), O(1) and on lane vectors: the 2 x 2 grid points around the
 * direction's (theta, phi) are the candidates.
 *
 *   zigzag_window_v()   the four candidates, as map indices and directions
 *                       (also the window of FILTERED lookups)
 *   nearest_zigzag_v()  the nearest of them (one-texel lookups)
 * A CSM type gives T = p1, P = p2, the cos and sin of one grid step in
 * theta and in phi (csm_type_t.zigzag_steps, scene_types.h) and the rows'
 * offset off (zigzag_offset: row i at theta = (i + off) pi / T).
 * Expects: LANES (lanes.h), LAYOUT_ZIGZAG (0: nothing is compiled; lane_math.h
 * still is, unused).
 */
#ifndef PYSHADOW_VIEWS_ZIGZAG_H
#define PYSHADOW_VIEWS_ZIGZAG_H

#include "lanes.h"
#include "views_common.h"
#include "lane_math.h"

#if LAYOUT_ZIGZAG
/* the 2 x 2 grid points around each lane's (theta, phi) -- rows r0, r0 + 1,
 * columns c0, c0 + 1 -- as map indices k[4] and directions (cx, cy, cz)[4],
 * in the order of views.ViewSet.filter_window. r0 is the last row at or
 * above theta (row 0 above the first row). Beyond the first or the last row
 * the second pair is, on centred rows (off 0.5) with P even, the same row's
 * opposite columns c + P / 2 across the pole (nearer than the next row's);
 * otherwise the next row, or the last row repeated. With cap (the vote's
 * window) and P a multiple of 4, beyond the first or last centred row the
 * four are that row's columns a quarter turn apart, from the nearer of c0,
 * c0 + 1: four sides of the pole (views.ViewSet._zigzag_window). */
__attribute__((always_inline)) inline void zigzag_window_v(int T, int P, float off, float cst, float sst,
                                                           float csp, float ssp, fv wx, fv wy, fv wz,
                                                           const int cap, iv *k, fv *cx, fv *cy, fv *cz)
{
    const fv th = acos_v(VMIN(VMAX(wy, (fv)(-1.0f)), (fv)(1.0f)));
    const fv ph = atan2_pos_v(wz, wx);
    const float dth = PI_F / (float)T, dph = 2.0f * PI_F / (float)P;
    /* ph >= 0: truncation is floor; th T / pi - off may lie in (-1, 0) above
     * the first row, where truncation gives 0 as the clamp would */
    const fv rowf = th * ((float)T / PI_F) - off;
    const iv ru = CONVERT(int, rowf);
    const iv r0 = VMIN(VMAX(ru, (iv)(0)), (iv)(T - 1));
    const iv across = (MASK(rowf < 0.0f) | MASK(ru >= T - 1)) & (iv)((off == 0.5f && (P & 1) == 0) ? -1 : 0);
    /* cu: the column below ph before wrapping (ph may round up to 2 pi just
     * below the seam: cu = P), the offset dcol is measured from it */
    const iv cu = VMIN(VMAX(CONVERT(int, ph * ((float)P / (2.0f * PI_F))), (iv)(0)), (iv)(P));
    const iv c0 = VSEL(cu, cu - P, MASK(cu >= P));
    /* the candidate grid directions by angle addition from the query's own
     * (cos, sin) of theta and phi: rotate back by the small offsets to the
     * grid lines, then forward by one grid step */
    const fv rho = VSQRT(wx * wx + wz * wz);
    const iv pole = MASK(rho == 0.0f);
    const fv cph = VSEL(wx / rho, (fv)(1.0f), pole), sph = VSEL(wz / rho, (fv)(0.0f), pole);
    const fv cth = wy, sth = rho;
    /* drow < 0 above the first row (the short series and cos, sin are odd and even) */
    const fv drow = th - (CONVERT(float, r0) + off) * dth, dcol = ph - CONVERT(float, cu) * dph;
    /* the offsets are below one grid step: the short series where a step is
     * below 0.2 rad (1e-8), the library's cos and sin on coarser grids */
    fv cd, sd, ce, se;
    if (dth < 0.2f && dph < 0.2f) {
        cd = cos_small(drow); sd = sin_small(drow); ce = cos_small(dcol); se = sin_small(dcol);
    } else {
        cd = cos(drow); sd = sin(drow); ce = cos(dcol); se = sin(dcol);
    }
    const fv ct0 = cth * cd + sth * sd, st0 = sth * cd - cth * sd;
    const fv cp0 = cph * ce + sph * se, sp0 = sph * ce - cph * se;
    /* the second row: one step on, the last row repeated, or across the
     * pole (theta mirrored through it: the same cos, the sine negated, which
     * turns (cos phi, sin phi) half a turn) */
    const iv last = MASK(r0 + 1 > T - 1) | across;
    const fv ct1 = VSEL(ct0 * cst - st0 * sst, ct0, last);
    const fv st1 = VSEL(VSEL(st0 * cst + ct0 * sst, st0, last), -st0, across);
    const fv cp1 = cp0 * csp - sp0 * ssp, sp1 = sp0 * csp + cp0 * ssp;
    iv c1 = c0 + 1;
    c1 = VSEL(c1, c1 - P, MASK(c1 >= P));
    const iv r1 = VSEL(VMIN(r0 + 1, (iv)(T - 1)), r0, across);
    /* the second row's columns: c0, c1, or across the pole c + P / 2 */
    iv a0 = VSEL(c0, c0 + P / 2, across), a1 = VSEL(c1, c1 + P / 2, across);
    a0 = VSEL(a0, a0 - P, MASK(a0 >= P));
    a1 = VSEL(a1, a1 - P, MASK(a1 >= P));
#define ZZ_CANDIDATE(I, R, C, CT, ST, CP, SP)                                        \
    k[I] = (R) * P + VSEL((C), (iv)(P - 1) - (C), MASK(((R) & 1) != 0));              \
    cx[I] = (ST) * (CP); cy[I] = (CT); cz[I] = (ST) * (SP);
    if (cap && off == 0.5f && (P & 3) == 0) {
        /* across: the nearer column cn and its quarter turns (phi + pi / 2:
         * (cos, sin) -> (-sin, cos)), all on row r0 */
        const iv n1 = across & MASK(dcol > 0.5f * dph);
        const iv cn = VSEL(c0, c1, n1);
        const fv cpn = VSEL(cp0, cp1, n1), spn = VSEL(sp0, sp1, n1);
        iv q1 = cn + P / 4, q2 = cn + P / 2, q3 = cn + 3 * (P / 4);
        q1 = VSEL(q1, q1 - P, MASK(q1 >= P));
        q2 = VSEL(q2, q2 - P, MASK(q2 >= P));
        q3 = VSEL(q3, q3 - P, MASK(q3 >= P));
        ZZ_CANDIDATE(0, r0, VSEL(c0, cn, across), ct0, st0, VSEL(cp0, cpn, across), VSEL(sp0, spn, across))
        ZZ_CANDIDATE(1, r0, VSEL(c1, q1, across), ct0, st0, VSEL(cp1, -spn, across), VSEL(sp1, cpn, across))
        ZZ_CANDIDATE(2, r1, VSEL(a0, q2, across), VSEL(ct1, ct0, across), VSEL(st1, st0, across),
                     VSEL(cp0, -cpn, across), VSEL(sp0, -spn, across))
        ZZ_CANDIDATE(3, r1, VSEL(a1, q3, across), VSEL(ct1, ct0, across), VSEL(st1, st0, across),
                     VSEL(cp1, spn, across), VSEL(sp1, -cpn, across))
    } else {
        ZZ_CANDIDATE(0, r0, c0, ct0, st0, cp0, sp0)
        ZZ_CANDIDATE(1, r0, c1, ct0, st0, cp1, sp1)
        ZZ_CANDIDATE(2, r1, a0, ct1, st1, cp0, sp0)
        ZZ_CANDIDATE(3, r1, a1, ct1, st1, cp1, sp1)
    }
#undef ZZ_CANDIDATE
}

/* map nearest to each lane's direction on a zigzag grid (views.py): of the
 * window's four, the largest dot product (the first of equals). theta
 * and phi need only be near: an error far below the grid step can only move
 * the 2 x 2 window when the direction is next to a grid line, and then the
 * grid point on that line -- the nearest -- stays in the window. */
inline iv nearest_zigzag_v(int T, int P, float off, float cst, float sst, float csp, float ssp,
                            fv wx, fv wy, fv wz)
{
    iv k[4];
    fv cx[4], cy[4], cz[4];
    zigzag_window_v(T, P, off, cst, sst, csp, ssp, wx, wy, wz, 0, k, cx, cy, cz);
    fv best_d = (fv)(-2.0f);
    iv best = (iv)(0);
    for (int c = 0; c < 4; ++c) {
        const fv dd = wx * cx[c] + wy * cy[c] + wz * cz[c];
        const iv take = MASK(dd > best_d);
        best_d = VSEL(best_d, dd, take);
        best = VSEL(best, k[c], take);
    }
    return best;
}
#endif

#endif

/* grid.h -- rays walking the uniform grid over the casters' bounding spheres
 * (INSTANCE_GRID; the host's pyshadow.visibility.grid builds it).
 *
 *   walk_v_t        the walks of a lane vector of rays, side by side, each
 *                   lane in its own cell: cells, steps, the ray parameters
 *                   t of the next cell faces, the cells' numbers
 *   grid_start_v()  their first cells: where each ray enters the grid
 *   grid_next_v()   their next cells (a 3D-DDA: per lane, the axis whose
 *                   cell face the ray reaches first)
 *   grid_at_v()     the walks' state from their cells (a walk taken up again)
 *   sphere_4()      sphere_v() of scene_tables.h for one ray and the four
 *                   spheres of a packet (copies of the instance table's)
 *   sphere_slot_v() sphere_v() for the lane vector and one sphere of a packet
 * Both sphere tests do the same operations on the same values as sphere_v,
 * sphere by sphere and lane by lane, hence give the same answers.
 *
 * A cell's list starts in packet number cid (its cell number) and goes on
 * through slot 3's links (pyshadow.visibility.grid.grid_packets).
 *
 * The walk visits, within float32 rounding, every cell its ray passes
 * through, in order; the host grows every sphere by a margin before listing
 * it in cells (grid_margin) that the rounding cannot exceed, so a ray that
 * meets a sphere visits a cell listing it. Each step moves one cell along one
 * axis, never back, and a lane's walk ends when it leaves the grid's cells
 * (not where the ray leaves the grid's box: no rounding can end it early), so
 * within the grid's cells along its three axes together. The lanes step
 * together until the last has left; each lane's steps are those it would
 * take alone. A NaN slab bound (a ray parallel to an axis, on a face's
 * plane) constrains nothing; such a ray lies outside every sphere.
 * Expects: LANES (lanes.h), NTYPES, INSTANCE_GRID, FINITE_RAYS (scene_tables.h).
 */
#ifndef PYSHADOW_GRID_H
#define PYSHADOW_GRID_H

#include "lanes.h"
#include "scene_tables.h"

#if NTYPES && INSTANCE_GRID
#if FINITE_RAYS
#define TMAX1_PARAM , float tm
#else
#define TMAX1_PARAM
#endif

/* -1 where ray p + t w meets sphere q of packet K, for the four q; 0 in
 * unused slots and the link */
__attribute__((always_inline)) inline int4 sphere_4(__global const grid_packet_t *K, float px, float py, float pz,
                                                    float wx, float wy, float wz TMAX1_PARAM)
{
    SPHERE_TERMS(float4, float4, *(__global const float4 *)K->cx, *(__global const float4 *)K->cy,
                 *(__global const float4 *)K->cz, *(__global const float4 *)K->radius, px, py, pz, wx, wy, wz);
#if FINITE_RAYS
    return ~((oc2 > r2) & ((tca < 0.0f) | (e2 > r2))) & (tca < tm) & (*(__global const int4 *)K->instance >= 0);
#else
    return ~((oc2 > r2) & ((tca < 0.0f) | (e2 > r2))) & (*(__global const int4 *)K->instance >= 0);
#endif
}

/* the lanes whose ray meets sphere q of packet K (whatever its slot holds) */
__attribute__((always_inline)) inline iv sphere_slot_v(__global const grid_packet_t *K, int q, const fv *p,
                                                       const fv *w TMAX_PARAM)
{
    SPHERE_TERMS(fv, float, K->cx[q], K->cy[q], K->cz[q], K->radius[q], p[0], p[1], p[2], w[0], w[1], w[2]);
#if FINITE_RAYS
    return ~(MASK(oc2 > r2) & (MASK(tca < 0.0f) | MASK(e2 > r2))) & MASK(tca < tm);
#else
    return ~(MASK(oc2 > r2) & (MASK(tca < 0.0f) | MASK(e2 > r2)));
#endif
}

typedef struct {
    iv cell[3], step[3];        /* cell index per axis; +1 / -1 along the ray (0: parallel to the axis) */
    fv next[3];                 /* t of the ray at the cell's next face per axis (+inf: parallel) */
    iv cid, dcid[3];            /* the cell's number; its change a step along each axis makes */
    iv walking;                 /* the lanes still in the grid's cells */
} walk_v_t;

/* the face of cell index k on the ray's side along axis a, as the ray's t;
 * +inf for an axis the (unit) ray is parallel to, or so nearly that 1 / w
 * overflows (a face at the point itself would give 0 x inf, a NaN) */
__attribute__((always_inline)) inline fv grid_face_v(__global const grid_t *G, int a, iv k, iv step, fv p, fv inv)
{
    const fv face = (CONVERT(float, k + (MASK(step > 0) & 1)) * G->cell[a] + G->origin[a] - p) * inv;
    return VSEL(face, (fv)(INFINITY), MASK(step == 0) | ~(MASK(inv < INFINITY) & MASK(inv > -INFINITY)));
}

/* the rest of the walks' state from their cells W->cell: steps, next
 * faces, cell numbers -- each a function of the cell and the ray, so a walk
 * set down (its cells kept) and taken up again here goes on as it would
 * have (batch_grid's spilled walks) */
__attribute__((always_inline)) inline void grid_at_v(__global const grid_t *G, walk_v_t *W, const fv *p,
                                                     const fv *w, const fv *inv)
{
    for (int a = 0; a < 3; ++a) {
        W->step[a] = VSEL(VSEL((iv)(0), (iv)(-1), MASK(w[a] < 0.0f)), (iv)(1), MASK(w[a] > 0.0f));
        W->next[a] = grid_face_v(G, a, W->cell[a], W->step[a], p[a], inv[a]);
    }
    W->cid = (W->cell[0] * G->dims[1] + W->cell[1]) * G->dims[2] + W->cell[2];
    W->dcid[0] = W->step[0] * (G->dims[1] * G->dims[2]);
    W->dcid[1] = W->step[1] * G->dims[2];
    W->dcid[2] = W->step[2];
}

/* the first cells of the lanes of open whose ray p + t w, t >= 0, meets the
 * grid's box (inv = 1 / w): that of p where p lies in the box, else that of
 * the ray's entry (the slab test); W->walking: those lanes */
__attribute__((always_inline)) inline void grid_start_v(__global const grid_t *G, walk_v_t *W, const fv *p,
                                                        const fv *w, const fv *inv, iv open)
{
    iv inside = (iv)(-1);
    fv t0 = (fv)(0.0f), t1 = (fv)(INFINITY);
    for (int a = 0; a < 3; ++a) {
        const float lo = G->origin[a], hi = G->origin[a] + (float)G->dims[a] * G->cell[a];
        inside &= MASK(p[a] >= lo) & MASK(p[a] <= hi);
        const fv ta = (lo - p[a]) * inv[a], tb = (hi - p[a]) * inv[a];
        t0 = VMAX(t0, VMIN(ta, tb));
        t1 = VMIN(t1, VMAX(ta, tb));
    }
    W->walking = open & (inside | MASK(t0 <= t1));
    t0 = VSEL(t0, (fv)(0.0f), inside);
    for (int a = 0; a < 3; ++a) {
        /* clamped, then truncated (x >= 0: the floor; a NaN, which a finite
         * ray cannot give, converts to a negative int, taken to 0) */
        const iv k = CONVERT(int, VMIN(VMAX((p[a] + t0 * w[a] - G->origin[a]) * G->inv_cell[a], (fv)(0.0f)),
                                       (fv)((float)(G->dims[a] - 1))));
        W->cell[a] = VSEL(k, (iv)(0), MASK(k < 0));
    }
    grid_at_v(G, W, p, w, inv);
}

/* each lane one cell on, along the axis whose face its ray reaches first
 * (x, then y, on ties); a lane that leaves the grid's cells stops walking */
__attribute__((always_inline)) inline void grid_next_v(__global const grid_t *G, walk_v_t *W, const fv *p,
                                                       const fv *inv)
{
    iv on[3], out = (iv)(0), dc = (iv)(0);
    on[0] = MASK(W->next[0] <= W->next[1]) & MASK(W->next[0] <= W->next[2]);
    on[1] = ~on[0] & MASK(W->next[1] <= W->next[2]);
    on[2] = ~(on[0] | on[1]);
    for (int a = 0; a < 3; ++a) {
        W->cell[a] += on[a] & W->step[a];
        out |= on[a] & (MASK(W->step[a] == 0) | MASK(W->cell[a] < 0) | MASK(W->cell[a] >= G->dims[a]));
        W->next[a] = VSEL(W->next[a], grid_face_v(G, a, W->cell[a], W->step[a], p[a], inv[a]), on[a]);
        dc |= on[a] & W->dcid[a];
    }
    W->cid += dc;
    W->walking &= ~out;
}
#endif

#endif

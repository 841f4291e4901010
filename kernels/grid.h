/* grid.h -- rays walking the uniform grid over the casters' bounding spheres
 * (INSTANCE_GRID; the host's pyshadow.visibility.grid builds it).
 *
 *   walk_t          the walk of one ray: its cell, its steps, the ray
 *                   parameters t of its next cell faces
 *   grid_start()    its first cell: where the ray enters the grid
 *   grid_next()     its next cell (a 3D-DDA: the axis whose cell face the
 *                   ray reaches first)
 *   sphere_1()      sphere_v() of scene_tables.h for one ray and a cell's
 *                   copy of the sphere: the same operations on the same
 *                   values, hence the same answer
 *
 * The walk visits, within float32 rounding, every cell its ray passes
 * through, in order; the host grows every sphere by a margin before listing
 * it in cells (grid_margin) that the rounding cannot exceed, so a ray that
 * meets a sphere visits a cell listing it. Each step moves one cell along one
 * axis, never back, and the walk ends when it leaves the grid's cells (not
 * where the ray leaves the grid's box: no rounding can end it early), so
 * within the grid's cells along its three axes together. Rays are walked one at a time, in scalar code, on every
 * device (lanes of one vector would walk as far as their longest). A NaN slab bound (a ray parallel to an axis, on a
 * face's plane) constrains nothing; such a ray lies outside every sphere.
 * Expects: LANES (lanes.h), NTYPES, INSTANCE_GRID, FINITE_RAYS (scene_tables.h).
 */
#ifndef PYSHADOW_GRID_H
#define PYSHADOW_GRID_H

#include "lanes.h"
#include "scene_tables.h"

#if NTYPES && INSTANCE_GRID
typedef struct {
    int cell[3], step[3];   /* cell index per axis; +1 / -1 along the ray (0: parallel to the axis) */
    float next[3];          /* t of the ray at the cell's next face per axis (+inf: parallel) */
} walk_t;

#if FINITE_RAYS
#define TMAX1_PARAM , float tm
#else
#define TMAX1_PARAM
#endif

__attribute__((always_inline)) inline int sphere_1(__global const grid_item_t *I, float px, float py, float pz, float wx, float wy, float wz
                    TMAX1_PARAM)
{
    SPHERE_TERMS(float, I, px, py, pz, wx, wy, wz);
#if FINITE_RAYS
    return !(oc2 > r2 && (tca < 0.0f || e2 > r2)) && tca < tm;
#else
    return !(oc2 > r2 && (tca < 0.0f || e2 > r2));
#endif
}

/* the face of cell index k on the ray's side along axis a, as the ray's t;
 * +inf for an axis the (unit) ray is parallel to, or so nearly that 1 / w
 * overflows (a face at the point itself would give 0 x inf, a NaN) */
__attribute__((always_inline)) inline float grid_face(__global const grid_t *G, int a, int k, int step, float p, float inv)
{
    return (step == 0 || !(inv < INFINITY && inv > -INFINITY)) ? INFINITY
                                                  : ((float)(k + (step > 0)) * G->cell + G->origin[a] - p) * inv;
}

/* whether the ray p + t w, t >= 0, meets the grid's box; if so W holds its first cell (inv = 1 / w):
 * that of p where p lies in the box, else that of the ray's entry (the slab test) */
__attribute__((always_inline)) inline int grid_start(__global const grid_t *G, walk_t *W, const float *p,
                                                     const float *w, const float *inv)
{
    float lo[3], hi[3];
    int inside = 1;
    for (int a = 0; a < 3; ++a) {
        lo[a] = G->origin[a];
        hi[a] = G->origin[a] + (float)G->dims[a] * G->cell;
        inside &= (p[a] >= lo[a]) & (p[a] <= hi[a]);
    }
    float t0 = 0.0f;
    if (!inside) {
        float t1 = INFINITY;
        for (int a = 0; a < 3; ++a) {
            const float ta = (lo[a] - p[a]) * inv[a], tb = (hi[a] - p[a]) * inv[a];
            t0 = VMAX(t0, VMIN(ta, tb));
            t1 = VMIN(t1, VMAX(ta, tb));
        }
        if (!(t0 <= t1))
            return 0;
    }
    for (int a = 0; a < 3; ++a) {
        /* clamped, then truncated (x >= 0: the floor; a NaN, which a finite
         * ray cannot give, converts to a negative int, taken to 0) */
        const int k = (int)VMIN(VMAX((p[a] + t0 * w[a] - G->origin[a]) * G->inv_cell, 0.0f),
                                (float)(G->dims[a] - 1));
        W->cell[a] = k > 0 ? k : 0;
        W->step[a] = w[a] > 0.0f ? 1 : (w[a] < 0.0f ? -1 : 0);
        W->next[a] = grid_face(G, a, W->cell[a], W->step[a], p[a], inv[a]);
    }
    return 1;
}

/* one cell on, along the axis whose face the ray reaches first (x, then y,
 * on ties); 0: the walk has left the grid */
__attribute__((always_inline)) inline int grid_next(__global const grid_t *G, walk_t *W, const float *p,
                                                    const float *inv)
{
    const int a = (W->next[0] <= W->next[1] && W->next[0] <= W->next[2]) ? 0 : (W->next[1] <= W->next[2] ? 1 : 2);
    W->cell[a] += W->step[a];
    if (W->cell[a] < 0 || W->cell[a] >= G->dims[a] || W->step[a] == 0)
        return 0;
    W->next[a] = grid_face(G, a, W->cell[a], W->step[a], p[a], inv[a]);
    return 1;
}
#endif

#endif

/* scene_tables.h -- a scene's device tables as one value, and the tests of
 * a query that need no CSM.
 *
 *   scene_t               the buffers and scalars of the scene kernels (the
 *                         "Scene data" of visibility.cl), passed to every
 *                         function of a lookup
 *   SCENE_ARGS, SCENE_INIT  the kernels' parameters for them, and the
 *                         scene_t S made of those parameters (same order)
 *   ground_v()            GROUND only: rays that cross the ground plane
 *   sphere_v()            NTYPES > 0 only: rays that can meet an instance's
 *                         bounding sphere
 *   box_v()               NTYPES > 0 and INSTANCE_BVH only: rays that can
 *                         meet a node's box
 * With FINITE_RAYS each takes one more argument, the rays' lengths tm (world
 * units, unit w; +inf = unbounded): the ground counts only where the segment
 * ends on the plane's other side, a sphere only where the segment passes the
 * midpoint of its chord (tca < tm: the host refuses or reroutes the rays that
 * end inside a sphere, so for the rest this says "the sphere lies wholly
 * before the end", and otherwise it lies wholly beyond), a box only where
 * the segment reaches it.
 * Expects: LANES (lanes.h), DEPTH_BITS, IEND_T, PAIR_WIDE, SEARCH_BLOCK
 * (csm_search.h: pair_t), NTYPES, GROUND, INSTANCE_BVH, INSTANCE_GRID, FINITE_RAYS (0/1).
 */
#ifndef PYSHADOW_SCENE_TABLES_H
#define PYSHADOW_SCENE_TABLES_H

#include "csm_search.h"
#include "scene_types.h"
#include "lanes.h"

typedef struct {
    __global const csm_type_t *types;
    __global const uint *offsets;
    __global const uint *soff;
    __global const IEND_T *summary;
    __global const pair_t *pairs;
    __global const float *bases;
    __global const int *cells;
    __global const uint *empty;         /* per texel, words of empty-map bits (csm_lookup.h) */
    __global const instance_t *inst;
    __global const int *itype;
    int ninst;
    float ground_y, ground_eps;
    float bias_abs, bias_texels, bias_tan, bias_other;
    __global const bvh_node_t *nodes;   /* INSTANCE_BVH: the tree over the casters, root first */
    __global const int *order;          /* its leaves' instances */
    float bvh_pad;                      /* margin around every box (pyshadow.visibility.bvh.box_pad) */
    __global const grid_t *grid;        /* INSTANCE_GRID: the grid over the casters (grid.h) */
    __global const grid_packet_t *gpackets;  /* its cells' lists, four spheres to a packet */
} scene_t;

#define SCENE_ARGS __global const csm_type_t *types, __global const uint *offsets,    \
                   __global const uint *soff, __global const IEND_T *summary,            \
                   __global const pair_t *pairs,                                         \
                   __global const float *bases, __global const int *cells,              \
                   __global const uint *empty,                                           \
                   __global const instance_t *inst, __global const int *itype,          \
                   const int ninst, const float ground_y, const float ground_eps,        \
                   const float bias_abs,                                                 \
                   const float bias_texels, const float bias_tan, const float bias_other,  \
                   __global const bvh_node_t *nodes, __global const int *order,         \
                   const float bvh_pad, __global const grid_t *grid,                    \
                   __global const grid_packet_t *gpackets

#define SCENE_INIT scene_t S = {types, offsets, soff, summary, pairs, bases, cells,     \
                                empty, inst, itype,                                            \
                                ninst, ground_y, ground_eps, bias_abs, bias_texels, bias_tan,   \
                                bias_other, nodes, order, bvh_pad, grid, gpackets}

#if FINITE_RAYS
#define TMAX_PARAM , fv tm
#else
#define TMAX_PARAM
#endif

#if GROUND
/* lanes (-1) whose ray crosses the ground plane y = ground_y; within
 * ground_eps of the plane counts as on it (above). A finite ray's end counts
 * as on it within ground_eps plus 2^-20 of the start's height and of the
 * plane's (both relative to the anchor: the rounding of an end computed from
 * the start, a light in the plane), as visibility.finite.ground_blocks */
inline iv ground_v(const scene_t *S, fv py, fv wy TMAX_PARAM)
{
    const fv h = py - S->ground_y;
#if FINITE_RAYS
    const fv e = h + tm * wy;             /* the segment's end's height */
    const fv te = (fv)(S->ground_eps) + (VABS(h) + fabs(S->ground_y)) * 9.5367431640625e-7f;
    /* a point on the plane going down enters the ground at once, whatever the ray's length */
    return (MASK(h >= -S->ground_eps) & MASK(wy < 0.0f) & (MASK(e < -te) | MASK(h <= S->ground_eps)))
           | (MASK(h < -S->ground_eps) & MASK(wy > 0.0f) & MASK(e > te));
#else
    return (MASK(h >= -S->ground_eps) & MASK(wy < 0.0f)) | (MASK(h < -S->ground_eps) & MASK(wy > 0.0f));
#endif
}
#endif

#if NTYPES
/* lanes (-1) whose ray p + t w, t >= 0 (w unit), can come within instance
 * j's bounding sphere. The ray's squared distance from the centre is that
 * of o - (o.w) w, not |o|^2 - (o.w)^2: far from the sphere the difference of
 * squares loses every digit (at 5000 radii float32 leaves it +-1.5 r^2). */
/* the test's terms for rays of float type T against spheres of centre
 * (cx, cy, cz) and radius rad (type R): tca, oc2, e2 (the ray's squared
 * distance from the centre) and r2 -- one text for the lanes here and for
 * grid.h's tests (one ray, four spheres; lanes, one sphere), so that all
 * give the same answer */
#define SPHERE_TERMS(T, R, cx, cy, cz, rad, px, py, pz, wx, wy, wz)                                \
    const T ox = (cx) - (px), oy = (cy) - (py), oz = (cz) - (pz);                                 \
    const T tca = ox * (wx) + oy * (wy) + oz * (wz);                                              \
    const T oc2 = ox * ox + oy * oy + oz * oz;                                                    \
    const T ex = ox - tca * (wx), ey = oy - tca * (wy), ez = oz - tca * (wz);                     \
    const T e2 = ex * ex + ey * ey + ez * ez;                                                     \
    const R r2 = (rad) * (rad)
inline iv sphere_v(const scene_t *S, int j, fv px, fv py, fv pz, fv wx, fv wy, fv wz TMAX_PARAM)
{
    __global const instance_t *I = S->inst + j;
    SPHERE_TERMS(fv, float, I->centre[0], I->centre[1], I->centre[2], I->radius, px, py, pz, wx, wy, wz);
#if FINITE_RAYS
    return ~(MASK(oc2 > r2) & (MASK(tca < 0.0f) | MASK(e2 > r2))) & MASK(tca < tm);
#else
    return ~(MASK(oc2 > r2) & (MASK(tca < 0.0f) | MASK(e2 > r2)));
#endif
}
#endif

#if NTYPES && INSTANCE_BVH
/* lanes (-1) whose ray p + t w, t >= 0, meets node B's box grown by
 * bvh_pad (slab test; ix = 1 / wx, +-inf where wx = 0). A sphere lies inside
 * its box, more than bvh_pad from every face, so a ray meeting the sphere
 * passes this test despite the float rounding; a NaN (a ray on a face's
 * plane, parallel to it) can only answer for rays outside the sphere. */
inline iv box_v(const scene_t *S, __global const bvh_node_t *B, fv px, fv py, fv pz, fv ix, fv iy,
                fv iz TMAX_PARAM)
{
    const float e = S->bvh_pad;
    const fv ax = (B->lo[0] - e - px) * ix, bx = (B->hi[0] + e - px) * ix;
    const fv ay = (B->lo[1] - e - py) * iy, by = (B->hi[1] + e - py) * iy;
    const fv az = (B->lo[2] - e - pz) * iz, bz = (B->hi[2] + e - pz) * iz;
    const fv t0 = VMAX(VMAX(VMIN(ax, bx), VMIN(ay, by)), VMIN(az, bz));
    const fv t1 = VMIN(VMIN(VMAX(ax, bx), VMAX(ay, by)), VMAX(az, bz));
#if FINITE_RAYS
    return MASK(t1 >= VMAX(t0, (fv)(0.0f))) & MASK(t0 <= tm);
#else
    return MASK(t1 >= VMAX(t0, (fv)(0.0f)));
#endif
}
#endif

#endif

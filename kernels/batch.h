/* batch.h -- batch_occluded(): a work-item's batch of queries against the
 * whole scene -- the ground plane, then per caster instance the bounding
 * sphere and the CSM lookup (csm_lookup.h) of the queries still open.
 * Expects: LANES (lanes.h), BATCH (queries per work-item, a multiple of
 * LANES), GROUND, SURFACE_NORMALS (0/1: each query's surface normal in
 * nx, ny, nz, for the surface rule of csm_lookup.h), INSTANCE_BVH (0/1:
 * find the casters through the tree over their boxes, BVH_STACK deep;
 * pyshadow.visibility.bvh), FINITE_RAYS (0/1: each query's length in tm,
 * scene_tables.h), NTYPES (0: the scene has no caster; only the
 * ground test is compiled -- no sphere test, tree or lookup), and what
 * csm_lookup.h expects.
 */
#ifndef PYSHADOW_BATCH_H
#define PYSHADOW_BATCH_H

#include "lanes.h"
#include "scene_tables.h"
#include "csm_lookup.h"

/* ---------------------------------------------------------------------
 * A batch of nb <= BATCH queries (private arrays; nb a multiple of LANES):
 * occ[i] != 0 on entry marks queries already decided (padding), on exit
 * the occluded ones. The ground plane is tested for all; then, per caster,
 * only the undecided queries whose ray can meet its bounding sphere are
 * packed into groups of LANES for the CSM lookup -- rays stopped by the
 * ground or missing a body cost no search. With INSTANCE_BVH the casters
 * come from the tree: a node is entered when the ray of any open query of
 * the batch meets its box, so a batch visits the casters its rays can
 * reach, not every caster; each is then asked exactly as without the tree
 * (the same sphere test and lookup; the OR over casters does not depend on
 * their order), so answers are the same bit for bit.
 * ------------------------------------------------------------------- */
#ifndef BATCH
#error "BATCH (queries per work-item, a multiple of LANES) must be defined by the host"
#endif
#if SURFACE_NORMALS
#define BATCH_NORMAL_PARAMS , const float *nx, const float *ny, const float *nz
#define BATCH_NORMAL_ARGS , nx, ny, nz
#else
#define BATCH_NORMAL_PARAMS
#define BATCH_NORMAL_ARGS
#endif
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
/* the open queries of the batch against caster j: its bounding sphere, then
 * the lookup of those whose ray can meet it, packed LANES at a time */
inline void batch_instance(const scene_t *S, const int j, const float *px, const float *py, const float *pz,
                           const float *wx, const float *wy, const float *wz, const int *own, int *occ,
                           const int nb BATCH_NORMAL_PARAMS BATCH_TMAX_PARAMS)
{
    LANE_ARRAY int idx[BATCH];
    int cnt = 0;
    for (int c = 0; c < nb; c += LANES) {
        const iv act = ~LANE_LOAD(occ + c)
                       & sphere_v(S, j, LANE_LOAD(px + c), LANE_LOAD(py + c), LANE_LOAD(pz + c),
                                  LANE_LOAD(wx + c), LANE_LOAD(wy + c), LANE_LOAD(wz + c) TMAX_LANES(c));
        LANE_ARRAY int am[LANES];
        LANE_STORE(act, am);
        for (int l = 0; l < LANES; ++l) {       /* branch-free packing; cnt <= c + l here */
            idx[cnt] = c + l;
            cnt += (am[l] != 0);
        }
    }
    for (int g = 0; g < cnt; g += LANES) {
        LANE_ARRAY float a[6 + 3 * SURFACE_NORMALS][LANES];
        LANE_ARRAY int ow[LANES], gi[LANES];
        for (int l = 0; l < LANES; ++l) {
            const int i = idx[min(g + l, cnt - 1)];
            gi[l] = i;
            a[0][l] = px[i]; a[1][l] = py[i]; a[2][l] = pz[i];
            a[3][l] = wx[i]; a[4][l] = wy[i]; a[5][l] = wz[i];
            ow[l] = own[i];
#if SURFACE_NORMALS
            a[6][l] = nx[i]; a[7][l] = ny[i]; a[8][l] = nz[i];
#endif
        }
        const iv act = MASK((iv)(g) + LANE_IDS < cnt);
        const iv r = instance_v(S, j, LANE_LOAD(a[0]), LANE_LOAD(a[1]), LANE_LOAD(a[2]),
                                LANE_LOAD(a[3]), LANE_LOAD(a[4]), LANE_LOAD(a[5]),
                                LANE_LOAD(ow), act
#if SURFACE_NORMALS
                                , LANE_LOAD(a[6]), LANE_LOAD(a[7]), LANE_LOAD(a[8])
#endif
                                );
        LANE_ARRAY int ra[LANES];
        LANE_STORE(r, ra);
        for (int l = 0; l < min(LANES, cnt - g); ++l)
            occ[gi[l]] |= ra[l];
    }
}
#endif

inline void batch_occluded(const scene_t *S, const float *px, const float *py, const float *pz,
                           const float *wx, const float *wy, const float *wz, const int *own,
                           int *occ, const int nb BATCH_NORMAL_PARAMS BATCH_TMAX_PARAMS)
{
#if GROUND
    for (int c = 0; c < nb; c += LANES)
        LANE_STORE(LANE_LOAD(occ + c) | ground_v(S, LANE_LOAD(py + c), LANE_LOAD(wy + c) TMAX_LANES(c)),
                   occ + c);
#endif
#if NTYPES && INSTANCE_BVH
    LANE_ARRAY float ix[BATCH], iy[BATCH], iz[BATCH];
    for (int c = 0; c < nb; c += LANES) {
        LANE_STORE((fv)(1.0f) / LANE_LOAD(wx + c), ix + c);
        LANE_STORE((fv)(1.0f) / LANE_LOAD(wy + c), iy + c);
        LANE_STORE((fv)(1.0f) / LANE_LOAD(wz + c), iz + c);
    }
    int stack[BVH_STACK];
    int sp = 0, node = 0;
    for (;;) {
        __global const bvh_node_t *B = S->nodes + node;
        iv hit = (iv)(0);
        for (int c = 0; c < nb; c += LANES)
            hit |= ~LANE_LOAD(occ + c) & box_v(S, B, LANE_LOAD(px + c), LANE_LOAD(py + c), LANE_LOAD(pz + c),
                                               LANE_LOAD(ix + c), LANE_LOAD(iy + c), LANE_LOAD(iz + c)
                                               TMAX_LANES(c));
        if (VANY(hit)) {
            const int a = B->a, b = B->b;
            if (b >= 0) {                       /* inner node: the left child next, the right one later */
                if (b != a)
                    stack[sp++] = b;
                node = a;
                continue;
            }
            for (int k = a; k < a - b; ++k)     /* leaf: its casters */
                batch_instance(S, S->order[k], px, py, pz, wx, wy, wz, own, occ, nb BATCH_NORMAL_ARGS
                               BATCH_TMAX_ARGS);
        }
        if (sp == 0)
            break;
        node = stack[--sp];
    }
#elif NTYPES
    for (int j = 0; j < S->ninst; ++j)
        batch_instance(S, j, px, py, pz, wx, wy, wz, own, occ, nb BATCH_NORMAL_ARGS BATCH_TMAX_ARGS);
#endif
}

#endif

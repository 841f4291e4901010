/* batch.h -- batch_occluded(): a work-item's batch of queries against the
 * whole scene -- the ground plane, then per caster instance the bounding
 * sphere and the CSM lookup (csm_lookup.h) of the queries still open.
 * Expects: LANES (lanes.h), BATCH (queries per work-item, a multiple of
 * LANES), GROUND, SURFACE_NORMALS (0/1: each query's surface normal in
 * nx, ny, nz, for the surface rule of csm_lookup.h), and what csm_lookup.h
 * expects.
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
 * ground or missing a body cost no search.
 * ------------------------------------------------------------------- */
#ifndef BATCH
#error "BATCH (queries per work-item, a multiple of LANES) must be defined by the host"
#endif
inline void batch_occluded(const scene_t *S, const float *px, const float *py, const float *pz,
                           const float *wx, const float *wy, const float *wz, const int *own,
                           int *occ, const int nb
#if SURFACE_NORMALS
                           , const float *nx, const float *ny, const float *nz
#endif
                           )
{
#if GROUND
    for (int c = 0; c < nb; c += LANES)
        LANE_STORE(LANE_LOAD(occ + c) | ground_v(S, LANE_LOAD(py + c), LANE_LOAD(wy + c)), occ + c);
#endif
    for (int j = 0; j < S->ninst; ++j) {
        LANE_ARRAY int idx[BATCH];
        int cnt = 0;
        for (int c = 0; c < nb; c += LANES) {
            const iv act = ~LANE_LOAD(occ + c)
                           & sphere_v(S, j, LANE_LOAD(px + c), LANE_LOAD(py + c), LANE_LOAD(pz + c),
                                      LANE_LOAD(wx + c), LANE_LOAD(wy + c), LANE_LOAD(wz + c));
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
}

#endif

/* visibility.cl -- shadow queries against the CSMs of a scene (thesis 000,
 * sections 5.3, 5.3.2, 5.3.3) and ambient occlusion from them.
 *
 * Kernels
 *   scene_visible   one work-item per BATCH (point, direction) queries: 1 if
 *                   the ray from the point along the direction is unoccluded.
 *   scene_ao        per point (AO_POINTS a work-item): SAMPLES cosine-weighted
 *                   directions from pattern pidx[i] (sampling.h), with
 *                   FINITE_RAYS of length tmax[i]; writes the
 *                   unoccluded fraction and, with BENT_NORMALS, the
 *                   normalised sum of the unoccluded directions, with
 *                   TRANSFER the shadowed SH transfer (9 sums).
 *
 * A query (p, w) is occluded when
 *   - GROUND and the ray from p crosses the plane y = ground_y (p above it
 *     and w pointing down, or below it and w pointing up; a point within
 *     ground_eps of the plane counts as on it and is occluded by downward
 *     directions only), no lookup needed; or
 *   - for some caster instance whose bounding sphere the ray can meet: with
 *     p' = A p + c (the instance's normalised frame) and w' = Rw w, the map k
 *     nearest w' (O(1), per layout) and the texel (row, col) of p' in map k,
 *     the point's depth (1 - p'.d_k)/2 exceeds the texel's stored depth for
 *     map k (the search of its segment list) plus the bias
 *         bias_abs + (bias_texels + bias_tan * tan(angle(w', d_k))) / R
 *     when p may lie on instance j itself (owner[i] == j, or -1: unknown),
 *     else only
 *     bias_other (the depth quantum): a point on another body or the
 *     ground needs no protection from acne, and contact shadows stay sharp.
 *     With SURFACE_NORMALS (scene_ao always; scene_visible when the host
 *     passes normals), a ray leaving the surface of instance j itself
 *     (w'.m' > 0, m' its normal in the frame) follows the surface rule of
 *     csm_lookup.h: its lookup direction is raised to the view set's
 *     covering angle above the tangent plane where it is lower, and each
 *     tap compares with the point's own plane at the tap's texel centre
 *     (PLANE_BIAS with the default bias; else the point is lifted off the
 *     surface where the map sees it obliquely; pyshadow.csm.surface_rule
 *     gives the reasons).
 *   A point before its ray's chord through the instance (inside its sphere
 *   and its mesh's box) is asked there (csm_lookup.h, instance_v; one more
 *   than two texels outside the sphere, or on another body, with a depth
 *   behind every stored one: a surface lying on the sphere); a ray
 *   whose chord is empty or behind it, points outside map k's square or in
 *   front of the bounding sphere (depth <= 0) are not shadowed by it.
 *   FILTERED: instead of one texel of map k, a vote -- the four maps of
 *   views.ViewSet.filter_window (inverse-angle weights) times the four
 *   texels around p' in each (bilinear weights of the texel centres), each
 *   tap comparing as above with the bias to its own map's axis; the
 *   instance shadows the ray when the weights of the shadowing taps exceed
 *   one half. Up to 16 searches instead of one.
 *
 * Scene data ("atlas": every CSM type of the scene concatenated)
 *   types    csm_type_t (one per CSM type): resolution, maps, layout (0 zigzag, 1
 *                  hilbert, 2 hilbert over two hemispheres), p1 (theta or
 *                  level), p2 (phi), texel, view and cell-table bases, the
 *                  zigzag grid steps' cos and sin (scene_types.h, generated
 *                  from pyshadow._cl.tables.CSM_TYPE)
 *   offsets, soff  uint (sum R^2, + 1); summary IEND_T; pairs pair_t: the
 *            search layout of csm_search.h with every list padded to whole
 *            blocks (CoherentShadowMap.search_arrays(padded=True)), every
 *            type's entries shifted so they index the concatenated arrays
 *            directly
 *   bases    float (sum D, 9)      rows u, v, d of every map
 *   cells    int   (sum cells)     hilbert cell -> map index
 *   inst     instance_t (NINST): to_object A (3x3, rows), offset c,
 *                  rotation Rw (3x3), world bounding sphere centre and
 *                  radius (pyshadow._cl.tables.INSTANCE)
 *   itype    int   (NINST)         CSM type of each instance
 * All of it is validated on the host (CSM files on load), so the search and
 * the map/texel indices stay inside their arrays whatever the query.
 * Query data: owner int (N): caster slot of the surface each point lies on,
 * -1 unknown, -2 none (validated: -2 <= owner < NINST);
 * scene_visible: points, dirs (N, 3) of point_t / dir_t, the caller's own
 * arrays (dirs need not be unit, only non-zero: normalised here) and the
 * scene anchor chosen by the host; points are made anchor-relative before
 * they are rounded to float, which keeps their precision for scenes far from
 * the world origin. scene_ao: points (anchor-relative) and unit normals float
 * (N, 3); pidx int (N); table float (M, 3, SPAD) local directions. Outputs
 * uchar / float (N), float (N, 3).
 *
 * Macros
 *   DEPTH_BITS, IEND_T, PAIR_WIDE   storage of the atlas (csm_common.h)
 *   NTYPES               the CSM types: 0 (no caster: no sphere test,
 *                        instance tree or grid, or CSM lookup is compiled;
 *                        csm_lookup.h, batch.h), 1, or 2 for two or more
 *                        (the tests are NTYPES, NTYPES > 1: one program)
 *   INSTANCE_BVH, INSTANCE_GRID  how the casters a ray can meet are found
 *                        (batch.h)
 *   GROUND               1: infinite ground plane y = ground_y (0: no
 *                        ground test is compiled)
 *   LAYOUT_ZIGZAG, LAYOUT_HILBERT  which nearest-map codes to compile (0/1)
 *   SAMPLES, BENT_NORMALS, AO_POINTS  (scene_ao only; AO_POINTS: below)
 *   TRANSFER             1: scene_ao also writes the shadowed SH transfer
 *                        (N, 9) float, pi / SAMPLES x the sum of the 9 basis
 *                        functions over the unoccluded directions
 *                        (pyshadow.lighting.transfer)
 *   SKY_SAMPLED          1: scene_ao also writes sky (N, 3) float, the mean
 *                        over SAMPLES of the lat-long map env (env_h, env_w,
 *                        3)'s nearest-texel radiance at the unoccluded
 *                        directions (envmap.h; the "sampled" sky)
 *   SURFACE_NORMALS      1: every query carries its surface's unit normal
 *                        (scene_visible: normals float (N, 3); scene_ao:
 *                        the point's normal) for the surface rule
 *   SURFACE_LIFT_TEXELS  float: the surface rule's lift (csm_map.h)
 *   PLANE_BIAS           1: the receiver's plane with SURFACE_NORMALS;
 *   PLANE_BIAS_TEXELS    float: its curvature allowance (csm_map.h)
 *   FINITE_RAYS          1: each query carries its length tmax float (N),
 *                        world units, > 0 (+inf = unbounded); occluders
 *                        beyond it do not count (scene_tables.h). In
 *                        scene_ao one length per point, for all its
 *                        samples (distance-limited AO). 0: not compiled,
 *                        bit-identical
 *   FILTERED             1: filtered lookups (instance16): the four maps of
 *                        views.ViewSet.filter_window, four texels each
 *   FILTER_ANGLE_EPS     float: views.FILTER_ANGLE_EPS (FILTERED only)
 *   LANES                queries per lane vector (lanes.h)
 *   BATCH                queries per work-item, a multiple of LANES
 *                        (scene.batch_size()): see batch_occluded()
 *   HAVE_FP64            the device has cl_khr_fp64 (anchor arithmetic in
 *                        double)
 *   POINTS_F64, DIRS_F64 scene_visible's inputs are double (needs HAVE_FP64)
 *                        or float
 *   PROFILE_SKIP_NEAREST, PROFILE_SKIP_SEARCH  (benchmarks/visibility.py
 *       --profile only: replace the nearest-map choice or the segment search
 *       by a trivial stand-in to measure their share; results are wrong)
 *
 * Headers, in the order included: csm_search.h (segment layout),
 * sampling.h (hemisphere frame), scene_types.h (generated table structs),
 * views_hilbert.h and views_zigzag.h (nearest maps; views_common.h,
 * lane_math.h), lanes.h (lane vectors and lane memory), scene_tables.h
 * (scene_t, the kernels' scene parameters, ground and bounding spheres),
 * csm_lookup.h (one instance's CSM lookup), batch.h (a batch of queries
 * against the whole scene), visibility_rows.h (scene_visible's input rows,
 * read as lane vectors), vec3.h (rows of (n, 3) arrays, and a length, inline;
 * views_common.h and envmap.h read their rows with it).
 * This file: the kernels.
 */
#include "csm_search.h"
#include "sampling.h"
#include "scene_types.h"
#include "views_hilbert.h"
#include "lanes.h"
#include "views_zigzag.h"
#include "scene_tables.h"
#include "csm_lookup.h"
#include "batch.h"
#include "visibility_rows.h"
#include "vec3.h"
#if SKY_SAMPLED
#include "envmap.h"
#endif
#if TRANSFER
#include "sh9.h"
#endif

/* BATCH queries per work-item; lanes past n are answered as "visible" and
 * not written. */
__kernel void scene_visible(SCENE_ARGS, const int n, __global const point_t *points,
                            __global const dir_t *dirs, const anchor_t ax, const anchor_t ay,
                            const anchor_t az, __global const int *owner,
#if SURFACE_NORMALS
                            __global const float *normals,
#endif
#if FINITE_RAYS
                            __global const float *tmax,
#endif
                            __global uchar *out)
{
    const int base = get_global_id(0) * BATCH;
    if (base >= n) return;
    SCENE_INIT;
    LANE_ARRAY float px[BATCH], py[BATCH], pz[BATCH], wx[BATCH], wy[BATCH], wz[BATCH];
    LANE_ARRAY int ow[BATCH], occ[BATCH];
    const int m = IMIN(BATCH, n - base);
    {   /* the next work-item's rows (the same thread's, in PoCL's loop over
         * a work-group): start their transfer now, under this batch's work */
        __global const uchar *np_ = (__global const uchar *)(points + 3 * (base + BATCH));
        __global const uchar *nd_ = (__global const uchar *)(dirs + 3 * (base + BATCH));
        const int rows = clamp(n - base - BATCH, 0, BATCH);
        for (int b = 0; b < rows * 3 * (int)sizeof(point_t); b += 64) PREFETCH(np_ + b);
        for (int b = 0; b < rows * 3 * (int)sizeof(dir_t); b += 64) PREFETCH(nd_ + b);
    }
    for (int c = 0; c < BATCH; c += LANES) {
        if (c + LANES <= m) {
            /* LANES whole rows: three vector loads per array, deinterleaved */
            __global const point_t *pp = points + 3 * (base + c);
            __global const dir_t *dp = dirs + 3 * (base + c);
            pointv_t a0 = LOADU(pointvu_t, pp, 0), a1 = LOADU(pointvu_t, pp, 1),
                     a2 = LOADU(pointvu_t, pp, 2), x, y, z;
            DEINTERLEAVE3(pointv_t, a0, a1, a2, x, y, z);
            LANE_STORE(CONVERT(float, TO_WIDE(x) - ax), px + c);
            LANE_STORE(CONVERT(float, TO_WIDE(y) - ay), py + c);
            LANE_STORE(CONVERT(float, TO_WIDE(z) - az), pz + c);
            dirv_t b0 = LOADU(dirvu_t, dp, 0), b1 = LOADU(dirvu_t, dp, 1),
                   b2 = LOADU(dirvu_t, dp, 2), u, v, w;
            DEINTERLEAVE3(dirv_t, b0, b1, b2, u, v, w);
            const dirv_t sq = u * u + v * v + w * w;
            /* the mask narrowed to int lanes before all(): no call with a
             * vector of doubles */
            if (VALL(CONVERT(int, MASK(sq > (dir_t)1e-30) & MASK(sq < (dir_t)1e30)))) {
                LANE_STORE(CONVERT(float, u), wx + c);
                LANE_STORE(CONVERT(float, v), wy + c);
                LANE_STORE(CONVERT(float, w), wz + c);
                LANE_STORE(LOADU(ivu_t, owner + base + c, 0), ow + c);
                LANE_STORE((iv)(0), occ + c);
                continue;
            }
        }
        for (int l = c; l < c + LANES; ++l) {          /* the batch's tail, or rescaling */
            const int i = base + IMIN(l, m - 1);
            px[l] = (float)((wide_t)points[3 * i] - ax);
            py[l] = (float)((wide_t)points[3 * i + 1] - ay);
            pz[l] = (float)((wide_t)points[3 * i + 2] - az);
            dir_t x = dirs[3 * i], y = dirs[3 * i + 1], z = dirs[3 * i + 2];
            const dir_t sq = x * x + y * y + z * z;
            if (!(sq > (dir_t)1e-30 && sq < (dir_t)1e30)) {
                /* rescale first, by a power of two (exact): the largest
                 * component to [0.5, 1) */
                int e;
                (void)frexp(fmax(fabs(x), fmax(fabs(y), fabs(z))), &e);
                x = ldexp(x, -e); y = ldexp(y, -e); z = ldexp(z, -e);
            }
            wx[l] = (float)x; wy[l] = (float)y; wz[l] = (float)z;
            ow[l] = owner[i];
            occ[l] = (l < m) ? 0 : -1;
        }
    }
    for (int c = 0; c < BATCH; c += LANES) {
        fv x = LANE_LOAD(wx + c), y = LANE_LOAD(wy + c), z = LANE_LOAD(wz + c);
        const fv inv = 1.0f / VSQRT(x * x + y * y + z * z);
        LANE_STORE(x * inv, wx + c); LANE_STORE(y * inv, wy + c); LANE_STORE(z * inv, wz + c);
    }
#if SURFACE_NORMALS
    LANE_ARRAY float nx[BATCH], ny[BATCH], nz[BATCH];
    for (int l = 0; l < BATCH; ++l) {              /* unit normals, validated on the host */
        const int i = base + IMIN(l, m - 1);
        nx[l] = normals[3 * i]; ny[l] = normals[3 * i + 1]; nz[l] = normals[3 * i + 2];
    }
#endif
#if FINITE_RAYS
    LANE_ARRAY float tm[BATCH];                    /* lengths, validated on the host */
    for (int l = 0; l < BATCH; ++l) tm[l] = tmax[base + IMIN(l, m - 1)];
#endif
    batch_occluded(&S, px, py, pz, wx, wy, wz, ow, occ, BATCH BATCH_NORMAL_ARGS BATCH_TMAX_ARGS);
    for (int c = 0; c < m; c += LANES) {
        if (c + LANES <= m) {                     /* -1 (occluded) -> 0, 0 -> 1 */
            STOREU(ucharvu_t, out + base + c, CONVERT(uchar, LANE_LOAD(occ + c) + 1));
        } else {
            for (int l = c; l < m; ++l) out[base + l] = occ[l] ? 0 : 1;
        }
    }
}

#ifdef SAMPLES
/* one work-item per AO_POINTS points (the host's choice: as many as fill a
 * batch of BATCH queries with their samples, or 1); their SAMPLES directions
 * LANES at a time, AO_SLICE of each point's per batch_occluded(), whose queue
 * of lookups the points share. table: local directions per pattern as (M,
 * 3, SPAD) structure of arrays, SPAD = SAMPLES rounded up to LANES (padding
 * lanes are masked out). */
#define SPAD (((SAMPLES + LANES - 1) / LANES) * LANES)
#define AO_SLICE (SPAD < BATCH ? SPAD : BATCH)     /* samples of a point per batch_occluded() */
#define AO_BATCH (AO_POINTS * AO_SLICE)
__kernel void scene_ao(SCENE_ARGS, const int n, __global const float *points,
                       __global const float *normals, __global const int *pidx,
                       __global const int *owner,
#if FINITE_RAYS
                       __global const float *tmax,
#endif
                       __global const float *table, __global float *ao,
                       __global float *bent, __global float *transfer
#if SKY_SAMPLED
                       , __global const float *env, const int env_h, const int env_w, __global float *sky
#endif
                       )
{
    const int i0 = get_global_id(0) * AO_POINTS;
    if (i0 >= n) return;
    SCENE_INIT;
    const int np = IMIN(AO_POINTS, n - i0);             /* points of this work-item */
    int open[AO_POINTS] = {0};                          /* per point, zero-initialised */
    float3 sum[AO_POINTS] = {(float3)(0.0f)};
#if TRANSFER
    float tr[AO_POINTS][9] = {{0.0f}};
#endif
#if SKY_SAMPLED
    float3 sky_sum[AO_POINTS] = {(float3)(0.0f)};
#endif
    for (int s0 = 0; s0 < SPAD; s0 += AO_SLICE) {
        LANE_ARRAY float px[AO_BATCH], py[AO_BATCH], pz[AO_BATCH], wx[AO_BATCH], wy[AO_BATCH],
                         wz[AO_BATCH];
        LANE_ARRAY int ow[AO_BATCH], occ[AO_BATCH];
#if SURFACE_NORMALS
        LANE_ARRAY float nx[AO_BATCH], ny[AO_BATCH], nz[AO_BATCH];
#endif
#if FINITE_RAYS
        LANE_ARRAY float tm[AO_BATCH];            /* the points' lengths, validated on the host */
#endif
        for (int k = 0; k < AO_POINTS; ++k) {
            const int i = i0 + IMIN(k, np - 1), q0 = k * AO_SLICE;   /* past the last point: its copy, decided */
            const float3 p = row3(points, i);
            const float3 nrm = row3(normals, i);
            float3 t, b;
            hemisphere_frame(nrm, &t, &b);
            __global const float *pat = table + (size_t)pidx[i] * 3 * SPAD;
#if SURFACE_NORMALS
            for (int l = q0; l < q0 + AO_SLICE; ++l) { nx[l] = nrm.x; ny[l] = nrm.y; nz[l] = nrm.z; }
#endif
#if FINITE_RAYS
            for (int l = q0; l < q0 + AO_SLICE; ++l) tm[l] = tmax[i];
#endif
            for (int c = 0; c < AO_SLICE; c += LANES) {
                const int s = IMIN(s0 + c, SPAD - LANES);
                const fv lx = LOADU(fvu_t, pat + s, 0), ly = LOADU(fvu_t, pat + SPAD + s, 0),
                         lz = LOADU(fvu_t, pat + 2 * SPAD + s, 0);
                /* cosine_direction() of sampling.h, per lane, same operations */
                LANE_STORE((lx * t.x + ly * nrm.x) + lz * b.x, wx + q0 + c);
                LANE_STORE((lx * t.y + ly * nrm.y) + lz * b.y, wy + q0 + c);
                LANE_STORE((lx * t.z + ly * nrm.z) + lz * b.z, wz + q0 + c);
                LANE_STORE((fv)(p.x), px + q0 + c); LANE_STORE((fv)(p.y), py + q0 + c);
                LANE_STORE((fv)(p.z), pz + q0 + c);
                LANE_STORE((iv)(owner[i]), ow + q0 + c);
                LANE_STORE(MASK((iv)(s0 + c) + LANE_IDS >= SAMPLES) | (k < np ? (iv)(0) : (iv)(-1)),
                           occ + q0 + c);         /* padding: decided */
            }
        }
#if SURFACE_NORMALS
        batch_occluded(&S, px, py, pz, wx, wy, wz, ow, occ, AO_BATCH, nx, ny, nz BATCH_TMAX_ARGS);
#else
        batch_occluded(&S, px, py, pz, wx, wy, wz, ow, occ, AO_BATCH BATCH_TMAX_ARGS);
#endif
        for (int k = 0; k < np; ++k) {
            /* the point's sums in registers (summed in the arrays, each add waited
             * on the store of the one before) */
            int o = open[k];
            float3 acc = sum[k];
            for (int l = k * AO_SLICE; l < k * AO_SLICE + IMIN(AO_SLICE, SAMPLES - s0); ++l) {
                /* without a branch (open or not is a coin toss to the predictor): an
                 * occluded sample adds +0 (its bits masked off), which leaves the sum
                 * as it was (a sum from +0 is never -0) */
                const int is_open = occ[l] == 0;
                o += is_open;
#if BENT_NORMALS
                acc += as_float3(as_int3((float3)(wx[l], wy[l], wz[l])) & (int3)(-is_open));
#endif
#if TRANSFER || SKY_SAMPLED
                if (!is_open) continue;
#endif
#if TRANSFER
                sh9_accumulate(wx[l], wy[l], wz[l], tr[k]);
#endif
#if SKY_SAMPLED
                sky_sum[k] += envmap_latlong(env, env_h, env_w, wx[l], wy[l], wz[l]);
#endif
            }
            open[k] = o;
            sum[k] = acc;
        }
    }
    for (int k = 0; k < np; ++k) {
        const int i = i0 + k;
        ao[i] = (float)open[k] / (float)SAMPLES;
#if BENT_NORMALS
        const float len = length3(sum[k]);
        store_row3(len > 0.0f ? sum[k] / len : row3(normals, i), bent, i);
#endif
#if TRANSFER
        /* cosine-weighted samples (pdf cos / pi): pi / SAMPLES x the sum is
         * the shadowed transfer integral of V Y_k cos */
        for (int c = 0; c < 9; ++c) transfer[9 * (size_t)i + c] = tr[k][c] * (M_PI_F / (float)SAMPLES);
#endif
#if SKY_SAMPLED
        store_row3(sky_sum[k] / (float)SAMPLES, sky, i);  /* mean radiance of the open samples */
#endif
    }
}
#endif

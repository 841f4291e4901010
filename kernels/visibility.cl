/* visibility.cl -- shadow queries against the CSMs of a scene (thesis 000,
 * sections 5.3, 5.3.2, 5.3.3) and ambient occlusion from them.
 *
 * Kernels
 *   scene_visible   one work-item per BATCH (point, direction) queries: 1 if
 *                   the ray from the point along the direction is unoccluded.
 *   scene_ao        one work-item per point: SAMPLES cosine-weighted
 *                   directions from pattern pidx[i] (sampling.h); writes the
 *                   unoccluded fraction and, with BENT_NORMALS, the
 *                   normalised sum of the unoccluded directions.
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
 *     map k (the counting search of its segment list) plus the bias
 *         bias_abs + (bias_texels + bias_tan * tan(angle(w', d_k))) / R
 *     when p may lie on instance j itself (owner[i] == j, or -1: unknown),
 *     else only
 *     bias_other (the depth quantum): a point on another body or the
 *     ground needs no protection from acne, and contact shadows stay sharp.
 *   Points outside map k's square or in front of the bounding sphere
 *   (depth <= 0) cannot be shadowed by that instance.
 *   FILTERED: instead of one texel of map k, a vote -- the four maps of
 *   views.ViewSet.filter_window (inverse-angle weights) times the four
 *   texels around p' in each (bilinear weights of the texel centres), each
 *   tap comparing as above with the bias to its own map's axis; the
 *   instance shadows the ray when the weights of the shadowing taps exceed
 *   one half. Up to 16 searches instead of one.
 *
 * Scene data ("atlas": every CSM type of the scene concatenated)
 *   types    csm_type_t (NTYPES): resolution, maps, layout (0 zigzag, 1
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
 *   NTYPES               number of CSM types (>= 0)
 *   GROUND               1: infinite ground plane y = ground_y
 *   LAYOUT_ZIGZAG, LAYOUT_HILBERT  which nearest-map codes to compile (0/1)
 *   SAMPLES, BENT_NORMALS  (scene_ao only)
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
 */
#include "csm_search.h"
#include "sampling.h"
#include "scene_types.h"

#define PI_F 3.14159265358979f

inline float3 bases_row(__global const float *bases, int view, int row)
{
    return vload3(3 * view + row, bases);
}


#if LAYOUT_HILBERT
/* fold a cell index that left its square back onto the sphere (views.py) */
inline int hilbert_cell(int split, int n, int i, int j, int h)
{
    if (!split) {
        const int out_i = (i < 0) || (i >= n);
        i = clamp(i, 0, n - 1);
        if (out_i) j = n - 1 - j;
        const int out_j = (j < 0) || (j >= n);
        j = clamp(j, 0, n - 1);
        if (out_j) i = n - 1 - i;
        return i * n + j;
    }
    if (i < 0 || i >= n) { h = 1 - h; i = (i >= n) ? 0 : n - 1; }
    if (j < 0 || j >= n) { h = 1 - h; i = n - 1 - i; j = clamp(j, 0, n - 1); }
    return (i + h * n) * n + j;
}

/* map indices of the 3 x 3 cells around the cell of unit direction w
 * (views.ViewSet._hilbert_candidates), in the scan order of views.py */
inline void hilbert_candidates(__global const int *cells, int cbase, int level, int split, float3 w,
                               int *k9)
{
    const int n = 1 << level;
    int h = 0;
    float3 q = w;
    if (split) { h = (w.y < 0.0f) ? 1 : 0; q.y = fabs(w.y); }
    /* equal-area octahedral encoding (views.octahedral_encode) */
    const float ay = fabs(q.y);
    const float r = sqrt((q.x * q.x + q.z * q.z) / (1.0f + ay));
    const float t = atan2(fabs(q.z), fabs(q.x)) * (4.0f / PI_F) - 1.0f;
    float a, b;
    if (q.y >= 0.0f) { a = r * (1.0f - t) * 0.5f; b = r * (1.0f + t) * 0.5f; }
    else { a = (2.0f - r - r * t) * 0.5f; b = (2.0f - r + r * t) * 0.5f; }
    float u = (q.x < 0.0f) ? -a : a, v = (q.z < 0.0f) ? -b : b;
    if (split) {
        const float s = u + v, tt = v - u;
        u = h ? -s : s;
        v = tt;
    }
    const int ci = clamp((int)floor((u + 1.0f) * 0.5f * n), 0, n - 1);
    const int cj = clamp((int)floor((v + 1.0f) * 0.5f * n), 0, n - 1);
    for (int di = -1; di <= 1; ++di)
        for (int dj = -1; dj <= 1; ++dj)
            k9[3 * (di + 1) + dj + 1] = cells[cbase + hilbert_cell(split, n, ci + di, cj + dj, h)];
}

inline int nearest_hilbert(__global const float *bases, int vbase, __global const int *cells,
                           int cbase, int level, int split, float3 w)
{
    int k9[9];
    hilbert_candidates(cells, cbase, level, split, w, k9);
    int best = 0;
    float bd = -2.0f;
    for (int c = 0; c < 9; ++c) {
        const float dd = dot(bases_row(bases, vbase + k9[c], 2), w);
        if (dd > bd) { bd = dd; best = k9[c]; }
    }
    return best;
}

#if FILTERED
/* the four of those cells nearest w, nearest first (ties: scan order), with
 * their unnormalised weights 1 / (angle + FILTER_ANGLE_EPS)
 * (views.ViewSet.filter_window) */
inline void window_hilbert(__global const float *bases, int vbase, __global const int *cells,
                           int cbase, int level, int split, float3 w, int *k4, float *w4)
{
    int k9[9];
    hilbert_candidates(cells, cbase, level, split, w, k9);
    float d4[4] = {-3.0f, -3.0f, -3.0f, -3.0f};
    for (int c = 0; c < 9; ++c) {
        const float dd = dot(bases_row(bases, vbase + k9[c], 2), w);
        int pos = 4;
        for (int p = 3; p >= 0; --p) if (dd > d4[p]) pos = p;
        for (int p = 3; p > pos; --p) { d4[p] = d4[p - 1]; k4[p] = k4[p - 1]; }
        if (pos < 4) { d4[pos] = dd; k4[pos] = k9[c]; }
    }
    for (int p = 0; p < 4; ++p)
        w4[p] = 1.0f / (2.0f * asin(min(0.5f * distance(w, bases_row(bases, vbase + k4[p], 2)), 1.0f))
                        + FILTER_ANGLE_EPS);
}
#endif
#endif

typedef struct {
    __global const csm_type_t *types;
    __global const uint *offsets;
    __global const uint *soff;
    __global const IEND_T *summary;
    __global const pair_t *pairs;
    __global const float *bases;
    __global const int *cells;
    __global const instance_t *inst;
    __global const int *itype;
    int ninst;
    float ground_y, ground_eps;
    float bias_abs, bias_texels, bias_tan, bias_other;
} scene_t;

/* ---------------------------------------------------------------------
 * Queries are answered LANES at a time (lanes.h; the host picks LANES per
 * device): the arithmetic runs on lane vectors (one lane per query), the
 * table reads (map bases, list offsets, the counting searches, stored
 * depths) run lane by lane, each phase for all lanes before the next, with
 * the block summaries and the blocks prefetched as soon as their addresses
 * are known -- so the lanes' cache misses overlap instead of queueing
 * (memory latency is what limits these kernels on CPUs). With LANES = 1
 * each work-item answers its queries one by one (GPUs).
 * ------------------------------------------------------------------- */
#include "lanes.h"
/* CPU targets of clang (PoCL): builtins PoCL would call rather than inline
 * get inline forms below; other compilers use the standard builtins */
#ifndef CPU_CLANG                /* the host may set it (tests: 0 on PoCL too) */
#if defined(__clang__) && (defined(__x86_64__) || defined(__aarch64__))
#define CPU_CLANG 1
#else
#define CPU_CLANG 0
#endif
#endif
/* private lane arrays: aligned to a whole lane vector, moved as whole
 * vectors (the type follows the array, so one macro serves float, int and
 * uint arrays) */
#define LANE_ARRAY __attribute__((aligned(4 * LANES)))
#if CPU_CLANG
#define LANE_LOAD(a) (*(__typeof__(VLOAD(0, (a))) *)(a))
#define LANE_STORE(v, a) (*(__typeof__(VLOAD(0, (a))) *)(a) = (v))
/* a cache-line prefetch that does not hold up the lane loop (PoCL's
 * prefetch() is a no-op; clang's builtin becomes the CPU's prefetch
 * instruction; memory is flat on CPUs) */
#define PREFETCH(p) __builtin_prefetch((const void *)(ulong)(p))
#else
#define LANE_LOAD(a) VLOAD(0, (a))
#define LANE_STORE(v, a) VSTORE((v), 0, (a))
#define PREFETCH(p) prefetch((p), 1)
#endif

#if LAYOUT_ZIGZAG
/* acos to 5e-5 rad (Abramowitz & Stegun 4.4.45) */
inline fv acos_v(fv x)
{
    const fv a = fabs(x);
    const fv r = sqrt(1.0f - a) * (1.5707288f + a * (-0.2121144f + a * (0.0742610f - 0.0187293f * a)));
    return VSEL(r, PI_F - r, MASK(x < 0.0f));
}

/* atan2 in [0, 2 pi) to 1e-5 rad (A&S 4.4.49 after octant reduction) */
inline fv atan2_pos_v(fv y, fv x)
{
    const fv ax = fabs(x), ay = fabs(y);
    const fv mx = VMAX(ax, ay);
    const fv t = VMIN(ax, ay) / VSEL(mx, (fv)(1.0f), MASK(mx == 0.0f));
    const fv t2 = t * t;
    fv r = t * (0.9998660f + t2 * (-0.3302995f + t2 * (0.1801410f + t2 * (-0.0851330f + t2 * 0.0208351f))));
    r = VSEL(r, 0.5f * PI_F - r, MASK(ay > ax));
    r = VSEL(r, PI_F - r, MASK(x < 0.0f));
    return VSEL(r, 2.0f * PI_F - r, MASK(y < 0.0f));
}

/* cos and sin of a small angle d (|d| < 0.2: error below 1e-8) */
inline fv cos_small(fv d) { const fv d2 = d * d; return 1.0f - d2 * (0.5f - d2 * (1.0f / 24.0f - d2 * (1.0f / 720.0f))); }
inline fv sin_small(fv d) { const fv d2 = d * d; return d * (1.0f - d2 * (1.0f / 6.0f - d2 * (1.0f / 120.0f))); }

/* the 2 x 2 grid points around each lane's (theta, phi) -- rows r0, r0 + 1
 * (the last row repeated), columns c0, c0 + 1 -- as map indices k[4] and
 * directions (cx, cy, cz)[4], in the order of views.ViewSet.filter_window */
inline void zigzag_window_v(int T, int P, float cst, float sst, float csp, float ssp,
                            fv wx, fv wy, fv wz, iv *k, fv *cx, fv *cy, fv *cz)
{
    const fv th = acos_v(VMIN(VMAX(wy, (fv)(-1.0f)), (fv)(1.0f)));
    const fv ph = atan2_pos_v(wz, wx);
    const float dth = PI_F / (float)T, dph = 2.0f * PI_F / (float)P;
    /* th, ph >= 0: truncation is floor */
    const iv r0 = VMIN(VMAX(CONVERT(int, th * ((float)T / PI_F)), (iv)(0)), (iv)(T - 1));
    iv c0 = VMIN(VMAX(CONVERT(int, ph * ((float)P / (2.0f * PI_F))), (iv)(0)), (iv)(P));
    c0 = VSEL(c0, c0 - P, MASK(c0 >= P));
    /* the candidate grid directions by angle addition from the query's own
     * (cos, sin) of theta and phi: rotate back by the small offsets to the
     * grid lines, then forward by one grid step */
    const fv rho = sqrt(wx * wx + wz * wz);
    const iv pole = MASK(rho == 0.0f);
    const fv cph = VSEL(wx / rho, (fv)(1.0f), pole), sph = VSEL(wz / rho, (fv)(0.0f), pole);
    const fv cth = wy, sth = rho;
    const fv drow = th - CONVERT(float, r0) * dth, dcol = ph - CONVERT(float, c0) * dph;
    const fv cd = cos_small(drow), sd = sin_small(drow);
    const fv ct0 = cth * cd + sth * sd, st0 = sth * cd - cth * sd;
    const fv ce = cos_small(dcol), se = sin_small(dcol);
    const fv cp0 = cph * ce + sph * se, sp0 = sph * ce - cph * se;
    const iv last = MASK(r0 + 1 > T - 1);
    const fv ct1 = VSEL(ct0 * cst - st0 * sst, ct0, last), st1 = VSEL(st0 * cst + ct0 * sst, st0, last);
    const fv cp1 = cp0 * csp - sp0 * ssp, sp1 = sp0 * csp + cp0 * ssp;
    iv c1 = c0 + 1;
    c1 = VSEL(c1, c1 - P, MASK(c1 >= P));
    const iv r1 = VMIN(r0 + 1, (iv)(T - 1));
#define ZZ_CANDIDATE(I, R, C, CT, ST, CP, SP)                                        \
    k[I] = (R) * P + VSEL((C), (iv)(P - 1) - (C), MASK(((R) & 1) != 0));              \
    cx[I] = (ST) * (CP); cy[I] = (CT); cz[I] = (ST) * (SP);
    ZZ_CANDIDATE(0, r0, c0, ct0, st0, cp0, sp0)
    ZZ_CANDIDATE(1, r0, c1, ct0, st0, cp1, sp1)
    ZZ_CANDIDATE(2, r1, c0, ct1, st1, cp0, sp0)
    ZZ_CANDIDATE(3, r1, c1, ct1, st1, cp1, sp1)
#undef ZZ_CANDIDATE
}

/* map nearest to each lane's direction on a zigzag grid (views.py): of the
 * window's four, the largest dot product (the first of equals). theta
 * and phi need only be near: an error far below the grid step can only move
 * the 2 x 2 window when the direction is next to a grid line, and then the
 * grid point on that line -- the nearest -- stays in the window. */
inline iv nearest_zigzag_v(int T, int P, float cst, float sst, float csp, float ssp,
                            fv wx, fv wy, fv wz)
{
    iv k[4];
    fv cx[4], cy[4], cz[4];
    zigzag_window_v(T, P, cst, sst, csp, ssp, wx, wy, wz, k, cx, cy, cz);
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

#if GROUND
/* lanes (-1) whose ray crosses the ground plane y = ground_y; within
 * ground_eps of the plane counts as on it (above) */
inline iv ground_v(const scene_t *S, fv py, fv wy)
{
    const fv h = py - S->ground_y;
    return (MASK(h >= -S->ground_eps) & MASK(wy < 0.0f)) | (MASK(h < -S->ground_eps) & MASK(wy > 0.0f));
}
#endif

/* lanes (-1) whose ray p + t w, t >= 0, can come within instance j's
 * bounding sphere */
inline iv sphere_v(const scene_t *S, int j, fv px, fv py, fv pz, fv wx, fv wy, fv wz)
{
    __global const instance_t *I = S->inst + j;
    const fv ox = I->centre[0] - px, oy = I->centre[1] - py, oz = I->centre[2] - pz;
    const fv tca = ox * wx + oy * wy + oz * wz;
    const fv oc2 = ox * ox + oy * oy + oz * oz;
    const float r2 = I->radius * I->radius;
    return ~(MASK(oc2 > r2) & (MASK(tca < 0.0f) | MASK(oc2 - tca * tca > r2)));
}

/* za[l]: the stored depth of (map ka[l], texel ta[l]) of CSM type T for
 * every lane with va[l] != 0, +inf for the others. The search of csm_find()
 * (csm_common.h) for every lane: first the list's block summary, then the
 * block. */
__attribute__((always_inline))
inline void stored_v(const scene_t *S, __global const csm_type_t *T, const int *ka, const int *ta,
                     const int *va, float *za)
{
    __global const uint *off = S->offsets + T->texel_base;
    __global const uint *sof = S->soff + T->texel_base;
    LANE_ARRAY uint lo[LANES], hi[LANES], base[LANES];
    for (int l = 0; l < LANES; ++l) {
        const uint t = va[l] ? (uint)ta[l] : 0u;
        base[l] = off[t];
        lo[l] = sof[t];
        hi[l] = va[l] ? sof[t + 1] - 1u : lo[l];
        PREFETCH(S->summary + lo[l]);
#if PROFILE_SKIP_SEARCH
        hi[l] = lo[l];
#endif
    }
    /* counting scans: the number of summary entries below the map is the
     * block, the number of i_end below it in that block the segment --
     * branch-free, sequential reads, no mispredicted jumps. The lists are
     * padded to whole blocks (search_arrays(padded=True)) with copies of
     * their last pair (i_end = D - 1, never below the map), so every block is
     * SEARCH_BLOCK pairs at an aligned start. First every lane's block is
     * found and its first pair read (the lanes' cache misses are in flight
     * together), then the blocks are counted. */
    LANE_ARRAY uint b0a[LANES];
    LANE_ARRAY pair_t first[LANES];
    for (int l = 0; l < LANES; ++l) {
        const uint k = (uint)ka[l];
        uint c = 0u;
        for (uint j = lo[l]; j < hi[l]; ++j) c += ((uint)S->summary[j] < k);
        b0a[l] = base[l] + SEARCH_BLOCK * c;
        PREFETCH(S->pairs + b0a[l]);
    }
    for (int l = 0; l < LANES; ++l) {
        const uint k = (uint)ka[l], b0 = b0a[l];
        uint c2 = 0u;
        for (uint j = 0; j < SEARCH_BLOCK; ++j) c2 += ((uint)PAIR_IEND(S->pairs[b0 + j]) < k);
        first[l] = S->pairs[b0 + c2];
    }
    for (int l = 0; l < LANES; ++l)
        za[l] = va[l] ? stored_depth(PAIR_STORED(first[l])) : INFINITY;
}

/* each lane's point (qx, qy, qz) seen from its map ka[l] (bases: the CSM
 * type's first map): the map axis d, the point's depth (1 - q.d) / 2 and
 * texel coordinates (fx, fy) in [0, R)^2 on the map; lanes (-1) where the
 * point lies inside the map's square, behind the bounding sphere's front */
__attribute__((always_inline))
inline iv map_frame_v(__global const float *bases, const int *ka, int R, fv qx, fv qy, fv qz,
                      fv *dx, fv *dy, fv *dz, fv *depth, fv *fx, fv *fy)
{
    LANE_ARRAY float bu[3][LANES], bv[3][LANES], bd[3][LANES];
    for (int l = 0; l < LANES; ++l) {
        __global const float *B = bases + 9 * ka[l];
        bu[0][l] = B[0]; bu[1][l] = B[1]; bu[2][l] = B[2];
        bv[0][l] = B[3]; bv[1][l] = B[4]; bv[2][l] = B[5];
        bd[0][l] = B[6]; bd[1][l] = B[7]; bd[2][l] = B[8];
    }
    *dx = LANE_LOAD(bd[0]); *dy = LANE_LOAD(bd[1]); *dz = LANE_LOAD(bd[2]);
    *depth = (1.0f - (qx * *dx + qy * *dy + qz * *dz)) * 0.5f;
    *fx = (qx * LANE_LOAD(bu[0]) + qy * LANE_LOAD(bu[1]) + qz * LANE_LOAD(bu[2]) + 1.0f) * (0.5f * (float)R);
    *fy = (qx * LANE_LOAD(bv[0]) + qy * LANE_LOAD(bv[1]) + qz * LANE_LOAD(bv[2]) + 1.0f) * (0.5f * (float)R);
    return MASK(*depth > 0.0f) & MASK(*fx >= 0.0f) & MASK(*fx < (float)R) & MASK(*fy >= 0.0f)
           & MASK(*fy < (float)R);
}

/* depth tolerance of each lane for map axis (dx, dy, dz): against the
 * point's own surface a quantum, a share of a texel and the angle a between
 * the query direction and the map's axis; against other casters only
 * bias_other (the quantum) */
inline fv bias_v(const scene_t *S, int R, int j, iv own, fv vx, fv vy, fv vz, fv dx, fv dy, fv dz)
{
    const fv ca = VMIN(VMAX(vx * dx + vy * dy + vz * dz, (fv)(1e-3f)), (fv)(1.0f));
    const fv tan_a = sqrt(VMAX(1.0f - ca * ca, (fv)(0.0f))) / ca;
    const fv bias_self = S->bias_abs + (S->bias_texels + S->bias_tan * tan_a) / (float)R;
    return VSEL((fv)(S->bias_other), bias_self, MASK(own == -1) | MASK(own == j));
}

#if FILTERED
/* sort four (weight w[i], item x[i]) lane vectors by weight, heaviest first,
 * lane by lane (a sorting network) */
inline void sort4_heaviest_first(fv *w, iv *x)
{
    const int pairs[5][2] = {{0, 1}, {2, 3}, {0, 2}, {1, 3}, {1, 2}};
    for (int p = 0; p < 5; ++p) {
        const int a = pairs[p][0], b = pairs[p][1];
        const iv swap = MASK(w[b] > w[a]);
        const fv wa = VSEL(w[a], w[b], swap), wb = VSEL(w[b], w[a], swap);
        const iv xa = VSEL(x[a], x[b], swap), xb = VSEL(x[b], x[a], swap);
        w[a] = wa; w[b] = wb; x[a] = xa; x[b] = xb;
    }
}
#endif

/* lanes (-1) of act occluded by caster instance j (the CSM lookup) */
inline iv instance_v(const scene_t *S, int j, fv px, fv py, fv pz, fv wx, fv wy, fv wz, iv own,
                     iv act)
{
    __global const instance_t *I = S->inst + j;
    __global const csm_type_t *T = S->types + S->itype[j];
    const int R = T->resolution, layout = T->layout, vbase = T->view_base;
    __global const float *A = I->to_object, *Rw = I->rotation;
    const fv qx = A[0] * px + A[1] * py + A[2] * pz + I->offset[0];
    const fv qy = A[3] * px + A[4] * py + A[5] * pz + I->offset[1];
    const fv qz = A[6] * px + A[7] * py + A[8] * pz + I->offset[2];
    fv vx = Rw[0] * wx + Rw[1] * wy + Rw[2] * wz;
    fv vy = Rw[3] * wx + Rw[4] * wy + Rw[5] * wz;
    fv vz = Rw[6] * wx + Rw[7] * wy + Rw[8] * wz;
    const fv inv = 1.0f / sqrt(vx * vx + vy * vy + vz * vz);
    vx *= inv; vy *= inv; vz *= inv;
    LANE_ARRAY int am[LANES];
    LANE_STORE(act, am);

#if FILTERED
    /* the four maps of ViewSet.filter_window, each asked by a bilinear vote
     * of the four texels around the point (texel centres; border texels
     * repeated); the instance shadows a lane when the weighted votes exceed
     * one half (scene.visible_reference(filtered=True)) */
    LANE_ARRAY int kw[4][LANES];
    LANE_ARRAY float mw[4][LANES];
#if LAYOUT_ZIGZAG
    if (layout == 0) {
        iv k[4];
        fv cx[4], cy[4], cz[4];
        zigzag_window_v(T->p1, T->p2, T->zigzag_steps[0], T->zigzag_steps[1], T->zigzag_steps[2],
                        T->zigzag_steps[3], vx, vy, vz, k, cx, cy, cz);
        fv wsum = (fv)(0.0f), wt[4];
        for (int m = 0; m < 4; ++m) {
            const fv ex = vx - cx[m], ey = vy - cy[m], ez = vz - cz[m];
            const fv chord = sqrt(ex * ex + ey * ey + ez * ez);
            wt[m] = 1.0f / (2.0f * asin(VMIN(0.5f * chord, (fv)(1.0f))) + FILTER_ANGLE_EPS);
            wsum += wt[m];
        }
        /* heaviest map first (a sorting network of the four), so that the
         * vote below is decided early */
        sort4_heaviest_first(wt, k);
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
    /* maps heaviest first (hilbert windows are nearest first); a lane is
     * decided, and asks no more, once its shadowing votes exceed one half
     * or the weight still to come cannot take them there (a margin of 1e-5
     * for the rounding of the running sums: nearer ties go to the end) */
    fv vote = (fv)(0.0f), rest = (fv)(1.0f);
    iv open = act;
    for (int m = 0; m < 4 && VANY(open); ++m) {
        fv dx, dy, dz, depth, fx, fy;
        const iv inside = open & map_frame_v(S->bases + 9 * vbase, kw[m], R, qx, qy, qz,
                                             &dx, &dy, &dz, &depth, &fx, &fy);
        const fv wm = LANE_LOAD(mw[m]);
        if (!VANY(inside)) {
            rest -= wm;
            open &= MASK(vote + rest > 0.5f - 1e-5f);
            continue;
        }
        const fv bias = bias_v(S, R, j, own, vx, vy, vz, dx, dy, dz);
        const fv gx = VSEL((fv)(0.0f), fx - 0.5f, inside), gy = VSEL((fv)(0.0f), fy - 0.5f, inside);
        const fv x0f = floor(gx), y0f = floor(gy);
        const fv tx = gx - x0f, ty = gy - y0f;
        const iv x0 = CONVERT(int, x0f), y0 = CONVERT(int, y0f);
        LANE_ARRAY int ta[LANES], va[LANES];
        LANE_ARRAY float za[LANES];
        iv tt[4];
        fv tw[4];
        for (int c = 0; c < 4; ++c) {
            const int ddy = c >> 1, ddx = c & 1;
            tt[c] = VMIN(VMAX(y0 + ddy, (iv)(0)), (iv)(R - 1)) * R + VMIN(VMAX(x0 + ddx, (iv)(0)), (iv)(R - 1));
            tw[c] = wm * (ddy ? ty : 1.0f - ty) * (ddx ? tx : 1.0f - tx);
        }
        sort4_heaviest_first(tw, tt);       /* texels heaviest first, too */
        for (int c = 0; c < 4; ++c) {
            const iv tex = tt[c];
            const fv w = tw[c];
            const iv ask = open & inside;
            LANE_STORE(tex, ta);
            LANE_STORE(ask, va);
            stored_v(S, T, kw[m], ta, va, za);
            vote += VSEL((fv)(0.0f), w, ask & MASK(depth > LANE_LOAD(za) + bias));
            rest -= w;
            open &= MASK(vote <= 0.5f) & MASK(vote + rest > 0.5f - 1e-5f);
            if (!VANY(open)) break;
        }
    }
    return act & MASK(vote > 0.5f);
#else
    iv k = (iv)(0);
#if LAYOUT_ZIGZAG
#if PROFILE_SKIP_NEAREST
    if (layout == 0) k = clamp(CONVERT(int, fabs(vx) * (float)(T->maps - 1)), 0, T->maps - 1);
#else
    if (layout == 0) k = nearest_zigzag_v(T->p1, T->p2, T->zigzag_steps[0], T->zigzag_steps[1],
                                          T->zigzag_steps[2], T->zigzag_steps[3], vx, vy, vz);
#endif
#endif
    LANE_ARRAY int ka[LANES];
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
    const iv valid = act & map_frame_v(S->bases + 9 * vbase, ka, R, qx, qy, qz,
                                       &dx, &dy, &dz, &depth, &fx, &fy);
    if (!VANY(valid)) return (iv)(0);
    const iv tex = VMIN(CONVERT(int, fy), (iv)(R - 1)) * R + VMIN(CONVERT(int, fx), (iv)(R - 1));
    LANE_ARRAY int ta[LANES], va[LANES];
    LANE_ARRAY float za[LANES];
    LANE_STORE(tex, ta);
    LANE_STORE(valid, va);
    stored_v(S, T, ka, ta, va, za);
    const fv bias = bias_v(S, R, j, own, vx, vy, vz, dx, dy, dz);
    return valid & MASK(depth > LANE_LOAD(za) + bias);
#endif
}

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
                           int *occ, const int nb)
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
            LANE_ARRAY float a[6][LANES];
            LANE_ARRAY int ow[LANES], gi[LANES];
            for (int l = 0; l < LANES; ++l) {
                const int i = idx[min(g + l, cnt - 1)];
                gi[l] = i;
                a[0][l] = px[i]; a[1][l] = py[i]; a[2][l] = pz[i];
                a[3][l] = wx[i]; a[4][l] = wy[i]; a[5][l] = wz[i];
                ow[l] = own[i];
            }
            const iv act = MASK((iv)(g) + LANE_IDS < cnt);
            const iv r = instance_v(S, j, LANE_LOAD(a[0]), LANE_LOAD(a[1]), LANE_LOAD(a[2]),
                                    LANE_LOAD(a[3]), LANE_LOAD(a[4]), LANE_LOAD(a[5]),
                                    LANE_LOAD(ow), act);
            LANE_ARRAY int ra[LANES];
            LANE_STORE(r, ra);
            for (int l = 0; l < min(LANES, cnt - g); ++l)
                occ[gi[l]] |= ra[l];
        }
    }
}

#define SCENE_ARGS __global const csm_type_t *types, __global const uint *offsets,    \
                   __global const uint *soff, __global const IEND_T *summary,            \
                   __global const pair_t *pairs,                                         \
                   __global const float *bases, __global const int *cells,              \
                   __global const instance_t *inst, __global const int *itype,          \
                   const int ninst, const float ground_y, const float ground_eps,        \
                   const float bias_abs,                                                 \
                   const float bias_texels, const float bias_tan, const float bias_other

#define SCENE_INIT scene_t S = {types, offsets, soff, summary, pairs, bases, cells,     \
                                inst, itype,                                            \
                                ninst, ground_y, ground_eps, bias_abs, bias_texels, bias_tan,   \
                                bias_other}

/* Inputs of scene_visible: (N, 3) rows of POINT_T and DIR_T (float or, with
 * HAVE_FP64, double), read in place from the caller's arrays. Points are made
 * relative to the anchor (in double where the device has it) and rounded to
 * float; directions are rescaled by a power of two where squaring them in
 * float would underflow or overflow, then normalised. */
#if HAVE_FP64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double anchor_t;
typedef double wide_t;
#else
typedef float anchor_t;
typedef float wide_t;
#endif
#if POINTS_F64
#define POINT_SCALAR double
#else
#define POINT_SCALAR float
#endif
#if DIRS_F64
#define DIR_SCALAR double
#else
#define DIR_SCALAR float
#endif
typedef POINT_SCALAR point_t;
typedef DIR_SCALAR dir_t;
typedef VTYPE(POINT_SCALAR) pointv_t;
typedef VTYPE(DIR_SCALAR) dirv_t;
/* whole-vector loads and stores of rows that are only element-aligned:
 * vloadN / vstoreN, or on clang CPU targets vector types of reduced
 * alignment (measured 5 % of the kernel) */
#if CPU_CLANG
typedef pointv_t pointvu_t __attribute__((aligned(sizeof(point_t))));
typedef dirv_t dirvu_t __attribute__((aligned(sizeof(dir_t))));
typedef iv ivu_t __attribute__((aligned(4)));
typedef VTYPE(uchar) ucharvu_t __attribute__((aligned(1)));
typedef fv fvu_t __attribute__((aligned(4)));
#define LOADU(T, p, i) (((__global const T *)(p))[i])
#define STOREU(T, p, v) (*(__global T *)(p) = (v))
#else
#define LOADU(T, p, i) VLOAD((i), (p))
#define STOREU(T, p, v) VSTORE((v), 0, (p))
#endif
#if HAVE_FP64
#define TO_WIDE(x) CONVERT(double, x)
#else
#define TO_WIDE(x) (x)
#endif
/* rows 0..LANES-1 of an (N, 3) array from its 3 LANES values in a0, a1, a2 */
#if LANES == 16
#define DEINTERLEAVE3(T, a0, a1, a2, X, Y, Z)                                               \
    X = (T)(a0.s0, a0.s3, a0.s6, a0.s9, a0.sc, a0.sf, a1.s2, a1.s5, a1.s8, a1.sb, a1.se,  \
            a2.s1, a2.s4, a2.s7, a2.sa, a2.sd);                                            \
    Y = (T)(a0.s1, a0.s4, a0.s7, a0.sa, a0.sd, a1.s0, a1.s3, a1.s6, a1.s9, a1.sc, a1.sf,  \
            a2.s2, a2.s5, a2.s8, a2.sb, a2.se);                                            \
    Z = (T)(a0.s2, a0.s5, a0.s8, a0.sb, a0.se, a1.s1, a1.s4, a1.s7, a1.sa, a1.sd, a2.s0,  \
            a2.s3, a2.s6, a2.s9, a2.sc, a2.sf)
#elif LANES == 8
#define DEINTERLEAVE3(T, a0, a1, a2, X, Y, Z)                                               \
    X = (T)(a0.s0, a0.s3, a0.s6, a1.s1, a1.s4, a1.s7, a2.s2, a2.s5);                       \
    Y = (T)(a0.s1, a0.s4, a0.s7, a1.s2, a1.s5, a2.s0, a2.s3, a2.s6);                       \
    Z = (T)(a0.s2, a0.s5, a1.s0, a1.s3, a1.s6, a2.s1, a2.s4, a2.s7)
#elif LANES == 4
#define DEINTERLEAVE3(T, a0, a1, a2, X, Y, Z)                                               \
    X = (T)(a0.s0, a0.s3, a1.s2, a2.s1);                                                   \
    Y = (T)(a0.s1, a1.s0, a1.s3, a2.s2);                                                   \
    Z = (T)(a0.s2, a1.s1, a2.s0, a2.s3)
#else
#define DEINTERLEAVE3(T, a0, a1, a2, X, Y, Z) X = (a0); Y = (a1); Z = (a2)
#endif

/* BATCH queries per work-item; lanes past n are answered as "visible" and
 * not written. */
__kernel void scene_visible(SCENE_ARGS, const int n, __global const point_t *points,
                            __global const dir_t *dirs, const anchor_t ax, const anchor_t ay,
                            const anchor_t az, __global const int *owner, __global uchar *out)
{
    const int base = get_global_id(0) * BATCH;
    if (base >= n) return;
    SCENE_INIT;
    LANE_ARRAY float px[BATCH], py[BATCH], pz[BATCH], wx[BATCH], wy[BATCH], wz[BATCH];
    LANE_ARRAY int ow[BATCH], occ[BATCH];
    const int m = min(BATCH, n - base);
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
            const int i = base + min(l, m - 1);
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
        const fv inv = 1.0f / sqrt(x * x + y * y + z * z);
        LANE_STORE(x * inv, wx + c); LANE_STORE(y * inv, wy + c); LANE_STORE(z * inv, wz + c);
    }
    batch_occluded(&S, px, py, pz, wx, wy, wz, ow, occ, BATCH);
    for (int c = 0; c < m; c += LANES) {
        if (c + LANES <= m) {                     /* -1 (occluded) -> 0, 0 -> 1 */
            STOREU(ucharvu_t, out + base + c, CONVERT(uchar, LANE_LOAD(occ + c) + 1));
        } else {
            for (int l = c; l < m; ++l) out[base + l] = occ[l] ? 0 : 1;
        }
    }
}

#ifdef SAMPLES
/* one work-item per point; its SAMPLES directions LANES at a time. table:
 * local directions per pattern as (M, 3, SPAD) structure of arrays, SPAD =
 * SAMPLES rounded up to LANES (padding lanes are masked out). */
#define SPAD (((SAMPLES + LANES - 1) / LANES) * LANES)
#define AO_BATCH (SPAD < BATCH ? SPAD : BATCH)     /* samples per batch_occluded() */
__kernel void scene_ao(SCENE_ARGS, const int n, __global const float *points,
                       __global const float *normals, __global const int *pidx,
                       __global const int *owner,
                       __global const float *table, __global float *ao,
                       __global float *bent)
{
    const int i = get_global_id(0);
    if (i >= n) return;
    SCENE_INIT;
    const float3 p = vload3(i, points);
    const float3 nrm = vload3(i, normals);
    const iv own = (iv)(owner[i]);
    float3 t, b;
    hemisphere_frame(nrm, &t, &b);
    __global const float *pat = table + (size_t)pidx[i] * 3 * SPAD;
    int open = 0;
    float3 sum = (float3)(0.0f);
    for (int s0 = 0; s0 < SPAD; s0 += AO_BATCH) {
        LANE_ARRAY float px[AO_BATCH], py[AO_BATCH], pz[AO_BATCH], wx[AO_BATCH], wy[AO_BATCH],
                         wz[AO_BATCH];
        LANE_ARRAY int ow[AO_BATCH], occ[AO_BATCH];
        for (int c = 0; c < AO_BATCH; c += LANES) {
            const int s = min(s0 + c, SPAD - LANES);
            const fv lx = LOADU(fvu_t, pat + s, 0), ly = LOADU(fvu_t, pat + SPAD + s, 0),
                     lz = LOADU(fvu_t, pat + 2 * SPAD + s, 0);
            /* cosine_direction() of sampling.h, per lane, same operations */
            LANE_STORE((lx * t.x + ly * nrm.x) + lz * b.x, wx + c);
            LANE_STORE((lx * t.y + ly * nrm.y) + lz * b.y, wy + c);
            LANE_STORE((lx * t.z + ly * nrm.z) + lz * b.z, wz + c);
            LANE_STORE((fv)(p.x), px + c); LANE_STORE((fv)(p.y), py + c); LANE_STORE((fv)(p.z), pz + c);
            LANE_STORE(own, ow + c);
            LANE_STORE(MASK((iv)(s0 + c) + LANE_IDS >= SAMPLES), occ + c);   /* padding: decided */
        }
        batch_occluded(&S, px, py, pz, wx, wy, wz, ow, occ, AO_BATCH);
        for (int l = 0; l < min(AO_BATCH, SAMPLES - s0); ++l) {
            if (occ[l]) continue;
            ++open;
#if BENT_NORMALS
            sum += (float3)(wx[l], wy[l], wz[l]);
#endif
        }
    }
    ao[i] = (float)open / (float)SAMPLES;
#if BENT_NORMALS
    const float len = length(sum);
    vstore3(len > 0.0f ? sum / len : nrm, i, bent);
#endif
}
#endif

/* visibility.cl -- shadow queries against the CSMs of a scene (thesis 000,
 * sections 5.3, 5.3.2, 5.3.3) and ambient occlusion from them.
 *
 * Kernels
 *   scene_visible   one work-item per (point, direction) query: 1 if the ray
 *                   from the point along the direction is unoccluded.
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
 *     map k (binary search of its segment list) plus the bias
 *         bias_abs + (bias_texels + bias_tan * tan(angle(w', d_k))) / R
 *     when p may lie on instance j itself (owner[i] == j, or -1: unknown),
 *     else only
 *     bias_other (the depth quantum): a point on another body or the
 *     ground needs no protection from acne, and contact shadows stay sharp.
 *   Points outside map k's square or in front of the bounding sphere
 *   (depth <= 0) cannot be shadowed by that instance.
 *
 * Scene data ("atlas": every CSM type of the scene concatenated)
 *   types    int   (NTYPES, 8): R, D, layout (0 zigzag, 1 hilbert, 2 hilbert
 *                  over two hemispheres), p1 (theta or level), p2 (phi),
 *                  offsets base, view base, cell-table base
 *   offsets, soff  uint (sum R^2, + 1); summary IEND_T; pairs pair_t: the
 *            search layout of csm_common.h, every type's entries shifted so
 *            they index the concatenated arrays directly
 *   bases    float (sum D, 9)      rows u, v, d of every map
 *   cells    int   (sum cells)     hilbert cell -> map index
 *   inst     float (NINST, 32): A (3x3, rows) 0..8, c 9..11, Rw (3x3) 12..20,
 *                  world bounding sphere centre 21..23, radius 24
 *   itype    int   (NINST)         CSM type of each instance
 * All of it is validated on the host (CSM files on load), so the search and
 * the map/texel indices stay inside their arrays whatever the query.
 * Query data: owner int (N): caster slot of the surface each point lies on,
 * -1 unknown, -2 none (validated: -2 <= owner < NINST);
 * points, normals, dirs float (N, 3) (dirs need not be unit:
 * normalised here; normals are unit); pidx int (N); table float
 * (M, SAMPLES, 3) local directions; outputs uchar / float (N), float (N, 3).
 * Points are relative to the scene anchor chosen by the host (float32 keeps
 * its precision for scenes far from the world origin).
 *
 * Macros
 *   DEPTH_BITS, IEND_T, PAIR_WIDE   storage of the atlas (csm_common.h)
 *   NTYPES               number of CSM types (>= 0)
 *   GROUND               1: infinite ground plane y = ground_y
 *   LAYOUT_ZIGZAG, LAYOUT_HILBERT  which nearest-map codes to compile (0/1)
 *   SAMPLES, BENT_NORMALS  (scene_ao only)
 *   INPUT_F64            scene_visible reads float64 (N, 3) points and dirs
 *                        (needs cl_khr_fp64; else float32 SoA from the host)
 *   PROFILE_SKIP_NEAREST, PROFILE_SKIP_SEARCH  (benchmarks/visibility.py
 *       --profile only: replace the nearest-map choice or the segment search
 *       by a trivial stand-in to measure their share; results are wrong)
 */
#include "csm_search.h"
#include "sampling.h"

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

inline int nearest_hilbert(__global const float *bases, int vbase, __global const int *cells,
                           int cbase, int level, int split, float3 w)
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
    int best = 0;
    float bd = -2.0f;
    for (int di = -1; di <= 1; ++di) {
        for (int dj = -1; dj <= 1; ++dj) {
            const int k = cells[cbase + hilbert_cell(split, n, ci + di, cj + dj, h)];
            const float dd = dot(bases_row(bases, vbase + k, 2), w);
            if (dd > bd) { bd = dd; best = k; }
        }
    }
    return best;
}
#endif

typedef struct {
    __global const int *types;
    __global const uint *offsets;
    __global const uint *soff;
    __global const IEND_T *summary;
    __global const pair_t *pairs;
    __global const float *bases;
    __global const int *cells;
    __global const float *inst;
    __global const int *itype;
    int ninst;
    float ground_y, ground_eps;
    float bias_abs, bias_texels, bias_tan, bias_other;
} scene_t;

/* ---------------------------------------------------------------------
 * Queries are answered LANES (16) at a time: the arithmetic runs on float16
 * vectors (one lane per query), the table reads (map bases, list offsets,
 * the binary searches, stored depths) run lane by lane -- the searches in
 * lockstep, so the lanes' cache misses overlap instead of queueing.
 * ------------------------------------------------------------------- */
#define LANES 16
typedef float16 fv;
typedef int16 iv;

#if LAYOUT_ZIGZAG
/* acos to 5e-5 rad (Abramowitz & Stegun 4.4.45) */
inline fv acos16(fv x)
{
    const fv a = fabs(x);
    const fv r = sqrt(1.0f - a) * (1.5707288f + a * (-0.2121144f + a * (0.0742610f - 0.0187293f * a)));
    return select(r, PI_F - r, x < 0.0f);
}

/* atan2 in [0, 2 pi) to 1e-5 rad (A&S 4.4.49 after octant reduction) */
inline fv atan2_pos16(fv y, fv x)
{
    const fv ax = fabs(x), ay = fabs(y);
    const fv mx = fmax(ax, ay);
    const fv t = fmin(ax, ay) / select(mx, (fv)(1.0f), mx == 0.0f);
    const fv t2 = t * t;
    fv r = t * (0.9998660f + t2 * (-0.3302995f + t2 * (0.1801410f + t2 * (-0.0851330f + t2 * 0.0208351f))));
    r = select(r, 0.5f * PI_F - r, ay > ax);
    r = select(r, PI_F - r, x < 0.0f);
    return select(r, 2.0f * PI_F - r, y < 0.0f);
}

/* map nearest to each lane's direction on a zigzag grid (views.py): the
 * 2 x 2 grid points around (theta, phi), compared by dot product. theta
 * and phi need only be near: an error far below the grid step can only move
 * the 2 x 2 window when the direction is next to a grid line, and then the
 * grid point on that line -- the nearest -- stays in the window. */
/* cos and sin of a small angle d (|d| < 0.2: error below 1e-8) */
inline fv cos_small(fv d) { const fv d2 = d * d; return 1.0f - d2 * (0.5f - d2 * (1.0f / 24.0f - d2 * (1.0f / 720.0f))); }
inline fv sin_small(fv d) { const fv d2 = d * d; return d * (1.0f - d2 * (1.0f / 6.0f - d2 * (1.0f / 120.0f))); }

inline iv nearest_zigzag16(int T, int P, fv wx, fv wy, fv wz)
{
    const fv th = acos16(clamp(wy, -1.0f, 1.0f));
    const fv ph = atan2_pos16(wz, wx);
    const float dth = PI_F / (float)T, dph = 2.0f * PI_F / (float)P;
    const iv r0 = clamp(convert_int16(floor(th * ((float)T / PI_F))), 0, T - 1);
    iv c0 = clamp(convert_int16(floor(ph * ((float)P / (2.0f * PI_F)))), 0, P);
    c0 = select(c0, c0 - P, c0 >= P);
    /* the candidate grid directions by angle addition from the query's own
     * (cos, sin) of theta and phi: rotate back by the small offsets to the
     * grid lines, then forward by one grid step */
    const fv rho = sqrt(wx * wx + wz * wz);
    const iv pole = rho == 0.0f;
    const fv cph = select(wx / rho, (fv)(1.0f), pole), sph = select(wz / rho, (fv)(0.0f), pole);
    const fv cth = wy, sth = rho;
    const fv drow = th - convert_float16(r0) * dth, dcol = ph - convert_float16(c0) * dph;
    const fv cd = cos_small(drow), sd = sin_small(drow);
    const fv ct0 = cth * cd + sth * sd, st0 = sth * cd - cth * sd;
    const fv ce = cos_small(dcol), se = sin_small(dcol);
    const fv cp0 = cph * ce + sph * se, sp0 = sph * ce - cph * se;
    const float cst = cos(dth), sst = sin(dth), csp = cos(dph), ssp = sin(dph);
    const iv last = r0 + 1 > T - 1;
    const fv ct1 = select(ct0 * cst - st0 * sst, ct0, last), st1 = select(st0 * cst + ct0 * sst, st0, last);
    const fv cp1 = cp0 * csp - sp0 * ssp, sp1 = sp0 * csp + cp0 * ssp;
    iv c1 = c0 + 1;
    c1 = select(c1, c1 - P, c1 >= P);
    const iv r1 = min(r0 + 1, T - 1);
    fv best_d = (fv)(-2.0f);
    iv best = (iv)(0);
#define ZZ_CANDIDATE(R, C, CT, ST, CP, SP)                                           \
    {                                                                                 \
        const fv dd = wx * ((ST) * (CP)) + wy * (CT) + wz * ((ST) * (SP));            \
        const iv k = (R) * P + select((C), (iv)(P - 1) - (C), ((R) & 1) != 0);        \
        const iv take = dd > best_d;                                                   \
        best_d = select(best_d, dd, take);                                             \
        best = select(best, k, take);                                                  \
    }
    ZZ_CANDIDATE(r0, c0, ct0, st0, cp0, sp0)
    ZZ_CANDIDATE(r0, c1, ct0, st0, cp1, sp1)
    ZZ_CANDIDATE(r1, c0, ct1, st1, cp0, sp0)
    ZZ_CANDIDATE(r1, c1, ct1, st1, cp1, sp1)
#undef ZZ_CANDIDATE
    return best;
}
#endif

/* lanes (-1 = true) occluded by the scene; occ: lanes already decided */
inline iv occluded16(const scene_t *S, fv px, fv py, fv pz, fv wx, fv wy, fv wz, iv own, iv occ)
{
#if GROUND
    /* within ground_eps of the plane counts as on it (above) */
    const fv h = py - S->ground_y;
    occ |= ((h >= -S->ground_eps) & (wy < 0.0f)) | ((h < -S->ground_eps) & (wy > 0.0f));
#endif
    for (int j = 0; j < S->ninst; ++j) {
        if (all(occ)) break;
        __global const float *I = S->inst + 32 * j;
        /* bounding-sphere cull: the ray p + t w, t >= 0, must come within radius */
        const fv ox = I[21] - px, oy = I[22] - py, oz = I[23] - pz;
        const fv tca = ox * wx + oy * wy + oz * wz;
        const fv oc2 = ox * ox + oy * oy + oz * oz;
        const float r2 = I[24] * I[24];
        const iv act = ~occ & ~((oc2 > r2) & ((tca < 0.0f) | (oc2 - tca * tca > r2)));
        if (!any(act)) continue;

        __global const int *T = S->types + 8 * S->itype[j];
        const int R = T[0], layout = T[2], vbase = T[6];
        const fv qx = I[0] * px + I[1] * py + I[2] * pz + I[9];
        const fv qy = I[3] * px + I[4] * py + I[5] * pz + I[10];
        const fv qz = I[6] * px + I[7] * py + I[8] * pz + I[11];
        fv vx = I[12] * wx + I[13] * wy + I[14] * wz;
        fv vy = I[15] * wx + I[16] * wy + I[17] * wz;
        fv vz = I[18] * wx + I[19] * wy + I[20] * wz;
        const fv inv = 1.0f / sqrt(vx * vx + vy * vy + vz * vz);
        vx *= inv; vy *= inv; vz *= inv;

        iv k = (iv)(0);
#if LAYOUT_ZIGZAG
#if PROFILE_SKIP_NEAREST
        if (layout == 0) k = clamp(convert_int16(fabs(vx) * (float)(T[1] - 1)), 0, T[1] - 1);
#else
        if (layout == 0) k = nearest_zigzag16(T[3], T[4], vx, vy, vz);
#endif
#endif
        int ka[LANES], am[LANES];
        vstore16(act, 0, am);
#if LAYOUT_HILBERT
        if (layout != 0) {
            float ax[LANES], ay[LANES], az[LANES];
            vstore16(vx, 0, ax); vstore16(vy, 0, ay); vstore16(vz, 0, az);
            for (int l = 0; l < LANES; ++l)
                ka[l] = am[l] ? nearest_hilbert(S->bases, vbase, S->cells, T[7], T[3], layout == 2,
                                                (float3)(ax[l], ay[l], az[l])) : 0;
        } else
#endif
        {
            vstore16(k, 0, ka);
        }
        /* the bases of each lane's map */
        float bu[3][LANES], bv[3][LANES], bd[3][LANES];
        for (int l = 0; l < LANES; ++l) {
            __global const float *B = S->bases + 9 * (vbase + ka[l]);
            bu[0][l] = B[0]; bu[1][l] = B[1]; bu[2][l] = B[2];
            bv[0][l] = B[3]; bv[1][l] = B[4]; bv[2][l] = B[5];
            bd[0][l] = B[6]; bd[1][l] = B[7]; bd[2][l] = B[8];
        }
        const fv dx = vload16(0, bd[0]), dy = vload16(0, bd[1]), dz = vload16(0, bd[2]);
        const fv depth = (1.0f - (qx * dx + qy * dy + qz * dz)) * 0.5f;
        const fv fx = (qx * vload16(0, bu[0]) + qy * vload16(0, bu[1]) + qz * vload16(0, bu[2]) + 1.0f)
                      * (0.5f * (float)R);
        const fv fy = (qx * vload16(0, bv[0]) + qy * vload16(0, bv[1]) + qz * vload16(0, bv[2]) + 1.0f)
                      * (0.5f * (float)R);
        const iv valid = act & (depth > 0.0f) & (fx >= 0.0f) & (fx < (float)R)
                         & (fy >= 0.0f) & (fy < (float)R);
        if (!any(valid)) continue;
        const iv tex = min(convert_int16(fy), R - 1) * R + min(convert_int16(fx), R - 1);
        int ta[LANES], va[LANES];
        vstore16(tex, 0, ta);
        vstore16(valid, 0, va);
        /* the search of csm_find() (csm_common.h) for every lane: first the
         * list's block summary, then the block */
        __global const uint *off = S->offsets + T[5];
        __global const uint *sof = S->soff + T[5];
        uint lo[LANES], hi[LANES], base[LANES], ba[LANES], end[LANES];
        for (int l = 0; l < LANES; ++l) {
            const uint t = va[l] ? (uint)ta[l] : 0u;
            base[l] = off[t];
            end[l] = off[t + 1];
            ba[l] = sof[t];
            lo[l] = ba[l];
            hi[l] = va[l] ? sof[t + 1] - 1u : ba[l];
#if PROFILE_SKIP_SEARCH
            hi[l] = lo[l];
#endif
        }
        /* counting scans: the number of summary entries below the map is the
         * block, the number of i_end below it in that block the segment --
         * branch-free, sequential reads, no mispredicted jumps */
        for (int l = 0; l < LANES; ++l) {
            const uint k = (uint)ka[l];
            uint c = 0u;
            for (uint j = lo[l]; j < hi[l]; ++j) c += ((uint)S->summary[j] < k);
            const uint b0 = base[l] + SEARCH_BLOCK * c;
            const uint e0 = va[l] ? min(b0 + SEARCH_BLOCK, end[l]) - 1u : b0;
            uint c2 = 0u;
            for (uint j = b0; j < e0; ++j) c2 += ((uint)PAIR_IEND(S->pairs[j]) < k);
            lo[l] = b0 + c2;
        }
        float za[LANES];
        for (int l = 0; l < LANES; ++l)
            za[l] = va[l] ? stored_depth(PAIR_STORED(S->pairs[lo[l]])) : INFINITY;
        /* depth tolerance against the point's own surface: a quantum, a share
         * of a texel and the angle a between the query direction and the
         * map's axis; against other casters only bias_other (the quantum) */
        const fv ca = clamp(vx * dx + vy * dy + vz * dz, 1e-3f, 1.0f);
        const fv tan_a = sqrt(fmax(1.0f - ca * ca, 0.0f)) / ca;
        const fv bias_self = S->bias_abs + (S->bias_texels + S->bias_tan * tan_a) / (float)R;
        const fv bias = select((fv)(S->bias_other), bias_self, (own == -1) | (own == j));
        occ |= valid & (depth > vload16(0, za) + bias);
    }
    return occ;
}

#define SCENE_ARGS __global const int *types, __global const uint *offsets,           \
                   __global const uint *soff, __global const IEND_T *summary,            \
                   __global const pair_t *pairs,                                         \
                   __global const float *bases, __global const int *cells,              \
                   __global const float *inst, __global const int *itype,               \
                   const int ninst, const float ground_y, const float ground_eps,        \
                   const float bias_abs,                                                 \
                   const float bias_texels, const float bias_tan, const float bias_other

#define SCENE_INIT scene_t S = {types, offsets, soff, summary, pairs, bases, cells,     \
                                inst, itype,                                            \
                                ninst, ground_y, ground_eps, bias_abs, bias_texels, bias_tan,   \
                                bias_other}

#if INPUT_F64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
/* queries LANES at a time, straight from the caller's float64 (N, 3) arrays
 * (no host-side conversion): points are made anchor-relative in double, then
 * rounded to float. Lanes past n are answered as "visible" and not written. */
__kernel void scene_visible(SCENE_ARGS, const int n, __global const double *points,
                            __global const double *dirs, const double ax, const double ay,
                            const double az, __global const int *owner, __global uchar *out)
{
    const int base = get_global_id(0) * LANES;
    if (base >= n) return;
    SCENE_INIT;
    float a[6][LANES];
    int ow[LANES];
    for (int l = 0; l < LANES; ++l) {
        const int i = min(base + l, n - 1);
        a[0][l] = (float)(points[3 * i] - ax);
        a[1][l] = (float)(points[3 * i + 1] - ay);
        a[2][l] = (float)(points[3 * i + 2] - az);
        a[3][l] = (float)dirs[3 * i];
        a[4][l] = (float)dirs[3 * i + 1];
        a[5][l] = (float)dirs[3 * i + 2];
        ow[l] = owner[i];
    }
    fv wx = vload16(0, a[3]), wy = vload16(0, a[4]), wz = vload16(0, a[5]);
    const fv inv = 1.0f / sqrt(wx * wx + wy * wy + wz * wz);
    wx *= inv; wy *= inv; wz *= inv;
    const iv pad = (iv)(base) + (iv)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15) >= n;
    const iv occ = occluded16(&S, vload16(0, a[0]), vload16(0, a[1]), vload16(0, a[2]),
                              wx, wy, wz, vload16(0, ow), pad);
    uchar res[LANES];
    vstore16(convert_uchar16(occ + 1), 0, res);            /* -1 -> 0, 0 -> 1 */
    for (int l = 0; l < min(LANES, n - base); ++l) out[base + l] = res[l];
}
#else
/* queries LANES at a time; inputs are float structure-of-arrays, anchor-
 * relative, padded to a multiple of LANES (padding lanes are answered and
 * ignored by the host). Used where the device has no double precision. */
__kernel void scene_visible(SCENE_ARGS, const int n, __global const float *points,
                            __global const float *dirs, __global const int *owner,
                            __global uchar *out)
{
    const int base = get_global_id(0) * LANES;
    if (base >= n) return;
    SCENE_INIT;
    const int stride = get_global_size(0) * LANES;     /* = padded N */
    const fv px = vload16(0, points + base), py = vload16(0, points + stride + base),
             pz = vload16(0, points + 2 * stride + base);
    fv wx = vload16(0, dirs + base), wy = vload16(0, dirs + stride + base),
       wz = vload16(0, dirs + 2 * stride + base);
    const fv inv = 1.0f / sqrt(wx * wx + wy * wy + wz * wz);
    wx *= inv; wy *= inv; wz *= inv;
    const iv occ = occluded16(&S, px, py, pz, wx, wy, wz, vload16(0, owner + base), (iv)(0));
    vstore16(convert_uchar16(occ + 1), 0, out + base);     /* -1 -> 0, 0 -> 1 */
}
#endif

#ifdef SAMPLES
/* one work-item per point; its SAMPLES directions LANES at a time. table:
 * local directions per pattern as (M, 3, SPAD) structure of arrays, SPAD =
 * SAMPLES rounded up to LANES (padding lanes are masked out). */
#define SPAD (((SAMPLES + LANES - 1) / LANES) * LANES)
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
    for (int s0 = 0; s0 < SPAD; s0 += LANES) {
        const fv lx = vload16(0, pat + s0), ly = vload16(0, pat + SPAD + s0),
                 lz = vload16(0, pat + 2 * SPAD + s0);
        /* cosine_direction() of sampling.h, per lane, same operations */
        const fv wx = (lx * t.x + ly * nrm.x) + lz * b.x;
        const fv wy = (lx * t.y + ly * nrm.y) + lz * b.y;
        const fv wz = (lx * t.z + ly * nrm.z) + lz * b.z;
        const iv pad = (iv)(s0) + (iv)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15) >= SAMPLES;
        const iv occ = occluded16(&S, (fv)(p.x), (fv)(p.y), (fv)(p.z), wx, wy, wz, own, pad);
        const iv lit = ~occ & ~pad;
        open -= (lit.s0 + lit.s1 + lit.s2 + lit.s3 + lit.s4 + lit.s5 + lit.s6 + lit.s7
                 + lit.s8 + lit.s9 + lit.sa + lit.sb + lit.sc + lit.sd + lit.se + lit.sf);
#if BENT_NORMALS
        const fv m = convert_float16(-lit);
        const fv sx = wx * m, sy = wy * m, sz = wz * m;
        sum += (float3)(sx.s0 + sx.s1 + sx.s2 + sx.s3 + sx.s4 + sx.s5 + sx.s6 + sx.s7
                        + sx.s8 + sx.s9 + sx.sa + sx.sb + sx.sc + sx.sd + sx.se + sx.sf,
                        sy.s0 + sy.s1 + sy.s2 + sy.s3 + sy.s4 + sy.s5 + sy.s6 + sy.s7
                        + sy.s8 + sy.s9 + sy.sa + sy.sb + sy.sc + sy.sd + sy.se + sy.sf,
                        sz.s0 + sz.s1 + sz.s2 + sz.s3 + sz.s4 + sz.s5 + sz.s6 + sz.s7
                        + sz.s8 + sz.s9 + sz.sa + sz.sb + sz.sc + sz.sd + sz.se + sz.sf);
#endif
    }
    ao[i] = (float)open / (float)SAMPLES;
#if BENT_NORMALS
    const float len = length(sum);
    vstore3(len > 0.0f ? sum / len : nrm, i, bent);
#endif
}
#endif

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
 *   offsets  uint  (sum R^2 + 1 per type); values index iend/depth directly
 *   iend     IEND_T (S total)      depth  depth_t (S total)
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
 *   DEPTH_BITS, IEND_T   storage of the atlas (csm_common.h)
 *   NTYPES               number of CSM types (>= 0)
 *   GROUND               1: infinite ground plane y = ground_y
 *   LAYOUT_ZIGZAG, LAYOUT_HILBERT  which nearest-map codes to compile (0/1)
 *   SAMPLES, BENT_NORMALS  (scene_ao only)
 */
#include "csm_common.h"
#include "sampling.h"

#define PI_F 3.14159265358979f

inline float3 bases_row(__global const float *bases, int view, int row)
{
    return vload3(3 * view + row, bases);
}

#if LAYOUT_ZIGZAG
inline int nearest_zigzag(__global const float *bases, int vbase, int T, int P, float3 w)
{
    const float th = acos(clamp(w.y, -1.0f, 1.0f));
    float ph = atan2(w.z, w.x);
    if (ph < 0.0f) ph += 2.0f * PI_F;
    const int r0 = clamp((int)floor(th * ((float)T / PI_F)), 0, T - 1);
    int c0 = clamp((int)floor(ph * ((float)P / (2.0f * PI_F))), 0, P);
    if (c0 >= P) c0 -= P;
    int best = 0;
    float bd = -2.0f;
    for (int dr = 0; dr < 2; ++dr) {
        const int r = min(r0 + dr, T - 1);
        for (int dc = 0; dc < 2; ++dc) {
            const int c = (c0 + dc >= P) ? c0 + dc - P : c0 + dc;
            const int k = r * P + ((r & 1) ? (P - 1 - c) : c);
            const float dd = dot(bases_row(bases, vbase + k, 2), w);
            if (dd > bd) { bd = dd; best = k; }
        }
    }
    return best;
}
#endif

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
    __global const IEND_T *iend;
    __global const depth_t *zs;
    __global const float *bases;
    __global const int *cells;
    __global const float *inst;
    __global const int *itype;
    int ninst;
    float ground_y, ground_eps;
    float bias_abs, bias_texels, bias_tan, bias_other;
} scene_t;

/* 1 if instance j's CSM shadows point p (world, anchor-relative) along w.
 * self: whether p may lie on instance j's own surface (then the bias keeps
 * that surface from shadowing itself; against any other caster only the
 * depth quantum is allowed, so contact shadows stay sharp). */
inline int instance_occludes(const scene_t *S, int j, float3 p, float3 w, int self)
{
    __global const float *I = S->inst + 32 * j;
    /* bounding-sphere cull: the ray p + t w, t >= 0, must come within radius */
    const float3 oc = (float3)(I[21], I[22], I[23]) - p;
    const float rad = I[24];
    const float tca = dot(oc, w);
    const float oc2 = dot(oc, oc);
    if (oc2 > rad * rad && (tca < 0.0f || oc2 - tca * tca > rad * rad)) return 0;

    __global const int *T = S->types + 8 * S->itype[j];
    const int R = T[0], layout = T[2], vbase = T[6];
    const float3 pn = (float3)(I[0] * p.x + I[1] * p.y + I[2] * p.z + I[9],
                               I[3] * p.x + I[4] * p.y + I[5] * p.z + I[10],
                               I[6] * p.x + I[7] * p.y + I[8] * p.z + I[11]);
    const float3 wn = normalize((float3)(I[12] * w.x + I[13] * w.y + I[14] * w.z,
                                         I[15] * w.x + I[16] * w.y + I[17] * w.z,
                                         I[18] * w.x + I[19] * w.y + I[20] * w.z));
    int k = 0;
#if LAYOUT_ZIGZAG
    if (layout == 0) k = nearest_zigzag(S->bases, vbase, T[3], T[4], wn);
#endif
#if LAYOUT_HILBERT
    if (layout != 0) k = nearest_hilbert(S->bases, vbase, S->cells, T[7], T[3], layout == 2, wn);
#endif
    const float3 bu = bases_row(S->bases, vbase + k, 0);
    const float3 bv = bases_row(S->bases, vbase + k, 1);
    const float3 bd = bases_row(S->bases, vbase + k, 2);
    const float depth = (1.0f - dot(pn, bd)) * 0.5f;
    if (!(depth > 0.0f)) return 0;
    const float fx = (dot(pn, bu) + 1.0f) * 0.5f * (float)R;
    const float fy = (dot(pn, bv) + 1.0f) * 0.5f * (float)R;
    if (!(fx >= 0.0f && fx < (float)R && fy >= 0.0f && fy < (float)R)) return 0;
    const int col = min((int)fx, R - 1), row = min((int)fy, R - 1);
    const uint tex = (uint)(row * R + col);
    __global const uint *off = S->offsets + T[5];
    const uint s = csm_find(S->iend, off[tex], off[tex + 1], (uint)k, (uint)T[1]);
    const float z = stored_depth(S->zs[s]);
    /* depth tolerance against the point's own surface: a quantum, a share
     * of a texel and the angle a between the query direction and the map's
     * axis; against other casters only bias_other (the quantum) */
    float bias = S->bias_other;
    if (self) {
        const float ca = clamp(dot(wn, bd), 1e-3f, 1.0f);
        const float tan_a = sqrt(fmax(1.0f - ca * ca, 0.0f)) / ca;
        bias = S->bias_abs + (S->bias_texels + S->bias_tan * tan_a) / (float)R;
    }
    return depth > z + bias;
}

/* owner: caster slot whose surface p lies on; -1 unknown (bias against
 * every caster); -2 on no caster (ground, receivers: no self bias) */
inline int occluded(const scene_t *S, float3 p, float3 w, int owner)
{
#if GROUND
    /* within ground_eps of the plane counts as on it (above) */
    const float h = p.y - S->ground_y;
    if ((h >= -S->ground_eps && w.y < 0.0f) || (h < -S->ground_eps && w.y > 0.0f)) return 1;
#endif
    for (int j = 0; j < S->ninst; ++j) {
        if (instance_occludes(S, j, p, w, owner == -1 || owner == j)) return 1;
    }
    return 0;
}

#define SCENE_ARGS __global const int *types, __global const uint *offsets,           \
                   __global const IEND_T *iend, __global const depth_t *zs,             \
                   __global const float *bases, __global const int *cells,              \
                   __global const float *inst, __global const int *itype,               \
                   const int ninst, const float ground_y, const float ground_eps,        \
                   const float bias_abs,                                                 \
                   const float bias_texels, const float bias_tan, const float bias_other

#define SCENE_INIT scene_t S = {types, offsets, iend, zs, bases, cells, inst, itype,   \
                                ninst, ground_y, ground_eps, bias_abs, bias_texels, bias_tan,   \
                                bias_other}

__kernel void scene_visible(SCENE_ARGS, const int n, __global const float *points,
                            __global const float *dirs, __global const int *owner,
                            __global uchar *out)
{
    const int i = get_global_id(0);
    if (i >= n) return;
    SCENE_INIT;
    out[i] = occluded(&S, vload3(i, points), normalize(vload3(i, dirs)), owner[i]) ? 0 : 1;
}

#ifdef SAMPLES
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
    const int own = owner[i];
    float3 t, b;
    hemisphere_frame(nrm, &t, &b);
    __global const float *pat = table + (size_t)pidx[i] * SAMPLES * 3;
    int open = 0;
    float3 sum = (float3)(0.0f);
    for (int s = 0; s < SAMPLES; ++s) {
        const float3 w = cosine_direction(nrm, t, b, vload3(s, pat));
        if (!occluded(&S, p, w, own)) {
            ++open;
#if BENT_NORMALS
            sum += w;
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

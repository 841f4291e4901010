/* csm.cl -- streaming compression of depth maps into a Coherent Shadow Map,
 * and stored-depth lookup (thesis 000, sections 4.2.1 and 5.3.2).
 *
 * csm_fold      one work-item per texel. Folds the maps of one block (in
 *               view-set order) into the texel's open run: the run keeps the
 *               intersection [lo, hi2] of the maps' [z1, z2) intervals (as
 *               keys, see csm_common.h; [z1, z2 - m2) with m2 below, {z1}
 *               when that is empty) and [lo, hi3]
 *               of their [z1, z3 - MARGIN) intervals (LAYER_RULE 3, where the
 *               ray exits at z2 and re-enters at z3 beyond z2 + MARGIN; else
 *               the map's [lo, hi2]). A surface facing the light behind the
 *               first one lies in its shadow and is asked with a self-bias:
 *               MARGIN keeps the stored depth clear of that bias. When the
 *               next map's interval does not meet the run, the run is
 *               emitted as (depth, i_end) and a new run starts. A map hit
 *               once is the point interval {z1}; a miss is {+inf} and meets
 *               only misses. The last block (last = 1) also emits every open
 *               run with i_end = D - 1.
 *               Emitted depth: middle of [lo, hi2] when not empty, else the
 *               middle of [lo, hi3].
 *               m2, the margin in front of the second surface z2: its slope
 *               term (how much nearer than z2 the surface comes within the
 *               texel: half the larger step nearer to a neighbour texel's
 *               second surface on each axis, exact for a plane; at most
 *               MARGIN, and MARGIN where an axis has no such neighbour)
 *               plus SLACK (two quanta: more than the query's bias for
 *               points off the object), plus MARGIN where the surface is
 *               asked with a self-bias: it faces the light by its winding,
 *               or TWO_SIDED (sheets asked from both sides). So points on z2
 *               anywhere in the texel (the ground under a closed body, a
 *               body touching its back, a self-biased point on a second
 *               sheet) stay in shadow wherever z2 comes at most MARGIN
 *               nearer within the texel (a horizontal face: maps more than
 *               13.3 degrees above it).
 *               Free space: where the ray runs through free space after
 *               z1 -- z1 does not face the light (a room's wall seen from
 *               outside), or OPEN_AIR (a mesh mostly open, such as a bowl)
 *               and z2 faces the light or is a back open to the outside (a
 *               bowl's far wall across its hollow), or TWO_SIDED -- the
 *               interval also
 *               ends z1's slope term behind z1 (how much deeper z1's surface
 *               goes within the texel, as m2's slope term, at most MARGIN),
 *               so points in that space (a ball in the bowl) stay in shadow;
 *               with LAYER_RULE 3 such a map keeps [lo, hi2].
 *               FOOTPRINT 1: where the centre ray meets two surfaces, the
 *               map's [z1, z2') (z2' = max(z2 - m2, z1)) narrows to the
 *               texel's footprint: each corner's first depth below z2'
 *               raises the lower end, each corner's second depth (less
 *               MARGIN where it faces the light or TWO_SIDED) above that
 *               lower end lowers the upper end. When no key is left the
 *               centre's interval stands. The result lies inside the
 *               centre's interval.
 * csm_compact   one work-item per texel; copies the block's emitted segments
 *               from the per-texel scratch into one packed array.
 *
 * Buffers
 *   depth  float (B, LAYERS, RES, RES)  block of depth maps, read (fold)
 *   front  uchar (B, LAYERS, RES, RES)  1 where that layer faces the light
 *          (pyshadow.raster, facing=True), read (fold)
 *   cdepth float (B, LAYERS, RES+1, RES+1), cfront uchar (same)  FOOTPRINT
 *          only: the same maps rendered at the texel corners (resolution
 *          RES+1 over a frame (RES+1)/RES times as wide), depth in that frame;
 *          cscale = (RES+1)/RES converts it: z = 0.5 - cscale (0.5 - z')
 *   state  uint  (RES*RES, 4)  lo, hi2, hi3, started; read+written (fold)
 *   seg_z  depth_t (RES*RES, BLOCK+1)  scratch, written (fold), read (compact);
 *          a block emits at most one segment per map plus the final one
 *   seg_i  uint  (RES*RES, BLOCK+1)  scratch i_end, as seg_z
 *   count  uint  (RES*RES)  segments emitted in this block; written (fold)
 *   start  uint  (RES*RES)  exclusive prefix sum of count; read (compact)
 *   out_z  depth_t (S_block), out_i IEND_T (S_block)  written (compact)
 * Macros
 *   RES, LAYERS (1..3, layers in the depth block), LAYER_RULE (2 or 3),
 *   BLOCK (maps per block), DEPTH_BITS (16 or 32), IEND_T (ushort or uint),
 *   MARGIN (float, normalised depth: the margin above), SLACK (float,
 *   normalised depth), TWO_SIDED (0 or 1: every second surface is asked),
 *   FOOTPRINT (0 or 1), OPEN_AIR (0 or 1)
 */
#include "csm_common.h"

#ifndef MARGIN
#error "the host sets MARGIN (depth units)"
#endif
#ifndef SLACK
#error "the host sets SLACK (depth units)"
#endif
#ifndef TWO_SIDED
#define TWO_SIDED 0
#endif
#ifndef FOOTPRINT
#define FOOTPRINT 0
#endif
#ifndef OPEN_AIR
#define OPEN_AIR 0
#endif

/* how much nearer (s = -1) or deeper (s = +1) than z the surface of one
 * depth layer (starting at layer) comes within texel t of the map, at most
 * MARGIN: half a texel times its slope on each axis, the slope being the
 * larger step max(s (zn - z), 0) to a neighbour zn that has a surface in
 * that layer (MARGIN where an axis has no such neighbour). second_slope:
 * the second surface towards the light (so that points on it stay in
 * shadow); first_slope: the first surface away from it (free space) */
inline float texel_slope(__global const float *layer, int t, float z, float s)
{
    const int r = t / RES, c = t % RES;
    float gx = -1.0f, gy = -1.0f, zn;
    if (c > 0 && (zn = layer[t - 1]) < INFINITY) gx = fmax(gx, fmax(s * (zn - z), 0.0f));
    if (c < RES - 1 && (zn = layer[t + 1]) < INFINITY) gx = fmax(gx, fmax(s * (zn - z), 0.0f));
    if (r > 0 && (zn = layer[t - RES]) < INFINITY) gy = fmax(gy, fmax(s * (zn - z), 0.0f));
    if (r < RES - 1 && (zn = layer[t + RES]) < INFINITY) gy = fmax(gy, fmax(s * (zn - z), 0.0f));
    if (gx < 0.0f || gy < 0.0f) return MARGIN;
    return fmin(0.5f * (gx + gy), MARGIN);
}
#define second_slope(DEPTH2, T, Z2) texel_slope((DEPTH2), (T), (Z2), -1.0f)
#define first_slope(DEPTH1, T, Z1) texel_slope((DEPTH1), (T), (Z1), 1.0f)

#if FOOTPRINT
/* the map's interval over the texel's footprint (see FOOTPRINT above);
 * hic: the centre's upper end z2'; *mlo, *mhi2 replaced when a key fits */
inline void footprint_keys(__global const float *cdepth, __global const uchar *cfront,
                           size_t at, float cscale, float z1, float hic, uint *mlo, uint *mhi2)
{
    const size_t cplane = (size_t)(RES + 1) * (RES + 1);
    float lof = z1, hif = hic;
    float c1[4], c2[4];
    for (int k = 0; k < 4; ++k) {
        const size_t a = at + (size_t)(k >> 1) * (RES + 1) + (size_t)(k & 1);
        const float k1 = cdepth[a], k2 = cdepth[a + cplane];
        c1[k] = (k1 < INFINITY) ? 0.5f - cscale * (0.5f - k1) : INFINITY;
        c2[k] = (k2 < INFINITY) ? 0.5f - cscale * (0.5f - k2) : INFINITY;
        if (c2[k] < INFINITY && (TWO_SIDED || cfront[a + cplane])) c2[k] = fmax(c2[k] - MARGIN, c1[k]);
        if (c1[k] < hic) lof = fmax(lof, c1[k]);
    }
    for (int k = 0; k < 4; ++k)
        if (c2[k] < INFINITY && c2[k] > lof) hif = fmin(hif, c2[k]);
    const uint flo = key_at_or_above(lof), fhi = key_below(hif);
    if (fhi != (uint)-1 && fhi >= flo) { *mlo = flo; *mhi2 = fhi; }
}
#endif

inline uint run_value(uint lo, uint hi2, uint hi3)
{
    const uint hi = (lo <= hi2) ? hi2 : hi3;
#if DEPTH_BITS == 16
    return (lo + hi) >> 1;
#else
    if (lo == KEY_MISS) return lo;
    const float a = as_float(lo), b = as_float(hi);
    const uint m = as_uint(a + (b - a) * 0.5f);
    return clamp(m, lo, hi);
#endif
}

inline depth_t key_to_stored(uint k)
{
#if DEPTH_BITS == 16
    return (depth_t)k;
#else
    return as_float(k);
#endif
}

__kernel void csm_fold(__global const float *depth, __global const uchar *front,
#if FOOTPRINT
                       __global const float *cdepth, __global const uchar *cfront,
                       const float cscale,
#endif
                       const int n_maps, const int first_map,
                       const int last, __global uint *state,
                       __global depth_t *seg_z, __global uint *seg_i, __global uint *count)
{
    const int t = get_global_id(0);
    const size_t plane = (size_t)RES * RES;
    if (t >= RES * RES) return;
    __global uint *st = state + 4 * t;
    uint lo = st[0], hi2 = st[1], hi3 = st[2], started = st[3];
    uint n = 0;
    __global depth_t *oz = seg_z + (size_t)t * (BLOCK + 1);
    __global uint *oi = seg_i + (size_t)t * (BLOCK + 1);
    for (int b = 0; b < n_maps; ++b) {
        const size_t at = (size_t)b * LAYERS * plane + t;
        const float z1 = depth[at];
#if LAYERS >= 2
        const float z2 = depth[at + plane];
#else
        const float z2 = INFINITY;
#endif
#if LAYERS >= 3
        const float z3 = depth[at + 2 * plane];
#else
        const float z3 = INFINITY;
#endif
        uint mlo, mhi2, mhi3;
        int air = 0;
        if (!(z1 < INFINITY)) {                   /* miss */
            mlo = mhi2 = mhi3 = KEY_MISS;
        } else {
            mlo = key_at_or_above(z1);
            if (z2 < INFINITY) {
                /* stay m2 in front of the second surface (header): points
                 * on it anywhere in the texel stay in shadow, with the
                 * self-bias where it is asked (it faces the light, or
                 * TWO_SIDED); with no room the map stands alone with z1 */
                float m2 = second_slope(depth + (size_t)b * LAYERS * plane + plane, t, z2) + SLACK;
                if (TWO_SIDED || front[at + plane]) m2 = m2 + MARGIN;
                float hic = fmax(z2 - m2, z1);
                /* free space behind z1 (header): end z1's slope term behind it */
                air = TWO_SIDED | (front[at] == 0) | (OPEN_AIR & (front[at + plane] != 0));
                if (air) hic = fmin(hic, z1 + first_slope(depth + (size_t)b * LAYERS * plane, t, z1));
                mhi2 = key_below(hic);
                if (mhi2 < mlo || mhi2 == (uint)-1) mhi2 = mlo;   /* no key fits: stands alone */
#if FOOTPRINT
                footprint_keys(cdepth, cfront,
                               (size_t)b * LAYERS * (RES + 1) * (RES + 1) + (size_t)(t / RES) * (RES + 1) + t % RES,
                               cscale, z1, hic, &mlo, &mhi2);
#endif
            } else {
                mhi2 = mlo;                      /* hit once: {z1} */
            }
#if LAYER_RULE == 3
            /* [z1, z3 - MARGIN) only where the ray exits at z2 and re-enters
             * the object at z3 (beyond the last exit everything must stay in
             * shadow) and that reaches past z2 */
            const float z3m = z3 - MARGIN;
            mhi3 = (z2 < INFINITY && !front[at + plane] && z3 < INFINITY && z3m > z2)
                   ? max(key_below(z3m), mhi2) : mhi2;
#else
            mhi3 = mhi2;
#endif
            if (air) mhi3 = mhi2;                /* no [z1, z3) through free space */
        }
        if (started) {
            const uint nlo = max(lo, mlo), nhi3 = min(hi3, mhi3);
            if (nlo <= nhi3) {                   /* the map joins the run */
                lo = nlo; hi2 = min(hi2, mhi2); hi3 = nhi3;
                continue;
            }
            oz[n] = key_to_stored(run_value(lo, hi2, hi3));
            oi[n] = (uint)(first_map + b - 1);
            ++n;
        }
        lo = mlo; hi2 = mhi2; hi3 = mhi3; started = 1u;
    }
    if (last && started) {
        oz[n] = key_to_stored(run_value(lo, hi2, hi3));
        oi[n] = (uint)(first_map + n_maps - 1);
        ++n;
        started = 0u;
    }
    st[0] = lo; st[1] = hi2; st[2] = hi3; st[3] = started;
    count[t] = n;
}

__kernel void csm_compact(__global const depth_t *seg_z, __global const uint *seg_i,
                          __global const uint *count, __global const uint *start,
                          __global depth_t *out_z, __global IEND_T *out_i)
{
    const int t = get_global_id(0);
    if (t >= RES * RES) return;
    const uint n = count[t], s = start[t];
    for (uint j = 0; j < n; ++j) {
        out_z[s + j] = seg_z[(size_t)t * (BLOCK + 1) + j];
        out_i[s + j] = (IEND_T)seg_i[(size_t)t * (BLOCK + 1) + j];
    }
}

/* raster_common.h -- shared pieces of pyshadow's triangle rasterisers.
 *
 * Coverage is decided at sample points (texel or pixel centres, which sit at
 * integer screen coordinates) with edge functions. Two rules make a closed
 * mesh watertight with no sample counted twice:
 *   1. the edge function of an edge is always evaluated from its
 *      lexicographically smaller endpoint, so the two triangles sharing the
 *      edge get exactly opposite values (FP contraction is off so the
 *      compiler cannot fuse one of them differently);
 *   2. a sample exactly on an edge belongs to the triangle for which the
 *      edge is a "top-left" edge (exactly one of the two directions is).
 * Macros: none.
 */
#ifndef PYSHADOW_RASTER_COMMON_H
#define PYSHADOW_RASTER_COMMON_H

#pragma OPENCL FP_CONTRACT OFF

/* a precedes b (lexicographic on x, then y) */
inline int pt_before(float2 a, float2 b)
{
    return (a.x < b.x) || (a.x == b.x && a.y < b.y);
}

/* cross(b - a, p - a), evaluated in the canonical endpoint order */
inline float edge_fn(float2 a, float2 b, float2 p)
{
    if (pt_before(b, a)) {
        return -((a.x - b.x) * (p.y - b.y) - (a.y - b.y) * (p.x - b.x));
    }
    return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
}

/* the directed edge a->b of a positively oriented triangle owns its samples */
inline int edge_owns(float2 a, float2 b)
{
    float dx = b.x - a.x, dy = b.y - a.y;
    return (dy > 0.0f) || (dy == 0.0f && dx < 0.0f);
}

/* Sample p inside triangle (p0, p1, p2) of signed doubled area `area` (!= 0)?
 * On success *w holds barycentric weights (sum 1) of p0, p1, p2. (Inlined:
 * the rasterisers ask it per sample, and a call passes its vectors through
 * memory.) */
__attribute__((always_inline)) inline int tri_covers(float2 p0, float2 p1, float2 p2, float area, float2 p, float3 *w)
{
    float e0 = edge_fn(p1, p2, p);   /* opposite p0 */
    float e1 = edge_fn(p2, p0, p);   /* opposite p1 */
    float e2 = edge_fn(p0, p1, p);   /* opposite p2 */
    int o0, o1, o2;
    if (area > 0.0f) {
        o0 = edge_owns(p1, p2); o1 = edge_owns(p2, p0); o2 = edge_owns(p0, p1);
    } else {
        e0 = -e0; e1 = -e1; e2 = -e2;
        o0 = edge_owns(p2, p1); o1 = edge_owns(p0, p2); o2 = edge_owns(p1, p0);
    }
    if (e0 < 0.0f || e1 < 0.0f || e2 < 0.0f) return 0;
    if ((e0 == 0.0f && !o0) || (e1 == 0.0f && !o1) || (e2 == 0.0f && !o2)) return 0;
    float s = e0 + e1 + e2;
    if (!(s > 0.0f)) return 0;
    *w = (float3)(e0, e1, e2) / s;
    return 1;
}

#endif

/* raster.cl -- layered orthographic depth maps of a mesh for many views.
 *
 * Kernel render_depth_layers: one work-item per view (map). Each work-item
 * walks every triangle, projects it into its own view and inserts the depth
 * of every texel centre it covers into that texel's sorted list of the
 * LAYERS nearest depths (depth peeling in one pass). No two work-items write
 * the same memory, so no atomics are needed.
 *
 * Triangles are read LANES at a time (lanes.h) from a structure-of-arrays
 * buffer and projected with lane-vector arithmetic; only triangles whose
 * screen bounding box
 * holds a texel centre (about 40 % for a 70k-triangle mesh at 128^2) go on to
 * the scalar coverage test. The projected coordinates of a vertex are the
 * same in every triangle that uses it (same operations, FP contraction off),
 * which the watertight edge rule of raster_common.h relies on.
 *
 * Conventions (DESIGN.md, pyshadow.raster): normalised object frame
 * (bounding sphere centre 0, radius 1). Map k has basis rows (u, v, d);
 * texel (row r, col c) is the ray x*u + y*v + d - t*d with
 * x = 2(c+0.5)/RES - 1, y = 2(r+0.5)/RES - 1; a surface point p has depth
 * (1 - p.d)/2 in [0, 1]. In screen coordinates sx = (x+1)*RES/2 - 0.5 the
 * texel centres are the integers.
 *
 * Buffers
 *   tris   float  (9 + FACING, tpad)  corner coordinates a.x a.y a.z b.x ...
 *                            c.z as rows, tpad a multiple of LANES; with
 *                            FACING a tenth row, nonzero where the triangle
 *                            faces the light from both sides (its back is
 *                            open to the outside: pyshadow.csm.exposure); read
 *   bases  float  (D, 9)     rows u, v, d of each view of the launch; read
 *   depth  float  (D, LAYERS, RES, RES)   written; must hold +inf on entry
 *   front  uchar  (D, LAYERS, RES, RES)   FACING only: 1 where that layer's
 *                            triangle faces the light (positive screen-space
 *                            area, i.e. winding normal along +d, or the
 *                            tenth row of tris nonzero); written,
 *                            must hold 0 on entry. Unused without FACING.
 * Scalars
 *   n_tris  triangles in use (<= tpad); tpad  row stride of tris
 *   n_views views in the launch (work-items beyond it return at once)
 * Macros
 *   RES     texels per side (1 .. 4096)
 *   LAYERS  depth layers kept (1 .. 3)
 *   FACING  0 or 1 (default 0): also keep each layer's facing flag
 *   LANES   triangles per lane vector (lanes.h)
 */
#include "raster_common.h"
#include "lanes.h"

/* edge function of a->b at p for every lane: the same operations, in the
 * same canonical endpoint order, as edge_fn() */
inline fv edge_v(fv ax, fv ay, fv bx, fv by, fv px, fv py)
{
    const iv sw = MASK(bx < ax) | (MASK(bx == ax) & MASK(by < ay));
    const fv ox = select(ax, bx, sw), oy = select(ay, by, sw);
    const fv ex = select(bx - ax, ax - bx, sw), ey = select(by - ay, ay - by, sw);
    const fv e = ex * (py - oy) - ey * (px - ox);
    return select(e, -e, sw);
}
/* edge_owns() for every lane */
#define OWNS_V(AX, AY, BX, BY) \
    (MASK(((BY) - (AY)) > 0.0f) | (MASK(((BY) - (AY)) == 0.0f) & MASK(((BX) - (AX)) < 0.0f)))

#ifndef FACING
#define FACING 0
#endif

/* insert z into the sorted LAYERS-deep list of one texel */
inline void insert_depth(__global float *px, const size_t plane, float z)
{
    for (int l = 0; l < LAYERS; ++l) {
        const float cur = px[l * plane];
        if (z < cur) { px[l * plane] = z; z = cur; }
    }
}

/* the same, carrying each depth's facing flag along in pf */
inline void insert_depth_facing(__global float *px, __global uchar *pf, const size_t plane, float z,
                                uchar f)
{
    for (int l = 0; l < LAYERS; ++l) {
        const float cur = px[l * plane];
        if (z < cur) {
            const uchar cf = pf[l * plane];
            px[l * plane] = z; pf[l * plane] = f;
            z = cur; f = cf;
        }
    }
}

#if FACING
#define INSERT(OFF, Z, F) insert_depth_facing(out + (OFF), fout + (OFF), plane, (Z), (uchar)(F))
#else
#define INSERT(OFF, Z, F) insert_depth(out + (OFF), plane, (Z))
#endif

#define PROJ(PX, PY, PZ, A) (((PX) * (A).x + (PY) * (A).y + (PZ) * (A).z + 1.0f) * half_res - 0.5f)

__kernel void render_depth_layers(__global const float *tris,
                                  const int n_tris,
                                  const int tpad,
                                  __global const float *bases,
                                  const int n_views,
                                  __global float *depth,
                                  __global uchar *front)
{
    const int view = get_global_id(0);
    if (view >= n_views) return;
    __global const float *B = bases + 9 * view;
    const float3 U = (float3)(B[0], B[1], B[2]);
    const float3 Vv = (float3)(B[3], B[4], B[5]);
    const float3 Dd = (float3)(B[6], B[7], B[8]);
    const float half_res = 0.5f * (float)RES;
    const float last = (float)(RES - 1);
    const size_t plane = (size_t)RES * RES;
    __global float *out = depth + (size_t)view * LAYERS * plane;
#if FACING
    __global uchar *fout = front + (size_t)view * LAYERS * plane;
#endif

    float sx0[LANES], sy0[LANES], sx1[LANES], sy1[LANES], sx2[LANES], sy2[LANES];
    float sz0[LANES], sz1[LANES], sz2[LANES];
    float zhit[LANES];
    int flag[LANES], cpos[LANES], rpos[LANES], fpos[LANES];

    for (int base = 0; base < n_tris; base += LANES) {
        const fv ax = VLOAD(0, tris + 0 * (size_t)tpad + base);
        const fv ay = VLOAD(0, tris + 1 * (size_t)tpad + base);
        const fv az = VLOAD(0, tris + 2 * (size_t)tpad + base);
        const fv bx = VLOAD(0, tris + 3 * (size_t)tpad + base);
        const fv by = VLOAD(0, tris + 4 * (size_t)tpad + base);
        const fv bz = VLOAD(0, tris + 5 * (size_t)tpad + base);
        const fv cx = VLOAD(0, tris + 6 * (size_t)tpad + base);
        const fv cy = VLOAD(0, tris + 7 * (size_t)tpad + base);
        const fv cz = VLOAD(0, tris + 8 * (size_t)tpad + base);
        const fv x0 = PROJ(ax, ay, az, U), y0 = PROJ(ax, ay, az, Vv);
        const fv x1 = PROJ(bx, by, bz, U), y1 = PROJ(bx, by, bz, Vv);
        const fv x2 = PROJ(cx, cy, cz, U), y2 = PROJ(cx, cy, cz, Vv);
        const fv c0 = fmax(ceil(fmin(x0, fmin(x1, x2))), 0.0f);
        const fv c1 = fmin(floor(fmax(x0, fmax(x1, x2))), last);
        const fv r0 = fmax(ceil(fmin(y0, fmin(y1, y2))), 0.0f);
        const fv r1 = fmin(floor(fmax(y0, fmax(y1, y2))), last);
        const iv live = MASK(c0 <= c1) & MASK(r0 <= r1);
        if (!VANY(live)) continue;
        /* Most live triangles hold one texel centre in their bounding box:
         * test it for all lanes at once with the scalar rule's exact
         * operations (see tri_covers); lanes with bigger boxes go scalar. */
        const iv multi = live & (MASK(c1 > c0) | MASK(r1 > r0));
        const fv area = edge_v(x0, y0, x1, y1, x2, y2);
        fv e0 = edge_v(x1, y1, x2, y2, c0, r0);
        fv e1 = edge_v(x2, y2, x0, y0, c0, r0);
        fv e2 = edge_v(x0, y0, x1, y1, c0, r0);
        const iv pos = MASK(area > 0.0f);
        e0 = select(-e0, e0, pos); e1 = select(-e1, e1, pos); e2 = select(-e2, e2, pos);
        const iv o0 = select(OWNS_V(x2, y2, x1, y1), OWNS_V(x1, y1, x2, y2), pos);
        const iv o1 = select(OWNS_V(x0, y0, x2, y2), OWNS_V(x2, y2, x0, y0), pos);
        const iv o2 = select(OWNS_V(x1, y1, x0, y0), OWNS_V(x0, y0, x1, y1), pos);
        const fv esum = e0 + e1 + e2;
        const iv in = MASK(e0 >= 0.0f) & MASK(e1 >= 0.0f) & MASK(e2 >= 0.0f)
                    & (MASK(e0 > 0.0f) | o0) & (MASK(e1 > 0.0f) | o1) & (MASK(e2 > 0.0f) | o2)
                    & MASK(esum > 0.0f) & MASK(area != 0.0f);
        const fv dz0 = (1.0f - (ax * Dd.x + ay * Dd.y + az * Dd.z)) * 0.5f;
        const fv dz1 = (1.0f - (bx * Dd.x + by * Dd.y + bz * Dd.z)) * 0.5f;
        const fv dz2 = (1.0f - (cx * Dd.x + cy * Dd.y + cz * Dd.z)) * 0.5f;
        const fv zc = (e0 / esum) * dz0 + (e1 / esum) * dz1 + (e2 / esum) * dz2;
        const iv single = live & in & ~multi;
        if (!VANY(single | multi)) continue;
        VSTORE(zc, 0, zhit);
        VSTORE(select((iv)0, (iv)1, single) | select((iv)0, (iv)2, multi), 0, flag);
        VSTORE(CONVERT(int, c0), 0, cpos);
        VSTORE(CONVERT(int, r0), 0, rpos);
#if FACING
        /* the facing flag of both paths below: area > 0 (edge_v: the scalar path's edge_fn value),
         * or the triangle faces the light from both sides */
        const iv both = MASK(VLOAD(0, tris + 9 * (size_t)tpad + base) != 0.0f);
        VSTORE(pos | both, 0, fpos);
#endif
        const int any_multi = VANY(multi);
        if (any_multi) {
            VSTORE(x0, 0, sx0); VSTORE(y0, 0, sy0);
            VSTORE(x1, 0, sx1); VSTORE(y1, 0, sy1);
            VSTORE(x2, 0, sx2); VSTORE(y2, 0, sy2);
            VSTORE(dz0, 0, sz0); VSTORE(dz1, 0, sz1); VSTORE(dz2, 0, sz2);
        }
        const int lanes = min(LANES, n_tris - base);
        for (int i = 0; i < lanes; ++i) {
            const int f = flag[i];
            if (f == 0) continue;
            if (f == 1) {
                INSERT((size_t)rpos[i] * RES + cpos[i], zhit[i], fpos[i] != 0);
                continue;
            }
            const float2 p0 = (float2)(sx0[i], sy0[i]);
            const float2 p1 = (float2)(sx1[i], sy1[i]);
            const float2 p2 = (float2)(sx2[i], sy2[i]);
            const float ar = edge_fn(p0, p1, p2);
            if (ar == 0.0f) continue;
            const int cc0 = cpos[i], rr0 = rpos[i];
            const int cc1 = (int)fmin(floor(fmax(p0.x, fmax(p1.x, p2.x))), last);
            const int rr1 = (int)fmin(floor(fmax(p0.y, fmax(p1.y, p2.y))), last);
            const float z0 = sz0[i], z1 = sz1[i], z2 = sz2[i];
            for (int r = rr0; r <= rr1; ++r) {
                for (int col = cc0; col <= cc1; ++col) {
                    float3 w;
                    if (!tri_covers(p0, p1, p2, ar, (float2)((float)col, (float)r), &w)) continue;
                    INSERT((size_t)r * RES + col, w.x * z0 + w.y * z1 + w.z * z2, fpos[i] != 0);
                }
            }
        }
    }
}

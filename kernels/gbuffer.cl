/* gbuffer.cl -- perspective G-buffer by triangle rasterisation ("visibility
 * buffer": first the nearest depth, then the id of the triangle that has it,
 * then the attributes per pixel).
 *
 * Kernels
 *   gbuffer_raster   one work-item per triangle (but the wide ones); walks
 *                    the pixel centres in its screen bounding box. pass 0: atomic_min of the
 *                    view-space depth (as uint; positive floats order like
 *                    their bit patterns) into zbuf. pass 1: where the
 *                    triangle's depth equals zbuf, atomic_min of its index
 *                    into idbuf (ties go to the lower index). Both passes run
 *                    the same code, so the depth they compute is bit-identical.
 *   gbuffer_raster_rows  the same for the triangles the host marks wide (a
 *                    screen box of many pixels), one work-item per row of
 *                    each: a triangle filling the image is not left to one
 *                    core. Both run per pass; the order of the atomics does
 *                    not change what wins. *   gbuffer_resolve  one work-item per pixel: distance t along the unit eye
 *                    ray to the plane of the winning triangle and its unit
 *                    normal, turned to face the camera.
 *
 * Camera space: x right, y up, z forward (along the view), eye at the origin;
 * triangles arrive clipped to z >= near by the host. Pixel (row i, col j) is
 * at screen (j, i) with the centre at integers:
 *   sx = x/z * fx + W/2 - 0.5,  sy = H/2 - 0.5 - y/z * fy,
 *   fx = W / (2 tan(fov/2) aspect),  fy = H / (2 tan(fov/2)).
 *
 * Buffers
 *   tris   float (T, 9)  camera-space corners a, b, c; read
 *   wide   uchar (T)     1: the triangle is rasterised by gbuffer_raster_rows
 *   rows   int2  (n)     (triangle, row) of the wide triangles' rows
 *   zbuf   uint  (H*W)   pass 0 writes (start at 0xffffffff), pass 1 reads
 *   idbuf  int   (H*W)   pass 1 writes (start at INT_MAX); resolve reads
 *   t_out  float (H*W)   resolve writes (inf where no triangle)
 *   n_out  float (H*W,3) resolve writes (0 where no triangle)
 *   planes float (T, 4)  resolve reads, where use_planes: unit normal and
 *                        offset (n . p of its points) of each triangle's
 *                        plane, NaN offset where the corners give it
 *   far_out uchar (H*W)  resolve writes: 1 where a corner of the pixel's
 *                        triangle lies beyond far_ratio times the distance
 *                        of its plane from the eye (t to redo in float64)
 * Macros: GBUFFER_ATOMIC64 (0/1; the host sets 1 where the device has
 * cl_khr_int64_extended_atomics): one raster pass, atom_min of the pair
 * (depth bits << 32 | triangle index) into zbuf read as ulong -- the least
 * depth, then the lower index, as the two passes find -- and gbuffer_ids to
 * split the winners off (sizes are arguments, so one build serves every
 * image size).
 */
#include "raster_common.h"
#include "vec3.h"

#ifndef GBUFFER_ATOMIC64
#define GBUFFER_ATOMIC64 0
#endif
#if GBUFFER_ATOMIC64
#pragma OPENCL EXTENSION cl_khr_int64_base_atomics : enable
#pragma OPENCL EXTENSION cl_khr_int64_extended_atomics : enable
#endif

inline float2 to_screen(float3 p, float fx, float fy, int W, int H)
{
    return (float2)(p.x / p.z * fx + (0.5f * W - 0.5f), (0.5f * H - 0.5f) - p.y / p.z * fy);
}

/* triangle t's screen corners p[3], doubled signed area, 1 / z of its
 * corners and pixel box (rows r[0]..r[1], columns c[0]..c[1]); 0 where it
 * covers no pixel centre's box */
inline int raster_setup(__global const float *tris, int t, int W, int H, float fx, float fy, float2 *p,
                        float *area, float3 *iz, int *r, int *c)
{
    const float3 a = row3(tris, 3 * t), b = row3(tris, 3 * t + 1), d = row3(tris, 3 * t + 2);
    p[0] = to_screen(a, fx, fy, W, H);
    p[1] = to_screen(b, fx, fy, W, H);
    p[2] = to_screen(d, fx, fy, W, H);
    *area = edge_fn(p[0], p[1], p[2]);
    if (*area == 0.0f || !isfinite(*area)) return 0;
    /* the box tested against the image in float first: a triangle wholly off it (screen
       coordinates beyond int's range near the near plane) never reaches a float-to-int conversion */
    const float x0 = ceil(fmin(p[0].x, fmin(p[1].x, p[2].x))), x1 = floor(fmax(p[0].x, fmax(p[1].x, p[2].x)));
    const float y0 = ceil(fmin(p[0].y, fmin(p[1].y, p[2].y))), y1 = floor(fmax(p[0].y, fmax(p[1].y, p[2].y)));
    if (!(x0 <= (float)(W - 1) && x1 >= 0.0f && y0 <= (float)(H - 1) && y1 >= 0.0f)) return 0;
    c[0] = (int)fmax(x0, 0.0f); c[1] = (int)fmin(x1, (float)(W - 1));
    r[0] = (int)fmax(y0, 0.0f); r[1] = (int)fmin(y1, (float)(H - 1));
    *iz = (float3)(1.0f / a.z, 1.0f / b.z, 1.0f / d.z);
    return 1;
}

/* the pixel centres of row r, columns c0..c1, that triangle t covers: pass 0
 * its depth into zbuf, pass 1 its index into idbuf where that depth won */
inline void raster_row(int t, const float2 *p, float area, float3 iz, int r, int c0, int c1, int W, int pass,
                       __global volatile uint *zbuf, __global volatile int *idbuf)
{
    for (int col = c0; col <= c1; ++col) {
        float3 w;
        if (!tri_covers(p[0], p[1], p[2], area, (float2)((float)col, (float)r), &w)) continue;
        const float z = 1.0f / (w.x * iz.x + w.y * iz.y + w.z * iz.z);
        if (!(z > 0.0f)) continue;
        const uint key = as_uint(z);
        const int pix = r * W + col;
#if GBUFFER_ATOMIC64
        /* one pass: the least (depth, index) pair, zbuf read as (H*W) ulong */
        atom_min((__global volatile ulong *)zbuf + pix, ((ulong)key << 32) | (ulong)(uint)t);
#else
        if (pass == 0) {
            atomic_min(&zbuf[pix], key);
        } else if (zbuf[pix] == key) {
            atomic_min(&idbuf[pix], t);
        }
#endif
    }
}

/* one work-item per triangle, but those marked wide (gbuffer_raster_rows) */
__kernel void gbuffer_raster(__global const float *tris, const int n_tris, __global const uchar *wide,
                             const int W, const int H, const float fx, const float fy,
                             const int pass,
                             __global volatile uint *zbuf, __global volatile int *idbuf)
{
    const int t = get_global_id(0);
    if (t >= n_tris || wide[t]) return;
    float2 p[3];
    float area;
    float3 iz;
    int r[2], c[2];
    if (!raster_setup(tris, t, W, H, fx, fy, p, &area, &iz, r, c)) return;
    for (int row = r[0]; row <= r[1]; ++row)
        raster_row(t, p, area, iz, row, c[0], c[1], W, pass, zbuf, idbuf);
}

/* one work-item per (triangle, row) of the wide triangles: rows[i] = (t, row),
 * a row outside the triangle's own box is passed over (the host lists more) */
__kernel void gbuffer_raster_rows(__global const float *tris, __global const int2 *rows, const int n_rows,
                                  const int W, const int H, const float fx, const float fy,
                                  const int pass,
                                  __global volatile uint *zbuf, __global volatile int *idbuf)
{
    const int i = get_global_id(0);
    if (i >= n_rows) return;
    const int2 tr = rows[i];
    float2 p[3];
    float area;
    float3 iz;
    int r[2], c[2];
    if (!raster_setup(tris, tr.x, W, H, fx, fy, p, &area, &iz, r, c) || tr.y < r[0] || tr.y > r[1]) return;
    /* the row's columns between the triangle's edges (where each edge line
     * crosses it), each widened by two pixels and by a bound on how far
     * tri_covers() may place a pixel's side of that edge from the crossing
     * computed here, both in float32: an edge function from corner o errs,
     * in columns, by at most about 4 u (|dx| |y - o.y| / |dy| + |x - o.x|)
     * (u = FLT_EPSILON / 2; two products and their difference, each rounded
     * once, o either corner as edge_fn() picks), and the crossing by less;
     * twice the sum over both corners, capped at the corners' largest
     * magnitude times 1e-5 (the margin before this rule). tri_covers() still
     * decides every pixel within. */
    float big = 0.0f;                                       /* the corners' largest |coordinate| */
    for (int k = 0; k < 3; ++k)
        big = fmax(big, fmax(fabs(p[k].x), fabs(p[k].y)));
    const float y = (float)tr.y;
    float lo = -INFINITY, hi = INFINITY;
    for (int e = 0; e < 3; ++e) {
        const float2 a = p[e], b = p[(e + 1) % 3];
        const float dx = b.x - a.x, dy = b.y - a.y;
        if (!(fabs(dy) > 0.0f)) continue;                   /* a row-parallel edge bounds no column */
        const float x = a.x + dx * ((y - a.y) / dy);
        const float err = 4.0f * FLT_EPSILON * (fabs(dx) * ((fabs(y - a.y) + fabs(y - b.y)) / fabs(dy))
                                                 + fabs(x - a.x) + fabs(x - b.x));
        const float m = 2.0f + fmin(err, 1e-5f * big);
        if ((dy > 0.0f) == (area > 0.0f)) hi = fmin(hi, x + m);  /* inside: left of an edge going down the rows */
        else lo = fmax(lo, x - m);
    }
    if (!(lo <= hi)) return;
    const int cl = (int)fmax((float)c[0], fmin(ceil(lo), (float)c[1] + 1.0f)),
              ch = (int)fmin((float)c[1], fmax(floor(hi), (float)c[0] - 1.0f));
    raster_row(tr.x, p, area, iz, tr.y, cl, ch, W, pass, zbuf, idbuf);
}

#if GBUFFER_ATOMIC64
/* the one pass's winners as gbuffer_resolve reads them: the index half of
 * each pixel's (depth, index) pair, INT_MAX where no triangle covers it */
__kernel void gbuffer_ids(__global const ulong *zid, const int n, __global int *idbuf)
{
    const int pix = get_global_id(0);
    if (pix >= n) return;
    const ulong v = zid[pix];
    idbuf[pix] = v == ~(ulong)0 ? INT_MAX : (int)(uint)(v & 0xffffffffUL);
}
#endif

/* the largest |coordinate| of p */
inline float max_abs3(float3 p)
{
    return fmax(fabs(p.x), fmax(fabs(p.y), fabs(p.z)));
}

__kernel void gbuffer_resolve(__global const float *tris, __global const float *planes, const int use_planes,
                              const int W, const int H,
                              const float tan_x, const float tan_y, const float far_ratio,
                              __global const int *idbuf,
                              __global float *t_out, __global float *n_out, __global uchar *far_out)
{
    const int pix = get_global_id(0);
    if (pix >= W * H) return;
    const int t = idbuf[pix];
    const int r = pix / W, col = pix - r * W;
    if (t == INT_MAX) {
        t_out[pix] = INFINITY;
        store_row3((float3)(0.0f), n_out, pix);
        far_out[pix] = 0;
        return;
    }
    const float3 a = row3(tris, 3 * t), b = row3(tris, 3 * t + 1), c = row3(tris, 3 * t + 2);
    /* the pixel centre's offset from the image centre as one exact integer over the size: one rounding
       (2 (col + 0.5) / W - 1 rounds twice, off by a float32 spacing near the centre of a wide image) */
    const float3 dir = normalize3((float3)((float)(2 * col + 1 - W) / (float)W * tan_x,
                                           (float)(H - 1 - 2 * r) / (float)H * tan_y, 1.0f));
    /* the plane: the host's (float64, rounded once) where it gives one, else from the float32 corners */
    const float w = use_planes ? planes[4 * t + 3] : NAN;
    float3 n;
    float off;                                  /* the plane's distance from the eye */
    if (isnan(w)) {
        n = normalize3(cross3(b - a, c - a));
        off = dot3(n, a);
    } else {
        n = (float3)(planes[4 * t], planes[4 * t + 1], planes[4 * t + 2]);
        off = w;
    }
    const float dn = dot3(n, dir);
    t_out[pix] = off / dn;
    store_row3(dn > 0.0f ? -n : n, n_out, pix);
    /* off from the corners is a sum of products of a corner's size: its rounding, about FLT_EPSILON |a|,
       errs t by that over |off| (a grazing ground seen from a low eye); and any plane errs t by about
       FLT_EPSILON t / (n . dir) from the float32 ray: the host redoes the pixel in float64 where a corner
       reaches beyond far_ratio times |off| */
    far_out[pix] = fmax(max_abs3(a), fmax(max_abs3(b), max_abs3(c))) > far_ratio * fabs(off);
}

/* gbuffer.cl -- perspective G-buffer by triangle rasterisation ("visibility
 * buffer": first the nearest depth, then the id of the triangle that has it,
 * then the attributes per pixel).
 *
 * Kernels
 *   gbuffer_raster   one work-item per triangle; walks the pixel centres in
 *                    its screen bounding box. pass 0: atomic_min of the
 *                    view-space depth (as uint; positive floats order like
 *                    their bit patterns) into zbuf. pass 1: where the
 *                    triangle's depth equals zbuf, atomic_min of its index
 *                    into idbuf (ties go to the lower index). Both passes run
 *                    the same code, so the depth they compute is bit-identical.
 *   gbuffer_resolve  one work-item per pixel: distance t along the unit eye
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
 *   zbuf   uint  (H*W)   pass 0 writes (start at 0xffffffff), pass 1 reads
 *   idbuf  int   (H*W)   pass 1 writes (start at INT_MAX); resolve reads
 *   t_out  float (H*W)   resolve writes (inf where no triangle)
 *   n_out  float (H*W,3) resolve writes (0 where no triangle)
 * Macros: none (sizes are arguments, so one build serves every image size).
 */
#include "raster_common.h"

inline float2 to_screen(float3 p, float fx, float fy, int W, int H)
{
    return (float2)(p.x / p.z * fx + (0.5f * W - 0.5f), (0.5f * H - 0.5f) - p.y / p.z * fy);
}

__kernel void gbuffer_raster(__global const float *tris, const int n_tris,
                             const int W, const int H, const float fx, const float fy,
                             const int pass,
                             __global volatile uint *zbuf, __global volatile int *idbuf)
{
    const int t = get_global_id(0);
    if (t >= n_tris) return;
    const float3 a = vload3(3 * t, tris), b = vload3(3 * t + 1, tris), c = vload3(3 * t + 2, tris);
    const float2 p0 = to_screen(a, fx, fy, W, H);
    const float2 p1 = to_screen(b, fx, fy, W, H);
    const float2 p2 = to_screen(c, fx, fy, W, H);
    const float area = edge_fn(p0, p1, p2);
    if (area == 0.0f || !isfinite(area)) return;
    /* the box tested against the image in float first: a triangle wholly off it (screen
       coordinates beyond int's range near the near plane) never reaches a float-to-int conversion */
    const float x0 = ceil(fmin(p0.x, fmin(p1.x, p2.x))), x1 = floor(fmax(p0.x, fmax(p1.x, p2.x)));
    const float y0 = ceil(fmin(p0.y, fmin(p1.y, p2.y))), y1 = floor(fmax(p0.y, fmax(p1.y, p2.y)));
    if (!(x0 <= (float)(W - 1) && x1 >= 0.0f && y0 <= (float)(H - 1) && y1 >= 0.0f)) return;
    const int c0 = (int)fmax(x0, 0.0f), c1 = (int)fmin(x1, (float)(W - 1));
    const int r0 = (int)fmax(y0, 0.0f), r1 = (int)fmin(y1, (float)(H - 1));
    const float3 iz = (float3)(1.0f / a.z, 1.0f / b.z, 1.0f / c.z);
    for (int r = r0; r <= r1; ++r) {
        for (int col = c0; col <= c1; ++col) {
            float3 w;
            if (!tri_covers(p0, p1, p2, area, (float2)((float)col, (float)r), &w)) continue;
            const float z = 1.0f / (w.x * iz.x + w.y * iz.y + w.z * iz.z);
            if (!(z > 0.0f)) continue;
            const uint key = as_uint(z);
            const int pix = r * W + col;
            if (pass == 0) {
                atomic_min(&zbuf[pix], key);
            } else if (zbuf[pix] == key) {
                atomic_min(&idbuf[pix], t);
            }
        }
    }
}

__kernel void gbuffer_resolve(__global const float *tris, const int W, const int H,
                              const float tan_x, const float tan_y,
                              __global const int *idbuf,
                              __global float *t_out, __global float *n_out)
{
    const int pix = get_global_id(0);
    if (pix >= W * H) return;
    const int t = idbuf[pix];
    const int r = pix / W, col = pix - r * W;
    if (t == INT_MAX) {
        t_out[pix] = INFINITY;
        vstore3((float3)(0.0f), pix, n_out);
        return;
    }
    const float3 a = vload3(3 * t, tris), b = vload3(3 * t + 1, tris), c = vload3(3 * t + 2, tris);
    const float3 dir = normalize((float3)((2.0f * (col + 0.5f) / W - 1.0f) * tan_x,
                                          (1.0f - 2.0f * (r + 0.5f) / H) * tan_y, 1.0f));
    float3 n = normalize(cross(b - a, c - a));
    const float dn = dot(n, dir);
    t_out[pix] = dot(n, a) / dn;
    vstore3(dn > 0.0f ? -n : n, pix, n_out);
}

/* ssao.cl -- screen-space ambient occlusion from a G-buffer (pyshadow.ssao).
 *
 * Kernel
 *   ssao    one work-item per pixel: SAMPLES cosine-weighted directions w
 *           about the pixel's normal (pattern pidx[i] of the table, the
 *           frame and operations of sampling.h, so they equal
 *           pyshadow.sample_directions bit for bit); each sample point
 *           q = p + radius w (p the pixel's surface point relative to the
 *           eye) is projected into the image; it is occluded when the
 *           depth buffer at its pixel (nearest) holds a surface closer to
 *           the camera than q by more than bias, and that surface's depth
 *           lies within range of the pixel's own depth (the range check).
 *           Samples behind the eye, off the image or over the background
 *           are open. Writes ao = 1 - occluded / SAMPLES (1 = open);
 *           background pixels (zbuf +inf) get 1.
 *
 * Buffers
 *   rel     float (N, 3)  surface point minus eye, world units; read
 *   normals float (N, 3)  unit world normals; read
 *   zbuf    float (N)     view depth (along forward) of each pixel's
 *                         surface, +inf for the background; read
 *   pidx    int (N)       pattern of each pixel, validated < M; read
 *   table   float (M, SAMPLES, 3) local directions (y along the normal)
 *   ao      float (N)     written
 * Camera: rows right (rx, ry, rz), up (ux, uy, uz), forward (fx, fy, fz);
 * sx = 1 / (tan(fov_y / 2) aspect), sy = 1 / tan(fov_y / 2); image W x H,
 * pixel (row k, column j) covers column coordinates [j, j + 1) of
 * (x / z sx + 1) W / 2 and row coordinates [k, k + 1) of (1 - y / z sy) H / 2
 * (pyshadow.Camera's pixel centres at j + 1/2, k + 1/2).
 * Macros: SAMPLES (1 .. 4096). FP_CONTRACT is off (sampling.h), so the
 * NumPy reference of pyshadow.ssao differs only by float32 rounding.
 */
#include "sampling.h"

__kernel void ssao(__global const float *rel, __global const float *normals, __global const float *zbuf,
                   __global const int *pidx, __global const float *table,
                   const float rx, const float ry, const float rz,
                   const float ux, const float uy, const float uz,
                   const float fx, const float fy, const float fz,
                   const float sx, const float sy, const int W, const int H,
                   const float radius, const float bias, const float range,
                   __global float *ao)
{
    const int i = get_global_id(0);
    if (i >= W * H) return;
    const float zp = zbuf[i];
    if (!(zp < INFINITY)) {
        ao[i] = 1.0f;
        return;
    }
    const float3 p = vload3(i, rel);
    const float3 n = vload3(i, normals);
    float3 t, b;
    hemisphere_frame(n, &t, &b);
    __global const float *pat = table + (size_t)pidx[i] * SAMPLES * 3;
    int occluded = 0;
    for (int s = 0; s < SAMPLES; ++s) {
        const float3 w = cosine_direction(n, t, b, vload3(s, pat));
        const float3 q = p + radius * w;
        const float zc = (q.x * fx + q.y * fy) + q.z * fz;
        if (!(zc > 0.0f)) continue;                       /* behind the eye */
        const float xc = (q.x * rx + q.y * ry) + q.z * rz;
        const float yc = (q.x * ux + q.y * uy) + q.z * uz;
        const float col = (xc / zc * sx + 1.0f) * 0.5f * (float)W;
        const float row = (1.0f - yc / zc * sy) * 0.5f * (float)H;
        if (!(col >= 0.0f && col < (float)W && row >= 0.0f && row < (float)H)) continue;
        const int j = min((int)col, W - 1), k = min((int)row, H - 1);
        const float zb = zbuf[k * W + j];
        if (!(zb < INFINITY)) continue;                   /* the background */
        if (zb < zc - bias && fabs(zp - zb) <= range) ++occluded;
    }
    ao[i] = 1.0f - (float)occluded / (float)SAMPLES;
}

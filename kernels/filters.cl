/* filters.cl -- edge-aware filters of a screen-space AO image, guided by the
 * G-buffer's depth and normal (DESIGN.md "Filtering"; seed 002, sections
 * 3.1.5 and 4.5, and the future work of its section 5.3).
 *
 * Kernels (all: one work-item per OUTPUT pixel, 2-D range (W, H),
 * get_global_id(0) = column x, get_global_id(1) = row y; work-items outside
 * the image return at once; no work-item writes another's pixel)
 *   bilateral_2d      joint bilateral filter over the (2 RADIUS + 1)^2 window
 *   bilateral_rows    the same weights over the 2 RADIUS + 1 taps of the row
 *   bilateral_cols    ... and of the column (run rows, then cols on its output:
 *                     the separable approximation)
 *   edge_aware_box    mean over the (2 HALF + 1)^2 window of the neighbours
 *                     whose relative depth difference and normal agree
 *   upsample_joint_bilateral
 *                     joint bilateral upsampling (Kopf et al. 2007) of an AO
 *                     image sampled at every SCALE-th pixel
 *
 * Conventions (pyshadow.filters): images are row-major (H, W), row 0 at the
 * top, pixel p = y * W + x. depth is the distance along the pixel's ray,
 * > 0 where finite, +inf on background (the host rejects NaN, -inf and
 * depth <= 0). Background pixels never contribute to a neighbour; a
 * background output pixel is the input passed through (upsampling: `fill`).
 * Taps outside the image are dropped (the window is cut at the border).
 *
 * Tap weight of neighbour q for centre p (bilateral kernels, upsampling):
 *   w = exp(-0.5 * ((d * inv_s)^2 + (r * inv_z)^2 + (m * inv_n)^2)),
 *   d = |p - q| in full-resolution pixels, r = |z_q - z_p| / z_p (relative,
 *   so the filter does not depend on the world unit), m = max(0, 1 - n_p.n_q).
 * The centre pixel itself always weighs exactly 1, so the normaliser is >= 1.
 * The host clamps inv_* to [1e-30, 1e18]: every product above is then
 * finite or +inf, never NaN.
 *
 * Buffers (all float32, C order)
 *   ao      (H, W)        read   (bilateral_*, edge_aware_box)
 *   src     (H, W)        read   bilateral_cols: output of bilateral_rows
 *   ao_low  (Hl, Wl)      read   upsample: Hl = ceil(H / SCALE), Wl likewise;
 *                                low-res pixel (i, j) holds the AO of
 *                                full-res pixel (SCALE i, SCALE j)
 *   depth   (H, W)        read   full resolution
 *   normal  (H, W, 3)     read   unit world-space normals, full resolution
 *   out     (H, W)        written
 * Macros
 *   RADIUS  bilateral_*: window radius in pixels (0 .. 32);
 *           upsample: low-res taps per side (1 .. 8), rows
 *           i0 - RADIUS + 1 .. i0 + RADIUS with i0 = y / SCALE (likewise columns)
 *   HALF    edge_aware_box: size / 2 (size odd, 1 .. 65)
 *   SCALE   upsample: 2 or 4
 *   MIN_WEIGHT  upsample: total weight below which the fallback is used
 * Each program is built only with the macros its kernels use.
 */

/* weight of tap q for centre p; dist2 = squared pixel distance */
inline float tap_weight(const float dist2, const float zp, const float zq,
                        const float3 np, const float3 nq,
                        const float inv_s, const float inv_z, const float inv_n)
{
    const float a2 = dist2 * inv_s * inv_s;
    const float r = fabs(zq - zp) / zp * inv_z;
    const float m = fmax(0.0f, 1.0f - dot(np, nq)) * inv_n;
    return exp(-0.5f * (a2 + r * r + m * m));
}

#ifdef RADIUS
#ifndef SCALE
/* ---------------------------------------------------------------- bilateral */
__kernel void bilateral_2d(__global const float *ao, __global const float *depth,
                           __global const float *normal, const int W, const int H,
                           const float inv_s, const float inv_z, const float inv_n,
                           __global float *out)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= W || y >= H) return;
    const int p = y * W + x;
    const float zp = depth[p];
    if (!isfinite(zp)) { out[p] = ao[p]; return; }
    const float3 np = vload3(p, normal);
    float sum = ao[p], wsum = 1.0f;
    const int y0 = max(y - RADIUS, 0), y1 = min(y + RADIUS, H - 1);
    const int x0 = max(x - RADIUS, 0), x1 = min(x + RADIUS, W - 1);
    for (int qy = y0; qy <= y1; ++qy) {
        for (int qx = x0; qx <= x1; ++qx) {
            if (qx == x && qy == y) continue;
            const int q = qy * W + qx;
            const float zq = depth[q];
            if (!isfinite(zq)) continue;
            const float dist2 = (float)((qx - x) * (qx - x) + (qy - y) * (qy - y));
            const float w = tap_weight(dist2, zp, zq, np, vload3(q, normal), inv_s, inv_z, inv_n);
            sum += w * ao[q];
            wsum += w;
        }
    }
    out[p] = sum / wsum;
}

/* one 1-D pass of the separable approximation: taps p + k*(sx, sy), |k| <= RADIUS;
 * weights always compare the guide (depth, normal) of p with that of the tap */
inline void bilateral_line(__global const float *src, __global const float *depth,
                           __global const float *normal, const int W, const int H,
                           const float inv_s, const float inv_z, const float inv_n,
                           __global float *out, const int sx, const int sy)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= W || y >= H) return;
    const int p = y * W + x;
    const float zp = depth[p];
    if (!isfinite(zp)) { out[p] = src[p]; return; }
    const float3 np = vload3(p, normal);
    float sum = src[p], wsum = 1.0f;
    for (int k = -RADIUS; k <= RADIUS; ++k) {
        const int qx = x + k * sx, qy = y + k * sy;
        if (k == 0 || qx < 0 || qx >= W || qy < 0 || qy >= H) continue;
        const int q = qy * W + qx;
        const float zq = depth[q];
        if (!isfinite(zq)) continue;
        const float w = tap_weight((float)(k * k), zp, zq, np, vload3(q, normal),
                                   inv_s, inv_z, inv_n);
        sum += w * src[q];
        wsum += w;
    }
    out[p] = sum / wsum;
}

__kernel void bilateral_rows(__global const float *ao, __global const float *depth,
                             __global const float *normal, const int W, const int H,
                             const float inv_s, const float inv_z, const float inv_n,
                             __global float *out)
{
    bilateral_line(ao, depth, normal, W, H, inv_s, inv_z, inv_n, out, 1, 0);
}

__kernel void bilateral_cols(__global const float *src, __global const float *depth,
                             __global const float *normal, const int W, const int H,
                             const float inv_s, const float inv_z, const float inv_n,
                             __global float *out)
{
    bilateral_line(src, depth, normal, W, H, inv_s, inv_z, inv_n, out, 0, 1);
}
#endif /* !SCALE */
#endif /* RADIUS */

#ifdef HALF
/* ---------------------------------------------------------- edge-aware box */
/* Seed 002, section 4.5 (Listing 4.15): a plain mean over the window, counting
 * only neighbours q with |z_q - z_p| / z_p < depth_thr and n_p.n_q > normal_thr. */
__kernel void edge_aware_box(__global const float *ao, __global const float *depth,
                             __global const float *normal, const int W, const int H,
                             const float depth_thr, const float normal_thr,
                             __global float *out)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= W || y >= H) return;
    const int p = y * W + x;
    const float zp = depth[p];
    if (!isfinite(zp)) { out[p] = ao[p]; return; }
    const float3 np = vload3(p, normal);
    float sum = ao[p];
    int count = 1;
    const int y0 = max(y - HALF, 0), y1 = min(y + HALF, H - 1);
    const int x0 = max(x - HALF, 0), x1 = min(x + HALF, W - 1);
    for (int qy = y0; qy <= y1; ++qy) {
        for (int qx = x0; qx <= x1; ++qx) {
            if (qx == x && qy == y) continue;
            const int q = qy * W + qx;
            const float zq = depth[q];
            if (!isfinite(zq)) continue;
            if (fabs(zq - zp) / zp < depth_thr && dot(np, vload3(q, normal)) > normal_thr) {
                sum += ao[q];
                ++count;
            }
        }
    }
    out[p] = sum / (float)count;
}
#endif /* HALF */

#if defined(SCALE) && defined(RADIUS)
/* ------------------------------------------------ joint bilateral upsampling */
/* Low-res pixel (i, j) is the AO of full-res pixel (SCALE i, SCALE j); its guide
 * depth and normal are read from the full-res G-buffer there. Output pixel
 * (y, x) uses the low-res rows i0 - RADIUS + 1 .. i0 + RADIUS, i0 = y / SCALE
 * (and likewise columns), cut at the low-res border. When the total weight is
 * below MIN_WEIGHT, the tap with the closest depth |z_q - z_p| wins (ties: the
 * spatially nearest, then the first in row-major order); with no surface tap at
 * all the pixel gets `fill`, as do background pixels. */
__kernel void upsample_joint_bilateral(__global const float *ao_low,
                                       __global const float *depth,
                                       __global const float *normal,
                                       const int W, const int H, const int Wl, const int Hl,
                                       const float inv_s, const float inv_z, const float inv_n,
                                       const float fill, __global float *out)
{
    const int x = get_global_id(0), y = get_global_id(1);
    if (x >= W || y >= H) return;
    const int p = y * W + x;
    const float zp = depth[p];
    if (!isfinite(zp)) { out[p] = fill; return; }
    const float3 np = vload3(p, normal);
    const int i0 = y / SCALE, j0 = x / SCALE;
    const int ia = max(i0 - RADIUS + 1, 0), ib = min(i0 + RADIUS, Hl - 1);
    const int ja = max(j0 - RADIUS + 1, 0), jb = min(j0 + RADIUS, Wl - 1);
    float sum = 0.0f, wsum = 0.0f;
    float best = fill, best_dz = INFINITY;
    int best_d2 = INT_MAX;
    for (int i = ia; i <= ib; ++i) {
        for (int j = ja; j <= jb; ++j) {
            const int fy = SCALE * i, fx = SCALE * j;   /* < H, < W since i < Hl, j < Wl */
            const int q = fy * W + fx;
            const float zq = depth[q];
            if (!isfinite(zq)) continue;
            const int d2 = (fy - y) * (fy - y) + (fx - x) * (fx - x);
            const float a = ao_low[i * Wl + j];
            const float w = tap_weight((float)d2, zp, zq, np, vload3(q, normal),
                                       inv_s, inv_z, inv_n);
            sum += w * a;
            wsum += w;
            const float dz = fabs(zq - zp);
            if (dz < best_dz || (dz == best_dz && d2 < best_d2)) {
                best_dz = dz;
                best_d2 = d2;
                best = a;
            }
        }
    }
    out[p] = wsum >= MIN_WEIGHT ? sum / wsum : best;
}
#endif /* SCALE && RADIUS */

/* filters.cl -- edge-aware filters of a screen-space AO image, guided by the
 * G-buffer's depth and normal (DESIGN.md "Filtering"; seed 002, sections
 * 3.1.5 and 4.5, and the future work of its section 5.3).
 *
 * Kernels (all write only their own pixels; work-items outside the image
 * return at once)
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
 * Lanes (lanes.h; LANES from the host): a work-item filters LANES pixels of
 * one row as lane vectors, so that a tap loop runs over window offsets
 * shared by its lanes (PoCL's work-group vectoriser gives up on per-pixel
 * loops with per-pixel bounds; LANES = 1, one pixel a work-item, is the GPU
 * shape). 2-D range (ceil(W / LANES), H) for the bilateral and box kernels:
 * work-item (g, y) has the pixels x = g LANES + l of row y, l < LANES;
 * (SCALE ceil(Wl / LANES), H) for the upsampling (below). The tap
 * weight and every sum are the scalar code's, lane by lane, in the same
 * order (filter_math.h), so the output is the same bit for bit at every
 * width. Work-items whose lanes and taps all lie inside the row read whole
 * vectors; the others (near the left and right borders, and the row's tail
 * when W is not a multiple of LANES) read lane by lane at columns clamped
 * into the row, mask the taps outside the window and store only the lanes
 * inside the image: nothing is read or written out of bounds.
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
 *   normal  (3, H, W)     read   bilateral_*, edge_aware_box: unit world-space
 *                                normals, one plane per component
 *           (H, W, 3)     read   upsample: the same, interleaved
 *   depth_low (Hl, Wl), normal_low (3, Hl, Wl)   read   upsample: the guide
 *                                at the samples, depth[SCALE i, SCALE j] ...
 *   out     (H, W)        written
 * Macros
 *   RADIUS  bilateral_*: window radius in pixels (0 .. 32);
 *           upsample: low-res taps per side (1 .. 8), rows
 *           i0 - RADIUS + 1 .. i0 + RADIUS with i0 = y / SCALE (likewise columns)
 *   HALF    edge_aware_box: size / 2 (size odd, 1 .. 65)
 *   SCALE   upsample: 2 or 4
 *   MIN_WEIGHT  upsample: total weight below which the fallback is used
 *   LANES   1, 4, 8 or 16 (lanes.h); CPU_CLANG optional (cpu_clang.h)
 * Each program is built only with the macros its kernels use.
 */
#include "filter_math.h"

#define FINITE(z) MASK(FABS_V(z) < INFINITY)
#define IMAX(a, b) ((a) > (b) ? (a) : (b))

/* LOADU(p), STOREU(v, p): the lane vector at p, 4-byte aligned (vloadN /
 * vstoreN, which PoCL calls rather than inlines: inline forms on CPU_CLANG) */
#if CPU_CLANG && LANES > 1
typedef float fv_u __attribute__((ext_vector_type(LANES), aligned(4)));
#define LOADU(p) ((fv)(*(__global const fv_u *)(p)))
#define STOREU(v, p) (*(__global fv_u *)(p) = (v))
#else
#define LOADU(p) VLOAD(0, (p))
#define STOREU(v, p) VSTORE((v), 0, (p))
#endif

/* the lanes a[row + c + l], l < LANES: a whole vector where `inner` says
 * columns c .. c + LANES - 1 all lie in [0, W); else lane by lane, each
 * column clamped into [0, W) (the caller masks what is outside) */
__attribute__((always_inline)) inline fv row_load(__global const float *a, const int row,
                                                  const int c, const int W, const bool inner)
{
    if (inner) return LOADU(a + row + c);
    const iv col = VMIN(VMAX(c + LANE_IDS, (iv)(0)), (iv)(W - 1));
#if LANES == 1
    return a[row + col];
#else
#define ROW_LANE(l, u) a[row + col[l]]
    return LANE_GATHER(fv, ROW_LANE, 0);
#endif
}

/* the lanes' normals from the planes a, a + plane, a + 2 plane (row_load) */
__attribute__((always_inline)) inline fv3 normal_load(__global const float *a, const int plane,
                                                      const int row, const int c, const int W,
                                                      const bool inner)
{
    const fv3 n = {row_load(a, row, c, W, inner), row_load(a + plane, row, c, W, inner),
                   row_load(a + 2 * plane, row, c, W, inner)};
    return n;
}

/* store lanes v at a[row + c + l * step] for the lanes with c + l * step < W */
__attribute__((always_inline)) inline void row_store(const fv v, __global float *a, const int row,
                                                     const int c, const int step, const int W,
                                                     const bool whole)
{
#if LANES == 1
    a[row + c] = v;
#else
    if (whole && step == 1) {
        STOREU(v, a + row + c);
        return;
    }
    float lane[LANES] LANE_ARRAY;
    LANE_STORE(v, lane);
    for (int l = 0; l < LANES && c + l * step < W; ++l)
        a[row + c + l * step] = lane[l];
#endif
}

#if (defined(RADIUS) && !defined(SCALE)) || defined(HALF)
/* ------------------------------------------- bilateral and edge-aware box */
/* Pixels xb .. xb + LANES - 1 of row y; taps (qy, xb + l + dx) for the rows
 * qy within RY of y and |dx| <= RX, in the scalar code's order (rows, then
 * columns, both ascending), the centre left out. box = 0: bilateral weights
 * with (p0, p1, p2) = (inv_s, inv_z, inv_n); box = 1: the edge-aware box
 * with (p0, p1) = (depth_thr, normal_thr). inner: every tap column lies in
 * the row for every lane. A tap a lane must skip (background, outside the
 * window) leaves its sums as they are (VSEL: its value may be NaN or inf);
 * `sum + w * (aq - ap)` is the scalar `sum += w * (ao[q] - ao[p])`, fused or
 * not as the compiler fuses that. The sums are of differences from the
 * centre's value, the result ap + sum / wsum (ap itself where sum is 0, which
 * keeps a -0.0): a constant image comes out unchanged, bit for bit (summing
 * the values themselves moved a constant 0.9 by up to 600 ulps, 4e-5, in a
 * 65 x 65 box, and 72 in a 65 x 65 bilateral window; a few ulps at the
 * default sizes). */
__attribute__((always_inline)) inline void window_lanes(
    __global const float *src, __global const float *depth, __global const float *normal,
    const int W, const int H, const float p0, const float p1, const float p2,
    __global float *out, const int RX, const int RY, const int box, const bool inner,
    const int xb, const int y)
{
    const int HW = W * H, row = y * W;
    const fv zp = row_load(depth, row, xb, W, inner);
    const fv ap = row_load(src, row, xb, W, inner);
    const iv surf = FINITE(zp);
    if (!VANY(surf)) {                  /* background only: passed through */
        row_store(ap, out, row, xb, 1, W, xb + LANES <= W);
        return;
    }
    const fv3 np = normal_load(normal, HW, row, xb, W, inner);
    const iv xs = xb + LANE_IDS;
    fv sum = 0.0f, wsum = 1.0f;
    iv count = 1;
    const int y0 = IMAX(y - RY, 0), y1 = IMIN(y + RY, H - 1);
    for (int qy = y0; qy <= y1; ++qy) {
        const int qrow = qy * W, dy = qy - y;
#if LANES == 1
        /* one pixel: the window cut at the row's ends, as the scalar code did */
        for (int dx = IMAX(-RX, -xb); dx <= IMIN(RX, W - 1 - xb); ++dx) {
#else
        for (int dx = -RX; dx <= RX; ++dx) {
#endif
            if (dy == 0 && dx == 0) continue;
            const fv zq = row_load(depth, qrow, xb + dx, W, inner);
            iv ok = FINITE(zq);
            if (!inner) ok &= MASK(xs + dx >= 0) & MASK(xs + dx < W);
            const fv3 nq = normal_load(normal, HW, qrow, xb + dx, W, inner);
            const fv aq = row_load(src, qrow, xb + dx, W, inner);
            if (box) {
                ok &= MASK(FABS_V(zq - zp) / zp < p0) & MASK(DOT_V(np, nq) > p1);
                sum = VSEL(sum, sum + (aq - ap), ok);
                count -= ok;
            } else {
                const fv w = tap_weight_v((float)(dx * dx + dy * dy), zp, zq, np, nq, p0, p1, p2);
                sum = VSEL(sum, sum + w * (aq - ap), ok);
                wsum = VSEL(wsum, wsum + w, ok);
            }
        }
    }
    const fv res = VSEL(ap + (box ? sum / TO_FLOAT(count) : sum / wsum), ap, MASK(sum == 0.0f));
    row_store(VSEL(ap, res, surf), out, row, xb, 1, W, xb + LANES <= W);
}

/* the work-item's pixels, with a whole-vector copy of the loop where it can */
#define WINDOW_KERNEL(src, p0, p1, p2, RX, RY, box)                                           \
    const int xb = get_global_id(0) * LANES, y = get_global_id(1);                             \
    if (xb >= W || y >= H) return;                                                             \
    if (LANES == 1 || (xb - (RX) >= 0 && xb + LANES - 1 + (RX) < W))                           \
        window_lanes(src, depth, normal, W, H, p0, p1, p2, out, RX, RY, box, true, xb, y);     \
    else                                                                                       \
        window_lanes(src, depth, normal, W, H, p0, p1, p2, out, RX, RY, box, false, xb, y)
#endif

#if defined(RADIUS) && !defined(SCALE)
/* ---------------------------------------------------------------- bilateral */
__kernel void bilateral_2d(__global const float *ao, __global const float *depth,
                           __global const float *normal, const int W, const int H,
                           const float inv_s, const float inv_z, const float inv_n,
                           __global float *out)
{
    WINDOW_KERNEL(ao, inv_s, inv_z, inv_n, RADIUS, RADIUS, 0);
}

/* the 1-D passes of the separable approximation: taps p + k*(1, 0) (rows) or
 * p + k*(0, 1) (cols), |k| <= RADIUS; weights always compare the guide
 * (depth, normal) of p with that of the tap */
__kernel void bilateral_rows(__global const float *ao, __global const float *depth,
                             __global const float *normal, const int W, const int H,
                             const float inv_s, const float inv_z, const float inv_n,
                             __global float *out)
{
    WINDOW_KERNEL(ao, inv_s, inv_z, inv_n, RADIUS, 0, 0);
}

__kernel void bilateral_cols(__global const float *src, __global const float *depth,
                             __global const float *normal, const int W, const int H,
                             const float inv_s, const float inv_z, const float inv_n,
                             __global float *out)
{
    WINDOW_KERNEL(src, inv_s, inv_z, inv_n, 0, RADIUS, 0);
}
#endif /* RADIUS && !SCALE */

#ifdef HALF
/* ---------------------------------------------------------- edge-aware box */
/* Seed 002, section 4.5 (Listing 4.15): a plain mean over the window, counting
 * only neighbours q with |z_q - z_p| / z_p < depth_thr and n_p.n_q > normal_thr. */
__kernel void edge_aware_box(__global const float *ao, __global const float *depth,
                             __global const float *normal, const int W, const int H,
                             const float depth_thr, const float normal_thr,
                             __global float *out)
{
    WINDOW_KERNEL(ao, depth_thr, normal_thr, 0.0f, HALF, HALF, 1);
}
#endif /* HALF */

#if defined(SCALE) && defined(RADIUS)
/* ------------------------------------------------ joint bilateral upsampling */
/* Low-res pixel (i, j) is the AO of full-res pixel (SCALE i, SCALE j); its guide
 * depth and normal are those of the full-res G-buffer there (depth_low,
 * normal_low: the host's copies of them). Output pixel (y, x) uses the
 * low-res rows i0 - RADIUS + 1 .. i0 + RADIUS, i0 = y / SCALE (and likewise
 * columns), cut at the low-res border. When the total weight is below
 * MIN_WEIGHT, the tap with the closest depth |z_q - z_p| wins (ties: the
 * spatially nearest, then the first in row-major order); with no surface tap
 * at all the pixel gets `fill`, as do background pixels. The weighted mean is
 * summed as differences from the first surface tap's value, piv + sum w (a -
 * piv) / sum w, so that a constant image stays constant bit for bit (as in
 * window_lanes).
 *
 * Lanes: work-item (g, y), r = g % SCALE, jb = (g / SCALE) LANES, has the
 * pixels x = SCALE (jb + l) + r of row y (every SCALE-th pixel: j0 = jb + l),
 * so that tap k of every lane is the low-res column j0 + k (consecutive
 * across the lanes, one vector load) at the same offset SCALE k - r from the
 * lane's x (the same spatial weight). Range (SCALE ceil(Wl / LANES), H); at
 * LANES = 1 work-item g is pixel x = g. */
__attribute__((always_inline)) inline void upsample_lanes(
    __global const float *ao_low, __global const float *depth, __global const float *normal,
    __global const float *depth_low, __global const float *normal_low,
    const int W, const int Wl, const int Hl, const float inv_s, const float inv_z,
    const float inv_n, const float fill, __global float *out, const bool inner,
    const int jb, const int r, const int y)
{
    const int HWl = Hl * Wl, row = y * W;
    /* the lanes' pixels, those beyond the image clamped to its last column */
    const iv js = jb + LANE_IDS, xs = SCALE * js + r;
    const iv pc = row + VMIN(xs, (iv)(W - 1));
#if LANES == 1
    const fv zp = depth[pc];
    const fv3 np = {normal[3 * pc], normal[3 * pc + 1], normal[3 * pc + 2]};
#else
#define DEPTH_LANE(l, u) depth[pc[l]]
#define NORMAL_LANE(l, c) normal[3 * pc[l] + (c)]
    const fv zp = LANE_GATHER(fv, DEPTH_LANE, 0);
    const fv3 np = {LANE_GATHER(fv, NORMAL_LANE, 0), LANE_GATHER(fv, NORMAL_LANE, 1),
                    LANE_GATHER(fv, NORMAL_LANE, 2)};
#endif
    const iv surf = FINITE(zp);
    if (!VANY(surf)) {                  /* background only */
        row_store((fv)(fill), out, row, SCALE * jb + r, SCALE, W, false);
        return;
    }
    const int i0 = y / SCALE;
    const int ia = IMAX(i0 - RADIUS + 1, 0), ib = IMIN(i0 + RADIUS, Hl - 1);
    fv sum = 0.0f, wsum = 0.0f, piv = 0.0f;   /* piv: the first surface tap's value */
    iv have = 0;
    fv best = fill, best_dz = INFINITY;
    iv best_d2 = INT_MAX;
    for (int i = ia; i <= ib; ++i) {
        const int lrow = i * Wl, fy = SCALE * i - y;
        for (int k = 1 - RADIUS; k <= RADIUS; ++k) {
            const fv zq = row_load(depth_low, lrow, jb + k, Wl, inner);
            iv ok = FINITE(zq);
            if (!inner) ok &= MASK(js + k >= 0) & MASK(js + k < Wl);
            const fv3 nq = normal_load(normal_low, HWl, lrow, jb + k, Wl, inner);
            const fv a = row_load(ao_low, lrow, jb + k, Wl, inner);
            const int fx = SCALE * k - r, d2 = fy * fy + fx * fx;
            const fv w = tap_weight_v((float)d2, zp, zq, np, nq, inv_s, inv_z, inv_n);
            piv = VSEL(piv, a, ok & ~have);
            have |= ok;
            sum = VSEL(sum, sum + w * (a - piv), ok);
            wsum = VSEL(wsum, wsum + w, ok);
            const fv dz = FABS_V(zq - zp);
            const iv closer = ok & (MASK(dz < best_dz) | (MASK(dz == best_dz) & MASK(d2 < best_d2)));
            best_dz = VSEL(best_dz, dz, closer);
            best_d2 = VSEL(best_d2, (iv)(d2), closer);
            best = VSEL(best, a, closer);
        }
    }
    fv res = VSEL(best, VSEL(piv + sum / wsum, piv, MASK(sum == 0.0f)), MASK(wsum >= MIN_WEIGHT));
    res = VSEL((fv)(fill), res, surf);
    row_store(res, out, row, SCALE * jb + r, SCALE, W, false);
}

__kernel void upsample_joint_bilateral(__global const float *ao_low,
                                       __global const float *depth,
                                       __global const float *normal,
                                       __global const float *depth_low,
                                       __global const float *normal_low,
                                       const int W, const int H, const int Wl, const int Hl,
                                       const float inv_s, const float inv_z, const float inv_n,
                                       const float fill, __global float *out)
{
    const int g = get_global_id(0), y = get_global_id(1);
    const int r = g % SCALE, jb = (g / SCALE) * LANES;
    if (SCALE * jb + r >= W || y >= H) return;
    if (jb + 1 - RADIUS >= 0 && jb + LANES - 1 + RADIUS < Wl && SCALE * (jb + LANES - 1) + r < W)
        upsample_lanes(ao_low, depth, normal, depth_low, normal_low, W, Wl, Hl, inv_s, inv_z,
                       inv_n, fill, out, true, jb, r, y);
    else
        upsample_lanes(ao_low, depth, normal, depth_low, normal_low, W, Wl, Hl, inv_s, inv_z,
                       inv_n, fill, out, false, jb, r, y);
}
#endif /* SCALE && RADIUS */

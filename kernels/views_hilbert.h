/* views_hilbert.h -- the map nearest a direction on a Hilbert view set
 * (layout 1, or 2 over two hemispheres: views.ViewSet.hilbert), O(1): the
 * direction's cell of the equal-area octahedral grid and its 3 x 3
 * neighbours (cells: hilbert cell -> map index) are the candidates, the
 * largest dot product with a map axis wins. Scalar code, one query at a
 * time (the lane kernels call it lane by lane).
 *
 *   nearest_hilbert()  the nearest map (one-texel lookups)
 *   window_hilbert()   FILTERED only: the four nearest and their weights
 *                      (views.ViewSet.filter_window)
 * Expects: LAYOUT_HILBERT (0: nothing is compiled), FILTERED, and with it
 * FILTER_ANGLE_EPS (float, views.FILTER_ANGLE_EPS).
 */
#ifndef PYSHADOW_VIEWS_HILBERT_H
#define PYSHADOW_VIEWS_HILBERT_H

#include "views_common.h"

#pragma OPENCL FP_CONTRACT OFF

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

/* map indices of the 3 x 3 cells around the cell of unit direction w
 * (views.ViewSet._hilbert_candidates), in the scan order of views.py */
inline void hilbert_candidates(__global const int *cells, int cbase, int level, int split, float3 w,
                               int *k9)
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
    for (int di = -1; di <= 1; ++di)
        for (int dj = -1; dj <= 1; ++dj)
            k9[3 * (di + 1) + dj + 1] = cells[cbase + hilbert_cell(split, n, ci + di, cj + dj, h)];
}

inline int nearest_hilbert(__global const float *bases, int vbase, __global const int *cells,
                           int cbase, int level, int split, float3 w)
{
    int k9[9];
    hilbert_candidates(cells, cbase, level, split, w, k9);
    int best = 0;
    float bd = -2.0f;
    for (int c = 0; c < 9; ++c) {
        const float dd = dot(bases_row(bases, vbase + k9[c], 2), w);
        if (dd > bd) { bd = dd; best = k9[c]; }
    }
    return best;
}

#if FILTERED
/* the four of those cells nearest w, nearest first (ties: scan order), with
 * their unnormalised weights 1 / (angle + FILTER_ANGLE_EPS)
 * (views.ViewSet.filter_window) */
inline void window_hilbert(__global const float *bases, int vbase, __global const int *cells,
                           int cbase, int level, int split, float3 w, int *k4, float *w4)
{
    int k9[9];
    hilbert_candidates(cells, cbase, level, split, w, k9);
    float d4[4] = {-3.0f, -3.0f, -3.0f, -3.0f};
    for (int c = 0; c < 9; ++c) {
        const float dd = dot(bases_row(bases, vbase + k9[c], 2), w);
        int pos = 4;
        for (int p = 3; p >= 0; --p) if (dd > d4[p]) pos = p;
        for (int p = 3; p > pos; --p) { d4[p] = d4[p - 1]; k4[p] = k4[p - 1]; }
        if (pos < 4) { d4[pos] = dd; k4[pos] = k9[c]; }
    }
    for (int p = 0; p < 4; ++p)
        w4[p] = 1.0f / (2.0f * asin(min(0.5f * distance(w, bases_row(bases, vbase + k4[p], 2)), 1.0f))
                        + FILTER_ANGLE_EPS);
}
#endif
#endif

#endif

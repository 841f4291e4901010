/* sampling.cl -- the sample directions the AO kernel traces, written out.
 *
 * sample_directions  one work-item per point: for each of its SAMPLES 2-D
 *                    points (pattern pidx[i] of the table) the world-space
 *                    cosine-weighted direction of sampling.h.
 * Buffers
 *   normals float (N, 3) unit; read      pidx  int (N); read (validated)
 *   table   float (M, SAMPLES, 3) local directions; read
 *   out     float (N, SAMPLES, 3); written
 * Macros: SAMPLES (1 .. 4096)
 */
#include "sampling.h"

__kernel void sample_directions(__global const float *normals, __global const int *pidx,
                                __global const float *table, const int n_points,
                                __global float *out)
{
    const int i = get_global_id(0);
    if (i >= n_points) return;
    const float3 n = vload3(i, normals);
    float3 t, b;
    hemisphere_frame(n, &t, &b);
    __global const float *pat = table + (size_t)pidx[i] * SAMPLES * 3;
    for (int s = 0; s < SAMPLES; ++s) {
        const float3 w = cosine_direction(n, t, b, vload3(s, pat));
        vstore3(w, (size_t)i * SAMPLES + s, out);
    }
}

/* sampling.h -- cosine-weighted hemisphere directions from 2-D sample points
 * (thesis 000, eq. 5.9 and the combined form after it), shared by the AO
 * kernel and sample_directions so both trace bit-identical directions.
 *
 * Frame of a unit normal n (Duff et al. 2017, branch-free):
 *   s = sign(n.z) (+1 at 0), a = -1/(s + n.z), c = n.x n.y a,
 *   t = (1 + s n.x^2 a, s c, -s n.x),  b = (c, s + n.y^2 a, -n.y).
 * Local direction (x, y, z) = (sqrt(xi1) cos 2pi xi2, sqrt(1-xi1),
 * sqrt(xi1) sin 2pi xi2), y along n, is computed on the host (float64, then
 * rounded to float32) into the pattern table, so the device only multiplies
 * and adds: world = x t + y n + z b.
 * Macros: none.
 */
#ifndef PYSHADOW_SAMPLING_H
#define PYSHADOW_SAMPLING_H

#pragma OPENCL FP_CONTRACT OFF

inline void hemisphere_frame(float3 n, float3 *t, float3 *b)
{
    const float s = (n.z >= 0.0f) ? 1.0f : -1.0f;
    const float a = -1.0f / (s + n.z);
    const float c = n.x * n.y * a;
    *t = (float3)(1.0f + s * n.x * n.x * a, s * c, -s * n.x);
    *b = (float3)(c, s + n.y * n.y * a, -n.y);
}

inline float3 cosine_direction(float3 n, float3 t, float3 b, float3 loc)
{
    return (loc.x * t + loc.y * n) + loc.z * b;
}

#endif

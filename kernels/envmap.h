/* envmap.h -- nearest-texel radiance of a lat-long environment map, for the
 * "sampled" sky of scene_ao (SKY_SAMPLED, visibility.cl).
 *
 * The texel rule of pyshadow.lighting.EnvironmentMap.texel_index, in float:
 * for a direction w (y up, normalised here),
 *   theta = acos(clamp(y, -1, 1)), phi = atan2(z, x) mod 2 pi,
 *   i = clamp(floor(theta h / pi), 0, h - 1), j = floor(phi w / 2 pi) mod w.
 * env: float (h, w, 3) RGB radiance, row i from theta = 0 (+y). i is clamped
 * and j taken mod w, so the read stays inside (h, w) whatever the direction.
 * Directions within float rounding of a texel edge may take the neighbouring
 * texel of the host's float64 rule.
 * Macros: none.
 */
#ifndef PYSHADOW_ENVMAP_H
#define PYSHADOW_ENVMAP_H

#include "vec3.h"

inline float3 envmap_latlong(__global const float *env, int h, int w, float x, float y, float z)
{
    const float inv = 1.0f / sqrt(x * x + y * y + z * z);
    x *= inv; y *= inv; z *= inv;
    const float th = acos(clamp(y, -1.0f, 1.0f));
    float ph = atan2(z, x);
    if (ph < 0.0f) ph += 2.0f * M_PI_F;
    const int i = clamp((int)floor(th * ((float)h / M_PI_F)), 0, h - 1);
    const int j = ((int)floor(ph * ((float)w / (2.0f * M_PI_F)))) % w;
    return row3(env, (size_t)i * w + j);
}

#endif

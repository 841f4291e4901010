/* csm_map.h -- a lookup's arithmetic against one map (csm_lookup.h):
 *
 *   map_frame_v()    a point seen from a map: axis, depth, texel coordinates
 *   bias_v()         the depth tolerance of a lane against a map (with
 *                    SURFACE_NORMALS and PLANE_BIAS, the receiver's plane's
 *                    at each tap: tap_bias_v())
 *   sort4_heaviest_first()  the vote's ordering of maps and taps (FILTERED)
 *   surface_rule_v() rays leaving their own body's surface (SURFACE_NORMALS)
 *
 * Expects what csm_lookup.h expects (it includes this file); NTYPES > 0.
 */
#ifndef PYSHADOW_CSM_MAP_H
#define PYSHADOW_CSM_MAP_H

#include "lanes.h"
#include "scene_tables.h"

#if NTYPES
#if SURFACE_NORMALS
#ifndef PLANE_BIAS
#error "PLANE_BIAS (0/1: the plane's bias of bias_v) must be defined by the host"
#endif
#if PLANE_BIAS && !defined(PLANE_BIAS_TEXELS)
#error "PLANE_BIAS_TEXELS (pyshadow.csm.core) must be defined by the host"
#endif
#define NORMAL_LIFT_PARAMS , iv up, fv ox, fv oy, fv oz, float btex, fv *pu, fv *pv, fv *pe
#define NORMAL_BIAS_PARAMS , iv up, float btex
#else
#define NORMAL_LIFT_PARAMS
#define NORMAL_BIAS_PARAMS
#endif

/* each lane's point (qx, qy, qz) seen from its map ka[l] (bases: the CSM
 * type's first map): the map axis d, the point's depth (1 - q.d) / 2 and
 * the texel coordinates (fx, fy) in [0, R)^2 of its texel point (tx, ty, tz)
 * (q, or its chord's midpoint: instance_v); lanes (-1) where the texel point
 * lies inside the map's square and the point behind the sphere's front.
 * With SURFACE_NORMALS, the lanes of `up` (a ray leaving this body's own
 * surface, unit normal (ox, oy, oz) in the object frame) are first lifted
 * off the surface along the normal by
 *     max(0, SURFACE_LIFT_TEXELS (|m.u| + |m.v|) - btex (m.d))  texels
 * (u, v, d the map's rows): the least lift after which the texel centres
 * within SURFACE_LIFT_TEXELS of the point on each map axis pass above the
 * tangent plane by more than the depth bias btex covers -- none for a map
 * that looks at the surface steeply, up to about 0.7 texel for a grazing one.
 * With PLANE_BIAS and the default bias (btex > 0) they are not lifted: the
 * receiver's plane through the point instead, whose depth grows by
 * (pu dx + pv dy + pe) / R at (dx, dy) texels from the texel point
 * (pe: the texel point's offset from the point, finite rays); tap_bias_v(). */
__attribute__((always_inline))
inline iv map_frame_v(__global const float *bases, const int *ka, int R, fv qx, fv qy, fv qz,
                      fv tx, fv ty, fv tz,
                      fv *dx, fv *dy, fv *dz, fv *depth, fv *fx, fv *fy NORMAL_LIFT_PARAMS)
{
    __global const float *B[LANES];             /* each lane's map: rows u, v, d */
    for (int l = 0; l < LANES; ++l)
        B[l] = bases + 9 * ka[l];
#define BASIS(l, c) B[l][c]
    *dx = LANE_GATHER(fv, BASIS, 6); *dy = LANE_GATHER(fv, BASIS, 7); *dz = LANE_GATHER(fv, BASIS, 8);
    const fv ux = LANE_GATHER(fv, BASIS, 0), uy = LANE_GATHER(fv, BASIS, 1), uz = LANE_GATHER(fv, BASIS, 2);
    const fv vx = LANE_GATHER(fv, BASIS, 3), vy = LANE_GATHER(fv, BASIS, 4), vz = LANE_GATHER(fv, BASIS, 5);
#undef BASIS
#if SURFACE_NORMALS
    const fv sd = ox * *dx + oy * *dy + oz * *dz;
#if PLANE_BIAS
    const int plane = btex > 0.0f;
#else
    const int plane = 0;
#endif
    if (plane) {
        const fv od = VMIN(VMAX(sd, (fv)(1e-3f)), (fv)(1.0f));
        *pu = VSEL((fv)(0.0f), (ox * ux + oy * uy + oz * uz) / od, up);
        *pv = VSEL((fv)(0.0f), (ox * vx + oy * vy + oz * vz) / od, up);
        *pe = -(*pu * ((qx - tx) * ux + (qy - ty) * uy + (qz - tz) * uz)
                + *pv * ((qx - tx) * vx + (qy - ty) * vy + (qz - tz) * vz)) * (0.5f * (float)R);
    } else {
        const fv lt = VABS(ox * ux + oy * uy + oz * uz) + VABS(ox * vx + oy * vy + oz * vz);
        const fv h = VMAX((fv)(SURFACE_LIFT_TEXELS) * lt - btex * sd, (fv)(0.0f)) * (2.0f / (float)R);
        const iv lift = up & MASK(sd > 0.0f);
        qx = VSEL(qx, qx + h * ox, lift);
        qy = VSEL(qy, qy + h * oy, lift);
        qz = VSEL(qz, qz + h * oz, lift);
        tx = VSEL(tx, tx + h * ox, lift);
        ty = VSEL(ty, ty + h * oy, lift);
        tz = VSEL(tz, tz + h * oz, lift);
        *pu = *pv = *pe = (fv)(0.0f);
    }
#endif
    *depth = (1.0f - (qx * *dx + qy * *dy + qz * *dz)) * 0.5f;
    *fx = (tx * ux + ty * uy + tz * uz + 1.0f) * (0.5f * (float)R);
    *fy = (tx * vx + ty * vy + tz * vz + 1.0f) * (0.5f * (float)R);
    return MASK(*depth > 0.0f) & MASK(*fx >= 0.0f) & MASK(*fx < (float)R) & MASK(*fy >= 0.0f)
           & MASK(*fy < (float)R);
}

/* depth tolerance of each lane for map axis (dx, dy, dz): against the
 * point's own surface a quantum, a share of a texel and the angle a between
 * the query direction and the map's axis; against other casters only
 * bias_other (the quantum). With SURFACE_NORMALS and PLANE_BIAS and the
 * default bias (btex > 0), the lanes of `up` (on their own surface, unit
 * normal known) take the quantum plus PLANE_BIAS_TEXELS and the same term
 * in a, to which tap_bias_v() adds their plane's depth at each tap's centre
 * (pyshadow.csm.core gives the derivation): a wall beside the point is seen
 * wherever it rises above the point's plane */
__attribute__((always_inline)) inline fv tan_of_cos_v(fv c)    /* the cosine clamped to [1e-3, 1] */
{
    c = VMIN(VMAX(c, (fv)(1e-3f)), (fv)(1.0f));
    return VSQRT(VMAX(1.0f - c * c, (fv)(0.0f))) / c;
}

inline fv bias_v(const scene_t *S, int R, iv j, iv own, fv vx, fv vy, fv vz, fv dx, fv dy, fv dz NORMAL_BIAS_PARAMS)
{
    const fv tan_a = tan_of_cos_v(vx * dx + vy * dy + vz * dz);
    fv bias_self = S->bias_abs + (S->bias_texels + S->bias_tan * tan_a) / (float)R;
#if SURFACE_NORMALS && PLANE_BIAS
    if (btex > 0.0f)
        bias_self = VSEL(bias_self, S->bias_abs + (PLANE_BIAS_TEXELS + S->bias_tan * tan_a) / (float)R, up);
#endif
    return VSEL((fv)(S->bias_other), bias_self, MASK(own == -1) | MASK(own == j));
}

#if SURFACE_NORMALS && PLANE_BIAS
/* the bias b of a tap whose texel centre lies (cx, cy) texels from the
 * texel point: b less the plane's rise there (map_frame_v's pu, pv, pe),
 * at least the quantum. The lanes without a plane (pu = pv = pe = 0) keep b. */
__attribute__((always_inline))
inline fv tap_bias_v(const scene_t *S, int R, fv b, fv pu, fv pv, fv pe, fv cx, fv cy)
{
    return VMAX(b - (pu * cx + pv * cy + pe) / (float)R, (fv)(S->bias_abs));
}
#endif

#if FILTERED
/* floor(x) of texel coordinates (x in [-1, R)): the truncation, less one
 * where it lies above x -- the builtin's value, inline (PoCL calls its
 * library's floor, and the call spills the live vector registers) */
__attribute__((always_inline)) inline fv floor_texel_v(fv x)
{
    const fv t = CONVERT(float, CONVERT(int, x));
    return VSEL(t, t - 1.0f, MASK(t > x));
}

/* sort four (weight w[i], item x[i], and z[i] unless z is 0) lane vectors by
 * weight, heaviest first (a sorting network) */
inline void sort4_heaviest_first(fv *w, iv *x, fv *z)
{
    const int pairs[5][2] = {{0, 1}, {2, 3}, {0, 2}, {1, 3}, {1, 2}};
    for (int p = 0; p < 5; ++p) {
        const int a = pairs[p][0], b = pairs[p][1];
        const iv swap = MASK(w[b] > w[a]);
        const fv wa = VSEL(w[a], w[b], swap), wb = VSEL(w[b], w[a], swap);
        const iv xa = VSEL(x[a], x[b], swap), xb = VSEL(x[b], x[a], swap);
        w[a] = wa; w[b] = wb; x[a] = xa; x[b] = xb;
        if (z) {
            const fv za = VSEL(z[a], z[b], swap), zb = VSEL(z[b], z[a], swap);
            z[a] = za; z[b] = zb;
        }
    }
}
#endif

#if SURFACE_NORMALS
/* The surface rule (SURFACE_NORMALS): for the lanes whose point lies on
 * its instance j (own == j, or -1: unknown; horizon hs) with a known unit
 * normal ((ox, oy, oz) in the object frame: instance_v turns the world
 * normal) and a direction v above its tangent plane (s = v.o > 0) -- the
 * lanes `up`:
 *   - the lookup direction is raised to the elevation hs (sine) where the
 *     ray is lower: every map the lookup may then pick (the
 *     nearest, or the four of the vote's window) lies above the tangent
 *     plane. A map below the plane looks at the surface from behind, and
 *     the body would shadow every grazing ray over it;
 *   - map_frame_v() lifts the point off its surface where the map is
 *     grazing (NORMAL_LIFT_ARGS).
 * Other lanes are unchanged. */
inline iv surface_rule_v(fv hs, iv j, iv own, const fv *ox, const fv *oy, const fv *oz, fv *vx, fv *vy, fv *vz)
{
    const fv s = *vx * *ox + *vy * *oy + *vz * *oz;
    const iv up = (MASK(own == -1) | MASK(own == j)) & MASK(s > 0.0f);
    /* raise: the tangential part scaled to cos(horizon), the normal part sin(horizon) */
    const iv low = up & MASK(s < hs);
    if (!VANY(low)) return up;          /* most rays: none of the lanes is that low */
    const fv tx = *vx - s * *ox, ty = *vy - s * *oy, tz = *vz - s * *oz;
    const fv tl = VSQRT(tx * tx + ty * ty + tz * tz);
    const fv k = VSEL((fv)(0.0f), VSQRT(1.0f - hs * hs) / VMAX(tl, (fv)(1e-30f)), low);
    *vx = VSEL(*vx, k * tx + hs * *ox, low);
    *vy = VSEL(*vy, k * ty + hs * *oy, low);
    *vz = VSEL(*vz, k * tz + hs * *oz, low);
    return up;
}
#define NORMAL_PARAMS , fv mx, fv my, fv mz
#define NORMAL_LIFT_ARGS , up, ox, oy, oz, S->bias_texels, &pu, &pv, &pe
#define NORMAL_BIAS_ARGS , up, S->bias_texels
#define NORMAL_PLANE_DECL fv pu, pv, pe;
#else
#define NORMAL_PARAMS
#define NORMAL_LIFT_ARGS
#define NORMAL_BIAS_ARGS
#define NORMAL_PLANE_DECL
#endif

#endif  /* NTYPES */
#endif

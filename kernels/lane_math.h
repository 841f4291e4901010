/* lane_math.h -- elementary functions on lane vectors (lanes.h) as inline
 * polynomials, where PoCL would call its builtins; each to the accuracy
 * stated (the zigzag nearest-map scheme of views_zigzag.h uses them).
 *
 *   acos_v(x)              acos to 5e-5 rad
 *   atan2_pos_v(y, x)      atan2 in [0, 2 pi) to 1e-5 rad
 *   cos_small, sin_small   of |d| < 0.2 to 1e-8
 * Expects: LANES (lanes.h); PI_F comes from views_common.h.
 */
#ifndef PYSHADOW_LANE_MATH_H
#define PYSHADOW_LANE_MATH_H

#include "lanes.h"
#include "views_common.h"

#pragma OPENCL FP_CONTRACT OFF

/* acos to 5e-5 rad (Abramowitz & Stegun 4.4.45) */
inline fv acos_v(fv x)
{
    const fv a = VABS(x);
    const fv r = VSQRT(1.0f - a) * (1.5707288f + a * (-0.2121144f + a * (0.0742610f - 0.0187293f * a)));
    return VSEL(r, PI_F - r, MASK(x < 0.0f));
}

/* atan2 in [0, 2 pi) to 1e-5 rad (A&S 4.4.49 after octant reduction) */
inline fv atan2_pos_v(fv y, fv x)
{
    const fv ax = VABS(x), ay = VABS(y);
    const fv mx = VMAX(ax, ay);
    const fv t = VMIN(ax, ay) / VSEL(mx, (fv)(1.0f), MASK(mx == 0.0f));
    const fv t2 = t * t;
    fv r = t * (0.9998660f + t2 * (-0.3302995f + t2 * (0.1801410f + t2 * (-0.0851330f + t2 * 0.0208351f))));
    r = VSEL(r, 0.5f * PI_F - r, MASK(ay > ax));
    r = VSEL(r, PI_F - r, MASK(x < 0.0f));
    return VSEL(r, 2.0f * PI_F - r, MASK(y < 0.0f));
}

/* cos and sin of a small angle d (|d| < 0.2: error below 1e-8) */
inline fv cos_small(fv d) { const fv d2 = d * d; return 1.0f - d2 * (0.5f - d2 * (1.0f / 24.0f - d2 * (1.0f / 720.0f))); }
inline fv sin_small(fv d) { const fv d2 = d * d; return d * (1.0f - d2 * (1.0f / 6.0f - d2 * (1.0f / 120.0f))); }

#endif

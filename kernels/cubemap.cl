/* cubemap.cl -- rays marched through a cube-map probe (pyshadow.cubemap,
 * the "raymarch" estimator; seed 002 section 4.3 with pyshadow's own sample
 * directions in place of its horizon search).
 *
 * Kernel
 *   cubemap_march   one work-item per RAY, 1-D range (>= n_rays); work-items
 *                   with gid >= n_rays return at once. Each marches its ray
 *                   q_k = o + t_k w, t_{k+1} = min(D, t_k + max(step * 2 r_k / R,
 *                   D / max_steps)), r_k = |q_k| (the probe's centre is the
 *                   origin), and stops at the first occluded q_k or at t = D.
 *                   The occlusion rule is pyshadow.cubemap.estimators'
 *                   (module docstring): q_k's texel shows a caster, q_k lies
 *                   more than bias r_k behind the texel's surface, and either
 *                   the previous march point was in front of that surface or
 *                   q_k lies at most tau behind it. The surface depth of a
 *                   texel along a unit direction u is its plane's,
 *                   h / (n.u), unless that is not > 0, or u is the previous
 *                   march point's (it may lie outside the texel) and
 *                   |n.u| < GRAZING (0.1): then the stored centre depth.
 *
 * Texel of a direction d (pyshadow.cubemap.probe.direction_texels): the face
 * of the largest |component| (x before y before z on ties; + then -), then
 * x = d.right / d.fwd, y = d.up / d.fwd, col = floor((x + 1) R / 2),
 * row = floor((1 - y) R / 2), both clamped to 0 .. R-1, so every read is
 * inside the 6 R^2 texel arrays whatever the float rounding.
 *
 * Buffers (float32 / uchar, C order)
 *   plane    (6 R R, 4) float  read   texel normal (xyz, unit, facing the probe)
 *                                     and h = n . (P - c) in w; 0 where empty
 *   depth    (6 R R)    float  read   centre-ray distance, +inf where empty
 *   occluder (6 R R)    uchar  read   1: the texel shows a caster
 *   frames   (6, 3, 3)  float  read   rows right, up, forward of each face
 *   origin   (N, 3)     float  read   ray origins relative to the probe centre
 *   dir      (N, 3)     float  read   unit ray directions
 *   visible  (N)        uchar  write  1 = no caster within D, 0 = occluded
 *
 * Macros: none (R, D, step, bias, tau and max_steps are arguments).
 */

#define GRAZING 0.1f

static int texel_of(float3 d, const int R, __global const float *frames)
{
    float3 a = fabs(d);
    int axis = (a.x >= a.y && a.x >= a.z) ? 0 : ((a.y >= a.z) ? 1 : 2);
    float comp = axis == 0 ? d.x : (axis == 1 ? d.y : d.z);
    int face = 2 * axis + (comp < 0.0f ? 1 : 0);
    __global const float *f = frames + 9 * face;
    float3 right = (float3)(f[0], f[1], f[2]);
    float3 up = (float3)(f[3], f[4], f[5]);
    float3 fwd = (float3)(f[6], f[7], f[8]);
    float fz = dot(d, fwd);
    float x = dot(d, right) / fz;
    float y = dot(d, up) / fz;
    float cf = floor((x + 1.0f) * 0.5f * (float)R);
    float rf = floor((1.0f - y) * 0.5f * (float)R);
    int col = (int)clamp(cf, 0.0f, (float)(R - 1));
    int row = (int)clamp(rf, 0.0f, (float)(R - 1));
    return (face * R + row) * R + col;
}

static float surface_depth(float4 pl, float zc, float3 u, float grazing)
{
    float den = dot(pl.xyz, u);
    float zp = pl.w / den;
    if (fabs(den) >= grazing && zp > 0.0f && isfinite(zc) && isfinite(zp))
        return zp;
    return zc;
}

__kernel void cubemap_march(__global const float4 *plane, __global const float *depth,
                            __global const uchar *occluder, __global const float *frames,
                            __global const float *origin, __global const float *dir,
                            const int n_rays, const int R, const float D, const float step,
                            const float bias, const float tau, const int max_steps,
                            __global uchar *visible)
{
    int gid = get_global_id(0);
    if (gid >= n_rays)
        return;
    float3 o = vload3(gid, origin);
    float3 w = vload3(gid, dir);
    float r = length(o);
    float3 uprev = o / fmax(r, 1e-30f);
    float t = 0.0f;
    float min_step = D / (float)max_steps;
    uchar vis = 1;
    for (int k = 0; k <= max_steps; k++) {
        float dt = fmax(step * 2.0f * r / (float)R, min_step);
        float tn = fmin(t + dt, D);
        float3 q = o + tn * w;
        float rn = length(q);
        float3 un = q / fmax(rn, 1e-30f);
        int flat = texel_of(un, R, frames);
        float4 pl = plane[flat];
        float zc = depth[flat];
        float z = surface_depth(pl, zc, un, 0.0f);         /* un lies in the texel: its plane */
        float zprev = surface_depth(pl, zc, uprev, GRAZING);
        float b = bias * rn;
        if (occluder[flat] && rn > z + b && (r <= zprev + b || rn - z <= tau)) {
            vis = 0;
            break;
        }
        t = tn;
        r = rn;
        uprev = un;
        if (tn >= D)
            break;
    }
    visible[gid] = vis;
}

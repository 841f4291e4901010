/* shadow_map.cl -- the classic scene shadow map: render the casters' depth
 * from the light, then look surface points up in it (hard or PCF).
 *
 * Kernels
 *   sm_raster   one work-item per triangle; walks the texel centres in its
 *               screen bounding box (watertight edge rule of raster_common.h)
 *               and keeps the nearest depth per texel by atomic_min on the
 *               depth's bit pattern (depths are >= 0, and non-negative
 *               floats order like their bit patterns).
 *   sm_lookup   one work-item per point: the lit fraction of the PCF taps
 *               (1 tap: the hard answer, 0 or 1).
 *
 * Maps (argument `cube`)
 *   0  orthographic map of a directional light. A corner q of a triangle is
 *      moved by the affine map m (3 rows of 4: texel column, texel row,
 *      depth) into texel space: texel (row i, column j) has its centre at
 *      (j, i); depth is the distance along the light's travel direction from
 *      a plane in front of every caster (>= 0; clamped at 0).
 *   1  cube map of a point light, six faces of R x R texels, face-major.
 *      Triangles arrive in a face's camera space (x right, y up, z forward,
 *      light at the origin, clipped to z >= near by the host; m is the
 *      identity then); screen (j, i) = (x/z f + R/2 - 0.5, R/2 - 0.5 - y/z f)
 *      with f = R/2 (90 degree faces); the stored depth is z, the distance
 *      along the face's axis.
 *
 * Lookup (the receiver-plane rule; pyshadow/lighting/shadow_map.py explains
 * it): a tap is the texel nearest to the point shifted by (dj, di) texels.
 * With normals, the receiver's depth at the tap's texel centre is the depth
 * of the point's tangent plane there (a change of at most TAN_MAX per unit
 * of lateral distance); without, the point's own depth. The tap is lit when
 * receiver depth - eps <= stored depth (+inf where no caster), with
 * eps = eps_world + eps_texels * (the world size of a texel at the tap).
 * Orthographic taps outside the map are lit (no caster projects there); a
 * cube tap is looked up on the face its receiver point lies in.
 *
 * Buffers
 *   tris    float (T, 9)   corners a, b, c (object frame, or face camera space); read
 *   m       float (12)     rows of the affine map to texel space; read
 *   zbuf    uint (F, R, R) depth bits, filled with +inf by the host; sm_raster writes
 *   zmap    float (F, R, R) the same buffer read as floats by sm_lookup
 *   frame   float          ortho: U'(3) a0 V'(3) b0 D(3) z0 tu tv (14): column
 *                          = U'.p + a0, row = V'.p + b0, depth = D.p + z0, tu, tv
 *                          the world size of a texel along U', V'; cube: the six
 *                          world-to-face rotations, rows right, up, forward (54)
 *   pts     float (N, 3)   points relative to the map's origin (cube: the light)
 *   nrm     float (N, 3)   unit world normals (read only when has_normals)
 *   frac    float (N)      lit fraction of the taps; written
 * Macros: TAN_MAX (float), the steepest receiver slope followed.
 * Every loop index is bounded by R (texels) or n (points): no read leaves the buffers.
 */
#include "raster_common.h"

#ifndef TAN_MAX
#define TAN_MAX 1e4f                    /* the host passes pyshadow.lighting.shadow_map.TAN_MAX */
#endif

__kernel void sm_raster(__global const float *tris, const int n_tris, __global const float *m,
                        const int R, const int cube, const int zoff, __global volatile uint *zbuf)
{
    const int t = get_global_id(0);
    if (t >= n_tris) return;
    const float4 m0 = vload4(0, m), m1 = vload4(1, m), m2 = vload4(2, m);
    float3 q[3];
    for (int k = 0; k < 3; ++k) {
        const float3 a = vload3(3 * t + k, tris);
        q[k] = (float3)(dot(m0.xyz, a) + m0.w, dot(m1.xyz, a) + m1.w, dot(m2.xyz, a) + m2.w);
    }
    const float f = 0.5f * R, h = 0.5f * R - 0.5f;
    float2 p0, p1, p2;
    if (cube) {
        p0 = (float2)(q[0].x / q[0].z * f + h, h - q[0].y / q[0].z * f);
        p1 = (float2)(q[1].x / q[1].z * f + h, h - q[1].y / q[1].z * f);
        p2 = (float2)(q[2].x / q[2].z * f + h, h - q[2].y / q[2].z * f);
    } else {
        p0 = q[0].xy; p1 = q[1].xy; p2 = q[2].xy;
    }
    const float area = edge_fn(p0, p1, p2);
    if (area == 0.0f || !isfinite(area)) return;
    /* the box clamped to the map in float first: no float-to-int conversion out of range */
    const float top = (float)(R - 1);
    const float x0 = ceil(fmin(p0.x, fmin(p1.x, p2.x))), x1 = floor(fmax(p0.x, fmax(p1.x, p2.x)));
    const float y0 = ceil(fmin(p0.y, fmin(p1.y, p2.y))), y1 = floor(fmax(p0.y, fmax(p1.y, p2.y)));
    if (!(x0 <= top && x1 >= 0.0f && y0 <= top && y1 >= 0.0f)) return;
    const int c0 = (int)fmax(x0, 0.0f), c1 = (int)fmin(x1, top);
    const int r0 = (int)fmax(y0, 0.0f), r1 = (int)fmin(y1, top);
    const float3 iz = (float3)(1.0f / q[0].z, 1.0f / q[1].z, 1.0f / q[2].z);
    const float3 zz = (float3)(q[0].z, q[1].z, q[2].z);
    for (int r = r0; r <= r1; ++r) {
        for (int col = c0; col <= c1; ++col) {
            float3 w;
            if (!tri_covers(p0, p1, p2, area, (float2)((float)col, (float)r), &w)) continue;
            float z = cube ? 1.0f / dot(w, iz) : fmax(dot(w, zz), 0.0f);
            if (!(z >= 0.0f) || !isfinite(z)) continue;
            const int idx = zoff + r * R + col;
            if (as_uint(z) < zbuf[idx]) atomic_min(&zbuf[idx], as_uint(z));   /* most overdraw skips the atomic */
        }
    }
}

/* nearest texel index of a texel coordinate, clamped to the map */
inline int texel_index(float s, int R)
{
    return clamp((int)floor(s + 0.5f), 0, R - 1);
}

/* the face whose axis is the major axis of x: +X 0, -X 1, +Y 2, -Y 3, +Z 4, -Z 5 */
inline int cube_face(float3 x)
{
    const float3 a = fabs(x);
    if (a.x >= a.y && a.x >= a.z) return x.x >= 0.0f ? 0 : 1;
    if (a.y >= a.z) return x.y >= 0.0f ? 2 : 3;
    return x.z >= 0.0f ? 4 : 5;
}

inline float3 face_coords(__global const float *frame, int g, float3 x)
{
    return (float3)(dot(vload3(3 * g, frame), x), dot(vload3(3 * g + 1, frame), x),
                    dot(vload3(3 * g + 2, frame), x));
}

/* one tap of the orthographic map: 1 lit, 0 shadowed */
inline int ortho_tap(__global const float *zmap, int R, __global const float *frame, float col, float row,
                     float z, float3 nl, int has_n, int tj, int ti, float eps_world, float eps_texels)
{
    if (tj < 0 || tj >= R || ti < 0 || ti >= R) return 1;
    const float tu = frame[12], tv = frame[13];
    const float du = (tj - col) * tu, dv = (ti - row) * tv;
    float zr = z;
    if (has_n && nl.z < 0.0f) {
        const float lim = TAN_MAX * (fabs(du) + fabs(dv));
        zr = z + clamp(-(nl.x * du + nl.y * dv) / nl.z, -lim, lim);
    }
    const float eps = eps_world + eps_texels * fmax(tu, tv);
    return zr - eps <= zmap[ti * R + tj];
}

/* one tap of the cube map, shifted (dj, di) texels from the point's texel on face g */
inline int cube_tap(__global const float *zmap, int R, __global const float *frame, int g, float3 c,
                    float col, float row, float3 nf, int has_n, int dj, int di, float eps_world, float eps_texels)
{
    const float f = 0.5f * R, h = 0.5f * R - 0.5f;
    const int tj = (int)floor(col + 0.5f) + dj, ti = (int)floor(row + 0.5f) + di;
    const float3 ray = (float3)((tj - h) / f, (h - ti) / f, 1.0f);
    float t = c.z;
    if (has_n) {
        const float nc = dot(nf, c), nr = dot(nf, ray);
        const float lim = TAN_MAX * (2.0f * c.z / R) * (fabs(tj - col) + fabs(ti - row));
        if (nc < 0.0f && nr < 0.0f) t = clamp(nc / nr, c.z - lim, c.z + lim);
    }
    /* the receiver point of the tap, light-relative world coordinates */
    const float3 x = t * (ray.x * vload3(3 * g, frame) + ray.y * vload3(3 * g + 1, frame)
                          + vload3(3 * g + 2, frame));
    const int k = cube_face(x);
    const float3 ck = face_coords(frame, k, x);
    if (!(ck.z > 0.0f)) return 1;
    const int j = texel_index(ck.x / ck.z * f + h, R), i = texel_index(h - ck.y / ck.z * f, R);
    const float eps = eps_world + eps_texels * (2.0f * ck.z / R);
    return ck.z - eps <= zmap[(k * R + i) * R + j];
}

__kernel void sm_lookup(__global const float *zmap, const int R, const int cube, __global const float *frame,
                        const int n, __global const float *pts, __global const float *nrm, const int has_normals,
                        const float eps_world, const float eps_texels, const int radius,
                        __global float *frac)
{
    const int gid = get_global_id(0);
    if (gid >= n) return;
    const float3 p = vload3(gid, pts);
    const float3 nw = has_normals ? vload3(gid, nrm) : (float3)(0.0f);
    int lit = 0;
    if (!cube) {
        const float3 U = vload3(0, frame), V = (float3)(frame[4], frame[5], frame[6]);
        const float3 D = (float3)(frame[8], frame[9], frame[10]);
        const float col = dot(U, p) + frame[3], row = dot(V, p) + frame[7], z = dot(D, p) + frame[11];
        const float3 nl = (float3)(dot(U, nw) * frame[12], dot(V, nw) * frame[13], dot(D, nw));
        if (!(fabs(col - 0.5f * R) < R && fabs(row - 0.5f * R) < R)) {
            frac[gid] = 1.0f;           /* every tap off the map (radius <= 3 < R / 2): lit; no int overflow */
            return;
        }
        const int cj = (int)floor(col + 0.5f), ci = (int)floor(row + 0.5f);
        for (int di = -radius; di <= radius; ++di)
            for (int dj = -radius; dj <= radius; ++dj)
                lit += ortho_tap(zmap, R, frame, col, row, z, nl, has_normals, cj + dj, ci + di,
                                 eps_world, eps_texels);
    } else {
        const int g = cube_face(p);
        const float3 c = face_coords(frame, g, p);
        const float3 nf = face_coords(frame, g, nw);
        const float f = 0.5f * R, h = 0.5f * R - 0.5f;
        if (!(c.z > 0.0f)) {            /* the point is at the light */
            frac[gid] = 1.0f;
            return;
        }
        const float col = c.x / c.z * f + h, row = h - c.y / c.z * f;
        for (int di = -radius; di <= radius; ++di)
            for (int dj = -radius; dj <= radius; ++dj)
                lit += cube_tap(zmap, R, frame, g, c, col, row, nf, has_normals, dj, di, eps_world, eps_texels);
    }
    frac[gid] = (float)lit / (float)((2 * radius + 1) * (2 * radius + 1));
}

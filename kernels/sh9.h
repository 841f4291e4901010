/* sh9.h -- the 9 real spherical harmonics of order 3 (scene_ao's TRANSFER sums).
 * Expects nothing.
 */
#ifndef PYSHADOW_SH9_H
#define PYSHADOW_SH9_H
/* adds the 9 real SH basis functions of order 3 at unit (x, y, z) to t, in
 * pyshadow.lighting.sh's y-up convention (k = l (l + 1) + m, no
 * Condon-Shortley phase) */
inline void sh9_accumulate(float x, float y, float z, float *t)
{
    t[0] += 0.28209479177387814f;
    t[1] += 0.4886025119029199f * z;
    t[2] += 0.4886025119029199f * y;
    t[3] += 0.4886025119029199f * x;
    t[4] += 1.0925484305920792f * x * z;
    t[5] += 1.0925484305920792f * y * z;
    t[6] += 0.31539156525252005f * (3.0f * y * y - 1.0f);
    t[7] += 1.0925484305920792f * x * y;
    t[8] += 0.5462742152960396f * (x * x - z * z);
}

#endif

/* views_common.h -- what the nearest-map schemes of views_zigzag.h and
 * views_hilbert.h share: pi in float and the map basis rows of the atlas.
 *
 *   bases  float (sum D, 9): rows u, v, d of every map of every CSM type of
 *          the scene (types[t].view_base is a type's first map); d is the
 *          map's axis, the direction it was rendered along
 * Expects: nothing (vec3.h's row3 reads the rows).
 */
#ifndef PYSHADOW_VIEWS_COMMON_H
#define PYSHADOW_VIEWS_COMMON_H

#include "vec3.h"

#define PI_F 3.14159265358979f

inline float3 bases_row(__global const float *bases, int view, int row)
{
    return row3(bases, 3 * view + row);
}

#endif

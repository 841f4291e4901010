/* visibility_rows.h -- the row types of scene_visible's inputs and the
 * loads and stores of lane vectors of rows (visibility.cl includes it).
 * Expects: HAVE_FP64, POINTS_F64, DIRS_F64, CPU_CLANG and lanes.h.
 */
#ifndef PYSHADOW_VISIBILITY_ROWS_H
#define PYSHADOW_VISIBILITY_ROWS_H

#include "lanes.h"

/* Inputs of scene_visible: (N, 3) rows of POINT_T and DIR_T (float or, with
 * HAVE_FP64, double), read in place from the caller's arrays. Points are made
 * relative to the anchor (in double where the device has it) and rounded to
 * float; directions are rescaled by a power of two where squaring them in
 * float would underflow or overflow, then normalised. */
#if HAVE_FP64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double anchor_t;
typedef double wide_t;
#else
typedef float anchor_t;
typedef float wide_t;
#endif
#if POINTS_F64
#define POINT_SCALAR double
#else
#define POINT_SCALAR float
#endif
#if DIRS_F64
#define DIR_SCALAR double
#else
#define DIR_SCALAR float
#endif
typedef POINT_SCALAR point_t;
typedef DIR_SCALAR dir_t;
typedef VTYPE(POINT_SCALAR) pointv_t;
typedef VTYPE(DIR_SCALAR) dirv_t;
/* whole-vector loads and stores of rows that are only element-aligned:
 * vloadN / vstoreN, or on clang CPU targets vector types of reduced
 * alignment (measured 5 % of the kernel) */
#if CPU_CLANG
typedef pointv_t pointvu_t __attribute__((aligned(sizeof(point_t))));
typedef dirv_t dirvu_t __attribute__((aligned(sizeof(dir_t))));
typedef iv ivu_t __attribute__((aligned(4)));
typedef VTYPE(uchar) ucharvu_t __attribute__((aligned(1)));
typedef fv fvu_t __attribute__((aligned(4)));
#define LOADU(T, p, i) (((__global const T *)(p))[i])
#define STOREU(T, p, v) (*(__global T *)(p) = (v))
#else
#define LOADU(T, p, i) VLOAD((i), (p))
#define STOREU(T, p, v) VSTORE((v), 0, (p))
#endif
#if HAVE_FP64
#define TO_WIDE(x) CONVERT(double, x)
#else
#define TO_WIDE(x) (x)
#endif

#endif

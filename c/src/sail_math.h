/* Internal: the sail_real flavour of <math.h>. */
#ifndef SAIL_MATH_H
#define SAIL_MATH_H

#include <math.h>

#include "sail.h"

#ifdef SAIL_DOUBLE
#define SAIL_SIN sin
#define SAIL_COS cos
#define SAIL_FABS fabs
#define SAIL_SQRT sqrt
#define SAIL_R(x) (x)
#else
#define SAIL_SIN sinf
#define SAIL_COS cosf
#define SAIL_FABS fabsf
#define SAIL_SQRT sqrtf
#define SAIL_R(x) (x##f)
#endif

#define SAIL_NAN ((sail_real)NAN)

static inline int sail_finite4(const sail_reading *r)
{
    return isfinite(r->theta1) && isfinite(r->theta2) && isfinite(r->load1) && isfinite(r->load2);
}

#endif /* SAIL_MATH_H */

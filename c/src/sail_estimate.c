/*
 * The run-time estimator (the static estimate itself is sail_static.h, shared with
 * sail_motion.c).  See sail.h.
 */
#include "sail.h"
#include "sail_static.h"

int sail_estimate(const sail_calibration *cal, const sail_reading *in, sail_force *out)
{
    sail_real jt[2][2], m[2][2], trig[4];
    return sail_estimate_parts(cal, in, out, jt, m, trig);
}

size_t sail_estimate_block(const sail_calibration *cal, const sail_reading *in, sail_force *out, size_t n)
{
    size_t i, ok = 0;
    for (i = 0; i < n; i++)
        ok += sail_estimate(cal, &in[i], &out[i]) == SAIL_OK;
    return ok;
}

size_t sail_calibration_real_size(void)
{
    return sizeof(sail_real);
}

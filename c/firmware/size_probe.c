/*
 * Flash-size probe: built twice, with and without SAIL_PROBE_ESTIMATE, so
 * that the difference in size is what sail_estimate and the default
 * calibration (examples/sail_calibration.h) cost in flash.
 */
#include "sail.h"
#include "sail_calibration.h"

volatile sail_real io[4];
volatile sail_real result[2];
volatile int status;

int main(void)
{
    sail_reading r;
    r.theta1 = io[0];
    r.theta2 = io[1];
    r.load1 = io[2];
    r.load2 = io[3];
#ifdef SAIL_PROBE_ESTIMATE
    {
        sail_force f;
        status = sail_estimate(&sail_cal, &r, &f);
        result[0] = f.fx;
        result[1] = f.fy;
    }
#else
    result[0] = r.theta1 + r.load1;
    result[1] = r.theta2 + r.load2;
    status = 0;
#endif
    return 0;
}

/*
 * sail_motion_step speed: `bench_motion N` pushes N readings of a moving arm, sampled
 * uniformly at the exported rate, and prints steps per second.  Compiled by
 * bench/bench_libsail.py against a calibration header defining BENCH_CAL and BENCH_DYN;
 * run under callgrind with --toggle-collect=sail_motion_step it gives instructions per step
 * (the rate filter, the dynamic term and the static estimate together).
 */
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "sail.h"
#include "bench_cal.h"
#include "bench_clock.h"

int main(int argc, char **argv)
{
    static sail_motion_state state;
    const long n = argc > 1 ? atol(argv[1]) : 1000000L;
    const sail_calibration *cal = &BENCH_CAL;
    const sail_dynamics *dyn = &BENCH_DYN;
    double checksum = 0, start;
    long i;
    sail_motion_init(&state, dyn);
    start = bench_now();
    for (i = 0; i < n; i++) {  /* a slow circle of the hand: delta stays inside the calibrated range */
        const double t = (double)i * (double)dyn->dt, phase = 2.0 * t;
        sail_reading r;
        sail_force f;
        r.theta2 = (sail_real)(0.2 * sin(phase));
        r.theta1 = r.theta2 + (sail_real)(0.5 * (cal->delta_min + cal->delta_max) + 0.3 * cos(phase));
        r.load1 = cal->offset[0] + (sail_real)0.1 * cal->capacity[0];
        r.load2 = cal->offset[1] - (sail_real)0.1 * cal->capacity[1];
        if (sail_motion_step(&state, cal, t, &r, &f, NULL, NULL))
            checksum += (double)f.fx + f.status;
    }
    bench_report(n, "steps", bench_now() - start, checksum);
    return 0;
}

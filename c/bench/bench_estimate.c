/*
 * sail_estimate speed: `bench_estimate N` makes N calls over 1024 varied
 * readings inside the calibrated range and prints calls per second.
 * Compiled by bench/bench_libsail.py against a calibration header that
 * defines BENCH_CAL; run under callgrind with --toggle-collect=sail_estimate
 * it gives instructions per call.
 */
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#include <stdio.h>
#include <stdlib.h>

#include "sail.h"
#include "bench_cal.h"
#include "bench_clock.h"

#define READINGS 1024

int main(int argc, char **argv)
{
    static sail_reading in[READINGS];
    const long n = argc > 1 ? atol(argv[1]) : 1000000L;
    const sail_calibration *cal = &BENCH_CAL;
    double checksum = 0, start;
    long i;
    unsigned int seed = 12345u;
    for (i = 0; i < READINGS; i++) {  /* delta spread over the calibrated range, loads over half the capacity */
        const double u = (double)i / READINGS;
        seed = seed * 1103515245u + 12345u;
        in[i].theta2 = (sail_real)(-0.5 + (double)(seed >> 16) / 65536.0);
        in[i].theta1 = in[i].theta2 + (sail_real)(cal->delta_min + u * (cal->delta_max - cal->delta_min));
        in[i].load1 = cal->offset[0] + (sail_real)(0.5 - u) * cal->capacity[0];
        in[i].load2 = cal->offset[1] + (sail_real)(u - 0.5) * cal->capacity[1] * (sail_real)0.7;
    }
    start = bench_now();
    for (i = 0; i < n; i++) {
        sail_force f;
        sail_estimate(cal, &in[i & (READINGS - 1)], &f);
        checksum += (double)f.fx + f.status;
    }
    bench_report(n, "calls", bench_now() - start, checksum);
    return 0;
}

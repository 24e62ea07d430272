/*
 * sail_multirate_step speed: `bench_multirate N` pushes N control ticks of a moving arm at the exported tick rate,
 * with each cell's conversion arriving at its own clock (the nominal rate, one chip 2 % fast, phases apart), and
 * prints ticks per second.  Compiled by bench/bench_thumb.py against a calibration header defining BENCH_CAL,
 * BENCH_DYN and BENCH_ADC (BENCH_STATIC: without the dynamic term); counted on QEMU it gives Thumb-2 instructions per control tick, conversions, windows and
 * solves included (the mean over the run: a tick with a conversion costs more than one without).
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
    static sail_multirate_state state;
    const long n = argc > 1 ? atol(argv[1]) : 1000000L;
    const sail_calibration *cal = &BENCH_CAL;
    const sail_adc *adc = &BENCH_ADC;
    const double period[2] = {adc->period, adc->period / 1.02};
    double next[2] = {0.3 * adc->period, 0.7 * adc->period}, checksum = 0, start;
    long i, conversions = 0;
#ifdef BENCH_STATIC
    const sail_dynamics *dyn = NULL;  /* no dynamic term: a static calibration */
#else
    const sail_dynamics *dyn = &BENCH_DYN;
#endif
    if (sail_multirate_init(&state, cal, dyn, adc) != SAIL_CHECK_OK) {
        fprintf(stderr, "bench_multirate: the calibration's ADC does not initialise\n");
        return 1;
    }
    start = bench_now();
    for (i = 0; i < n; i++) {  /* a slow circle of the hand: delta stays inside the calibrated range */
        const double t = (double)i * adc->tick, phase = 2.0 * t;
        sail_tick tick;
        sail_timed_force f;
        int k;
        tick.t = t;
        tick.theta2 = (sail_real)(0.2 * sin(phase));
        tick.theta1 = tick.theta2 + (sail_real)(0.5 * (cal->delta_min + cal->delta_max) + 0.3 * cos(phase));
        for (k = 0; k < 2; k++) {
            tick.ready[k] = NAN;
            tick.load[k] = (sail_real)NAN;
            if (t >= next[k]) {  /* data ready since the last tick */
                tick.ready[k] = next[k];
                tick.load[k] = cal->offset[k] + (sail_real)(k ? -0.1 : 0.1) * cal->capacity[k];
                next[k] += period[k];
                conversions++;
            }
        }
        if (sail_multirate_step(&state, &tick, &f, NULL))
            checksum += (double)f.fx + f.status;
    }
    bench_report(n, "ticks", bench_now() - start, checksum + (double)conversions);
    return 0;
}

/* The bench programs' timing: a monotonic clock on a host; none on a bare-metal target
 * (SAIL_BENCH_NO_CLOCK, bench/bench_thumb.py), where only the calls are reported. */
#ifndef SAIL_BENCH_CLOCK_H
#define SAIL_BENCH_CLOCK_H

#include <stdio.h>
#ifndef SAIL_BENCH_NO_CLOCK
#include <time.h>
#endif

/* Seconds since an arbitrary origin (0 without a clock). */
static double bench_now(void)
{
#ifdef SAIL_BENCH_NO_CLOCK
    return 0.0;
#else
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
#endif
}

/* "N units in S s: R units/s (checksum C)", or "N units (checksum C)" without a clock. */
static void bench_report(long n, const char *unit, double seconds, double checksum)
{
#ifdef SAIL_BENCH_NO_CLOCK
    (void)seconds;
    printf("%ld %s (checksum %.6g)\n", n, unit, checksum);
#else
    printf("%ld %s in %.6f s: %.4g %s/s (checksum %.6g)\n", n, unit, seconds, (double)n / seconds, unit, checksum);
#endif
}

#endif /* SAIL_BENCH_CLOCK_H */

/* Minimal test helpers for libsail's CTest programs. */
#ifndef SAIL_CHECK_H
#define SAIL_CHECK_H

#include <math.h>
#include <stdio.h>

#include "sail.h"

/* Agreement with the Python toolkit: 1e-5 relative in float, 1e-12 in double. */
#ifdef SAIL_DOUBLE
#define SAIL_TEST_RTOL 1e-12
#define SAIL_TEST_TIME_TOL 1e-12
#else
#define SAIL_TEST_RTOL 1e-5
#define SAIL_TEST_TIME_TOL 1e-7  /* [s]: float times within 0.25 s of an epoch carry 1.5e-8 s, a few roundings of it */
#endif
/* The multi-rate estimator's dynamic term with knots (SAIL_TICK_STRIDE > 1, sail.h) against sailforce's every-tick
 * windows: the knots keep more of the term's content near their rate (the rates' noise; 7.3e-4 of the term's largest
 * value at worst in the shared vectors, 1.1e-4 typical), which an every-tick window averages out. */
#define SAIL_TEST_KNOT_RTOL 1.5e-3
/* ... and the force's RMS difference [N] they may make: half the HX711's input noise at the vectors' hand (90 nV on 5 V
 * through their arm and cells: 4.4 mN, 1 sigma, sailforce.design.maps.adc_noise_at_hand), so that the knots add
 * at most a quarter to the noise's variance.  Every-tick windows agree to rounding (1.3e-4 N in float). */
#define SAIL_TEST_KNOT_RMS_N 2.2e-3

static int check_failures = 0;

#define CHECK(cond, ...)                                                        \
    do {                                                                        \
        if (!(cond)) {                                                          \
            check_failures++;                                                   \
            fprintf(stderr, "%s:%d: check failed: %s: ", __FILE__, __LINE__, #cond); \
            fprintf(stderr, __VA_ARGS__);                                       \
            fputc('\n', stderr);                                                \
        }                                                                       \
    } while (0)

/* |a - b| <= rtol * scale */
#define CHECK_CLOSE(a, b, scale, rtol) \
    CHECK(fabs((double)(a) - (double)(b)) <= (rtol) * (double)(scale), "%.17g vs %.17g (scale %.3g)", (double)(a), (double)(b), (double)(scale))

static int check_report(const char *name)
{
    if (check_failures)
        fprintf(stderr, "%s: %d check(s) failed\n", name, check_failures);
    else
        printf("%s: all checks passed\n", name);
    return check_failures ? 1 : 0;
}

#endif /* SAIL_CHECK_H */

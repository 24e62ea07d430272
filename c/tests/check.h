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

/*
 * libsail against the Python toolkit's shared test vectors (c/tests/make_vectors.py):
 *   test_vectors matrix|seed VECTORS.csv   sail_estimate vs Calibration.estimate
 *   test_vectors lowpass LOWPASS.csv        sail_lowpass_process vs sailforce.estimate.LowPass
 *   test_vectors motion MOTION.csv          sail_motion_step/flush vs sailforce.estimate.estimate_moving
 *   test_vectors multirate[_static|_sinc3] MR.csv  sail_multirate_step/flush vs sailforce.estimate.multirate
 *   test_vectors rezero REZERO.csv         sail_rezero_step vs sailforce.estimate.rezero.ReZero
 *   test_vectors temperature T.csv         sail_temperature_correct vs sailforce.drift.TemperatureCompensation
 * Statuses must be identical; forces agree norm-wise, |dF| <= SAIL_TEST_RTOL |F|.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cal_matrix.h"
#include "cal_motion.h"
#include "cal_multirate.h"
#include "cal_seed.h"
#include "cal_sinc3.h"
#include "cal_temperature.h"
#include "check.h"
#include "sail.h"

#define MAX_ROWS 8192
#define COLUMNS 13

/* Rows of numbers below a header line; returns the row count, or -1. */
static int read_rows(const char *path, double rows[][COLUMNS], int columns)
{
    char line[1024];
    int n = 0;
    FILE *f = fopen(path, "r");
    if (!f) {
        fprintf(stderr, "%s: cannot open\n", path);
        return -1;
    }
    if (!fgets(line, sizeof line, f)) {
        fclose(f);
        return -1;
    }
    while (n < MAX_ROWS && fgets(line, sizeof line, f)) {
        char *p = line, *end;
        int c;
        for (c = 0; c < columns; c++) {
            rows[n][c] = strtod(p, &end);  /* C99 strtod reads nan, inf, -inf */
            if (end == p) {
                fprintf(stderr, "%s: row %d, column %d is not a number\n", path, n + 2, c + 1);
                fclose(f);
                return -1;
            }
            p = (*end == ',') ? end + 1 : end;
        }
        n++;
    }
    fclose(f);
    return n;
}

static double rows[MAX_ROWS][COLUMNS];

static sail_reading reading(const double *row)
{
    sail_reading r;
    r.theta1 = (sail_real)row[0];
    r.theta2 = (sail_real)row[1];
    r.load1 = (sail_real)row[2];
    r.load2 = (sail_real)row[3];
    return r;
}

static int estimate_vectors(const sail_calibration *cal, const char *path)
{
    int i, n = read_rows(path, rows, 7), counts[5] = {0, 0, 0, 0, 0};
    double worst = 0;
    CHECK(n > 0, "no vectors in %s", path);
    for (i = 0; i < n; i++) {
        const sail_reading r = reading(rows[i]);
        const int expected = (int)rows[i][6];
        sail_force f;
        const int status = sail_estimate(cal, &r, &f);
        CHECK(status == expected && f.status == status, "row %d: status %d, Python %d", i + 2, status, expected);
        if (expected == SAIL_INVALID || expected == SAIL_SINGULAR) {
            CHECK(isnan(f.fx) && isnan(f.fy), "row %d: no estimate expected", i + 2);
        } else {
            const double norm = hypot(rows[i][4], rows[i][5]);
            const double err = hypot((double)f.fx - rows[i][4], (double)f.fy - rows[i][5]);
            CHECK(err <= SAIL_TEST_RTOL * norm, "row %d: F (%.17g, %.17g), Python (%.17g, %.17g)",
                  i + 2, (double)f.fx, (double)f.fy, rows[i][4], rows[i][5]);
            if (err / norm > worst)
                worst = err / norm;
        }
        if (expected >= 0 && expected < 5)
            counts[expected]++;
    }
    for (i = 0; i < 5; i++)
        CHECK(counts[i] > 0, "the vectors lack status %d", i);
    printf("%s: %d vectors (ok %d, singular %d, saturated %d, extrapolated %d, invalid %d); worst |dF|/|F| %.3g\n",
           path, n, counts[0], counts[1], counts[2], counts[3], counts[4], worst);
    return 0;
}

static int lowpass_vectors(const char *path)
{
    static sail_reading block[MAX_ROWS];
    static const size_t sizes[] = {1, 7, 64, 3, 200};  /* the state must carry across blocks of any size */
    sail_lowpass_state state;
    int i, n = read_rows(path, rows, 6);
    size_t done = 0, k = 0;
    double scale = 0;
    CHECK(n > 0, "no vectors in %s", path);
    for (i = 0; i < n; i++) {
        block[i] = reading(rows[i]);
        if (isfinite(rows[i][4]) && fabs(rows[i][4]) > scale)
            scale = fabs(rows[i][4]);
    }
    sail_lowpass_init(&state, &sail_cal_matrix_lowpass);
    while (done < (size_t)n) {
        size_t size = sizes[k++ % (sizeof sizes / sizeof sizes[0])];
        if (size > (size_t)n - done)
            size = (size_t)n - done;
        sail_lowpass_process(&state, block + done, size);
        done += size;
    }
    for (i = 0; i < n; i++) {
        if (isnan(rows[i][4])) {
            CHECK(isnan(block[i].load1) && isnan(block[i].load2), "row %d: skipped reading should give NaN", i + 2);
            continue;
        }
        CHECK_CLOSE(block[i].load1, rows[i][4], scale, 10 * SAIL_TEST_RTOL);
        CHECK_CLOSE(block[i].load2, rows[i][5], scale, 10 * SAIL_TEST_RTOL);
    }
    printf("%s: %d filtered readings\n", path, n);
    return 0;
}

/* Rows in, one at a time, as the firmware would; each estimate comes out `half` rows later, then the flush. */
static int motion_vectors(const char *path)
{
    sail_motion_state state;
    int i, n = read_rows(path, rows, 10), out = 0, counts[6] = {0, 0, 0, 0, 0, 0};
    double scale = 0, inertial_scale = 0, worst = 0;
    CHECK(n > 0, "no vectors in %s", path);
    for (i = 0; i < n; i++) {
        if (isfinite(rows[i][5]))
            scale = fmax(scale, hypot(rows[i][5], rows[i][6]));
        if (isfinite(rows[i][8]))
            inertial_scale = fmax(inertial_scale, fmax(fabs(rows[i][8]), fabs(rows[i][9])));
    }
    sail_motion_init(&state, &sail_cal_motion_dynamics);
    for (i = 0; i <= n + sail_cal_motion_dynamics.half; i++) {
        sail_force f;
        sail_real inertial[2];
        sail_reading held;
        int got;
        if (i < n) {
            const sail_reading r = {(sail_real)rows[i][1], (sail_real)rows[i][2], (sail_real)rows[i][3], (sail_real)rows[i][4]};
            got = sail_motion_step(&state, &sail_cal_motion, rows[i][0], &r, &f, inertial, &held);
            CHECK(got == (i >= sail_cal_motion_dynamics.half), "row %d: step returned %d", i + 2, got);
        } else {
            got = sail_motion_flush(&state, &sail_cal_motion, &f, inertial, &held);
            CHECK(got == (out < n), "flush returned %d after %d rows", got, out);
        }
        if (!got)
            continue;
        {
            const double *row = rows[out];
            const int expected = (int)row[7];
            CHECK(f.status == expected, "row %d: status %d, Python %d", out + 2, f.status, expected);
            CHECK((double)held.load2 == (double)(sail_real)row[4] || (isnan(held.load2) && isnan(row[4])),
                  "row %d: the held reading is not the row's", out + 2);
            if (isnan(row[5])) {
                CHECK(isnan(f.fx) && isnan(f.fy), "row %d: no estimate expected", out + 2);
            } else {
                const double err = hypot((double)f.fx - row[5], (double)f.fy - row[6]);
                CHECK(err <= SAIL_TEST_RTOL * scale, "row %d: F (%.17g, %.17g), Python (%.17g, %.17g)", out + 2,
                      (double)f.fx, (double)f.fy, row[5], row[6]);
                worst = fmax(worst, err / scale);
            }
            if (isnan(row[8])) {
                CHECK(isnan(inertial[0]) && isnan(inertial[1]), "row %d: no inertial load expected", out + 2);
            } else {
                /* the longer chain: rates, shears, M (the rates are read on exact integer projections: no cancellation) */
                CHECK_CLOSE(inertial[0], row[8], inertial_scale, SAIL_TEST_RTOL);
                CHECK_CLOSE(inertial[1], row[9], inertial_scale, SAIL_TEST_RTOL);
            }
            if (expected >= 0 && expected < 6)
                counts[expected]++;
            out++;
        }
    }
    CHECK(out == n, "%d estimates for %d readings", out, n);
    CHECK(counts[SAIL_OK] > 0 && counts[SAIL_SATURATED] > 0 && counts[SAIL_INVALID] > 0 && counts[SAIL_MOTION_UNKNOWN] > 0,
          "the vectors lack a status");
    printf("%s: %d readings (ok %d, saturated %d, invalid %d, motion-unknown %d), delay %d; worst |dF| / max|F| %.3g\n",
           path, n, counts[SAIL_OK], counts[SAIL_SATURATED], counts[SAIL_INVALID], counts[SAIL_MOTION_UNKNOWN],
           sail_cal_motion_dynamics.half, worst);
    return 0;
}

/* Ticks in, one at a time, with each cell's conversions; each tick comes out `half` ticks later (at once without a
 * dynamic term), then the flush.  force_t is compared in absolute time: it is the estimate's instant. */
static int multirate_vectors(const char *path, const sail_calibration *cal, const sail_dynamics *dyn, const sail_adc *adc)
{
    static sail_multirate_state state;
    const int delay = dyn ? dyn->half : 0;
    int i, k, n = read_rows(path, rows, 13), out = 0, counts[6] = {0, 0, 0, 0, 0, 0};
    double scale = 0, inertial_scale = 0, worst = 0, worst_t = 0, worst_inertial = 0, sum_sq = 0;
    int compared = 0;
    CHECK(n > 0, "no vectors in %s", path);
    for (i = 0; i < n; i++) {
        if (isfinite(rows[i][7]))
            scale = fmax(scale, hypot(rows[i][7], rows[i][8]));
        if (isfinite(rows[i][10]))
            inertial_scale = fmax(inertial_scale, fmax(fabs(rows[i][10]), fabs(rows[i][11])));
    }
    CHECK(sail_multirate_init(&state, cal, dyn, adc) == SAIL_CHECK_OK, "init");
    for (i = 0; i <= n + delay; i++) {
        sail_timed_force f;
        sail_tick held;
        int got;
        if (i < n) {
            sail_tick tick;
            tick.t = rows[i][0];
            tick.theta1 = (sail_real)rows[i][1];
            tick.theta2 = (sail_real)rows[i][2];
            tick.load[0] = (sail_real)rows[i][3];
            tick.load[1] = (sail_real)rows[i][4];
            tick.ready[0] = rows[i][5];
            tick.ready[1] = rows[i][6];
            got = sail_multirate_step(&state, &tick, &f, &held);
            CHECK(got == (i >= delay), "row %d: step returned %d", i + 2, got);
        } else {
            got = sail_multirate_flush(&state, &f, &held);
            CHECK(got == (out < n), "flush returned %d after %d rows", got, out);
        }
        if (!got)
            continue;
        {
            const double *row = rows[out];
            const int expected = (int)row[9];
            CHECK(f.status == expected, "row %d: status %d, Python %d", out + 2, f.status, expected);
            CHECK(held.t == row[0] || (isnan(held.t) && isnan(row[0])), "row %d: the held tick is not the row's", out + 2);
            if (isnan(row[7])) {
                CHECK(isnan(f.fx) && isnan(f.fy), "row %d: no estimate expected, got (%g, %g)", out + 2, (double)f.fx,
                      (double)f.fy);
            } else {
                const double err = hypot((double)f.fx - row[7], (double)f.fy - row[8]);
                CHECK(err <= SAIL_TEST_RTOL * scale, "row %d: F (%.17g, %.17g), Python (%.17g, %.17g)", out + 2,
                      (double)f.fx, (double)f.fy, row[7], row[8]);
                worst = fmax(worst, err / scale);
                sum_sq += err * err;
                compared++;
            }
            for (k = 0; k < 2; k++) {
                if (isnan(row[10 + k]))
                    CHECK(isnan(f.inertial[k]), "row %d: no inertial load %d expected, got %g", out + 2, k + 1,
                          (double)f.inertial[k]);
                else {
                    const double off = fabs((double)f.inertial[k] - row[10 + k]) / (inertial_scale > 0 ? inertial_scale : 1);
                    CHECK(off <= (state.knot_mask ? SAIL_TEST_KNOT_RTOL : SAIL_TEST_RTOL),
                          "row %d: inertial load %d %.17g, Python %.17g (%.3g of the largest)", out + 2, k + 1,
                          (double)f.inertial[k], row[10 + k], off);
                    worst_inertial = fmax(worst_inertial, off);
                }
            }
            if (isnan(row[12])) {
                CHECK(isnan(f.force_t), "row %d: no force_t expected, got %.17g", out + 2, f.force_t);
            } else {
                /* an instant: float keeps times relative to an epoch, within 0.25 s of it */
                CHECK(fabs(f.force_t - row[12]) <= SAIL_TEST_TIME_TOL, "row %d: force_t %.17g, Python %.17g", out + 2,
                      f.force_t, row[12]);
                worst_t = fmax(worst_t, fabs(f.force_t - row[12]));
            }
            if (expected >= 0 && expected < 6)
                counts[expected]++;
            out++;
        }
    }
    CHECK(out == n, "%d estimates for %d ticks", out, n);
    CHECK(compared > 0 && sqrt(sum_sq / compared) <= SAIL_TEST_KNOT_RMS_N, "the force's rms difference %.3g N",
          compared ? sqrt(sum_sq / compared) : 0.0);
    CHECK(counts[SAIL_OK] > 0 && counts[SAIL_SATURATED] > 0 && counts[SAIL_INVALID] > 0 && counts[SAIL_MOTION_UNKNOWN] > 0,
          "the vectors lack a status");
    printf("%s: %d ticks (ok %d, saturated %d, invalid %d, motion-unknown %d), delay %d, knots every %d ticks; worst "
           "|dF| / max|F| %.3g (rms |dF| %.3g N), worst |d inertial| / max|inertial| %.3g, worst |d force_t| %.3g s\n", path, n,
           counts[SAIL_OK], counts[SAIL_SATURATED], counts[SAIL_INVALID], counts[SAIL_MOTION_UNKNOWN], delay,
           (int)state.knot_mask + 1, worst, compared ? sqrt(sum_sq / compared) : 0.0, worst_inertial, worst_t);
    return 0;
}

/* theta1, theta2, load1, load2, celsius, fx, fy, status: sail_temperature_correct then sail_estimate vs
 * TemperatureCompensation.corrected then Calibration.estimate. */
static int temperature_vectors(const char *path)
{
    const int n = read_rows(path, rows, 8);
    int i, invalid = 0;
    CHECK(n >= 100, "%d vectors in %s", n, path);
    for (i = 0; i < n; i++) {
        sail_reading r = reading(rows[i]);
        sail_force f;
        const int expected = (int)rows[i][7];
        sail_temperature_correct(&sail_cal_temperature_temperature, &sail_cal_temperature, &r, (sail_real)rows[i][4]);
        CHECK(sail_estimate(&sail_cal_temperature, &r, &f) == expected, "row %d: status %d, Python %d", i + 2,
              (int)f.status, expected);
        if (expected == SAIL_INVALID) {
            invalid++;
            CHECK(isnan(f.fx) && isnan(f.fy), "row %d: no estimate expected", i + 2);
        } else {
            const double norm = hypot(rows[i][5], rows[i][6]);
            CHECK(hypot((double)f.fx - rows[i][5], (double)f.fy - rows[i][6]) <= SAIL_TEST_RTOL * norm,
                  "row %d: F (%.17g, %.17g), Python (%.17g, %.17g)", i + 2, (double)f.fx, (double)f.fy, rows[i][5],
                  rows[i][6]);
        }
    }
    CHECK(invalid == 1, "%d invalid rows (the NaN temperature's)", invalid);
    return 0;
}

/* t, theta1, theta2, fx, fy, status, contact, fx_out, fy_out, begins: sail_rezero_step vs ReZero.process. */
static int rezero_vectors(const char *path)
{
    static sail_rezero_state state;
    const int n = read_rows(path, rows, 10);
    int i, made = 0, marked = 0, refused = 0;
    if (n < 0)
        return check_failures++, 1;
    CHECK(sail_rezero_init(&state, &sail_cal_motion, NULL) == SAIL_CHECK_OK, "init");
    for (i = 0; i < n; i++) {
        const double *r = rows[i];
        sail_force f;
        sail_rezero_event event;
        int32_t begins;
        int decision;
        f.fx = (sail_real)r[3];
        f.fy = (sail_real)r[4];
        f.status = (int32_t)r[5];
        decision = sail_rezero_step(&state, r[0], (sail_real)r[1], (sail_real)r[2], &f, (int32_t)r[6], &event, &begins);
        made += decision == SAIL_REZERO_MADE;
        refused += decision == SAIL_REZERO_REFUSED_STEP || decision == SAIL_REZERO_REFUSED_TOTAL;
        marked += begins;
        CHECK(begins == (int32_t)r[9], "row %d: begins %d, expected %d", i + 2, (int)begins, (int)r[9]);
        if (isnan(r[7])) {
            CHECK(isnan(f.fx) && isnan(f.fy), "row %d: a force where Python has none", i + 2);
        } else {
            const double scale = hypot(r[7], r[8]) > 1.0 ? hypot(r[7], r[8]) : 1.0;
            CHECK_CLOSE(f.fx, r[7], scale, SAIL_TEST_RTOL);
            CHECK_CLOSE(f.fy, r[8], scale, SAIL_TEST_RTOL);
        }
    }
    CHECK(made >= 3 && made == marked, "%d re-zeros made, %d rows marked", made, marked);
    CHECK(sail_rezero_init(&state, &sail_cal_motion, NULL) == SAIL_CHECK_OK && refused <= made, "%d refused", refused);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: test_vectors matrix|seed|lowpass|motion|multirate|multirate_static|multirate_sinc3|rezero|temperature FILE.csv\n");
        return 2;
    }
    if (!strcmp(argv[1], "matrix"))
        estimate_vectors(&sail_cal_matrix, argv[2]);
    else if (!strcmp(argv[1], "seed"))
        estimate_vectors(&sail_cal_seed, argv[2]);
    else if (!strcmp(argv[1], "lowpass"))
        lowpass_vectors(argv[2]);
    else if (!strcmp(argv[1], "motion"))
        motion_vectors(argv[2]);
    else if (!strcmp(argv[1], "multirate"))
        multirate_vectors(argv[2], &sail_cal_multirate, &sail_cal_multirate_dynamics, &sail_cal_multirate_adc);
    else if (!strcmp(argv[1], "multirate_static"))
        multirate_vectors(argv[2], &sail_cal_multirate, NULL, &sail_cal_multirate_adc);
    else if (!strcmp(argv[1], "multirate_sinc3"))
        multirate_vectors(argv[2], &sail_cal_sinc3, NULL, &sail_cal_sinc3_adc);
    else if (!strcmp(argv[1], "rezero"))
        rezero_vectors(argv[2]);
    else if (!strcmp(argv[1], "temperature"))
        temperature_vectors(argv[2]);
    else {
        fprintf(stderr, "unknown vector set %s\n", argv[1]);
        return 2;
    }
    return check_report(argv[1]);
}

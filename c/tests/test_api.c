/*
 * libsail against analytic results, without the Python toolkit:
 * a statically determinate arm (pin joints) has signals s_i = g_i T_i with
 * T = J^T F (seed Eq. 7), i.e. a matrix model of order 0, C = diag(g1, g2).
 * Gains of tens of thousands of counts per N m are an HX711's on a bonded cell.
 */
#include <math.h>
#include <string.h>

#include "check.h"
#include "sail.h"
#include "sail_math.h"
#include "sail_rates.h"

static const double PI = 3.14159265358979323846;
static const double G1 = 74000.0, G2 = 52800.0;  /* raw units (counts) per N m */
static const double L2 = 0.3, L3 = 0.45;
/* The rate filter against a double convolution: a float build reads its rates to 1e-6 of their scale. */
#ifdef SAIL_DOUBLE
#define SAIL_RATE_RTOL 1e-12
#else
#define SAIL_RATE_RTOL 1e-6
#endif

static sail_calibration pin_calibration(void)
{
    sail_calibration cal;
    memset(&cal, 0, sizeof cal);
    cal.kind = SAIL_MODEL_MATRIX;
    cal.l2 = (sail_real)L2;
    cal.l3 = (sail_real)L3;
    cal.offset[0] = 100;
    cal.offset[1] = -50;
    cal.capacity[0] = cal.capacity[1] = 4e6;
    cal.delta_min = (sail_real)(15 * PI / 180);
    cal.delta_max = (sail_real)(165 * PI / 180);
    cal.model.matrix.n_terms = 1;
    cal.model.matrix.cheb_lo = cal.delta_min;
    cal.model.matrix.cheb_hi = cal.delta_max;
    cal.model.matrix.cheb[0][0][0] = (sail_real)G1;
    cal.model.matrix.cheb[0][1][1] = (sail_real)G2;
    return cal;
}

/* The raw readings a pin-jointed arm gives for force (fx, fy) at (t1, t2). */
static sail_reading reading_for(const sail_calibration *cal, double t1, double t2, double fx, double fy)
{
    sail_reading r;
    const double tq1 = L3 * (-sin(t1) * fx + cos(t1) * fy), tq2 = L2 * (-sin(t2) * fx + cos(t2) * fy);
    r.theta1 = (sail_real)t1;
    r.theta2 = (sail_real)t2;
    r.load1 = (sail_real)(cal->offset[0] + G1 * tq1);
    r.load2 = (sail_real)(cal->offset[1] + G2 * tq2);
    return r;
}

static void test_square_pose(void)
{
    /* theta1 = 90 deg, theta2 = 0: T1 = -l3 fx, T2 = l2 fy, so loads (0, 3 G2) above offset mean F = (0, 10) N. */
    const sail_calibration cal = pin_calibration();
    sail_reading r = {(sail_real)(PI / 2), 0, 100, (sail_real)(-50 + 3.0 * G2)};
    sail_force f;
    CHECK(sail_estimate(&cal, &r, &f) == SAIL_OK, "status %d", f.status);
    CHECK_CLOSE(f.fx, 0.0, 10.0, SAIL_TEST_RTOL);
    CHECK_CLOSE(f.fy, 10.0, 10.0, SAIL_TEST_RTOL);
}

static void test_round_trip_over_workspace(void)
{
    const sail_calibration cal = pin_calibration();
    double d, t2, phi;
    for (d = 20; d <= 160; d += 10)
        for (t2 = -60; t2 <= 60; t2 += 30)
            for (phi = 0; phi < 360; phi += 45) {
                const double fx = 25 * cos(phi * PI / 180), fy = 25 * sin(phi * PI / 180);
                const sail_reading r = reading_for(&cal, (d + t2) * PI / 180, t2 * PI / 180, fx, fy);
                sail_force f;
                CHECK(sail_estimate(&cal, &r, &f) == SAIL_OK, "delta %g: status %d", d, f.status);
                /* cond(J) <= 1 / sin 20 deg amplifies the rounding of angles and loads */
                CHECK_CLOSE(f.fx, fx, 25.0, 30 * SAIL_TEST_RTOL);
                CHECK_CLOSE(f.fy, fy, 25.0, 30 * SAIL_TEST_RTOL);
            }
}

static void test_statuses_and_precedence(void)
{
    const sail_calibration cal = pin_calibration();
    sail_reading r = reading_for(&cal, PI / 2, 0, 3, 4);
    sail_force f;
    sail_reading bad;

    bad = r;
    bad.load2 = (sail_real)NAN;
    CHECK(sail_estimate(&cal, &bad, &f) == SAIL_INVALID && isnan(f.fx) && isnan(f.fy), "NaN load: status %d", f.status);
    bad = r;
    bad.theta1 = (sail_real)INFINITY;
    CHECK(sail_estimate(&cal, &bad, &f) == SAIL_INVALID, "infinite angle: status %d", f.status);

    bad = r;
    bad.theta1 = (sail_real)(1.0 * PI / 180);  /* delta = 1 deg < 2 deg */
    CHECK(sail_estimate(&cal, &bad, &f) == SAIL_SINGULAR && isnan(f.fx), "delta 1 deg: status %d", f.status);
    bad.theta1 = (sail_real)(PI + 0.5 * PI / 180);  /* delta = 180.5 deg */
    CHECK(sail_estimate(&cal, &bad, &f) == SAIL_SINGULAR, "delta 180.5 deg: status %d", f.status);
    bad.theta1 = (sail_real)(3.0 * PI / 180);  /* 3 deg: estimated, but outside 15..165 */
    CHECK(sail_estimate(&cal, &bad, &f) == SAIL_EXTRAPOLATED && !isnan(f.fx), "delta 3 deg: status %d", f.status);
    bad.theta1 = (sail_real)(170.0 * PI / 180);
    CHECK(sail_estimate(&cal, &bad, &f) == SAIL_EXTRAPOLATED, "delta 170 deg: status %d", f.status);

    bad = r;
    bad.load1 = cal.offset[0] + (sail_real)4.5e6;  /* capacity 4e6 */
    CHECK(sail_estimate(&cal, &bad, &f) == SAIL_SATURATED && !isnan(f.fx), "over capacity: status %d", f.status);
    bad.theta1 = (sail_real)(170.0 * PI / 180);
    CHECK(sail_estimate(&cal, &bad, &f) == SAIL_SATURATED, "saturated beats extrapolated: status %d", f.status);
    bad.theta1 = 0;
    CHECK(sail_estimate(&cal, &bad, &f) == SAIL_SINGULAR, "singular beats saturated: status %d", f.status);
    bad.load2 = (sail_real)NAN;
    CHECK(sail_estimate(&cal, &bad, &f) == SAIL_INVALID, "invalid beats singular: status %d", f.status);
}

static void test_degenerate_and_unknown_models(void)
{
    sail_calibration cal = pin_calibration();
    const sail_reading r = reading_for(&cal, PI / 2, 0, 3, 4);
    sail_force f;
    cal.model.matrix.cheb[0][1][1] = 0;  /* one cell reads nothing: the map cannot be inverted */
    CHECK(sail_estimate(&cal, &r, &f) == SAIL_SINGULAR && isnan(f.fy), "degenerate map: status %d", f.status);
    cal = pin_calibration();
    cal.kind = 99;
    CHECK(sail_estimate(&cal, &r, &f) == SAIL_INVALID, "unknown kind: status %d", f.status);
}

static void test_seed_model_matches_matrix(void)
{
    /* A_i = 1 / g_i, P_i = 0 is the same map as C = diag(g1, g2); P_1 = 90 deg turns row 1 by -90 deg. */
    const sail_calibration matrix = pin_calibration();
    sail_calibration seed = matrix;
    const sail_reading r = reading_for(&matrix, 1.9, 0.3, -7, 12);
    sail_force a, b;
    seed.kind = SAIL_MODEL_SEED;
    seed.model.seed.amplitude_terms[0] = seed.model.seed.amplitude_terms[1] = 2;
    seed.model.seed.phase_terms[0] = seed.model.seed.phase_terms[1] = 1;
    seed.model.seed.amplitude[0][0] = 0; seed.model.seed.amplitude[0][1] = (sail_real)(1 / G1);  /* 0 * delta_deg + 1 / g1 */
    seed.model.seed.amplitude[1][0] = 0; seed.model.seed.amplitude[1][1] = (sail_real)(1 / G2);
    seed.model.seed.phase_deg[0][0] = seed.model.seed.phase_deg[1][0] = 0;
    sail_estimate(&matrix, &r, &a);
    CHECK(sail_estimate(&seed, &r, &b) == SAIL_OK, "status %d", b.status);
    CHECK_CLOSE(b.fx, a.fx, 14.0, 10 * SAIL_TEST_RTOL);
    CHECK_CLOSE(b.fy, a.fy, 14.0, 10 * SAIL_TEST_RTOL);
    {
        /* P_1 = 90 deg: s_1 = g1 R(-90) j_1 . F = g1 (j_1y, -j_1x) . F */
        const double t1 = 1.9, t2 = 0.3, fx = -7, fy = 12;
        sail_reading q = reading_for(&matrix, t1, t2, fx, fy);
        q.load1 = (sail_real)(matrix.offset[0] + G1 * L3 * (cos(t1) * fx + sin(t1) * fy));
        seed.model.seed.phase_deg[0][0] = 90;
        CHECK(sail_estimate(&seed, &q, &b) == SAIL_OK, "status %d", b.status);
        CHECK_CLOSE(b.fx, fx, 14.0, 10 * SAIL_TEST_RTOL);
        CHECK_CLOSE(b.fy, fy, 14.0, 10 * SAIL_TEST_RTOL);
    }
}

static void test_block(void)
{
    const sail_calibration cal = pin_calibration();
    sail_reading in[3];
    sail_force out[3], one;
    int i;
    in[0] = reading_for(&cal, 2.0, 0.5, 1, 2);
    in[1] = in[0];
    in[1].theta2 = (sail_real)NAN;
    in[2] = reading_for(&cal, 1.0, -0.5, -3, 2);
    CHECK(sail_estimate_block(&cal, in, out, 3) == 2, "two of three are ok");
    for (i = 0; i < 3; i++) {
        sail_estimate(&cal, &in[i], &one);
        CHECK(one.status == out[i].status && (isnan(one.fx) ? isnan(out[i].fx) : one.fx == out[i].fx), "block row %d", i);
    }
    CHECK(sail_calibration_real_size() == sizeof(sail_real), "real size %u", (unsigned)sail_calibration_real_size());
}

static void test_tare(void)
{
    sail_calibration cal = pin_calibration();
    sail_tare_state tare;
    sail_reading r[12];
    sail_real spread[2];
    int i;
    sail_tare_init(&tare);
    CHECK(sail_tare_finish(&tare, &cal, spread) == SAIL_CHECK_TOO_FEW && cal.offset[0] == 100, "no readings: offsets kept");
    for (i = 0; i < 12; i++) {
        r[i].theta1 = r[i].theta2 = 0;
        r[i].load1 = (sail_real)(1000 + i);  /* 1000..1009 valid: mean 1004.5, sample std sqrt(55/6) */
        r[i].load2 = (sail_real)(-2 * i);
    }
    r[10].load1 = (sail_real)NAN;  /* skipped */
    r[11].load2 = (sail_real)INFINITY;
    sail_tare_process(&tare, r, 5);
    sail_tare_process(&tare, r + 5, 7);
    CHECK(tare.count == 10, "count %lu", tare.count);
    CHECK(sail_tare_finish(&tare, &cal, spread) == SAIL_CHECK_OK, "finish");
    CHECK(sail_tare_finish(NULL, &cal, spread) == SAIL_CHECK_NULL && sail_tare_finish(&tare, NULL, spread) == SAIL_CHECK_NULL,
          "NULL state or calibration");
    CHECK_CLOSE(cal.offset[0], 1004.5, 1004.5, SAIL_TEST_RTOL);
    CHECK_CLOSE(cal.offset[1], -9.0, 9.0, SAIL_TEST_RTOL);
    CHECK_CLOSE(spread[0], sqrt(55.0 / 6.0), 3.0, SAIL_TEST_RTOL);
    CHECK_CLOSE(spread[1], 2 * sqrt(55.0 / 6.0), 6.0, SAIL_TEST_RTOL);
}

static void test_lowpass_first_order(void)
{
    /* y[n] = 0.5 x[n] + 0.5 y[n-1]: unit DC gain; b = (0.5, 0, 0), a = (1, -0.5, 0); steady state z0 = 0.5 x. */
    static const sail_lowpass design = {1, {{0.5, 0, 0, 1, -0.5, 0}}, {{0.5, 0}}};
    sail_lowpass_state state;
    sail_reading r[5];
    int i;
    for (i = 0; i < 5; i++) {
        r[i].theta1 = 1;
        r[i].theta2 = 0;
        r[i].load1 = 3;
        r[i].load2 = -2;
    }
    r[1].theta2 = (sail_real)NAN;  /* skipped: neither enters nor advances the filter */
    r[3].load1 = r[4].load1 = 5;   /* step */
    sail_lowpass_init(&state, &design);
    sail_lowpass_process(&state, r, 2);
    sail_lowpass_process(&state, r + 2, 3);
    CHECK(r[0].load1 == 3 && r[0].load2 == -2 && r[2].load1 == 3, "steady from the first reading: %g %g", (double)r[0].load1, (double)r[2].load1);
    CHECK(isnan(r[1].load1) && isnan(r[1].load2), "invalid reading's loads become NaN");
    CHECK(r[3].load1 == 4 && r[4].load1 == (sail_real)4.5 && r[4].load2 == -2, "step response %g %g", (double)r[3].load1, (double)r[4].load1);
}

static void test_sincos(void)
{
    /* Float builds use their own sin/cos (sail_math.h): within 2 ulp of 1 on joint angles; sane far out. */
    double worst = 0, x;
    sail_real s, c;
    for (x = -50; x <= 50; x += 1e-3) {
        const sail_real xr = (sail_real)x;
        sail_sincos(xr, &s, &c);
        if (fabs(s - sin((double)xr)) > worst)
            worst = fabs(s - sin((double)xr));
        if (fabs(c - cos((double)xr)) > worst)
            worst = fabs(c - cos((double)xr));
    }
    CHECK(worst <= 2.5e-7, "sin/cos error %.3g on |x| <= 50", worst);
    sail_sincos((sail_real)1e7, &s, &c);
    CHECK(fabs(s * s + c * c - 1) < 1e-5, "far out: s^2 + c^2 = %g", (double)(s * s + c * c));
    printf("sail_sincos: max error %.3g on |x| <= 50\n", worst);
}

/* Order-2 Savitzky-Golay kernels in closed form (Savitzky & Golay 1964), over offsets j = -h..h at step dt:
 * rate c_j = j / (dt S2), S2 = sum j^2; acceleration c_j = 2 (j^2 - S2/N) / (dt^2 D), D = sum (j^2 - S2/N)^2. */
static sail_dynamics quadratic_dynamics(int half, double dt)
{
    sail_dynamics dyn;
    double s2 = 0, d = 0;
    int j;
    memset(&dyn, 0, sizeof dyn);
    for (j = -half; j <= half; j++)
        s2 += (double)j * j;
    for (j = -half; j <= half; j++)
        d += ((double)j * j - s2 / (2 * half + 1)) * ((double)j * j - s2 / (2 * half + 1));
    dyn.dt = dt;
    dyn.half = half;
    dyn.order = 2;
    dyn.rate[1] = 1 / (dt * s2);
    dyn.accel[2] = 2 / (dt * dt * d);
    dyn.accel[0] = -dyn.accel[2] * s2 / (2 * half + 1);
    return dyn;
}

/* The rate filter in sail_real against the same kernels convolved in double with the angles in counts: the float
 * build's rates stay within 1e-6 of the exact ones although the angle's level (1.2 rad, 3.2e6 counts) is thousands of
 * times the window's change, because they are read on exact integer projections. */
static void test_rate_filter_against_the_convolution(void)
{
    enum { HALF = 50, N = 2 * HALF + 1, SAMPLES = 600 };
    const double dt = 1e-3, per_count = 6.283185307179586 / SAIL_COUNTS_PER_TURN;
    const sail_dynamics dyn = quadratic_dynamics(HALF, dt);
    static sail_rate_filter filter;
    static int32_t counts[SAMPLES][2];
    double worst_rate = 0, worst_accel = 0, scale_rate = 0, scale_accel = 0;
    int i, j, k;
    CHECK(sail_rates_check(&dyn) == SAIL_CHECK_OK, "closed-form kernels refused");
    sail_rates_init(&filter, &dyn);
    for (i = 0; i < SAMPLES; i++) {
        const double t = i * dt;
        int ok = 1;
        counts[i][0] = sail_to_counts((sail_real)(1.2 + 0.8 * sin(3.0 * t)), &ok);
        counts[i][1] = sail_to_counts((sail_real)(-0.4 + 0.5 * cos(5.0 * t)), &ok);
        sail_rates_link(&filter, ok, 1);
        sail_rates_push(&filter, counts[i][0], counts[i][1]);
        if (i >= N - 1) {  /* the window's centre is sample i - HALF */
            sail_real got[4];
            double exact[4] = {0, 0, 0, 0};
            sail_rates_read(&filter, got);
            for (j = -HALF; j <= HALF; j++)
                for (k = 0; k < 2; k++) {
                    const double x = counts[i - HALF + j][k] * per_count;
                    exact[2 * k] += dyn.rate[1] * j * x;
                    exact[2 * k + 1] += (dyn.accel[0] + dyn.accel[2] * j * j) * x;
                }
            for (k = 0; k < 2; k++) {
                worst_rate = fmax(worst_rate, fabs((double)got[2 * k] - exact[2 * k]));
                worst_accel = fmax(worst_accel, fabs((double)got[2 * k + 1] - exact[2 * k + 1]));
                scale_rate = fmax(scale_rate, fabs(exact[2 * k]));
                scale_accel = fmax(scale_accel, fabs(exact[2 * k + 1]));
            }
        }
    }
    CHECK(worst_rate <= SAIL_RATE_RTOL * scale_rate, "rate off by %.3g of %.3g rad/s", worst_rate, scale_rate);
    CHECK(worst_accel <= SAIL_RATE_RTOL * scale_accel, "acceleration off by %.3g of %.3g rad/s^2", worst_accel,
          scale_accel);
    printf("rate filter: worst |d omega| / max|omega| %.3g, |d alpha| / max|alpha| %.3g\n", worst_rate / scale_rate,
           worst_accel / scale_accel);
}

/* sail_calibration_check and the init functions name what is wrong; the per-sample functions trust them. */
static void test_checks(void)
{
    const sail_calibration good = pin_calibration();
    sail_calibration cal = good;
    sail_lowpass design;
    sail_lowpass_state lowpass;
    sail_dynamics dyn;
    sail_motion_state motion;
    const sail_real nan = (sail_real)NAN;
    CHECK(sail_calibration_check(&good) == SAIL_CHECK_OK, "good: %d", (int)sail_calibration_check(&good));
    CHECK(sail_calibration_check(NULL) == SAIL_CHECK_NULL, "NULL");
    cal.kind = 7;
    CHECK(sail_calibration_check(&cal) == SAIL_CHECK_KIND, "kind 7: %d", (int)sail_calibration_check(&cal));
    cal = good;
    cal.model.matrix.n_terms = SAIL_MAX_TERMS + 1;
    CHECK(sail_calibration_check(&cal) == SAIL_CHECK_TERMS, "n_terms %d", SAIL_MAX_TERMS + 1);
    cal.model.matrix.n_terms = 0;
    CHECK(sail_calibration_check(&cal) == SAIL_CHECK_TERMS, "n_terms 0");
    cal = good;
    cal.model.matrix.cheb_hi = cal.model.matrix.cheb_lo;
    CHECK(sail_calibration_check(&cal) == SAIL_CHECK_RANGE, "cheb_lo == cheb_hi");
    cal = good;
    cal.delta_max = nan;
    CHECK(sail_calibration_check(&cal) == SAIL_CHECK_RANGE, "delta_max NaN");
    cal = good;
    cal.l3 = 0;
    CHECK(sail_calibration_check(&cal) == SAIL_CHECK_GEOMETRY, "l3 = 0");
    cal = good;
    cal.capacity[1] = -1;
    CHECK(sail_calibration_check(&cal) == SAIL_CHECK_CAPACITY, "capacity < 0");
    cal = good;
    cal.kind = SAIL_MODEL_SEED;
    cal.model.seed.amplitude_terms[0] = cal.model.seed.amplitude_terms[1] = 1;
    cal.model.seed.phase_terms[0] = 1;
    cal.model.seed.phase_terms[1] = SAIL_MAX_TERMS + 1;
    CHECK(sail_calibration_check(&cal) == SAIL_CHECK_TERMS, "seed phase_terms");
    cal.model.seed.phase_terms[1] = SAIL_MAX_TERMS;
    CHECK(sail_calibration_check(&cal) == SAIL_CHECK_OK, "seed: %d", (int)sail_calibration_check(&cal));

    memset(&design, 0, sizeof design);
    CHECK(sail_lowpass_init(&lowpass, &design) == SAIL_CHECK_SECTIONS, "0 sections");
    design.n_sections = SAIL_MAX_SECTIONS + 1;
    CHECK(sail_lowpass_init(&lowpass, &design) == SAIL_CHECK_SECTIONS, "too many sections");
    design.n_sections = 1;
    CHECK(sail_lowpass_init(&lowpass, &design) == SAIL_CHECK_OK, "1 section");
    CHECK(sail_lowpass_init(NULL, &design) == SAIL_CHECK_NULL, "NULL state");

    memset(&dyn, 0, sizeof dyn);
    dyn.half = 5;
    dyn.order = 2;
    dyn.dt = 1e-3;
    CHECK(sail_motion_init(&motion, &dyn) == SAIL_CHECK_OK, "dynamics");
    dyn.half = SAIL_MAX_HALF_WINDOW + 1;
    CHECK(sail_motion_init(&motion, &dyn) == SAIL_CHECK_DYNAMICS, "half too long");
    dyn.half = 5;
    dyn.order = SAIL_MAX_RATE_ORDER + 1;
    CHECK(sail_motion_init(&motion, &dyn) == SAIL_CHECK_DYNAMICS, "order too high");
    dyn.order = 2;
    dyn.dt = 0;
    CHECK(sail_motion_init(&motion, &dyn) == SAIL_CHECK_DYNAMICS, "dt = 0");
    CHECK(sail_motion_init(&motion, NULL) == SAIL_CHECK_NULL, "NULL dynamics");
}

/* sail_multirate_init names what is wrong with an ADC. */
static void test_multirate_checks(void)
{
    static sail_multirate_state state;
    const sail_calibration cal = pin_calibration();
    const sail_dynamics dyn = quadratic_dynamics(20, 1e-3);
    sail_adc adc = {0.0125, 4, 0.0, 1e-3};  /* an HX711 at 80 SPS, ticks at 1 kHz */
    CHECK(sail_multirate_init(&state, &cal, &dyn, &adc) == SAIL_CHECK_OK, "HX711 at 80 SPS");
    CHECK(sail_multirate_init(&state, &cal, NULL, &adc) == SAIL_CHECK_OK, "no dynamic term");
    CHECK(sail_multirate_init(NULL, &cal, &dyn, &adc) == SAIL_CHECK_NULL, "NULL state");
    CHECK(sail_multirate_init(&state, &cal, &dyn, NULL) == SAIL_CHECK_NULL, "NULL ADC");
    adc.sinc_order = 0;
    CHECK(sail_multirate_init(&state, &cal, &dyn, &adc) == SAIL_CHECK_ADC, "sinc^0");
    adc.sinc_order = SAIL_MAX_SINC_ORDER + 1;
    CHECK(sail_multirate_init(&state, &cal, &dyn, &adc) == SAIL_CHECK_ADC, "sinc^9");
    adc.sinc_order = 4;
    adc.period = 0.1;  /* an HX711 at 10 SPS: a 400 ms window does not fit 256 ticks of 1 ms */
    CHECK(sail_multirate_init(&state, &cal, NULL, &adc) == SAIL_CHECK_ADC, "a window longer than the ring");
    adc.period = 0.0125;
    adc.delay = 0.02;  /* more than a period */
    CHECK(sail_multirate_init(&state, &cal, &dyn, &adc) == SAIL_CHECK_ADC, "delay beyond a period");
    adc.delay = 0;
    adc.tick = 2e-3;  /* not the dynamic term's dt */
    CHECK(sail_multirate_init(&state, &cal, &dyn, &adc) == SAIL_CHECK_ADC, "tick != dt");
    adc.tick = NAN;
    CHECK(sail_multirate_init(&state, &cal, NULL, &adc) == SAIL_CHECK_ADC, "tick NaN");
}

static void test_rezero(void)
{
    /* A free handle on the pin-jointed arm whose offsets drifted by D, the readings of (0.5, -0.3) N: the first
     * quiet window (2 s) re-zeros by exactly D (W^-1 W D), and from the next row on the estimate is zero. */
    const sail_calibration cal = pin_calibration();
    static sail_rezero_state state;
    sail_rezero_policy bad = SAIL_REZERO_POLICY_DEFAULT;
    const sail_reading drift = reading_for(&cal, 80 * PI / 180, 10 * PI / 180, 0.5, -0.3);
    const double D[2] = {(double)(drift.load1 - cal.offset[0]), (double)(drift.load2 - cal.offset[1])};
    int i, made = 0, first_begin = -1;
    CHECK(sail_rezero_init(NULL, &cal, NULL) == SAIL_CHECK_NULL, "NULL state");
    bad.blocks = SAIL_REZERO_MAX_BLOCKS + 1;
    CHECK(sail_rezero_init(&state, &cal, &bad) == SAIL_CHECK_POLICY, "too many blocks");
    bad.blocks = 8;
    bad.max_step_N = 10.0; /* beyond max_total */
    CHECK(sail_rezero_init(&state, &cal, &bad) == SAIL_CHECK_POLICY, "max_step over max_total");
    CHECK(sail_rezero_init(&state, &cal, NULL) == SAIL_CHECK_OK, "defaults");
    for (i = 0; i < 300; i++) { /* 3 s at 100 Hz */
        sail_reading r = reading_for(&cal, 80 * PI / 180, 10 * PI / 180, 0.0, 0.0);
        sail_force f;
        sail_rezero_event event;
        int32_t begins;
        r.load1 += (sail_real)D[0];
        r.load2 += (sail_real)D[1];
        sail_estimate(&cal, &r, &f);
        if (sail_rezero_step(&state, 0.01 * i, r.theta1, r.theta2, &f, SAIL_CONTACT_NONE, &event, &begins) ==
            SAIL_REZERO_MADE) {
            made++;
            CHECK_CLOSE(event.t, 2.0, 1.0, 1e-12);
            CHECK_CLOSE(event.delta[0], D[0], fabs(D[0]) + fabs(D[1]), SAIL_TEST_RTOL);
            CHECK_CLOSE(event.delta[1], D[1], fabs(D[0]) + fabs(D[1]), SAIL_TEST_RTOL);
            CHECK_CLOSE(event.step_N, hypot(0.5, 0.3), 1.0, SAIL_TEST_RTOL);
        }
        if (begins && first_begin < 0)
            first_begin = i;
        if (first_begin >= 0)
            CHECK(fabs((double)f.fx) < 1e-4 && fabs((double)f.fy) < 1e-4, "row %d after the re-zero: %g, %g N", i,
                  (double)f.fx, (double)f.fy);
        else
            CHECK(fabs((double)f.fx - 0.5) < 1e-4 && fabs((double)f.fy + 0.3) < 1e-4, "row %d: the drift before", i);
    }
    CHECK(made == 1 && first_begin == 200, "%d re-zeros, the first row under them %d (the 2 s mark's)", made, first_begin);
}

int main(void)
{
    test_checks();
    test_sincos();
    test_square_pose();
    test_round_trip_over_workspace();
    test_statuses_and_precedence();
    test_degenerate_and_unknown_models();
    test_seed_model_matches_matrix();
    test_block();
    test_tare();
    test_lowpass_first_order();
    test_rate_filter_against_the_convolution();
    test_multirate_checks();
    test_rezero();
    return check_report("test_api");
}

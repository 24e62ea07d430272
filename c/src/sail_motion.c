/*
 * Force in motion: the dynamic term and the causal rate filter.  Mirrors
 * sailforce.estimator.estimate_moving (the force) and
 * sailforce.differentiate.RateTracker fed one reading at a time (the rates):
 * see sail.h and docs/dynamics.md.
 */
#include "sail.h"
#include "sail_math.h"

int sail_estimate_moving(const sail_calibration *cal, const sail_dynamics *dyn, const sail_reading *in,
                         sail_real omega1, sail_real omega2, sail_real alpha1, sail_real alpha2,
                         sail_force *out, sail_real inertial[2])
{
    sail_real jt[2][2], m[2][2], trig[4], sd, cd, w1, w2, v1, v2, b1, b2, det, wx, wy;
    const int status = sail_estimate_parts(cal, in, out, jt, m, trig);
    if (inertial) {
        inertial[0] = SAIL_NAN;
        inertial[1] = SAIL_NAN;
    }
    if (status == SAIL_INVALID || status == SAIL_SINGULAR)
        return status;
    if (!(isfinite(omega1) && isfinite(omega2) && isfinite(alpha1) && isfinite(alpha2))) {
        out->fx = SAIL_NAN;
        out->fy = SAIL_NAN;
        if (status != SAIL_SATURATED)
            out->status = SAIL_MOTION_UNKNOWN;
        return out->status;
    }
    sd = trig[0] * trig[3] - trig[1] * trig[2];  /* sin(theta1 - theta2) */
    cd = trig[1] * trig[3] + trig[0] * trig[2];
    w1 = omega1 * omega1;
    w2 = omega2 * omega2;
    /* the cells' dynamic shears (sailforce.dynamics.ShearModel; Eqs. D1-D2 of docs/dynamics.md) */
    v1 = dyn->k[0][0] * alpha1 + dyn->k[0][1] * w1 + dyn->k[0][2] * (alpha2 * cd + w2 * sd)
         + dyn->k[0][3] * (w2 * cd - alpha2 * sd) + dyn->k[0][4] * trig[1] + dyn->k[0][5] * trig[0];
    v2 = dyn->k[1][0] * alpha2 + dyn->k[1][1] * w2 + dyn->k[1][2] * (alpha1 * cd - w1 * sd)
         + dyn->k[1][3] * (alpha1 * sd + w1 * cd) + dyn->k[1][4] * trig[3] + dyn->k[1][5] * trig[2];
    /* J^T w = (l1 V1, l2 V2) by Cramer's rule; J^T is regular here (the pose is not singular) */
    b1 = dyn->l1 * v1;
    b2 = dyn->l2 * v2;
    det = jt[0][0] * jt[1][1] - jt[0][1] * jt[1][0];
    wx = (jt[1][1] * b1 - jt[0][1] * b2) / det;
    wy = (jt[0][0] * b2 - jt[1][0] * b1) / det;
    out->fx -= wx;
    out->fy -= wy;
    if (inertial) {
        inertial[0] = m[0][0] * wx + m[0][1] * wy;
        inertial[1] = m[1][0] * wx + m[1][1] * wy;
    }
    return status;
}

void sail_motion_init(sail_motion_state *state, const sail_dynamics *dyn)
{
    int i, k;
    state->dyn = dyn;
    state->pushed = 0;
    state->emitted = 0;
    state->run = 0;
    state->t_last = 0;
    for (k = 0; k <= SAIL_MAX_RATE_ORDER; k++) {
        state->moment[0][k] = state->moment[1][k] = 0;
        state->power_out[k] = k ? state->power_out[k - 1] * (unsigned long long)(-(long long)dyn->half - 1) : 1;
        state->power_in[k] = k ? state->power_in[k - 1] * (unsigned long long)dyn->half : 1;
    }
    for (i = 0; i < 2 * SAIL_MAX_HALF_WINDOW + 1; i++)  /* the window starts full of zeros: its moments are 0 */
        state->counts[i][0] = state->counts[i][1] = 0;
}

/* Slide the window by one sample: x_old (offset -half) leaves, x_new (offset +half) enters:
 *   T_k' = sum_m (-1)^(k-m) C(k, m) T_m - (-half - 1)^k x_old + half^k x_new
 * written out to k = 4, in unsigned (modulo 2^64) arithmetic: exact, since every T_k fits in 64 bits.  power_out
 * and power_in hold (-half - 1)^k and half^k. */
static void slide(unsigned long long t[SAIL_MAX_RATE_ORDER + 1], const unsigned long long power_out[],
                  const unsigned long long power_in[], long x_old, long x_new)
{
    const unsigned long long o = (unsigned long long)(long long)x_old, n = (unsigned long long)(long long)x_new;
    const unsigned long long t0 = t[0], t1 = t[1], t2 = t[2], t3 = t[3], t4 = t[4];
    t[0] = t0 - o + n;
    t[1] = t1 - t0 - power_out[1] * o + power_in[1] * n;
    t[2] = t2 - 2 * t1 + t0 - power_out[2] * o + power_in[2] * n;
    t[3] = t3 - 3 * t2 + 3 * t1 - t0 - power_out[3] * o + power_in[3] * n;
    t[4] = t4 - 4 * t3 + 6 * t2 - 4 * t1 + t0 - power_out[4] * o + power_in[4] * n;
}

/* sum_k b[k] T_k over the odd (rate) or even (acceleration) k, the moments read as signed 64-bit integers */
static double odd_kernel(const double *b, const unsigned long long *t)
{
    return b[1] * (double)(long long)t[1] + b[3] * (double)(long long)t[3];
}

static double even_kernel(const double *b, const unsigned long long *t)
{
    return b[0] * (double)(long long)t[0] + b[2] * (double)(long long)t[2] + b[4] * (double)(long long)t[4];
}

/* The estimate of reading i (the oldest not yet returned); `known`: its centred window is complete and linked,
 * and the moments are the window's. */
static void emit(sail_motion_state *state, const sail_calibration *cal, long i, int known, sail_force *out,
                 sail_real inertial[2], sail_reading *held)
{
    const sail_dynamics *dyn = state->dyn;
    const sail_reading *r = &state->held[i % (2 * dyn->half + 1)];
    sail_real omega1 = SAIL_NAN, omega2 = SAIL_NAN, alpha1 = SAIL_NAN, alpha2 = SAIL_NAN;
    if (held)
        *held = *r;
    if (known) {
        const double scale = 6.283185307179586 / SAIL_COUNTS_PER_TURN;
        omega1 = (sail_real)(scale * odd_kernel(dyn->rate, state->moment[0]));
        omega2 = (sail_real)(scale * odd_kernel(dyn->rate, state->moment[1]));
        alpha1 = (sail_real)(scale * even_kernel(dyn->accel, state->moment[0]));
        alpha2 = (sail_real)(scale * even_kernel(dyn->accel, state->moment[1]));
    }
    sail_estimate_moving(cal, dyn, r, omega1, omega2, alpha1, alpha2, out, inertial);
}

/* An angle in whole counts; 0 (and *ok cleared) beyond +-2^31 counts (128 turns) or when not finite. */
static long to_counts(sail_real theta, int *ok)
{
    const double x = (double)theta * (SAIL_COUNTS_PER_TURN / 6.283185307179586);
    if (!(x > -2147483647.0 && x < 2147483647.0)) {
        *ok = 0;
        return 0;
    }
    return (long)(x < 0 ? x - 0.5 : x + 0.5);  /* nearest */
}

int sail_motion_step(sail_motion_state *state, const sail_calibration *cal, double t, const sail_reading *in,
                     sail_force *out, sail_real inertial[2], sail_reading *held)
{
    const sail_dynamics *dyn = state->dyn;
    const int width = 2 * dyn->half + 1;
    const int slot = (int)(state->pushed % width);
    int valid = isfinite(t);
    const long x1 = to_counts(in->theta1, &valid), x2 = to_counts(in->theta2, &valid);
    const double step = t - state->t_last;
    if (!valid)
        state->run = 0;  /* an invalid reading cuts the window on both sides */
    else if (state->run > 0 && step > 0 && step <= SAIL_GAP_FACTOR * dyn->dt)
        state->run++;
    else
        state->run = 1;  /* a gap, a step back in time, or the first reading after a cut */
    if (valid)
        state->t_last = t;
    /* the slot being overwritten holds the window's oldest sample: it leaves as the new one enters */
    slide(state->moment[0], state->power_out, state->power_in, state->counts[slot][0], x1);
    slide(state->moment[1], state->power_out, state->power_in, state->counts[slot][1], x2);
    state->counts[slot][0] = x1;
    state->counts[slot][1] = x2;
    state->held[slot] = *in;
    state->pushed++;
    if (state->pushed - state->emitted <= dyn->half)
        return 0;
    emit(state, cal, state->emitted++, state->run >= width, out, inertial, held);
    return 1;
}

int sail_motion_flush(sail_motion_state *state, const sail_calibration *cal, sail_force *out, sail_real inertial[2],
                      sail_reading *held)
{
    if (state->emitted >= state->pushed)
        return 0;
    emit(state, cal, state->emitted++, 0, out, inertial, held);
    return 1;
}

/*
 * Force in motion: the dynamic term and the causal rate filter.  Mirrors
 * sailforce.estimate.estimate_moving (the force) and
 * sailforce.motion.differentiate.RateTracker fed one reading at a time (the rates):
 * see sail.h and docs/dynamics.md.
 */
#include "sail.h"
#include "sail_rates.h"
#include "sail_static.h"

/* The static estimate, and the dynamic term subtracted when the rates are `known` (then finite). */
static SAIL_ALWAYS_INLINE int estimate_moving(const sail_calibration *cal, const sail_dynamics *dyn, const sail_reading *in, int known,
                           sail_real omega1, sail_real omega2, sail_real alpha1, sail_real alpha2, sail_force *out,
                           sail_real inertial[2])
{
    sail_real jt[2][2], m[2][2], trig[4], sd, cd, w1, w2, v1, v2, b1, b2, det, wx, wy;
    const int status = sail_estimate_parts(cal, in, out, jt, m, trig);
    if (inertial) {
        inertial[0] = SAIL_NAN;
        inertial[1] = SAIL_NAN;
    }
    if (status == SAIL_INVALID || status == SAIL_SINGULAR)
        return status;
    if (!known) {
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
    /* the cells' dynamic shears (sailforce.motion.dynamics.ShearModel; Eqs. D1-D2 of docs/dynamics.md) */
    v1 = dyn->k[0][0] * alpha1 + dyn->k[0][1] * w1 + dyn->k[0][2] * (alpha2 * cd + w2 * sd)
         + dyn->k[0][3] * (w2 * cd - alpha2 * sd) + dyn->k[0][4] * trig[1] + dyn->k[0][5] * trig[0];
    v2 = dyn->k[1][0] * alpha2 + dyn->k[1][1] * w2 + dyn->k[1][2] * (alpha1 * cd - w1 * sd)
         + dyn->k[1][3] * (alpha1 * sd + w1 * cd) + dyn->k[1][4] * trig[3] + dyn->k[1][5] * trig[2];
    /* J^T w = (l1 V1, l2 V2) by Cramer's rule; det J^T = -l2 l3 sin(delta) (seed Eq. 9), not 0 here */
    b1 = dyn->l1 * v1;
    b2 = dyn->l2 * v2;
    det = -cal->l2 * cal->l3 * sd;
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

enum sail_status sail_estimate_moving(const sail_calibration *cal, const sail_dynamics *dyn, const sail_reading *in,
                         sail_real omega1, sail_real omega2, sail_real alpha1, sail_real alpha2,
                         sail_force *out, sail_real inertial[2])
{
    const int known = isfinite(omega1) && isfinite(omega2) && isfinite(alpha1) && isfinite(alpha2);
    return estimate_moving(cal, dyn, in, known, omega1, omega2, alpha1, alpha2, out, inertial);
}

enum sail_check sail_motion_init(sail_motion_state *state, const sail_dynamics *dyn)
{
    if (state == NULL || dyn == NULL)
        return SAIL_CHECK_NULL;
    if (dyn->half < 1 || dyn->half > SAIL_MAX_HALF_WINDOW || dyn->order < 0 || dyn->order > SAIL_MAX_RATE_ORDER
        || !(dyn->dt > 0) || sail_rates_check(dyn) != SAIL_CHECK_OK)
        return SAIL_CHECK_DYNAMICS;
    state->dyn = dyn;
    state->pending = 0;
    state->t_last = 0;
    state->gap = (sail_real)(SAIL_GAP_FACTOR * dyn->dt);
    sail_rates_init(&state->rates, dyn);
    return SAIL_CHECK_OK;
}

/* The estimate of the oldest reading held; `known`: its centred window is complete and linked, and the moments are
 * the window's. */
static void emit(sail_motion_state *state, const sail_calibration *cal, int known, sail_force *out,
                 sail_real inertial[2], sail_reading *held)
{
    const sail_reading *r = &state->held[sail_rates_oldest(&state->rates, state->pending)];
    sail_real rates[4] = {0, 0, 0, 0};
    state->pending--;
    if (held)
        *held = *r;
    if (known)
        sail_rates_read(&state->rates, rates);
    estimate_moving(cal, state->dyn, r, known, rates[0], rates[2], rates[1], rates[3], out, inertial);
}

int sail_motion_step(sail_motion_state *state, const sail_calibration *cal, double t, const sail_reading *in,
                     sail_force *out, sail_real inertial[2], sail_reading *held)
{
    int valid = sail_finite_time(t);
    const int32_t x1 = sail_to_counts(in->theta1, &valid), x2 = sail_to_counts(in->theta2, &valid);
    const sail_instant now = valid ? INSTANT(t) : 0;
    const sail_real step = SECONDS(now - state->t_last);  /* no software double arithmetic on a single-precision FPU */
    const int whole = sail_rates_link(&state->rates, valid, step > 0 && step <= state->gap);
    if (valid)
        state->t_last = now;
    state->held[state->rates.slot] = *in;
    sail_rates_push(&state->rates, x1, x2);
    if (++state->pending <= state->dyn->half)
        return 0;
    emit(state, cal, whole, out, inertial, held);
    return 1;
}

int sail_motion_flush(sail_motion_state *state, const sail_calibration *cal, sail_force *out, sail_real inertial[2],
                      sail_reading *held)
{
    if (state->pending <= 0)
        return 0;
    emit(state, cal, 0, out, inertial, held);
    return 1;
}

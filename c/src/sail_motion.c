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
    state->dyn = dyn;
    state->pushed = 0;
    state->emitted = 0;
    state->run = 0;
    state->t_last = 0;
}

/* The estimate of reading i (the oldest not yet returned); its centred window is known when the last `width`
 * readings pushed are linked (run >= width), which the caller decides. */
static void emit(sail_motion_state *state, const sail_calibration *cal, long i, int known, sail_force *out,
                 sail_real inertial[2], sail_reading *held)
{
    const sail_dynamics *dyn = state->dyn;
    const int half = dyn->half, width = 2 * half + 1;
    const sail_reading *r = &state->held[i % width];
    sail_real omega1 = SAIL_NAN, omega2 = SAIL_NAN, alpha1 = SAIL_NAN, alpha2 = SAIL_NAN;
    if (held)
        *held = *r;
    if (known) {  /* then i >= half: the window starts at slot (i - half) mod width, contiguous in angles[] */
        const sail_real(*q)[2] = (const sail_real(*)[2])state->angles[(i - half) % width + half];
        /* Savitzky-Golay: rate = sum_j c_j (q[+j] - q[-j]); acceleration = sum_j a_j ((q[+j] - q[0]) + (q[-j] - q[0])),
         * which is a_0 q[0] + sum_j a_j (q[+j] + q[-j]) as the a_j sum to zero, without its cancellation in
         * float (the differences of nearby angles are exact) */
        const sail_real q1 = q[0][0], q2 = q[0][1];
        sail_real r1 = 0, r2 = 0, a1 = 0, a2 = 0;
        int j;
        for (j = 1; j <= half; j++) {
            const sail_real c = dyn->rate[j], a = dyn->accel[j];
            r1 += c * (q[j][0] - q[-j][0]);
            r2 += c * (q[j][1] - q[-j][1]);
            a1 += a * ((q[j][0] - q1) + (q[-j][0] - q1));
            a2 += a * ((q[j][1] - q2) + (q[-j][1] - q2));
        }
        omega1 = r1;
        omega2 = r2;
        alpha1 = a1;
        alpha2 = a2;
    }
    sail_estimate_moving(cal, dyn, r, omega1, omega2, alpha1, alpha2, out, inertial);
}

int sail_motion_step(sail_motion_state *state, const sail_calibration *cal, double t, const sail_reading *in,
                     sail_force *out, sail_real inertial[2], sail_reading *held)
{
    const sail_dynamics *dyn = state->dyn;
    const int width = 2 * dyn->half + 1;
    const int slot = (int)(state->pushed % width);
    const int valid = isfinite(t) && isfinite(in->theta1) && isfinite(in->theta2);
    const double step = t - state->t_last;
    if (!valid)
        state->run = 0;  /* an invalid reading cuts the window on both sides */
    else if (state->run > 0 && step > 0 && step <= SAIL_GAP_FACTOR * (double)dyn->dt)
        state->run++;
    else
        state->run = 1;  /* a gap, a step back in time, or the first reading after a cut */
    if (valid)
        state->t_last = t;
    state->held[slot] = *in;
    state->angles[slot][0] = state->angles[slot + width][0] = in->theta1;
    state->angles[slot][1] = state->angles[slot + width][1] = in->theta2;
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

/*
 * Force in motion: the dynamic term and the causal rate filter.  Mirrors
 * sailforce.estimate.estimate_moving (the force) and
 * sailforce.motion.differentiate.RateTracker fed one reading at a time (the rates):
 * see sail.h and docs/dynamics.md.
 */
#include "sail.h"
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

/* C(n, k) for the small n and k here, exactly. */
static uint64_t binomial(int n, int k)
{
    uint64_t c = 1;
    int i;
    for (i = 1; i <= k; i++)
        c = c * (uint64_t)(n - k + i) / (uint64_t)i;  /* C(n-k+i, i), an integer at each step */
    return c;
}

/* A kernel sum_m b[m] j^m over the window's offsets j = u - half, rewritten in the binomial basis C(u, k):
 * its Newton forward differences at u = 0,  beta_k = sum_i (-1)^(k-i) C(k, i) w(i - half)  (exact for a polynomial of
 * degree <= SAIL_MAX_RATE_ORDER), scaled by the count's angle. */
static void binomial_kernel(const double b[SAIL_MAX_RATE_ORDER + 1], int half, double beta[SAIL_MAX_RATE_ORDER + 1])
{
    const double rad_per_count = 6.283185307179586 / SAIL_COUNTS_PER_TURN;
    int k, i, m;
    for (k = 0; k <= SAIL_MAX_RATE_ORDER; k++) {
        double sum = 0;
        for (m = 0; m <= SAIL_MAX_RATE_ORDER; m++) {
            double difference = 0;  /* Delta^k (u - half)^m at u = 0: an integer, exact in double */
            for (i = 0; i <= k; i++) {
                const double j = (double)(i - half);
                double power = 1;
                int p;
                for (p = 0; p < m; p++)
                    power *= j;
                difference += ((k - i) % 2 ? -1.0 : 1.0) * (double)binomial(k, i) * power;
            }
            sum += b[m] * difference;
        }
        beta[k] = rad_per_count * sum;
    }
}

enum sail_check sail_motion_init(sail_motion_state *state, const sail_dynamics *dyn)
{
    int i, k;
    if (state == NULL || dyn == NULL)
        return SAIL_CHECK_NULL;
    if (dyn->half < 1 || dyn->half > SAIL_MAX_HALF_WINDOW || dyn->order < 0 || dyn->order > SAIL_MAX_RATE_ORDER
        || !(dyn->dt > 0))
        return SAIL_CHECK_DYNAMICS;
    state->dyn = dyn;
    state->width = 2 * dyn->half + 1;
    state->slot = 0;
    state->pending = 0;
    state->run = 0;
    state->t_last = 0;
    state->gap = SAIL_GAP_FACTOR * dyn->dt;
    binomial_kernel(dyn->rate, dyn->half, state->rate);
    binomial_kernel(dyn->accel, dyn->half, state->accel);
    for (k = 0; k <= SAIL_MAX_RATE_ORDER; k++) {
        state->moment[0][k] = state->moment[1][k] = 0;
        state->entry[k] = binomial(state->width, k);
    }
    for (i = 0; i < 2 * SAIL_MAX_HALF_WINDOW + 1; i++)  /* the window starts full of zeros: its moments are 0 */
        state->counts[i][0] = state->counts[i][1] = 0;
    return SAIL_CHECK_OK;
}

/* Slide the window by one sample: x_old (u = 0) leaves, the others move to u - 1, and x_new enters at u = 2 half.
 * By Pascal's rule C(u - 1, k) = C(u, k) - C(u - 1, k - 1):
 *   U_0' = U_0 - x_old + x_new,   U_k' = U_k - U_{k-1}' + C(2 half + 1, k) x_new   (k >= 1),
 * in unsigned (modulo 2^64) arithmetic: exact, since every U_k fits in 64 bits. */
static inline void slide(uint64_t u[SAIL_MAX_RATE_ORDER + 1], const uint64_t entry[], long x_old,
                         long x_new)
{
    const uint64_t n = (uint64_t)(long long)x_new;
    u[0] = u[0] - (uint64_t)(long long)x_old + n;
    u[1] = u[1] - u[0] + entry[1] * n;
    u[2] = u[2] - u[1] + entry[2] * n;
    u[3] = u[3] - u[2] + entry[3] * n;
    u[4] = u[4] - u[3] + entry[4] * n;
}

/* The rate and the acceleration of one angle, sum_k beta[k] U_k with the moments read as signed 64-bit integers */
static inline void rates(const sail_motion_state *state, const uint64_t *u, sail_real *omega,
                         sail_real *alpha)
{
    const double u0 = (double)(long long)u[0], u1 = (double)(long long)u[1], u2 = (double)(long long)u[2],
                 u3 = (double)(long long)u[3], u4 = (double)(long long)u[4];
    const double *a = state->accel, *w = state->rate;
    *omega = (sail_real)(w[0] * u0 + w[1] * u1 + w[2] * u2 + w[3] * u3 + w[4] * u4);
    *alpha = (sail_real)(a[0] * u0 + a[1] * u1 + a[2] * u2 + a[3] * u3 + a[4] * u4);
}

/* The estimate of the oldest reading held; `known`: its centred window is complete and linked, and the moments are
 * the window's. */
static void emit(sail_motion_state *state, const sail_calibration *cal, int known, sail_force *out,
                 sail_real inertial[2], sail_reading *held)
{
    int oldest = state->slot - state->pending;
    const sail_reading *r;
    sail_real omega1 = 0, omega2 = 0, alpha1 = 0, alpha2 = 0;
    if (oldest < 0)
        oldest += state->width;
    r = &state->held[oldest];
    state->pending--;
    if (held)
        *held = *r;
    if (known) {
        rates(state, state->moment[0], &omega1, &alpha1);
        rates(state, state->moment[1], &omega2, &alpha2);
    }
    estimate_moving(cal, state->dyn, r, known, omega1, omega2, alpha1, alpha2, out, inertial);
}

/* An angle in whole counts; 0 (and *ok cleared) beyond +-2^31 counts (128 turns) or when not finite. */
static inline long to_counts(sail_real theta, int *ok)
{
    const double x = (double)theta * (SAIL_COUNTS_PER_TURN / 6.283185307179586);
    if (!(x > -2147483647.0 && x < 2147483647.0)) {
        *ok = 0;
        return 0;
    }
    return (long)((long long)(x + 2147483648.5) - 2147483648LL);  /* nearest: floor(x + 1/2), truncating a positive */
}

int sail_motion_step(sail_motion_state *state, const sail_calibration *cal, double t, const sail_reading *in,
                     sail_force *out, sail_real inertial[2], sail_reading *held)
{
    const int slot = state->slot;
    int valid = isfinite(t);
    const long x1 = to_counts(in->theta1, &valid), x2 = to_counts(in->theta2, &valid);
    const double step = t - state->t_last;
    if (!valid)
        state->run = 0;  /* an invalid reading cuts the window on both sides */
    else if (state->run > 0 && step > 0 && step <= state->gap)
        state->run += state->run < state->width;
    else
        state->run = 1;  /* a gap, a step back in time, or the first reading after a cut */
    if (valid)
        state->t_last = t;
    /* the slot being overwritten holds the window's oldest sample: it leaves as the new one enters */
    slide(state->moment[0], state->entry, state->counts[slot][0], x1);
    slide(state->moment[1], state->entry, state->counts[slot][1], x2);
    state->counts[slot][0] = x1;
    state->counts[slot][1] = x2;
    state->held[slot] = *in;
    state->slot = slot + 1 == state->width ? 0 : slot + 1;
    if (++state->pending <= state->dyn->half)
        return 0;
    emit(state, cal, state->run == state->width, out, inertial, held);
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

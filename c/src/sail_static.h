/*
 * Internal: the static estimate, solve M(theta1, theta2) F = s for the end-effector force F,
 * with s the offset-free load-cell readings.  Mirrors sailforce.estimate.estimate and
 * sailforce.sensing (see sail.h).  A header so that both entry points, sail_estimate
 * (sail_estimate.c) and sail_motion_step (sail_motion.c), inline it into their hot path.
 */
#ifndef SAIL_STATIC_H
#define SAIL_STATIC_H

#include "sail.h"
#include "sail_math.h"

/* 180 / pi: the seed model's polynomials take delta in degrees and give the phase in degrees. */
#define SAIL_DEG_PER_RAD SAIL_R(57.29577951308232)
#define SAIL_RAD_PER_DEG SAIL_R(0.017453292519943295)

/* C(delta) = sum_k c[k] T_k(x) by Clenshaw's recurrence, the four entries at once (as numpy's chebval). */
static inline void chebyshev_matrix(const sail_matrix_model *cal, sail_real delta, sail_real c[2][2])
{
    const int n = cal->n_terms;
    const sail_real x = (SAIL_R(2.0) * delta - (cal->cheb_lo + cal->cheb_hi)) / (cal->cheb_hi - cal->cheb_lo);
    const sail_real x2 = x + x;
    sail_real a0, a1, a2, a3, b0, b1, b2, b3;  /* Clenshaw's b_k and b_{k+1} of the four entries, in registers */
    int k;
    if (n < 2) {
        c[0][0] = cal->cheb[0][0][0];
        c[0][1] = cal->cheb[0][0][1];
        c[1][0] = cal->cheb[0][1][0];
        c[1][1] = cal->cheb[0][1][1];
        return;
    }
    a0 = cal->cheb[n - 2][0][0], a1 = cal->cheb[n - 2][0][1], a2 = cal->cheb[n - 2][1][0], a3 = cal->cheb[n - 2][1][1];
    b0 = cal->cheb[n - 1][0][0], b1 = cal->cheb[n - 1][0][1], b2 = cal->cheb[n - 1][1][0], b3 = cal->cheb[n - 1][1][1];
    for (k = n - 3; k >= 0; k--) {  /* the term's four entries together: one pass over the series */
        const sail_real t0 = a0, t1 = a1, t2 = a2, t3 = a3;
        a0 = cal->cheb[k][0][0] - b0;
        a1 = cal->cheb[k][0][1] - b1;
        a2 = cal->cheb[k][1][0] - b2;
        a3 = cal->cheb[k][1][1] - b3;
        b0 = t0 + b0 * x2;
        b1 = t1 + b1 * x2;
        b2 = t2 + b2 * x2;
        b3 = t3 + b3 * x2;
    }
    c[0][0] = a0 + b0 * x;
    c[0][1] = a1 + b1 * x;
    c[1][0] = a2 + b2 * x;
    c[1][1] = a3 + b3 * x;
}

/* p(x) for coefficients highest power first (numpy.polyval). */
static inline sail_real polyval(const sail_real *p, int n, sail_real x)
{
    sail_real y = 0;
    int k;
    for (k = 0; k < n; k++)
        y = y * x + p[k];
    return y;
}

/* The sensing matrix M: signal per newton.  jt is J^T (rows j_1, j_2).  Returns 0, or -1 for an unknown kind. */
static SAIL_ALWAYS_INLINE int sensing_matrix(const sail_calibration *cal, sail_real delta, sail_real jt[2][2], sail_real m[2][2])
{
    int i;
    if (cal->kind == SAIL_MODEL_MATRIX) {
        sail_real c[2][2];
        chebyshev_matrix(&cal->model.matrix, delta, c);
        for (i = 0; i < 2; i++) {
            m[i][0] = c[i][0] * jt[0][0] + c[i][1] * jt[1][0];
            m[i][1] = c[i][0] * jt[0][1] + c[i][1] * jt[1][1];
        }
        return 0;
    }
    if (cal->kind == SAIL_MODEL_SEED) {
        const sail_real delta_deg = delta * SAIL_DEG_PER_RAD;
        for (i = 0; i < 2; i++) {  /* row i = R(-P_i) j_i / A_i */
            const sail_seed_model *seed = &cal->model.seed;
            const sail_real a = polyval(seed->amplitude[i], seed->amplitude_terms[i], delta_deg);
            const sail_real p = polyval(seed->phase_deg[i], seed->phase_terms[i], delta_deg) * SAIL_RAD_PER_DEG;
            sail_real cp, sp;
            sail_sincos(p, &sp, &cp);
            m[i][0] = (cp * jt[i][0] + sp * jt[i][1]) / a;
            m[i][1] = (cp * jt[i][1] - sp * jt[i][0]) / a;
        }
        return 0;
    }
    return -1;
}

static inline int finish(sail_force *out, sail_real fx, sail_real fy, int32_t status)
{
    out->fx = fx;
    out->fy = fy;
    out->status = status;
    return status;
}

/* The estimate, also giving J^T, M and (sin th1, cos th1, sin th2, cos th2); jt and m are set
 * unless the status is SAIL_INVALID or SAIL_SINGULAR, trig unless SAIL_INVALID. */
static SAIL_ALWAYS_INLINE int sail_estimate_parts(const sail_calibration *cal, const sail_reading *in, sail_force *out,
                                                  sail_real jt[2][2], sail_real m[2][2], sail_real trig[4])
{
    sail_real s1, c1, s2, c2, delta, det, u1, u2;
    int status = SAIL_OK;
    if (!sail_finite4(in))
        return finish(out, SAIL_NAN, SAIL_NAN, SAIL_INVALID);
    sail_sincos(in->theta1, &s1, &c1);
    sail_sincos(in->theta2, &s2, &c2);
    trig[0] = s1;
    trig[1] = c1;
    trig[2] = s2;
    trig[3] = c2;
    /* det J = -l2 l3 sin(delta) (seed Eq. 9): the parallelogram collapses as sin(delta) -> 0 */
    if (SAIL_FABS(s1 * c2 - c1 * s2) < (sail_real)SAIL_SINGULAR_SIN_DELTA)
        return finish(out, SAIL_NAN, SAIL_NAN, SAIL_SINGULAR);
    jt[0][0] = -cal->l3 * s1;  /* J^T (seed Eqs. 3, 4 and 7) */
    jt[0][1] = cal->l3 * c1;
    jt[1][0] = -cal->l2 * s2;
    jt[1][1] = cal->l2 * c2;
    delta = in->theta1 - in->theta2;
    if (sensing_matrix(cal, delta, jt, m) != 0)
        return finish(out, SAIL_NAN, SAIL_NAN, SAIL_INVALID);
    det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    if (det == 0 || !(det - det == 0))  /* a degenerate fitted map cannot be inverted either (det - det: NaN unless finite) */
        return finish(out, SAIL_NAN, SAIL_NAN, SAIL_SINGULAR);
    u1 = in->load1 - cal->offset[0];
    u2 = in->load2 - cal->offset[1];
    if (SAIL_FABS(u1) > cal->capacity[0] || SAIL_FABS(u2) > cal->capacity[1])
        status = SAIL_SATURATED;
    else if (delta < cal->delta_min - (sail_real)SAIL_DELTA_RANGE_SLACK
             || delta > cal->delta_max + (sail_real)SAIL_DELTA_RANGE_SLACK)
        status = SAIL_EXTRAPOLATED;
    /* Cramer's rule (cf. seed Eq. 8) */
    return finish(out, (m[1][1] * u1 - m[0][1] * u2) / det, (m[0][0] * u2 - m[1][0] * u1) / det, status);
}

#endif /* SAIL_STATIC_H */

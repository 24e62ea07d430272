/*
 * Internal: the causal Savitzky-Golay rate filter of sail_motion_step and sail_multirate_step
 * (docs/dynamics.md, "The rate filter in libsail").  The window's angles, in whole counts, are held as exact
 * moments in the binomial basis (a slide costs O(order) whatever the window's length); a rate is read out on the
 * window's discrete orthogonal (Gram) polynomials, whose projections are exact integers that stay small, so that
 * float arithmetic loses nothing to cancellation.
 */
#ifndef SAIL_RATES_H
#define SAIL_RATES_H

#include "sail.h"
#include "sail_math.h"

/* 2^24 / (2 pi): counts per radian (SAIL_COUNTS_PER_TURN). */
#define SAIL_COUNTS_PER_RAD (SAIL_COUNTS_PER_TURN / 6.283185307179586)
/* An angle beyond this many counts (128 turns) cannot be a count: the reading is invalid. */
#define SAIL_COUNTS_LIMIT SAIL_R(2147483520.0)

/* An angle in whole counts, the nearest; 0 (and *ok cleared) beyond +-SAIL_COUNTS_LIMIT or when not finite. */
static SAIL_ALWAYS_INLINE int32_t sail_to_counts(sail_real theta, int *ok)
{
    const sail_real x = theta * (sail_real)SAIL_COUNTS_PER_RAD;
    if (!(x > -SAIL_COUNTS_LIMIT && x < SAIL_COUNTS_LIMIT)) {
        *ok = 0;
        return 0;
    }
    return (int32_t)(x + (x < 0 ? SAIL_R(-0.5) : SAIL_R(0.5)));  /* the conversion truncates: nearest, halves away */
}

/* Slide one angle's window by one sample: x_old (u = 0) leaves, the others move to u - 1, and x_new enters at
 * u = 2 half.  By Pascal's rule C(u - 1, k) = C(u, k) - C(u - 1, k - 1):
 *   U_0' = U_0 - x_old + x_new,   U_k' = U_k - U_{k-1}' + C(2 half + 1, k) x_new   (k >= 1),
 * in unsigned (modulo 2^64) arithmetic: exact, since every U_k fits in 64 bits.  C(2 half + 1, k) < 2^24, so each
 * product is one signed 32 x 32 -> 64-bit multiplication. */
static SAIL_OWN_CALL void sail_slide(uint64_t u[SAIL_MAX_RATE_ORDER + 1], const uint32_t entry[],
                                     int32_t x_old, int32_t x_new)
{
#define SAIL_ENTERS(k) ((uint64_t)((int64_t)(int32_t)entry[k] * x_new))
    /* in locals: the compiler cannot know that u and entry do not overlap */
    const uint64_t u0 = u[0] - (uint64_t)(int64_t)x_old + (uint64_t)(int64_t)x_new;
    const uint64_t u1 = u[1] - u0 + SAIL_ENTERS(1);
    const uint64_t u2 = u[2] - u1 + SAIL_ENTERS(2);
    const uint64_t u3 = u[3] - u2 + SAIL_ENTERS(3);
    const uint64_t u4 = u[4] - u3 + SAIL_ENTERS(4);
#undef SAIL_ENTERS
    u[0] = u0;
    u[1] = u1;
    u[2] = u2;
    u[3] = u3;
    u[4] = u4;
}

#ifdef __arm__
/* A projection's value as a sail_real: `low` plus 2^32 `high`, modulo 2^64 (the low halves' products summed in 64
 * bits and the high halves' in 32). */
static SAIL_ALWAYS_INLINE sail_real sail_projection(uint64_t low, uint32_t high)
{
    return sail_int64_real(low + ((uint64_t)high << 32));
}
#endif

/* One angle's rate and acceleration: the projections P_d = sum_k gram[d][k] U_k (exact integers, modulo 2^64)
 * weighted by the kernels' Gram coefficients, unrolled to SAIL_MAX_RATE_ORDER (a lower order's coefficients are
 * zero).  The coefficients' signs alternate, (-1)^(degree + k) (checked by sail_rates_check), and their magnitudes
 * g are unsigned 32-bit.  On a 32-bit core, with U_k = 2^32 h_k + l_k, modulo 2^64
 *   P_d = sum_+ g l_k - sum_- g l_k + 2^32 (sum_+- g h_k  modulo 2^32):
 * a 32 x 32 -> 64-bit product per low half and a 32-bit one per high half (on a Cortex-M4F 130 instructions a
 * call against 153 for the 64 x 32-bit products, which a 64-bit core does in one instruction each). */
static SAIL_OWN_CALL void sail_rates_of(const sail_rate_filter *f, const uint64_t u[SAIL_MAX_RATE_ORDER + 1],
                                        sail_real *omega, sail_real *alpha)
{
#ifdef __arm__  /* a 32-bit core: the halves */
    const uint32_t(*g)[SAIL_MAX_RATE_ORDER + 1] = f->gram;
    const uint32_t l0 = (uint32_t)u[0], l1 = (uint32_t)u[1], l2 = (uint32_t)u[2], l3 = (uint32_t)u[3];
    const uint32_t l4 = (uint32_t)u[4];
    const uint32_t h0 = (uint32_t)(u[0] >> 32), h1 = (uint32_t)(u[1] >> 32), h2 = (uint32_t)(u[2] >> 32);
    const uint32_t h3 = (uint32_t)(u[3] >> 32), h4 = (uint32_t)(u[4] >> 32);
    uint64_t plus, minus;
    sail_real p1, p2, p3, p4;
    plus = (uint64_t)g[0][1] * l1;
    minus = (uint64_t)g[0][0] * l0;
    p1 = sail_projection(plus - minus, g[0][1] * h1 - g[0][0] * h0);
    plus = (uint64_t)g[1][0] * l0;
    plus += (uint64_t)g[1][2] * l2;
    minus = (uint64_t)g[1][1] * l1;
    p2 = sail_projection(plus - minus, g[1][0] * h0 + g[1][2] * h2 - g[1][1] * h1);
    plus = (uint64_t)g[2][1] * l1;
    plus += (uint64_t)g[2][3] * l3;
    minus = (uint64_t)g[2][0] * l0;
    minus += (uint64_t)g[2][2] * l2;
    p3 = sail_projection(plus - minus, g[2][1] * h1 + g[2][3] * h3 - g[2][0] * h0 - g[2][2] * h2);
    plus = (uint64_t)g[3][0] * l0;
    plus += (uint64_t)g[3][2] * l2;
    plus += (uint64_t)g[3][4] * l4;
    minus = (uint64_t)g[3][1] * l1;
    minus += (uint64_t)g[3][3] * l3;
    p4 = sail_projection(plus - minus, g[3][0] * h0 + g[3][2] * h2 + g[3][4] * h4 - g[3][1] * h1 - g[3][3] * h3);
#else  /* a 64-bit core multiplies 64 x 64 bits in one instruction */
    const uint64_t u0 = u[0], u1 = u[1], u2 = u[2], u3 = u[3], u4 = u[4];
#define SAIL_G(d, k) ((uint64_t)f->gram[d][k])
    const sail_real p1 = sail_int64_real(SAIL_G(0, 1) * u1 - SAIL_G(0, 0) * u0);
    const sail_real p2 = sail_int64_real(SAIL_G(1, 0) * u0 + SAIL_G(1, 2) * u2 - SAIL_G(1, 1) * u1);
    const sail_real p3 = sail_int64_real(SAIL_G(2, 1) * u1 + SAIL_G(2, 3) * u3 - SAIL_G(2, 0) * u0 - SAIL_G(2, 2) * u2);
    const sail_real p4 = sail_int64_real(SAIL_G(3, 0) * u0 + SAIL_G(3, 2) * u2 + SAIL_G(3, 4) * u4 - SAIL_G(3, 1) * u1
                                         - SAIL_G(3, 3) * u3);
#undef SAIL_G
#endif
    /* a centred window's rate kernel is odd and its acceleration kernel even (sail_rates_check): each lies on the
     * Gram polynomials of its own parity */
    *omega = f->gamma_rate[0] * p1 + f->gamma_rate[2] * p3;
    *alpha = f->gamma_accel[1] * p2 + f->gamma_accel[3] * p4;
}

/* Push one sample's counts into the window (the slot the oldest leaves from). */
static SAIL_ALWAYS_INLINE void sail_rates_push(sail_rate_filter *f, int32_t x1, int32_t x2)
{
    const int32_t slot = f->slot;
    sail_slide(f->moment[0], f->entry, f->counts[slot][0], x1);
    sail_slide(f->moment[1], f->entry, f->counts[slot][1], x2);
    f->counts[slot][0] = x1;
    f->counts[slot][1] = x2;
    f->slot = slot + 1 == f->width ? 0 : slot + 1;
}

/* The centre sample's rates (omega1, alpha1, omega2, alpha2): valid once a whole linked window is in. */
static SAIL_ALWAYS_INLINE void sail_rates_read(const sail_rate_filter *f, sail_real out[4])
{
    sail_rates_of(f, f->moment[0], &out[0], &out[1]);
    sail_rates_of(f, f->moment[1], &out[2], &out[3]);
}

/* Track how many linked samples the window holds: `valid` (the sample's time and angles are numbers) and `linked`
 * (its step from the last valid sample is positive and within the gap); returns whether the window is whole. */
static SAIL_ALWAYS_INLINE int sail_rates_link(sail_rate_filter *f, int valid, int linked)
{
    if (!valid)
        f->run = 0;  /* an invalid sample cuts the window on both sides */
    else if (f->run > 0 && linked)
        f->run += f->run < f->width;
    else
        f->run = 1;  /* a gap, a step back in time, or the first sample after a cut */
    return f->run == f->width;
}

/* The ring slot of the oldest of `pending` samples held (the next to come out of the delay line). */
static SAIL_ALWAYS_INLINE int sail_rates_oldest(const sail_rate_filter *f, int32_t pending)
{
    const int oldest = f->slot - pending;
    return oldest < 0 ? oldest + f->width : oldest;
}

/* Set up the filter for dyn's kernels (checked by the caller, with sail_rates_check). */
void sail_rates_init(sail_rate_filter *f, const sail_dynamics *dyn);
/* Whether dyn's kernels are derivatives (they sum to zero over the window): SAIL_CHECK_OK or SAIL_CHECK_DYNAMICS. */
enum sail_check sail_rates_check(const sail_dynamics *dyn);

#endif /* SAIL_RATES_H */

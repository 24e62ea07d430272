/* Internal: the sail_real flavour of <math.h>. */
#ifndef SAIL_MATH_H
#define SAIL_MATH_H

#include <math.h>
#include <string.h>

#include "sail.h"

#ifdef SAIL_DOUBLE
#define SAIL_SIN sin
#define SAIL_COS cos
#define SAIL_FABS fabs
#define SAIL_SQRT sqrt
#define SAIL_R(x) (x)
#else
#define SAIL_SIN sinf
#define SAIL_COS cosf
#define SAIL_FABS fabsf
#define SAIL_SQRT sqrtf
#define SAIL_R(x) (x##f)
#endif

#define SAIL_NAN ((sail_real)NAN)

/* Inline whatever the compiler's size heuristics say: for the hot path's few call sites (cf. CMSIS's
 * __STATIC_FORCEINLINE). */
#if defined(__GNUC__)
#define SAIL_ALWAYS_INLINE inline __attribute__((always_inline))
#if defined(__arm__)
/* A call of its own: for 64-bit integer work, whose registers a 32-bit core spills when it is inlined into a larger
 * function (measured on Cortex-M4: a fifth fewer instructions for the rate filter). */
#define SAIL_OWN_CALL __attribute__((noinline))
#else
#define SAIL_OWN_CALL inline
#endif
#else
#define SAIL_ALWAYS_INLINE inline
#define SAIL_OWN_CALL
#endif

#if defined(SAIL_DOUBLE) || defined(SAIL_LIBM_TRIG)
static inline void sail_sincos(sail_real x, sail_real *s, sail_real *c)
{
    *s = SAIL_SIN(x);
    *c = SAIL_COS(x);
}
#else
/*
 * sin and cos in float without libm's large-argument reduction, which alone
 * costs 3.3 KB of Cortex-M flash (newlib's __kernel_rem_pio2f and its
 * 2/pi table): a measured need (4 KiB for sail_estimate).
 *
 * x = k pi/2 + r with |r| <= pi/4, by Cody and Waite's three-part pi/2
 * (P1 and P2 have few significant bits, so k P1 and k P2 are exact for
 * |k| < 2^12, |x| < ~6400 rad: any joint angle); then the minimax
 * polynomials of Cephes' sinf/cosf on [-pi/4, pi/4] (Moshier, "Methods and
 * Programs for Mathematical Functions", 1989), within 2 ulp.  Beyond
 * 2^16 rad, where a float angle is coarser than a radian anyway, x is first
 * folded by 2 pi in float.
 */
#define SAIL_PIO2_1 1.5703125f                   /* pi/2 = P1 + P2 + P3 */
#define SAIL_PIO2_2 4.837512969970703125e-4f
#define SAIL_PIO2_3 7.54978995489188216e-8f
#define SAIL_2_OVER_PI 0.636619772367581343f
#define SAIL_TWO_PI 6.28318530717958648f
#define SAIL_TRIG_FOLD 65536.0f
#define SAIL_ROUNDING_SHIFT 12582912.0f            /* 1.5 2^23 */

static inline void sail_sincos(float x, float *s, float *c)
{
    float shifted, k, r, z, sr, cr;
    int q;
    if (fabsf(x) > SAIL_TRIG_FOLD)
        x -= SAIL_TWO_PI * (float)(long)(x / SAIL_TWO_PI);
    shifted = x * SAIL_2_OVER_PI + SAIL_ROUNDING_SHIFT;  /* nearest integer: |x 2/pi| < 2^22, so the sum's */
    k = shifted - SAIL_ROUNDING_SHIFT;                   /* unit is 1 (stored in a float: rounded even in excess precision) */
    r = ((x - k * SAIL_PIO2_1) - k * SAIL_PIO2_2) - k * SAIL_PIO2_3;
    z = r * r;
    sr = r + r * z * (-1.6666654611e-1f + z * (8.3321608736e-3f + z * -1.9515295891e-4f));
    cr = 1.0f - 0.5f * z + z * z * (4.166664568298827e-2f + z * (-1.388731625493765e-3f + z * 2.443315711809948e-5f));
    q = (int)((long)k & 3);
    switch (q) {
    case 0: *s = sr; *c = cr; break;
    case 1: *s = cr; *c = -sr; break;
    case 2: *s = -sr; *c = -cr; break;
    default: *s = -cr; *c = sr; break;
    }
}
#endif

/* isfinite for a double, from its exponent bits: no software double arithmetic on a single-precision FPU. */
static inline int sail_finite_time(double t)
{
    uint64_t bits;
    memcpy(&bits, &t, sizeof bits);
    return ((bits >> 52) & 0x7ff) != 0x7ff;
}

/* A 64-bit two's-complement integer (held unsigned, for modulo arithmetic) as a sail_real: int64_t is two's
 * complement in C99 (7.18.1.1), so the bits say the value.  With SAIL_FIXED_TIME (a float build on a core without
 * double hardware), from its two halves instead
 * of libgcc's software conversion (the high half is exact below 2^56, the result within 1.5 ulp). */
static SAIL_ALWAYS_INLINE sail_real sail_int64_real(uint64_t v)
{
#ifdef SAIL_FIXED_TIME
    const uint32_t hi = (uint32_t)(v >> 32), lo = (uint32_t)v;
    int32_t high;
    memcpy(&high, &hi, sizeof high);  /* two's complement (C99 7.18.1.1): the signed high half */
    return (float)high * 4294967296.0f + (float)lo;
#else
    int64_t value;
    memcpy(&value, &v, sizeof value);
    return (sail_real)value;
#endif
}

/* Units of a fixed-point time: 2^-32 s (0.23 ns). */
#define SAIL_TIME_UNITS_PER_S 4294967296.0
/* A time [s] as a whole number of 2^-32 s, truncated, from its bits: no software double arithmetic on a
 * single-precision FPU.  Exact to the unit below 2^21 s (24 days); |t| must be below 2^30 s (34 years; beyond, the
 * value saturates) and finite (checked by the caller). */
static inline int64_t sail_time_fixed(double t)
{
    uint64_t bits, mantissa;
    int shift;
    int64_t value;
    memcpy(&bits, &t, sizeof bits);
    shift = (int)((bits >> 52) & 0x7ff) - 1075 + 32;  /* t = mantissa 2^(exponent - 1075), mantissa < 2^53 */
    mantissa = (bits & 0xfffffffffffffULL) | 0x10000000000000ULL;
    if (shift <= -53)
        return 0;
    if (shift > 9)
        value = INT64_MAX / 2;
    else
        value = (int64_t)(shift >= 0 ? mantissa << shift : mantissa >> -shift);
    return bits >> 63 ? -value : value;
}

/* Instants (sail_instant): seconds, or 2^-32 s with SAIL_FIXED_TIME (sail.h). */
#ifndef SAIL_FIXED_TIME
#define INSTANT(t) (t)
#define INSTANT_SPAN(s) ((double)(s))
#define SECONDS(d) ((sail_real)(d))
#else
#define INSTANT(t) sail_time_fixed(t)
#define INSTANT_SPAN(s) ((int64_t)((double)(s) * SAIL_TIME_UNITS_PER_S))
#define SECONDS(d) (sail_int64_real((uint64_t)(d)) * 2.3283064365386963e-10f)  /* 2^-32 */
#endif

static inline int sail_finite4(const sail_reading *r)
{
    /* x - x is 0 for a finite x and NaN for an infinite or NaN one, and NaN propagates through the sum */
    return (r->theta1 - r->theta1) + (r->theta2 - r->theta2) + (r->load1 - r->load1) + (r->load2 - r->load2) == 0;
}

#endif /* SAIL_MATH_H */

/*
 * The rate filter's set-up: the window's Gram polynomials in the binomial basis, and the Savitzky-Golay kernels
 * (sailforce.motion.differentiate.kernel_polynomials, exported by `sail export-c`) projected on them.
 * See sail_rates.h and docs/dynamics.md.
 */
#include "sail_rates.h"

/* C(n, k) for the small n and k here, exactly. */
static int64_t binomial(int64_t n, int k)
{
    int64_t c = 1;
    int i;
    for (i = 1; i <= k; i++)
        c = c * (n - k + i) / i;  /* C(n-k+i, i), an integer at each step */
    return c;
}

/* C(y, k) for any integer y (negative too): y (y - 1) ... (y - k + 1) / k!, an integer. */
static int64_t binomial_any(int64_t y, int k)
{
    int64_t c = 1;
    int i;
    for (i = 0; i < k; i++)
        c = c * (y - i) / (i + 1);  /* C(y, i + 1) = C(y, i) (y - i) / (i + 1), an integer at each step */
    return c;
}

/* The discrete Chebyshev (Gram) polynomial of degree d on u = 0..n-1 at u (Abramowitz & Stegun 22.17.1's
 * Delta-formula): t_d(u) = d! Delta^d [C(u, d) C(u - n, d)], an integer; orthogonal to every polynomial of lower
 * degree over the window. */
static int64_t gram(int d, int64_t n, int64_t u)
{
    int64_t sum = 0;
    int i;
    for (i = 0; i <= d; i++)
        sum += ((d - i) % 2 ? -1 : 1) * binomial(d, i) * binomial_any(u + i, d) * binomial_any(u + i - n, d);
    for (i = 2; i <= d; i++)
        sum *= i;
    return sum;
}

/* A kernel polynomial sum_m b[m] j^m at the centred offset j. */
static double kernel_at(const double b[SAIL_MAX_RATE_ORDER + 1], double j)
{
    double y = 0;
    int m;
    for (m = SAIL_MAX_RATE_ORDER; m >= 0; m--)
        y = y * j + b[m];
    return y;
}

enum sail_check sail_rates_check(const sail_dynamics *dyn)
{
    double sum_rate = 0, sum_accel = 0, size_rate = 0, size_accel = 0;
    int u, d, k;
    for (u = 0; u <= 2 * dyn->half; u++) {
        const double w = kernel_at(dyn->rate, u - dyn->half), a = kernel_at(dyn->accel, u - dyn->half);
        sum_rate += w;
        sum_accel += a;
        size_rate += fabs(w);
        size_accel += fabs(a);
    }
    for (d = 1; d <= SAIL_MAX_RATE_ORDER; d++)  /* sail_rates_of takes t_d's Newton coefficients to alternate in sign */
        for (k = 0; k <= d; k++) {
            int64_t difference = 0;
            int i;
            for (i = 0; i <= k; i++)
                difference += ((k - i) % 2 ? -1 : 1) * binomial(k, i) * gram(d, 2 * dyn->half + 1, i);
            if (difference == 0 || (difference < 0) != ((d + k) % 2 == 1))
                return SAIL_CHECK_DYNAMICS;
        }
    /* a derivative's kernel takes nothing from a constant angle: the rates are read on t_1.. only */
    if (!(fabs(sum_rate) <= 1e-9 * size_rate && fabs(sum_accel) <= 1e-9 * size_accel))
        return SAIL_CHECK_DYNAMICS;
    /* and, centred, the rate's kernel is odd and the acceleration's even: sail_rates_of reads each on its parity */
    for (u = 1; u <= dyn->half; u++) {
        const double wp = kernel_at(dyn->rate, u), wm = kernel_at(dyn->rate, -u);
        const double ap = kernel_at(dyn->accel, u), am = kernel_at(dyn->accel, -u);
        if (!(fabs(wp + wm) <= 1e-9 * size_rate && fabs(ap - am) <= 1e-9 * size_accel))
            return SAIL_CHECK_DYNAMICS;
    }
    return SAIL_CHECK_OK;
}

void sail_rates_init(sail_rate_filter *f, const sail_dynamics *dyn)
{
    const int64_t n = 2 * dyn->half + 1;
    const double rad_per_count = 1.0 / SAIL_COUNTS_PER_RAD;
    int d, k, u, i;
    f->width = (int32_t)n;
    f->order = dyn->order;
    f->slot = 0;
    f->run = 0;
    for (k = 0; k <= SAIL_MAX_RATE_ORDER; k++) {
        f->moment[0][k] = f->moment[1][k] = 0;
        f->entry[k] = (uint32_t)binomial(n, k);  /* C(129, 4) < 2^24 */
    }
    for (d = 0; d < SAIL_MAX_RATE_ORDER; d++) {
        double norm = 0, rate = 0, accel = 0;
        for (k = 0; k <= SAIL_MAX_RATE_ORDER; k++) {  /* t_{d+1} = sum_k Delta^k t_{d+1}(0) C(u, k) (Newton) */
            int64_t difference = 0;
            for (i = 0; i <= k; i++)
                difference += ((k - i) % 2 ? -1 : 1) * binomial(k, i) * gram(d + 1, n, i);
            f->gram[d][k] = (uint32_t)(difference < 0 ? -difference : difference);  /* |t_4| < 2^31 up to 129 samples */
        }
        for (u = 0; u < n; u++) {  /* the kernels' coefficients on t_{d+1}: <w, t> / <t, t> */
            const double t = (double)gram(d + 1, n, u);
            norm += t * t;
            rate += kernel_at(dyn->rate, u - dyn->half) * t;
            accel += kernel_at(dyn->accel, u - dyn->half) * t;
        }
        f->gamma_rate[d] = d < dyn->order ? (sail_real)(rad_per_count * rate / norm) : 0;  /* zero beyond the order */
        f->gamma_accel[d] = d < dyn->order ? (sail_real)(rad_per_count * accel / norm) : 0;
    }
    for (u = 0; u < 2 * SAIL_MAX_HALF_WINDOW + 1; u++)  /* the window starts full of zeros: its moments are 0 */
        f->counts[u][0] = f->counts[u][1] = 0;
}

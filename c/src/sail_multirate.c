/*
 * Force from real ADCs: each cell's conversions, through its filter, asynchronous to the control ticks.  Mirrors
 * sailforce.estimate.multirate.MultiRateEstimator fed one row at a time (sailforce.stream's multi-rate stage, whose
 * rates come from the same centred Savitzky-Golay window): see sail.h and docs/reference/multirate.md.
 *
 * Per tick: the rate filter, the sensing map M and the dynamic term's reading d at the tick, kept in a ring.  Per
 * conversion: the chip's measured period, the filter's weights over the ticks in its window, and the averaged row
 * of M and d.  Per tick that has a conversion: the solve at force_t.
 */
#include <string.h>

#include "sail.h"
#include "sail_rates.h"
#include "sail_static.h"

/* What may be wrong with a tick (sail_adc_tick.flags). */
enum {
    SAIL_TICK_INVALID = 1,   /* its time or an angle is not a number */
    SAIL_TICK_UNKNOWN = 2,   /* M or d is not known (with a dynamic term: the rates are not) */
    SAIL_TICK_GAP_AFTER = 4  /* the step to the next tick is beyond SAIL_GAP_STEPS ticks */
};

/* Stored times stay within a quarter of a second of the epoch, which moves on by an eighth (exactly, in binary):
 * a float keeps them to 15 ns, 1e-6 of an HX711's period.  A move shifts every time held, about two operations a
 * tick on average. */
#define SAIL_EPOCH_SPAN SAIL_R(0.25)
#define SAIL_EPOCH_STEP SAIL_R(0.125)
/* A conversion's window edges take ticks this close as inside (sailforce's 1e-12 s). */
#define SAIL_WINDOW_SLACK 1e-12

static double factorial(int n)
{
    double f = 1;
    int i;
    for (i = 2; i <= n; i++)
        f *= i;
    return f;
}

static double binomial_real(int n, int k)
{
    return factorial(n) / (factorial(k) * factorial(n - k));
}

/* The cardinal B-spline of order n on [0, n] (de Boor, "A Practical Guide to Splines", 2001, IX (20)):
 *   B_n(x) = sum_k (-1)^k C(n, k) (x - k)_+^(n-1) / (n - 1)!,
 * on each piece [s, s + 1) a polynomial in y = x - s: coefficient of y^p = C(n-1, p) sum_{k<=s} (-1)^k C(n, k)
 * (s - k)^(n-1-p) / (n - 1)!.  Stored highest power first, for Horner, as pieces[s + 1]: pieces[0] (before the
 * window) and pieces[n + 1] (past it) are zero. */
static void spline_pieces(int n, sail_real pieces[SAIL_MAX_SINC_ORDER + 2][SAIL_MAX_SINC_ORDER])
{
    int s, p, k, i;
    for (s = 0; s < SAIL_MAX_SINC_ORDER + 2; s++)  /* the pieces before and past the window stay zero */
        for (p = 0; p < SAIL_MAX_SINC_ORDER; p++)
            pieces[s][p] = 0;
    for (s = 0; s < n; s++) {
        for (p = 0; p < n; p++) {
            double sum = 0;
            for (k = 0; k <= s; k++) {
                double power = 1;
                for (i = 0; i < n - 1 - p; i++)
                    power *= s - k;
                sum += (k % 2 ? -1.0 : 1.0) * binomial_real(n, k) * power;
            }
            pieces[s + 1][n - 1 - p] = (sail_real)(binomial_real(n - 1, p) * sum / factorial(n - 1));
        }
    }
}

enum sail_check sail_multirate_init(sail_multirate_state *state, const sail_calibration *cal, const sail_dynamics *dyn,
                                    const sail_adc *adc)
{
    int i;
    double window;
    if (state == NULL || cal == NULL || adc == NULL)
        return SAIL_CHECK_NULL;
    if (!(adc->period > 0 && adc->period < 1e3 && adc->tick > 0 && adc->tick < 1e3 && fabs(adc->delay) < adc->period)
        || adc->sinc_order < 1 || adc->sinc_order > SAIL_MAX_SINC_ORDER)
        return SAIL_CHECK_ADC;
    if (dyn != NULL) {
        if (dyn->half < 1 || dyn->half > SAIL_MAX_HALF_WINDOW || dyn->order < 0 || dyn->order > SAIL_MAX_RATE_ORDER
            || !(dyn->dt > 0) || sail_rates_check(dyn) != SAIL_CHECK_OK)
            return SAIL_CHECK_DYNAMICS;
        if (!(fabs(dyn->dt - adc->tick) <= 1e-9 * adc->tick))
            return SAIL_CHECK_ADC;
        sail_rates_init(&state->rates, dyn);
    }
    /* what a conversion looks back over: its window at a period up to a missed conversion's, its delay, and the
     * other cell's centroid up to two periods older */
    window = (SAIL_MISSED_CONVERSION * adc->sinc_order + 2.0) * adc->period + fabs(adc->delay);
    if (window / adc->tick + 4 > SAIL_MAX_TICKS)
        return SAIL_CHECK_ADC;
    state->adc = adc;
    state->dyn = dyn;
    state->cal = cal;
    state->pending = 0;
    state->t_last = 0;
    for (i = 0; i < 2 * SAIL_MAX_HALF_WINDOW + 1; i++)
        state->held_t[i] = 0;
    state->gap = dyn != NULL ? (sail_real)(SAIL_GAP_FACTOR * dyn->dt) : 0;
    state->epoch = 0;
    state->epoch_instant = 0;
    state->has_epoch = 0;
    state->delay_instant = INSTANT_SPAN(adc->delay);
    spline_pieces(adc->sinc_order, state->spline);
    state->tick_gap = (sail_real)(SAIL_GAP_STEPS * adc->tick);
    state->ticks = 0;
    state->newest = SAIL_MAX_TICKS - 1;
    state->knot_mask = SAIL_TICK_STRIDE;  /* the knots' stride (sail.h): at least SAIL_KNOTS_PER_PERIOD a period */
    while (state->knot_mask > 1 && state->knot_mask * adc->tick * SAIL_KNOTS_PER_PERIOD > adc->period)
        state->knot_mask /= 2;
    state->knot_mask -= 1;
    memset(state->tick, 0, sizeof state->tick);  /* every slot a defined value: the epoch's moves shift them all */
    memset(state->cell, 0, sizeof state->cell);
    for (i = 0; i < 2; i++)
        state->cell[i].newest = SAIL_HISTORY - 1;
    state->current.fx = state->current.fy = SAIL_NAN;
    state->current.status = SAIL_MOTION_UNKNOWN;
    state->current.inertial[0] = state->current.inertial[1] = dyn != NULL ? SAIL_NAN : 0;
    state->current.force_t = NAN;
    return SAIL_CHECK_OK;
}

/* M at the tick, and the dynamic term's reading d = M w, J^T w = (l1 V1, l2 V2) (sail_motion.c's estimate_moving at
 * the offsets); d is NaN where the rates are unknown or the pose is singular. */
static SAIL_ALWAYS_INLINE int tick_parts(const sail_calibration *cal, const sail_dynamics *dyn, sail_real theta1,
                                         sail_real theta2, int known, const sail_real rates[4], sail_adc_tick *out)
{
    sail_real s1, c1, s2, c2, jt[2][2], m[2][2], sd, cd;
    sail_sincos(theta1, &s1, &c1);
    sail_sincos(theta2, &s2, &c2);
    jt[0][0] = -cal->l3 * s1;  /* J^T (seed Eqs. 3, 4 and 7) */
    jt[0][1] = cal->l3 * c1;
    jt[1][0] = -cal->l2 * s2;
    jt[1][1] = cal->l2 * c2;
    if (sensing_matrix(cal, theta1 - theta2, jt, m) != 0)
        return 0;
    out->v[0][0] = m[0][0];
    out->v[0][1] = m[0][1];
    out->v[1][0] = m[1][0];
    out->v[1][1] = m[1][1];
    if (dyn == NULL) {
        out->v[0][2] = out->v[1][2] = 0;
        return 1;
    }
    sd = s1 * c2 - c1 * s2;  /* sin(theta1 - theta2) */
    if (!known || SAIL_FABS(sd) < (sail_real)SAIL_SINGULAR_SIN_DELTA)
        return 0;
    cd = c1 * c2 + s1 * s2;
    {
        const sail_real w1 = rates[0] * rates[0], w2 = rates[2] * rates[2], a1 = rates[1], a2 = rates[3];
        /* the cells' dynamic shears (sailforce.motion.dynamics.ShearModel; Eqs. D1-D2 of docs/dynamics.md) */
        const sail_real v1 = dyn->k[0][0] * a1 + dyn->k[0][1] * w1 + dyn->k[0][2] * (a2 * cd + w2 * sd)
                             + dyn->k[0][3] * (w2 * cd - a2 * sd) + dyn->k[0][4] * c1 + dyn->k[0][5] * s1;
        const sail_real v2 = dyn->k[1][0] * a2 + dyn->k[1][1] * w2 + dyn->k[1][2] * (a1 * cd - w1 * sd)
                             + dyn->k[1][3] * (a1 * sd + w1 * cd) + dyn->k[1][4] * c2 + dyn->k[1][5] * s2;
        const sail_real b1 = dyn->l1 * v1, b2 = dyn->l2 * v2, det = -cal->l2 * cal->l3 * sd;  /* seed Eq. 9 */
        const sail_real wx = (jt[1][1] * b1 - jt[0][1] * b2) / det, wy = (jt[0][0] * b2 - jt[1][0] * b1) / det;
        out->v[0][2] = m[0][0] * wx + m[0][1] * wy;
        out->v[1][2] = m[1][0] * wx + m[1][1] * wy;
    }
    return out->v[0][2] - out->v[0][2] == 0 && out->v[1][2] - out->v[1][2] == 0;
}

/* Move the epoch on: every stored time shifts by the same amount, exactly (a power of two, on times below it). */
static void rebase(sail_multirate_state *state, sail_real shift)
{
    int i, j;
    for (i = 0; i < SAIL_MAX_TICKS; i++)
        state->tick[i].t -= shift;
    for (i = 0; i < 2; i++)
        for (j = 0; j < SAIL_HISTORY; j++)
            state->cell[i].centroid[j] -= shift;
    for (i = 0; i < 2 * SAIL_MAX_HALF_WINDOW + 1; i++)
        state->held_t[i] -= shift;
    state->t_last -= shift;
    state->epoch += (double)shift;
    state->epoch_instant += INSTANT_SPAN(shift);
}

/* Slot of the tick `back` ticks before the newest. */
static SAIL_ALWAYS_INLINE int tick_slot(const sail_multirate_state *state, int back)
{
    const int slot = state->newest - back;
    return slot < 0 ? slot + SAIL_MAX_TICKS : slot;
}

/* The chip's period at a conversion ready at `ready`: the mean of its last intervals, this one's included, the
 * nominal until it has one; an interval of a missed conversion (or a step back) is left out. */
static sail_real measured_period(sail_adc_cell *cell, const sail_adc *adc, sail_instant ready)
{
    const sail_real step = SECONDS(ready - cell->last_ready);
    const int have = cell->converted;
    sail_real sum = 0;
    int i;
    cell->last_ready = ready;
    cell->converted = 1;
    if (have && step > 0 && step < (sail_real)(SAIL_MISSED_CONVERSION * adc->period)) {
        cell->interval[cell->next_interval] = step;
        cell->next_interval = cell->next_interval + 1 == SAIL_PERIOD_MEMORY ? 0 : cell->next_interval + 1;
        cell->intervals += cell->intervals < SAIL_PERIOD_MEMORY;
    }
    if (cell->intervals == 0)
        return (sail_real)adc->period;
    for (i = cell->intervals; i > 0; i--) {  /* oldest first, as sailforce sums them */
        int slot = cell->next_interval - i;
        sum += cell->interval[slot < 0 ? slot + SAIL_PERIOD_MEMORY : slot];
    }
    return sum / (sail_real)cell->intervals;
}

/* A conversion window's sums over the ticks inside it: of the weights, and of the weighted rows and dynamic term. */
typedef struct {
    sail_real late, inverse, start;    /* the window's end, 1 / period, and its start less the slack [s after epoch] */
    sail_real total, row0, row1, dynamic;
    int flags;                         /* every flag of the ticks taken */
} window_sums;

/* Take up to `count` (>= 1) ticks from slot `top` down (slots top - count + 1 .. top, newest first) into cell i's window
 * sums: stops at the first tick before the window, and returns how many it took.  Every tick taken gives its flags,
 * and the knots among them (slots that are multiples of knot_mask + 1: SAIL_TICK_STRIDE in sail.h) their weighted
 * rows and dynamic term.  The weight is the spline's piece at x = (late - t) / period + 1 (pieces outside the window
 * are zero), by Horner's rule: unrolled for the HX711's and the ADS1232's sinc^4. */
static SAIL_OWN_CALL int window_run(const sail_multirate_state *state, int top, int count, int i, window_sums *sums)
{
    const sail_real late = sums->late, inverse = sums->inverse, start = sums->start;
    const int n = state->adc->sinc_order;
    const sail_adc_tick *const ticks = state->tick;
    const sail_real(*const spline)[SAIL_MAX_SINC_ORDER] = state->spline;
    sail_real total = sums->total, row0 = sums->row0, row1 = sums->row1, dynamic = sums->dynamic;
    const int mask = state->knot_mask, bottom = top - count + 1;
    int flags = sums->flags, slot = top;
#define SAIL_WINDOW_LOOP(WEIGHT)                                                           \
    for (; slot >= bottom; slot--) {                                                       \
        const sail_adc_tick *const tick = &ticks[slot];                                    \
        const sail_real t = tick->t, *v = tick->v[i];                                      \
        sail_real x, y, w;                                                                 \
        const sail_real *piece;                                                            \
        int p;                                                                             \
        if (t < start)                                                                     \
            break;                                                                         \
        flags |= tick->flags;                                                              \
        if (slot & mask)  /* between knots: its flags only */                              \
            continue;                                                                      \
        x = (late - t) * inverse + 1;                                                      \
        p = (int)x;  /* x + 1 >= 0: the truncation is the floor; piece 0 is before the window */ \
        y = x - (sail_real)p;                                                              \
        piece = spline[p];                                                                 \
        WEIGHT;                                                                            \
        total += w;                                                                        \
        row0 += w * v[0];                                                                  \
        row1 += w * v[1];                                                                  \
        dynamic += w * v[2];                                                               \
    }
    if (n == 4) {
        SAIL_WINDOW_LOOP(w = ((piece[0] * y + piece[1]) * y + piece[2]) * y + piece[3])
    } else {
        SAIL_WINDOW_LOOP(w = piece[0]; for (p = 1; p < n; p++) w = w * y + piece[p])
    }
#undef SAIL_WINDOW_LOOP
    sums->total = total;
    sums->row0 = row0;
    sums->row1 = row1;
    sums->dynamic = dynamic;
    sums->flags = flags;
    return top - slot;
}

/* A conversion of cell i: its window over the ticks held, and the entry it adds to the cell's history. */
static void convert(sail_multirate_state *state, int i, sail_real raw, sail_instant ready)
{
    const sail_adc *adc = state->adc;
    sail_adc_cell *cell = &state->cell[i];
    const sail_real period = measured_period(cell, adc, ready);
    const int n = adc->sinc_order;
    window_sums sums;
    sail_real end;
    int left = state->ticks, top = state->newest, inside = 0, ok, slot, newest_flags = 0;
    sums.late = SECONDS(ready - state->delay_instant - state->epoch_instant);
    sums.inverse = 1 / period;
    sums.start = sums.late - (sail_real)n * period - (sail_real)SAIL_WINDOW_SLACK;
    sums.total = sums.row0 = sums.row1 = sums.dynamic = 0;
    sums.flags = 0;
    end = sums.late + (sail_real)SAIL_WINDOW_SLACK;
    while (left > 0 && state->tick[top].t > end) {  /* ticks after the window's end */
        left--;
        top = top == 0 ? SAIL_MAX_TICKS - 1 : top - 1;
    }
    /* the window's ticks, newest first: every one valid and known, and no step between two of them a gap.  The
     * newest's step after it is outside, so it is taken on its own; the rest in at most two runs, the ring's wrap
     * between them. */
    if (left > 0 && window_run(state, top, 1, i, &sums) == 1) {
        newest_flags = sums.flags;
        sums.flags = 0;
        inside = 1;
        left--;
        top = top == 0 ? SAIL_MAX_TICKS - 1 : top - 1;
        while (left > 0) {
            const int run = left < top + 1 ? left : top + 1;
            const int taken = window_run(state, top, run, i, &sums);
            inside += taken;
            left -= taken;
            top = top - taken < 0 ? SAIL_MAX_TICKS - 1 : top - taken;
            if (taken < run)
                break;
        }
    }
    /* a tick before the window is held, and valid */
    ok = left > 0 && !(state->tick[top].flags & SAIL_TICK_INVALID)
         && !(newest_flags & (SAIL_TICK_INVALID | SAIL_TICK_UNKNOWN)) && !sums.flags && inside >= 2 && sums.total > 0;
    slot = cell->newest + 1 == SAIL_HISTORY ? 0 : cell->newest + 1;
    cell->newest = slot;
    cell->count += cell->count < SAIL_HISTORY;
    cell->centroid[slot] = sums.late - SAIL_R(0.5) * (sail_real)n * period;
    cell->raw[slot] = raw;
    cell->known[slot] = (uint8_t)ok;
    if (ok) {
        cell->row[slot][0] = sums.row0 / sums.total;
        cell->row[slot][1] = sums.row1 / sums.total;
        cell->dynamic[slot] = sums.dynamic / sums.total;
    } else {
        cell->row[slot][0] = cell->row[slot][1] = cell->dynamic[slot] = SAIL_NAN;
    }
    cell->u[slot] = raw - state->cal->offset[i] - cell->dynamic[slot];
}

/* A cell's values interpolated at `instant`, between the conversions around it (sailforce's _at).  Returns 0 when
 * the instant precedes every centroid the cell holds: v then holds its oldest conversion, as sailforce's does. */
typedef struct { sail_real u, row[2], dynamic, raw[2]; int known; } cell_value;

static int cell_at(const sail_adc_cell *cell, sail_real instant, cell_value *v)
{
    int back, j = -1, next, have = 1;
    sail_real a = 0;
    for (back = 0; back < cell->count; back++) {  /* the newest conversion whose centroid is not after instant */
        const int slot = cell->newest - back < 0 ? cell->newest - back + SAIL_HISTORY : cell->newest - back;
        j = slot;
        if (cell->centroid[slot] <= instant)
            break;
    }
    if (back == cell->count)  /* none: the oldest, as it is */
        have = 0;
    next = back == 0 || !have ? j : (j + 1 == SAIL_HISTORY ? 0 : j + 1);
    if (next != j && cell->centroid[j] != instant)
        a = (instant - cell->centroid[j]) / (cell->centroid[next] - cell->centroid[j]);
    v->u = (1 - a) * cell->u[j] + a * cell->u[next];
    v->row[0] = (1 - a) * cell->row[j][0] + a * cell->row[next][0];
    v->row[1] = (1 - a) * cell->row[j][1] + a * cell->row[next][1];
    v->dynamic = (1 - a) * cell->dynamic[j] + a * cell->dynamic[next];
    v->raw[0] = cell->raw[j];
    v->raw[1] = next == j || cell->centroid[j] == instant ? cell->raw[j] : cell->raw[next];
    v->known = have && cell->known[j] && cell->known[next];
    return have;
}

/* The angles at `instant`, linear between the valid ticks around it (numpy.interp over the valid ticks); 0 outside
 * them. */
static int angles_at(const sail_multirate_state *state, sail_real instant, sail_real theta[2])
{
    int lo = 0, hi = state->ticks, back;
    const sail_adc_tick *older = NULL, *newer = NULL;
    /* times do not increase with age (an invalid tick repeats the last valid time): the youngest tick not after
     * instant, by bisection */
    while (lo < hi) {
        const int mid = (lo + hi) / 2;
        if (state->tick[tick_slot(state, mid)].t <= instant)
            hi = mid;
        else
            lo = mid + 1;
    }
    for (back = lo; back < state->ticks && older == NULL; back++)
        if (!(state->tick[tick_slot(state, back)].flags & SAIL_TICK_INVALID))
            older = &state->tick[tick_slot(state, back)];
    for (back = lo - 1; back >= 0 && newer == NULL; back--)
        if (!(state->tick[tick_slot(state, back)].flags & SAIL_TICK_INVALID))
            newer = &state->tick[tick_slot(state, back)];
    if (older == NULL || (newer == NULL && older->t != instant))
        return 0;
    if (newer == NULL || older->t == instant) {
        theta[0] = older->theta[0];
        theta[1] = older->theta[1];
    } else {
        const sail_real f = (instant - older->t) / (newer->t - older->t);
        theta[0] = older->theta[0] + f * (newer->theta[0] - older->theta[0]);
        theta[1] = older->theta[1] + f * (newer->theta[1] - older->theta[1]);
    }
    return 1;
}

/* The estimate at the older of the cells' latest centroids (sailforce's _estimates, one event), in its status
 * precedence. */
static void estimate(sail_multirate_state *state)
{
    const sail_calibration *cal = state->cal;
    sail_timed_force *out = &state->current;
    cell_value v1, v2;
    sail_real instant, theta[2], det, fx = SAIL_NAN, fy = SAIL_NAN, delta, sd, cd;
    int known, status = SAIL_OK, saturated = 0, k, finite = 1;
    if (state->cell[0].count == 0 || state->cell[1].count == 0) {
        out->fx = out->fy = SAIL_NAN;
        out->inertial[0] = out->inertial[1] = state->dyn != NULL ? SAIL_NAN : 0;
        out->status = SAIL_MOTION_UNKNOWN;
        out->force_t = NAN;
        return;
    }
    instant = state->cell[0].centroid[state->cell[0].newest];
    if (state->cell[1].centroid[state->cell[1].newest] < instant)
        instant = state->cell[1].centroid[state->cell[1].newest];
    known = cell_at(&state->cell[0], instant, &v1) & cell_at(&state->cell[1], instant, &v2);
    known = known && v1.known && v2.known;
    if (known) {  /* Cramer's rule (cf. seed Eq. 8) on the averaged rows */
        det = v1.row[0] * v2.row[1] - v1.row[1] * v2.row[0];
        if (det != 0) {
            fx = (v2.row[1] * v1.u - v1.row[1] * v2.u) / det;
            fy = (v1.row[0] * v2.u - v2.row[0] * v1.u) / det;
        }
    }
    if (!angles_at(state, instant, theta))
        theta[0] = theta[1] = SAIL_NAN;
    delta = theta[0] - theta[1];
    sail_sincos(delta, &sd, &cd);
    for (k = 0; k < 2; k++) {
        const sail_real s1 = v1.raw[k] - cal->offset[0], s2 = v2.raw[k] - cal->offset[1];
        saturated |= SAIL_FABS(s1) > cal->capacity[0] || SAIL_FABS(s2) > cal->capacity[1];
        finite &= s1 - s1 == 0 && s2 - s2 == 0;
    }
    if (!(delta >= cal->delta_min - (sail_real)SAIL_DELTA_RANGE_SLACK
          && delta <= cal->delta_max + (sail_real)SAIL_DELTA_RANGE_SLACK))
        status = SAIL_EXTRAPOLATED;
    if (!known)
        status = SAIL_MOTION_UNKNOWN;
    if (saturated)
        status = SAIL_SATURATED;
    if (SAIL_FABS(sd) < (sail_real)SAIL_SINGULAR_SIN_DELTA || (known && !(fx - fx == 0 && fy - fy == 0)))
        status = SAIL_SINGULAR;
    if (!finite || !(delta - delta == 0))
        status = SAIL_INVALID;
    if (status == SAIL_SINGULAR || status == SAIL_INVALID || status == SAIL_MOTION_UNKNOWN)
        fx = fy = SAIL_NAN;
    out->fx = fx;
    out->fy = fy;
    out->status = status;
    out->inertial[0] = state->dyn != NULL ? v1.dynamic : 0;
    out->inertial[1] = state->dyn != NULL ? v2.dynamic : 0;
    out->force_t = state->epoch + (double)instant;
}

/* A time [s] as an instant; the first finite time sets the epoch. */
static SAIL_ALWAYS_INLINE sail_instant instant(sail_multirate_state *state, double t)
{
    const sail_instant value = INSTANT(t);
    if (!state->has_epoch) {
        state->has_epoch = 1;
        state->epoch = t;
        state->epoch_instant = value;
    }
    return value;
}

/* A time [s] relative to the epoch; NaN for a time that is not a number. */
static SAIL_ALWAYS_INLINE sail_real relative(sail_multirate_state *state, double t)
{
    if (!sail_finite_time(t))
        return SAIL_NAN;
    return SECONDS(instant(state, t) - state->epoch_instant);
}

/* A tick whose rates are known (or not) comes out of the rate window: store it, take its conversions, and give
 * the latest estimate for its row. */
static void process(sail_multirate_state *state, const sail_tick *tick, sail_real t, int known,
                    const sail_real rates[4], sail_timed_force *out)
{
    int valid = t - t == 0 && tick->theta1 - tick->theta1 == 0 && tick->theta2 - tick->theta2 == 0;
    int i, fresh = 0;
    sail_adc_tick *slot;
    if (valid && t >= SAIL_EPOCH_SPAN) {
        const sail_real shift = SAIL_EPOCH_STEP * (sail_real)(int32_t)(t / SAIL_EPOCH_STEP);
        rebase(state, shift);
        t -= shift;
    }
    state->newest = state->newest + 1 == SAIL_MAX_TICKS ? 0 : state->newest + 1;
    state->ticks += state->ticks < SAIL_MAX_TICKS;
    slot = &state->tick[state->newest];
    if (valid) {
        slot->t = t;
        slot->theta[0] = tick->theta1;
        slot->theta[1] = tick->theta2;
        if ((state->newest & state->knot_mask) == 0)  /* a knot: M and d (sail.h's SAIL_TICK_STRIDE) */
            slot->flags = tick_parts(state->cal, state->dyn, tick->theta1, tick->theta2, known, rates, slot)
                          ? 0 : SAIL_TICK_UNKNOWN;
        else  /* between knots: whether its rates are known */
            slot->flags = known ? 0 : SAIL_TICK_UNKNOWN;
        if (state->ticks > 1) {
            sail_adc_tick *before = &state->tick[tick_slot(state, 1)];
            if (t - before->t > state->tick_gap)
                before->flags |= SAIL_TICK_GAP_AFTER;
        }
    } else {
        slot->t = state->ticks > 1 ? state->tick[tick_slot(state, 1)].t : 0;
        slot->theta[0] = slot->theta[1] = SAIL_NAN;
        slot->flags = SAIL_TICK_INVALID | SAIL_TICK_UNKNOWN;
    }
    for (i = 0; i < 2; i++) {
        const double ready = sail_finite_time(tick->ready[i]) ? tick->ready[i] : tick->t;
        if (tick->load[i] - tick->load[i] == 0 && sail_finite_time(ready)) {  /* a conversion, at a known time */
            convert(state, i, tick->load[i], instant(state, ready));
            fresh = 1;
        }
    }
    if (fresh)
        estimate(state);
    *out = state->current;
    if (!valid) {
        out->fx = out->fy = SAIL_NAN;
        out->inertial[0] = out->inertial[1] = SAIL_NAN;
        out->force_t = NAN;
        out->status = SAIL_INVALID;
    }
}

int sail_multirate_step(sail_multirate_state *state, const sail_tick *in, sail_timed_force *out, sail_tick *held)
{
    sail_real rates[4];
    const sail_real t = relative(state, in->t);
    rates[0] = rates[1] = rates[2] = rates[3] = 0;
    if (state->dyn == NULL) {
        if (held)
            *held = *in;
        process(state, in, t, 1, rates, out);
        return 1;
    }
    {
        int valid = t - t == 0;
        const int32_t x1 = sail_to_counts(in->theta1, &valid), x2 = sail_to_counts(in->theta2, &valid);
        const sail_real step = t - state->t_last;
        const int whole = sail_rates_link(&state->rates, valid, step > 0 && step <= state->gap);
        int oldest;
        if (valid)
            state->t_last = t;
        state->held[state->rates.slot] = *in;
        state->held_t[state->rates.slot] = t;
        sail_rates_push(&state->rates, x1, x2);
        if (++state->pending <= state->dyn->half)
            return 0;
        oldest = sail_rates_oldest(&state->rates, state->pending);
        state->pending--;
        if (whole && ((state->newest + 1) & state->knot_mask) == 0)  /* the tick out goes to a knot's slot */
            sail_rates_read(&state->rates, rates);
        if (held)
            *held = state->held[oldest];
        process(state, &state->held[oldest], state->held_t[oldest], whole, rates, out);
        return 1;
    }
}

int sail_multirate_flush(sail_multirate_state *state, sail_timed_force *out, sail_tick *held)
{
    sail_real rates[4];
    int oldest;
    if (state->dyn == NULL || state->pending <= 0)
        return 0;
    rates[0] = rates[1] = rates[2] = rates[3] = 0;
    oldest = sail_rates_oldest(&state->rates, state->pending);
    state->pending--;
    if (held)
        *held = state->held[oldest];
    process(state, &state->held[oldest], state->held_t[oldest], 0, rates, out);
    return 1;
}

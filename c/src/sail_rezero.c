/* Automatic re-zero: sail.h's "automatic re-zero" section; the same sums as sailforce.estimate.rezero.ReZero. */
#include <string.h>

#include "sail.h"
#include "sail_math.h"

/* Each cell's probe [raw] for reading W(q) off the estimate: sailforce.estimate.rezero.PROBE_COUNTS. */
#define SAIL_REZERO_PROBE 1000.0

enum sail_check sail_rezero_init(sail_rezero_state *state, const sail_calibration *cal, const sail_rezero_policy *policy)
{
    static const sail_rezero_policy defaults = SAIL_REZERO_POLICY_DEFAULT;
    const sail_rezero_policy *p = policy ? policy : &defaults;
    if (!state || !cal)
        return SAIL_CHECK_NULL;
    if (!(p->window_s > 0 && isfinite(p->window_s) && p->blocks >= 1 && p->blocks <= SAIL_REZERO_MAX_BLOCKS &&
          p->quiet_N > 0 && 0 <= p->min_step_N && p->min_step_N <= p->max_step_N && p->max_step_N <= p->max_total_N))
        return SAIL_CHECK_POLICY;
    memset(state, 0, sizeof *state);
    state->cal = cal;
    state->policy = *p;
    state->block_s = p->window_s / (double)p->blocks;
    state->wait_until = -1;
    return SAIL_CHECK_OK;
}

/* The estimate of readings `load` at the angles, with the calibration's offsets. */
static void force_of(const sail_rezero_state *state, sail_real theta1, sail_real theta2, sail_real load1,
                     sail_real load2, double *fx, double *fy)
{
    sail_reading r;
    sail_force f;
    r.theta1 = theta1;
    r.theta2 = theta2;
    r.load1 = load1;
    r.load2 = load2;
    sail_estimate(state->cal, &r, &f);
    *fx = (double)f.fx;
    *fy = (double)f.fy;
}

static void start_block(sail_rezero_block *block, int64_t index)
{
    memset(block, 0, sizeof *block);
    block->index = index;
    block->free = 1;
}

/* The block is whole: judge the window that ends with it (sailforce's ReZero._finish). */
static int finish(sail_rezero_state *s, sail_rezero_event *event)
{
    const sail_rezero_policy *p = &s->policy;
    const sail_rezero_block *b = &s->block;
    double n = 0, m[6] = {0, 0, 0, 0, 0, 0}, wander, step, total, w[2][2], det, gx, gy;
    int32_t i, k, ready, all_free = 1;
    if (s->held > 0 && b->index != s->window[s->held - 1].index + 1)
        s->held = 0; /* a gap: the window starts again */
    if (s->held == p->blocks) {
        memmove(s->window, s->window + 1, (size_t)(p->blocks - 1) * sizeof s->window[0]);
        s->held--;
    }
    s->window[s->held++] = *b;
    for (i = 0; i < s->held; i++)
        all_free &= s->window[i].free && s->window[i].n > 0;
    ready = s->held == p->blocks && b->index >= s->wait_until && all_free;
    if (!ready) {
        for (i = 0; i < s->held; i++)
            if (!s->window[i].free)
                s->refused = 0; /* someone holds it: the next quiet stretch reports afresh */
        return SAIL_REZERO_NONE;
    }
    for (i = 0; i < s->held; i++) {
        n += s->window[i].n;
        for (k = 0; k < 6; k++)
            m[k] += s->window[i].sums[k];
    }
    for (k = 0; k < 6; k++)
        m[k] /= n;
    wander = sqrt((m[2] - m[0] * m[0] > 0 ? m[2] - m[0] * m[0] : 0) + (m[3] - m[1] * m[1] > 0 ? m[3] - m[1] * m[1] : 0));
    if (wander > p->quiet_N) {
        s->refused = 0;
        return SAIL_REZERO_NONE;
    }
    step = hypot(m[0], m[1]);
    total = hypot(m[4], m[5]);
    if (event) {
        event->t = s->t0 + (double)(b->index + 1) * s->block_s;
        event->step_N = step;
        event->total_N = total;
    }
    if (step > p->max_step_N || total > p->max_total_N) {
        if (s->refused)
            return SAIL_REZERO_NONE;
        s->refused = 1;
        if (event) {
            event->decision = step > p->max_step_N ? SAIL_REZERO_REFUSED_STEP : SAIL_REZERO_REFUSED_TOTAL;
            event->delta[0] = s->delta[0];
            event->delta[1] = s->delta[1];
        }
        return step > p->max_step_N ? SAIL_REZERO_REFUSED_STEP : SAIL_REZERO_REFUSED_TOTAL;
    }
    if (step < p->min_step_N)
        return SAIL_REZERO_NONE;
    /* W(q) off the estimate of a probe on each cell (affine: F(o) = 0), then dD = W^-1 F */
    for (k = 0; k < 2; k++) {
        force_of(s, b->theta[0], b->theta[1], s->cal->offset[0] + (sail_real)(k == 0 ? SAIL_REZERO_PROBE : 0.0),
                 s->cal->offset[1] + (sail_real)(k == 1 ? SAIL_REZERO_PROBE : 0.0), &gx, &gy);
        w[0][k] = gx / SAIL_REZERO_PROBE;
        w[1][k] = gy / SAIL_REZERO_PROBE;
    }
    det = w[0][0] * w[1][1] - w[0][1] * w[1][0];
    s->delta[0] += (sail_real)((w[1][1] * m[0] - w[0][1] * m[1]) / det);
    s->delta[1] += (sail_real)((w[0][0] * m[1] - w[1][0] * m[0]) / det);
    s->wait_until = b->index + p->blocks; /* a window wholly under the new offsets */
    s->begins = 1;
    if (event) {
        event->decision = SAIL_REZERO_MADE;
        event->delta[0] = s->delta[0];
        event->delta[1] = s->delta[1];
    }
    return SAIL_REZERO_MADE;
}

int sail_rezero_step(sail_rezero_state *s, double t, sail_real theta1, sail_real theta2, sail_force *force,
                     int32_t contact, sail_rezero_event *event, int32_t *begins)
{
    int decision = SAIL_REZERO_NONE;
    int64_t index = 0;
    const double raw_x = (double)force->fx, raw_y = (double)force->fy;
    double fx = raw_x, fy = raw_y;
    int free_row;
    if (!s->started && isfinite(t)) {
        s->t0 = t;
        s->started = 1;
    }
    if (s->started && isfinite(t))
        index = (int64_t)floor((t - s->t0) / s->block_s);
    else if (s->in_block)
        index = s->block.index;
    if (s->in_block && index < s->block.index)
        index = s->block.index; /* a step back stays in its block */
    if (begins)
        *begins = 0;
    if (!s->in_block || index != s->block.index) {
        if (s->in_block)
            decision = finish(s, event);
        start_block(&s->block, index);
        s->in_block = 1;
        if (begins)
            *begins = s->begins;
        s->begins = 0;
    }
    if (s->delta[0] != 0 || s->delta[1] != 0) { /* F - F(o + D) */
        double dx, dy;
        force_of(s, theta1, theta2, s->cal->offset[0] + s->delta[0], s->cal->offset[1] + s->delta[1], &dx, &dy);
        fx -= dx;
        fy -= dy;
        force->fx = (sail_real)fx;
        force->fy = (sail_real)fy;
    }
    free_row = force->status == SAIL_OK && isfinite(fx) && isfinite(fy) && isfinite(t) && contact <= SAIL_CONTACT_FREE;
    if (!free_row) {
        s->block.free = 0;
    } else if (s->block.free) {
        sail_rezero_block *b = &s->block;
        b->n += 1;
        b->sums[0] += fx;
        b->sums[1] += fy;
        b->sums[2] += fx * fx;
        b->sums[3] += fy * fy;
        b->sums[4] += raw_x;
        b->sums[5] += raw_y;
        b->theta[0] = theta1;
        b->theta[1] = theta2;
    }
    return decision;
}

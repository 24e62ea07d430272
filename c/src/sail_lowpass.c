/*
 * Butterworth low-pass on the loads, second-order sections in transposed
 * direct form II, as scipy.signal.sosfilt; state carried across blocks and
 * started at the first valid reading's steady state (sailforce.estimate.LowPass).
 */
#include "sail.h"
#include "sail_math.h"

enum sail_check sail_lowpass_init(sail_lowpass_state *state, const sail_lowpass *design)
{
    int c, s;
    if (state == NULL || design == NULL)
        return SAIL_CHECK_NULL;
    if (design->n_sections < 1 || design->n_sections > SAIL_MAX_SECTIONS)
        return SAIL_CHECK_SECTIONS;
    state->design = design;
    state->started = 0;
    for (c = 0; c < 2; c++)
        for (s = 0; s < SAIL_MAX_SECTIONS; s++)
            state->state[c][s][0] = state->state[c][s][1] = 0;
    return SAIL_CHECK_OK;
}

static sail_real cascade(const sail_lowpass *d, sail_real z[SAIL_MAX_SECTIONS][2], sail_real x)
{
    int s;
    for (s = 0; s < d->n_sections; s++) {
        const sail_real *q = d->sos[s];
        const sail_real y = q[0] * x + z[s][0];
        z[s][0] = q[1] * x - q[4] * y + z[s][1];
        z[s][1] = q[2] * x - q[5] * y;
        x = y;
    }
    return x;
}

void sail_lowpass_process(sail_lowpass_state *state, sail_reading *block, size_t n)
{
    const sail_lowpass *d = state->design;
    size_t k;
    int s;
    for (k = 0; k < n; k++) {
        sail_reading *r = &block[k];
        if (!sail_finite4(r)) {
            r->load1 = r->load2 = SAIL_NAN;
            continue;
        }
        if (!state->started) {
            for (s = 0; s < d->n_sections; s++) {
                state->state[0][s][0] = d->zi[s][0] * r->load1;
                state->state[0][s][1] = d->zi[s][1] * r->load1;
                state->state[1][s][0] = d->zi[s][0] * r->load2;
                state->state[1][s][1] = d->zi[s][1] * r->load2;
            }
            state->started = 1;
        }
        r->load1 = cascade(d, state->state[0], r->load1);
        r->load2 = cascade(d, state->state[1], r->load2);
    }
}

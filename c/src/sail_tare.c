/* Tare: offsets as the mean of a no-load recording (cf. `sail tare`, src/sailforce/cli/calibrate_cmd.py). */
#include "sail.h"
#include "sail_math.h"

void sail_tare_init(sail_tare_state *state)
{
    int i;
    state->count = 0;
    for (i = 0; i < 2; i++)
        state->mean[i] = state->m2[i] = 0.0;
}

void sail_tare_process(sail_tare_state *state, const sail_reading *in, size_t n)
{
    size_t k;
    int i;
    for (k = 0; k < n; k++) {
        const double x[2] = {(double)in[k].load1, (double)in[k].load2};
        if (!isfinite(x[0]) || !isfinite(x[1]))
            continue;
        state->count++;
        for (i = 0; i < 2; i++) {  /* Welford's update: stable for long recordings of large counts */
            const double d = x[i] - state->mean[i];
            state->mean[i] += d / (double)state->count;
            state->m2[i] += d * (x[i] - state->mean[i]);
        }
    }
}

enum sail_check sail_tare_finish(const sail_tare_state *state, sail_calibration *cal, sail_real spread[2])
{
    int i;
    if (!state || !cal)
        return SAIL_CHECK_NULL;
    if (state->count < 2)
        return SAIL_CHECK_TOO_FEW;
    for (i = 0; i < 2; i++) {
        cal->offset[i] = (sail_real)state->mean[i];
        if (spread)
            spread[i] = (sail_real)sqrt(state->m2[i] / (double)(state->count - 1));
    }
    return SAIL_CHECK_OK;
}

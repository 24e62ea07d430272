/*
 * The run-time estimator (the static estimate itself is sail_static.h, shared with
 * sail_motion.c).  See sail.h.
 */
#include "sail.h"
#include "sail_static.h"

enum sail_status sail_estimate(const sail_calibration *cal, const sail_reading *in, sail_force *out)
{
    sail_real jt[2][2], m[2][2], trig[4];
    return sail_estimate_parts(cal, in, out, jt, m, trig);
}

size_t sail_estimate_block(const sail_calibration *cal, const sail_reading *in, sail_force *out, size_t n)
{
    size_t i, ok = 0;
    for (i = 0; i < n; i++)
        ok += sail_estimate(cal, &in[i], &out[i]) == SAIL_OK;
    return ok;
}

size_t sail_calibration_real_size(void)
{
    return sizeof(sail_real);
}

/* finite and > 0 (false for NaN) */
static int positive(sail_real x)
{
    return x > 0 && x - x == 0;
}

static int terms_ok(int32_t n)
{
    return n >= 1 && n <= SAIL_MAX_TERMS;
}

enum sail_check sail_calibration_check(const sail_calibration *cal)
{
    if (cal == NULL)
        return SAIL_CHECK_NULL;
    if (!positive(cal->l2) || !positive(cal->l3))
        return SAIL_CHECK_GEOMETRY;
    if (!positive(cal->capacity[0]) || !positive(cal->capacity[1]) || !(cal->offset[0] - cal->offset[0] == 0)
        || !(cal->offset[1] - cal->offset[1] == 0))
        return SAIL_CHECK_CAPACITY;
    if (!(cal->delta_min < cal->delta_max) || !(cal->delta_max - cal->delta_min - (cal->delta_max - cal->delta_min) == 0))
        return SAIL_CHECK_RANGE;
    if (cal->kind == SAIL_MODEL_MATRIX) {
        const sail_matrix_model *m = &cal->model.matrix;
        if (!terms_ok(m->n_terms))
            return SAIL_CHECK_TERMS;
        if (!(m->cheb_lo < m->cheb_hi) || !(m->cheb_hi - m->cheb_lo - (m->cheb_hi - m->cheb_lo) == 0))
            return SAIL_CHECK_RANGE;
        return SAIL_CHECK_OK;
    }
    if (cal->kind == SAIL_MODEL_SEED) {
        const sail_seed_model *s = &cal->model.seed;
        int i;
        for (i = 0; i < 2; i++)
            if (!terms_ok(s->amplitude_terms[i]) || !terms_ok(s->phase_terms[i]))
                return SAIL_CHECK_TERMS;
        return SAIL_CHECK_OK;
    }
    return SAIL_CHECK_KIND;
}

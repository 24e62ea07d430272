/* Temperature compensation of the loads: sail.h's "temperature" section (sailforce.drift.TemperatureCompensation). */
#include "sail.h"
#include "sail_math.h"

void sail_temperature_correct(const sail_temperature *t, const sail_calibration *cal, sail_reading *r, sail_real celsius)
{
    const sail_real dT = celsius - t->reference_C;
    r->load1 = cal->offset[0] + (r->load1 - cal->offset[0] - t->zero_per_C[0] * dT) / (1 + t->span_per_C[0] * dT);
    r->load2 = cal->offset[1] + (r->load2 - cal->offset[1] - t->zero_per_C[1] * dT) / (1 + t->span_per_C[1] * dT);
}

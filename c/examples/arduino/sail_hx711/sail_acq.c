/* The sketch's acquisition: see sail_acq.h. */
#include <math.h>
#include <string.h>

#include "sail_acq.h"

/* A 24-bit conversion at either limit: the bridge is beyond the ADC's range (Avia HX711 datasheet: the output
 * saturates at 0x7FFFFF and 0x800000). */
#define HX711_MAX 8388607
#define HX711_MIN (-8388608)
#define TWO_PI 6.283185307179586

static int32_t since(uint32_t now_us, uint32_t then_us) { return (int32_t)(now_us - then_us); }  /* across the wrap */

void sail_cell_restart(sail_cell *cell, uint32_t now_us)
{
    cell->start_us = now_us;
    cell->settled = 0;
    cell->converted = 0;
    cell->edge = 0;
}

void sail_acq_start(sail_acq *acq, const sail_cell_config config[2])
{
    const sail_hx711_port *clock = &config[0].port;
    uint32_t t0, now;
    int i;
    memset(acq, 0, sizeof *acq);
    for (i = 0; i < 2; i++) {
        acq->cell[i].config = &config[i];
        config[i].port.sck(config[i].port.context, 1);
    }
    t0 = (uint32_t)clock->micros(clock->context);
    do
        now = (uint32_t)clock->micros(clock->context);
    while (now - t0 < SAIL_HX711_POWER_DOWN_US);
    for (i = 0; i < 2; i++)
        config[i].port.sck(config[i].port.context, 0);
    now = (uint32_t)clock->micros(clock->context);
    for (i = 0; i < 2; i++)
        sail_cell_restart(&acq->cell[i], now);
}

void sail_cell_data_ready(sail_cell *cell, uint32_t now_us)
{
    cell->edge_us = now_us;
    cell->edge = 1;
}

/* Take the cell's conversion if DOUT is low now: 1 with *value and *ready_us for a settled one, else 0. */
static int poll(sail_cell *cell, uint32_t now_us, int32_t *value, uint32_t *ready_us)
{
    const sail_cell_config *c = cell->config;
    int taken = 0;
    if (!c->port.dout(c->port.context)) {
        *value = sail_hx711_decode(sail_hx711_shift(&c->port, c->gain));
        if (cell->edge)
            *ready_us = cell->edge_us;
        else if (cell->polled)  /* it became ready after the last tick's look: the middle of that interval */
            *ready_us = cell->last_poll_us + (now_us - cell->last_poll_us) / 2u;
        else
            *ready_us = now_us;
        cell->edge = 0;
        cell->last_ready_us = *ready_us;
        cell->converted = 1;
        if (since(*ready_us, cell->start_us) < (int32_t)c->settle_us) {
            cell->discarded++;
        } else {
            cell->settled = 1;
            cell->conversions++;
            taken = 1;
        }
    }
    cell->last_poll_us = now_us;
    cell->polled = 1;
    return taken;
}

static uint8_t health(const sail_cell *cell, uint32_t now_us)
{
    const sail_cell_config *c = cell->config;
    const int32_t limit = (int32_t)(SAIL_ACQ_TIMEOUT_PERIODS * c->period_us);
    uint8_t status = 0;
    if (!cell->settled)
        status |= SAIL_ACQ_SETTLING;
    if (cell->converted ? since(now_us, cell->last_ready_us) > limit
                        : since(now_us, cell->start_us) > (int32_t)c->settle_us + limit)
        status |= SAIL_ACQ_TIMEOUT;
    return status;
}

void sail_acq_tick(sail_acq *acq, uint32_t now_us, const int32_t counts[2], uint32_t missed, sail_frame_tick *out)
{
    int i;
    memset(out, 0, sizeof *out);
    out->sequence = acq->sequence++;
    out->time_us = now_us;
    out->status = acq->pending_status;
    acq->pending_status = 0;
    if (missed != acq->missed_seen) {
        out->status |= SAIL_ACQ_ENCODER;
        acq->missed_seen = missed;
    }
    for (i = 0; i < 2; i++) {
        int32_t value;
        uint32_t ready_us;
        out->counts[i] = counts[i];
        if (poll(&acq->cell[i], now_us, &value, &ready_us)) {
            const int32_t age = since(ready_us, now_us);
            out->fresh |= (uint8_t)(1u << i);
            out->load[i] = value;
            out->ready_us[i] = (int16_t)(age < -32768 ? -32768 : age);
            if (value == HX711_MAX || value == HX711_MIN)
                out->status |= SAIL_ACQ_SATURATED;
        }
        out->status |= health(&acq->cell[i], now_us);
    }
}

void sail_acq_dropped(sail_acq *acq, uint16_t ticks)
{
    acq->sequence = (uint16_t)(acq->sequence + ticks);
    acq->pending_status |= SAIL_ACQ_OVERRUN;
}

void sail_acq_tare_init(sail_acq_tare *tare)
{
    sail_tare_init(&tare->state);
    tare->latest[0] = tare->latest[1] = 0;
    tare->fresh = 0;
}

uint32_t sail_acq_tare_feed(sail_acq_tare *tare, const sail_frame_tick *tick)
{
    int i;
    for (i = 0; i < 2; i++)
        if (tick->fresh & (1u << i)) {
            tare->latest[i] = (sail_real)tick->load[i];
            tare->fresh |= (uint8_t)(1u << i);
        }
    if (tare->fresh == 3u) {
        sail_reading pair;
        pair.theta1 = pair.theta2 = 0;
        pair.load1 = tare->latest[0];
        pair.load2 = tare->latest[1];
        sail_tare_process(&tare->state, &pair, 1);
        tare->fresh = 0;
    }
    return tare->state.count;
}

void sail_acq_reading(const sail_frame_tick *frame, const sail_encoders *encoders, uint64_t *clock_us, sail_tick *out)
{
    int i;
    *clock_us += (uint32_t)(frame->time_us - (uint32_t)*clock_us);  /* the 32-bit clock wraps every 71.6 min */
    out->t = (double)*clock_us * 1e-6;
    out->theta1 = (sail_real)(encoders->zero[0] + TWO_PI * (double)frame->counts[0] / (double)encoders->counts_per_turn[0]);
    out->theta2 = (sail_real)(encoders->zero[1] + TWO_PI * (double)frame->counts[1] / (double)encoders->counts_per_turn[1]);
    for (i = 0; i < 2; i++) {
        const int fresh = (frame->fresh >> i) & 1;
        out->load[i] = fresh ? (sail_real)frame->load[i] : (sail_real)NAN;
        out->ready[i] = fresh ? out->t + (double)frame->ready_us[i] * 1e-6 : NAN;
    }
}

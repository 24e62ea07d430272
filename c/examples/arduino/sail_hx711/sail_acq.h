/*
 * The sketch's acquisition, apart from the hardware: a fixed-rate control tick that latches the encoders, takes
 * each HX711's conversion when its data-ready shows (never waiting for one), stamps it with the device's
 * microsecond clock, discards the conversions within the settling time after power-up or a gain change, and
 * tares only on settled ones.  Each tick becomes one frame of the wire format (sail_frame.h) and one sail_tick of
 * libsail's multi-rate estimator (sail_multirate_step).  Tested on the host and on the emulated Cortex-M4F against
 * simulated HX711s on their own clocks (c/tests/test_acq.c).
 *
 * The two HX711s convert on their own oscillators: nothing in the chip lets one follow the other.
 * sail_acq_start powers both down and up together, so that they start in step, and they then drift apart by
 * their clocks' tolerance; the stamps, not any lock-step, keep the estimator right (docs/guide/firmware.md).
 */
#ifndef SAIL_ACQ_H
#define SAIL_ACQ_H

#include <stdint.h>

#include "sail.h"
#include "sail_frame.h"
#include "sail_io.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Status bits of a tick (its frame's status byte, the reader's device_status). */
#define SAIL_ACQ_SETTLING 0x01u   /* a cell is still within its settling time: its conversions are discarded */
#define SAIL_ACQ_TIMEOUT 0x02u    /* a cell has given no conversion for SAIL_ACQ_TIMEOUT_PERIODS periods */
#define SAIL_ACQ_ENCODER 0x04u    /* an encoder missed an edge since the last tick (its angle may be 2 counts off) */
#define SAIL_ACQ_OVERRUN 0x08u    /* ticks were dropped before this one (the sketch's queue was full) */
#define SAIL_ACQ_SATURATED 0x10u  /* a new conversion sits at the 24-bit limit */
#define SAIL_ACQ_TARING 0x20u     /* the tare is not yet taken: loads are raw, offsets unknown */

/* A cell with no conversion for this many nominal periods is SAIL_ACQ_TIMEOUT. */
#define SAIL_ACQ_TIMEOUT_PERIODS 3u
/* The HX711's settling time after power-up, a reset or a change of input or gain (Avia HX711 datasheet, "Output
 * settling time": 400 ms at 10 SPS, 50 ms at 80 SPS) [us]. */
#define SAIL_HX711_SETTLE_10SPS_US 400000u
#define SAIL_HX711_SETTLE_80SPS_US 50000u
/* SCK held high this long powers an HX711 down (datasheet: more than 60 us); low again resets it [us]. */
#define SAIL_HX711_POWER_DOWN_US 80u

typedef struct {
    sail_hx711_port port;   /* the pins */
    sail_hx711_gain gain;   /* the input and gain of every conversion */
    uint32_t period_us;     /* the nominal conversion period [us]: 12,500 at 80 SPS, 100,000 at 10 SPS */
    uint32_t settle_us;     /* conversions ready sooner than this after a start are discarded [us] */
} sail_cell_config;

typedef struct {
    const sail_cell_config *config;
    uint32_t start_us;        /* the power-up or gain change the settling counts from */
    uint32_t last_poll_us;    /* the tick before this one */
    uint32_t last_ready_us;   /* the last conversion's stamp */
    uint8_t polled, converted, settled;
    volatile uint8_t edge;    /* set by sail_cell_data_ready, from DOUT's falling-edge interrupt */
    volatile uint32_t edge_us;
    uint32_t conversions;     /* settled conversions taken */
    uint32_t discarded;       /* conversions read and thrown away while settling */
} sail_cell;

typedef struct {
    sail_cell cell[2];
    uint16_t sequence;        /* the next frame's */
    uint32_t missed_seen;     /* encoder missed edges already reported */
    uint8_t pending_status;   /* bits for the next tick (SAIL_ACQ_OVERRUN) */
} sail_acq;

/* Power both HX711s down and up together (SCK high SAIL_HX711_POWER_DOWN_US, then low; waits on the first port's
 * clock), so that they start in step, and begin their settling at that instant. */
void sail_acq_start(sail_acq *acq, const sail_cell_config config[2]);
/* From a cell's DOUT falling-edge interrupt, if the board has one: the exact data-ready stamp.  Without it the
 * tick that sees DOUT low stamps the conversion midway between itself and the tick before (within half a tick). */
void sail_cell_data_ready(sail_cell *cell, uint32_t now_us);
/* A cell's gain or input changed (or it was reset): its settling starts again at now_us. */
void sail_cell_restart(sail_cell *cell, uint32_t now_us);
/* One control tick at now_us: the encoders' counts, latched by the caller with interrupts off, and their running
 * total of missed edges.  Polls each cell once (reads a conversion only when DOUT is already low: no waiting) and
 * fills the frame.  Call it from the timer interrupt, at a fixed rate. */
void sail_acq_tick(sail_acq *acq, uint32_t now_us, const int32_t counts[2], uint32_t missed, sail_frame_tick *out);
/* Ticks the caller had to drop (its queue was full): the next tick carries SAIL_ACQ_OVERRUN and the sequence
 * numbers skip them, so the reader counts them lost. */
void sail_acq_dropped(sail_acq *acq, uint16_t ticks);

/* ---- the PC-free side: tare and the multi-rate estimator on the MCU ---- */

/* The tare on settled conversions: pairs of the two cells' latest conversions, a pair each time both are new. */
typedef struct {
    sail_tare_state state;
    sail_real latest[2];
    uint8_t fresh;            /* bits of the cells with a conversion since the last pair */
} sail_acq_tare;

void sail_acq_tare_init(sail_acq_tare *tare);
/* Feed a tick (ticks with SAIL_ACQ_SETTLING carry no conversion and add nothing).  Returns the pairs so far. */
uint32_t sail_acq_tare_feed(sail_acq_tare *tare, const sail_frame_tick *tick);

/* The encoders' geometry: counts per turn and each joint's angle at count 0 [rad]. */
typedef struct {
    uint32_t counts_per_turn[2];
    double zero[2];
} sail_encoders;

/* A tick for sail_multirate_step: the time unwrapped into *epoch_us (the device's microseconds since start-up;
 * start it at 0 and pass the same variable every tick), the angles [rad], each new conversion and its stamp [s]. */
void sail_acq_reading(const sail_frame_tick *frame, const sail_encoders *encoders, uint64_t *clock_us, sail_tick *out);

#ifdef __cplusplus
}
#endif

#endif /* SAIL_ACQ_H */

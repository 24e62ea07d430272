/*
 * SAIL on a microcontroller: two HX711 load-cell ADCs, two quadrature encoders on the motor shafts, libsail for
 * the force (docs/guide/firmware.md).
 *
 * A fixed-rate control tick (TICK_US, 1 kHz) latches the encoders and looks at each HX711's data-ready once: a
 * conversion is read only when it is already there, and stamped with the device's microsecond clock (exactly,
 * when DOUT's falling edge has an interrupt; else within half a tick).  Nothing in the tick waits.  Conversions
 * within the settling time after power-up are discarded (sail_acq.h), and only then is the tare taken.  With a
 * calibration that has an ADC (sail export-c of a `sail calibrate --adc` calibration, SAIL_CAL_HAS_ADC) the MCU
 * runs libsail's multi-rate estimator, with the dynamic term when the calibration has one; without, the static
 * estimate on the latest conversions.
 *
 * Every tick is sent to the PC, by default as a binary frame (docs/reference/frames.md: device time, sequence
 * number, CRC; 33 bytes, so 1 kHz needs 921,600 baud or USB), which `sail estimate --serial PORT` and
 * `sail live --serial PORT` read; with SAIL_TEXT_LINES, as a CSV line of the multi-rate format with the MCU's
 * force (at 1 kHz, USB only: the baud budget in docs/reference/frames.md).
 *
 * Setup:
 *   1. `sail calibrate DATA.csv --adc hx711-80 [--free-motion FREE.csv] -o cal.json` on the PC, then
 *      `sail export-c cal.json -o sail_calibration.h --sample-rate-hz 1000` and put sail_calibration.h beside this
 *      sketch (c/examples/hx711/ holds one for a simulated rig).
 *   2. Copy c/include/sail.h and c/src/ into the sketch folder (or install libsail as a library).
 *      sail_io, sail_acq and sail_frame (.c, .h: the HX711, encoder, acquisition and wire-format logic, tested on
 *      an emulated Cortex-M4) are here.
 *   3. Set the pins, encoder resolution and zero angles below.
 * At power-up the arm must hang free: the first TARE_PAIRS settled conversions of each cell set the offsets.
 */
#include <Arduino.h>
#include <math.h>

#include "sail.h"
#include "sail_acq.h"
#include "sail_calibration.h"
#include "sail_frame.h"
#include "sail_io.h"

/* Wiring: HX711 data and clock pins, encoder channels (A and B both on change-interrupt pins). */
static const uint8_t HX1_DOUT = 2, HX1_SCK = 3;
static const uint8_t HX2_DOUT = 4, HX2_SCK = 5;
static const uint8_t ENC1_A = 6, ENC1_B = 7;
static const uint8_t ENC2_A = 8, ENC2_B = 9;
/* Define when HX1_DOUT and HX2_DOUT are on interrupt pins: the conversions are then stamped exactly. */
/* #define SAIL_DATA_READY_INTERRUPTS */
/* Define for CSV lines instead of binary frames. */
/* #define SAIL_TEXT_LINES */

static const unsigned long BAUD = 921600;  /* USB CDC boards ignore it */
static const uint32_t TICK_US = 1000;      /* the control tick: 1 kHz (the calibration header's --sample-rate-hz) */
/* The HX711's rate pin: RATE high is 80 SPS (50 ms settling), low is 10 SPS (400 ms). */
static const uint32_t HX711_PERIOD_US = 12500, HX711_SETTLE_US = SAIL_HX711_SETTLE_80SPS_US;
static const uint32_t TARE_PAIRS = 40;     /* half a second of conversions at 80 SPS */

/* Encoder counts per shaft revolution with x4 decoding (every edge of A and B), and the joint angle at count 0. */
static const sail_encoders ENCODERS = {{4u * 2048u, 4u * 2048u}, {1.5707963267948966, 0.0}};

static sail_quadrature encoder1, encoder2;
static sail_calibration cal; /* RAM copy of sail_cal, re-tared at start-up */
static sail_acq acq;
static sail_acq_tare tare;
static int tared;
#ifdef SAIL_CAL_HAS_ADC
static sail_multirate_state estimator; /* ~12 KB with SAIL_MAX_TICKS 256 */
static sail_rezero_state rezero;       /* the offsets follow the drift while the handle is free (docs/reference/drift.md) */
static uint32_t rezeros;
static uint64_t device_us;
#else
static sail_reading latest;
#endif

/* Ticks from the timer interrupt to loop(): a single-producer, single-consumer ring. */
#define QUEUE 32u
static sail_frame_tick queue[QUEUE];
static volatile uint32_t queue_head, queue_tail;

static void encoder1_edge(void) { sail_quadrature_update(&encoder1, digitalRead(ENC1_A), digitalRead(ENC1_B)); }
static void encoder2_edge(void) { sail_quadrature_update(&encoder2, digitalRead(ENC2_A), digitalRead(ENC2_B)); }

/* An HX711's pins for sail_io: the context is the pin pair. */
struct hx711_pins { uint8_t dout, sck; };
static struct hx711_pins hx1 = {HX1_DOUT, HX1_SCK}, hx2 = {HX2_DOUT, HX2_SCK};
static int hx711_dout(void *context) { return digitalRead(((struct hx711_pins *)context)->dout) == HIGH; }
static void hx711_sck(void *context, int level)
{
    digitalWrite(((struct hx711_pins *)context)->sck, level ? HIGH : LOW);
    delayMicroseconds(1);
}
static unsigned long hx711_micros(void *context) { (void)context; return micros(); }
static const sail_cell_config CELLS[2] = {
    {{&hx1, hx711_dout, hx711_sck, hx711_micros}, SAIL_HX711_A128, HX711_PERIOD_US, HX711_SETTLE_US},
    {{&hx2, hx711_dout, hx711_sck, hx711_micros}, SAIL_HX711_A128, HX711_PERIOD_US, HX711_SETTLE_US},
};

#ifdef SAIL_DATA_READY_INTERRUPTS
static void hx1_ready(void) { sail_cell_data_ready(&acq.cell[0], (uint32_t)micros()); }
static void hx2_ready(void) { sail_cell_data_ready(&acq.cell[1], (uint32_t)micros()); }
#endif

/* The control tick, in the timer's interrupt: about 120 us with a conversion to shift out, 10 us without. */
static void control_tick(void)
{
    const uint32_t now = (uint32_t)micros();
    int32_t counts[2];
    uint32_t missed;
    sail_frame_tick f;
    noInterrupts();
    counts[0] = encoder1.count;
    counts[1] = encoder2.count;
    missed = encoder1.missed + encoder2.missed;
    interrupts();
    sail_acq_tick(&acq, now, counts, missed, &f);
    if (queue_head - queue_tail >= QUEUE) {
        sail_acq_dropped(&acq, 0); /* loop() fell behind: this tick's sequence number is skipped, the next flagged */
        return;
    }
    queue[queue_head % QUEUE] = f;
    queue_head = queue_head + 1;
}

/* The tick's source: a hardware timer where the core has a portable one; elsewhere loop() paces it on micros(),
 * with loop()'s jitter (docs/guide/firmware.md: a board's own timer library gives a steady tick). */
#if defined(TEENSYDUINO)
static IntervalTimer tick_timer;
static void start_ticks(void) { tick_timer.begin(control_tick, TICK_US); }
static void pace_ticks(void) {}
#else
static uint32_t next_tick_us;
static void start_ticks(void) { next_tick_us = (uint32_t)micros() + TICK_US; }
static void pace_ticks(void)
{
    if ((int32_t)((uint32_t)micros() - next_tick_us) >= 0) {
        next_tick_us += TICK_US; /* on the grid: no drift from late passes */
        control_tick();
    }
}
#endif

void setup(void)
{
    Serial.begin(BAUD);
    pinMode(HX1_DOUT, INPUT);
    pinMode(HX2_DOUT, INPUT);
    pinMode(HX1_SCK, OUTPUT);
    pinMode(HX2_SCK, OUTPUT);
    pinMode(ENC1_A, INPUT_PULLUP);
    pinMode(ENC1_B, INPUT_PULLUP);
    pinMode(ENC2_A, INPUT_PULLUP);
    pinMode(ENC2_B, INPUT_PULLUP);
    sail_quadrature_init(&encoder1, digitalRead(ENC1_A), digitalRead(ENC1_B));
    sail_quadrature_init(&encoder2, digitalRead(ENC2_A), digitalRead(ENC2_B));
    attachInterrupt(digitalPinToInterrupt(ENC1_A), encoder1_edge, CHANGE);
    attachInterrupt(digitalPinToInterrupt(ENC1_B), encoder1_edge, CHANGE);
    attachInterrupt(digitalPinToInterrupt(ENC2_A), encoder2_edge, CHANGE);
    attachInterrupt(digitalPinToInterrupt(ENC2_B), encoder2_edge, CHANGE);

    if (sail_calibration_check(&sail_cal) != SAIL_CHECK_OK) {
        Serial.println("# sail_calibration.h is not a valid calibration for this libsail: regenerate it with sail export-c");
        for (;;) {
        }
    }
    cal = sail_cal;
    sail_acq_tare_init(&tare);
    sail_acq_start(&acq, CELLS); /* both HX711s reset together: they start in step, then drift on their clocks */
#ifdef SAIL_DATA_READY_INTERRUPTS
    attachInterrupt(digitalPinToInterrupt(HX1_DOUT), hx1_ready, FALLING);
    attachInterrupt(digitalPinToInterrupt(HX2_DOUT), hx2_ready, FALLING);
#endif
#ifdef SAIL_TEXT_LINES
    Serial.println("t_s,theta1_deg,theta2_deg,load1,load2,load1_t_s,load2_t_s,device_status,fx_N,fy_N,status");
#else
    {
        uint8_t hello[SAIL_FRAME_MAX];
        const size_t n = sail_frame_encode_hello(ENCODERS.counts_per_turn[0], ENCODERS.counts_per_turn[1], hello);
        Serial.write(hello, n);
    }
#endif
    start_ticks();
}

/* The settled conversions tare the cells; then the estimator starts. */
static void take_tare(const sail_frame_tick *f)
{
    if (sail_acq_tare_feed(&tare, f) < TARE_PAIRS)
        return;
    if (sail_tare_finish(&tare.state, &cal, NULL) != SAIL_CHECK_OK)
        return;
#ifdef SAIL_CAL_HAS_ADC
#ifdef SAIL_CAL_HAS_DYNAMICS
    const enum sail_check check = sail_multirate_init(&estimator, &cal, &sail_cal_dynamics, &sail_cal_adc);
#else
    const enum sail_check check = sail_multirate_init(&estimator, &cal, NULL, &sail_cal_adc);
#endif
    if (check != SAIL_CHECK_OK || sail_rezero_init(&rezero, &cal, NULL) != SAIL_CHECK_OK) {
        Serial.println("# sail_calibration.h's ADC or dynamic term does not suit this libsail: regenerate it");
        for (;;) {
        }
    }
#endif
    tared = 1;
}

/* The MCU's own force for this tick (for a controller: an admittance loop would use it here). */
static void estimate(const sail_frame_tick *f, sail_real force[2], int32_t *status)
{
    force[0] = force[1] = (sail_real)NAN;
    *status = SAIL_MOTION_UNKNOWN;
    if (!tared)
        return;
#ifdef SAIL_CAL_HAS_ADC
    {
        sail_tick t, held;
        sail_timed_force out;
        sail_acq_reading(f, &ENCODERS, &device_us, &t);
        if (sail_multirate_step(&estimator, &t, &out, &held)) { /* the tick half a rate window back */
            sail_force corrected;
            corrected.fx = out.fx;
            corrected.fy = out.fy;
            corrected.status = out.status;
            /* no contact sensor here: SAIL_CONTACT_NONE (pass a switch's reading if the handle has one) */
            if (sail_rezero_step(&rezero, out.force_t, held.theta1, held.theta2, &corrected, SAIL_CONTACT_NONE, NULL,
                                 NULL) == SAIL_REZERO_MADE)
                rezeros++;
            force[0] = corrected.fx;
            force[1] = corrected.fy;
            *status = corrected.status;
        }
    }
#else
    {
        sail_force out;
        latest.theta1 = (sail_real)(ENCODERS.zero[0] + 6.283185307179586 * f->counts[0] / ENCODERS.counts_per_turn[0]);
        latest.theta2 = (sail_real)(ENCODERS.zero[1] + 6.283185307179586 * f->counts[1] / ENCODERS.counts_per_turn[1]);
        if (f->fresh & 1u)
            latest.load1 = (sail_real)f->load[0];
        if (f->fresh & 2u)
            latest.load2 = (sail_real)f->load[1];
        sail_estimate(&cal, &latest, &out);
        force[0] = out.fx;
        force[1] = out.fy;
        *status = out.status;
    }
#endif
}

#ifdef SAIL_TEXT_LINES
static void send(const sail_frame_tick *f, const sail_real force[2], int32_t status)
{
    static const char *const STATUS_NAMES[] = {"ok", "singular", "saturated", "extrapolated", "invalid", "motion-unknown"};
    const double t = (double)f->time_us * 1e-6; /* wraps after 71.6 min: the binary frames' reader unwraps it */
    int i;
    Serial.print(t, 6);
    Serial.print(',');
    for (i = 0; i < 2; i++) {
        Serial.print(360.0 * f->counts[i] / ENCODERS.counts_per_turn[i] + 57.29577951308232 * ENCODERS.zero[i], 4);
        Serial.print(',');
    }
    for (i = 0; i < 2; i++) {
        if (f->fresh & (1u << i))
            Serial.print((long)f->load[i]);
        Serial.print(',');
    }
    for (i = 0; i < 2; i++) {
        if (f->fresh & (1u << i))
            Serial.print(t + f->ready_us[i] * 1e-6, 6);
        Serial.print(',');
    }
    Serial.print((long)f->status);
    Serial.print(',');
    if (!isnan(force[0])) {
        Serial.print((double)force[0], 3);
        Serial.print(',');
        Serial.print((double)force[1], 3);
    } else {
        Serial.print(',');
    }
    Serial.print(',');
    Serial.println(STATUS_NAMES[status]);
}
#else
static void send(const sail_frame_tick *f, const sail_real force[2], int32_t status)
{
    uint8_t bytes[SAIL_FRAME_MAX];
    (void)force;
    (void)status;
    Serial.write(bytes, sail_frame_encode_tick(f, bytes));
}
#endif

void loop(void)
{
    pace_ticks();
    while (queue_tail != queue_head) {
        sail_frame_tick f = queue[queue_tail % QUEUE];
        sail_real force[2];
        int32_t status;
        queue_tail = queue_tail + 1;
        if (!tared) {
            take_tare(&f);
            f.status |= SAIL_ACQ_TARING;
        }
        estimate(&f, force, &status);
        send(&f, force, status);
        pace_ticks();
    }
}

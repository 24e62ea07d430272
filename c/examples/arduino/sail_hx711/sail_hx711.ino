/*
 * SAIL on a microcontroller: two HX711 load-cell ADCs, two quadrature
 * encoders on the motor shafts, libsail for the force.
 *
 * Streams the `sail estimate` line format over serial:
 *   theta1_deg,theta2_deg,load1,load2,fx_N,fy_N,status
 * so the PC side can log it or feed it to `sail estimate --serial` for a
 * cross-check.
 *
 * Setup:
 *   1. `sail calibrate DATA.csv -o cal.json` on the PC, then
 *      `sail export-c cal.json -o sail_calibration.h --lowpass-hz 10 --sample-rate-hz 80`
 *      and put sail_calibration.h beside this sketch.
 *   2. Copy c/include/sail.h and c/src/ into the sketch folder (or install libsail as a library).
 *      sail_io.c and sail_io.h (the HX711 and encoder logic, tested on an emulated Cortex-M4) are here.
 *   3. Set the pins, encoder resolution and zero angles below.
 * At power-up the arm must hang free: the first TARE_SAMPLES readings set the offsets.
 */
#include <Arduino.h>
#include <math.h>

#include "sail.h"
#include "sail_calibration.h"
#include "sail_io.h"

/* Wiring: HX711 data and clock pins, encoder channels (A and B both on change-interrupt pins). */
static const uint8_t HX1_DOUT = 2, HX1_SCK = 3;
static const uint8_t HX2_DOUT = 4, HX2_SCK = 5;
static const uint8_t ENC1_A = 6, ENC1_B = 7;
static const uint8_t ENC2_A = 8, ENC2_B = 9;

/* Encoder counts per shaft revolution with x4 decoding (every edge of A and B), and the joint angle
 * at count 0 [rad]. */
static const float COUNTS_PER_REV = 4.0f * 2048.0f;
static const float THETA1_ZERO_RAD = 1.5707963f;  /* link 1 vertical at start-up */
static const float THETA2_ZERO_RAD = 0.0f;        /* link 2 horizontal */
static const float TWO_PI_F = 6.2831853f;

static const unsigned int TARE_SAMPLES = 80;  /* one second at the HX711's 80 SPS */
static const unsigned long HX711_TIMEOUT_US = 200000;

static sail_quadrature encoder1, encoder2;
static sail_calibration cal;        /* RAM copy of sail_cal, re-tared at start-up */
static sail_lowpass_state lowpass;
static const char *const STATUS_NAMES[] = {"ok", "singular", "saturated", "extrapolated", "invalid", "motion-unknown"};

static void encoder1_edge(void) { sail_quadrature_update(&encoder1, digitalRead(ENC1_A), digitalRead(ENC1_B)); }
static void encoder2_edge(void) { sail_quadrature_update(&encoder2, digitalRead(ENC2_A), digitalRead(ENC2_B)); }

/* An HX711's pins for sail_io: the context is the pin pair. */
struct hx711_pins { uint8_t dout, sck; };
static int hx711_dout(void *context) { return digitalRead(((struct hx711_pins *)context)->dout) == HIGH; }
static void hx711_sck(void *context, int level)
{
    digitalWrite(((struct hx711_pins *)context)->sck, level ? HIGH : LOW);
    delayMicroseconds(1);
}
static unsigned long hx711_micros(void *context) { (void)context; return micros(); }

/* One 24-bit conversion, channel A at gain 128; NaN if the HX711 is not ready in time. */
static float hx711_read(uint8_t dout, uint8_t sck)
{
    struct hx711_pins pins = {dout, sck};
    const sail_hx711_port port = {&pins, hx711_dout, hx711_sck, hx711_micros};
    uint32_t bits;
    if (sail_hx711_wait(&port, HX711_TIMEOUT_US) != 0)
        return NAN;
    noInterrupts();  /* SCK high for more than 60 us powers the HX711 down */
    bits = sail_hx711_shift(&port, SAIL_HX711_A128);
    interrupts();
    return (float)sail_hx711_decode(bits);
}

static sail_reading read_sensors(void)
{
    sail_reading r;
    long c1, c2;
    noInterrupts();
    c1 = encoder1.count;
    c2 = encoder2.count;
    interrupts();
    r.theta1 = THETA1_ZERO_RAD + TWO_PI_F * (float)c1 / COUNTS_PER_REV;
    r.theta2 = THETA2_ZERO_RAD + TWO_PI_F * (float)c2 / COUNTS_PER_REV;
    r.load1 = hx711_read(HX1_DOUT, HX1_SCK);
    r.load2 = hx711_read(HX2_DOUT, HX2_SCK);
    return r;
}

void setup(void)
{
    sail_tare_state tare;
    sail_real spread[2];
    unsigned int i;
    Serial.begin(115200);
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

    if (sail_calibration_check(&sail_cal) != SAIL_CHECK_OK || sail_lowpass_init(&lowpass, &sail_cal_lowpass) != SAIL_CHECK_OK) {
        Serial.println("# sail_calibration.h is not a valid calibration for this libsail: regenerate it with sail export-c");
        for (;;) {
        }
    }
    cal = sail_cal;
    sail_tare_init(&tare);
    for (i = 0; i < TARE_SAMPLES; i++) {
        const sail_reading r = read_sensors();
        sail_tare_process(&tare, &r, 1);
    }
    if (sail_tare_finish(&tare, &cal, spread) != SAIL_CHECK_OK)
        Serial.println("# tare failed: no HX711 readings; using the calibration's offsets");
    Serial.println("theta1_deg,theta2_deg,load1,load2,fx_N,fy_N,status");
}

void loop(void)
{
    sail_reading r = read_sensors();
    const sail_reading raw = r;
    sail_force f;
    static uint32_t missed_reported = 0;
    const uint32_t missed = encoder1.missed + encoder2.missed;  /* a torn read only delays the note */
    if (missed != missed_reported) {  /* an edge came faster than the interrupt: the angle may be 2 counts off */
        Serial.print("# encoders: missed edges ");
        Serial.print((long)missed);
        Serial.println("");
        missed_reported = missed;
    }
    sail_lowpass_process(&lowpass, &r, 1);
    sail_estimate(&cal, &r, &f);
    Serial.print((double)(raw.theta1 * 57.29578f), 4);
    Serial.print(',');
    Serial.print((double)(raw.theta2 * 57.29578f), 4);
    Serial.print(',');
    if (!isnan(raw.load1))
        Serial.print((long)raw.load1);
    Serial.print(',');
    if (!isnan(raw.load2))
        Serial.print((long)raw.load2);
    Serial.print(',');
    if (f.status != SAIL_SINGULAR && f.status != SAIL_INVALID) {
        Serial.print((double)f.fx, 3);
        Serial.print(',');
        Serial.print((double)f.fy, 3);
    } else {
        Serial.print(',');
    }
    Serial.print(',');
    Serial.println(STATUS_NAMES[f.status]);
}

/*
 * The sketch's acquisition (c/examples/arduino/sail_hx711/sail_acq.c) and wire format (sail_frame.c) against
 * simulated HX711s converting on their own clocks, as the Avia HX711 datasheet describes them: DOUT falls when a
 * conversion is ready and stays low until it is shifted out; SCK high for more than 60 us powers the chip down,
 * and low again resets it; the conversions within the output settling time after a reset are not valid.
 *   test_acq [FRAMES.csv]   FRAMES.csv: ticks and their bytes from sailforce.io.frames (c/tests/make_vectors.py)
 * Runs on the host and on the emulated Cortex-M4F (make cross-test).
 */
#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "sail_acq.h"
#include "sail_frame.h"

#define TICK_US 1000u

/* ---- a simulated HX711 ------------------------------------------------------------------ */

typedef struct {
    uint32_t *clock;        /* the board's microsecond clock, shared */
    uint32_t period_us;     /* its own conversion period */
    uint32_t settle_us;     /* conversions ready sooner than this after a reset are garbage */
    int32_t settled_value;  /* a settled conversion's value; +index if `counting` */
    int counting;
    int32_t garbage;        /* an unsettled one's */
    int unplugged;          /* DOUT pulled high for ever */
    uint32_t stop_after_us; /* no conversion after this long (0: never stops) */
    uint32_t reset_us;      /* the last reset */
    int powered;
    uint32_t sck_high_us;
    int sck, pulses, last_pulses;
    int32_t latched;        /* the conversion being shifted out */
    long read_index;        /* the last conversion shifted out (-1: none) */
    long dout_reads;
} hx711_sim;

static long ready_index(const hx711_sim *d)
{
    /* conversion n is ready at reset + (n + 1) T */
    const uint32_t age = *d->clock - d->reset_us;
    if (!d->powered || d->unplugged)
        return -1;
    if (d->stop_after_us && age > d->stop_after_us)
        return d->read_index;  /* it stopped: nothing new */
    return (long)(age / d->period_us) - 1;
}

static int32_t value_of(const hx711_sim *d, long n)
{
    if ((uint32_t)(n + 1) * d->period_us < d->settle_us)
        return d->garbage;
    return d->settled_value + (d->counting ? (int32_t)n : 0);
}

static int sim_dout(void *context)
{
    hx711_sim *d = (hx711_sim *)context;
    long n;
    d->dout_reads++;
    if (!d->sck && d->pulses > 0) {  /* the last shift is over */
        d->last_pulses = d->pulses;
        d->pulses = 0;
    }
    if (d->pulses > 0)  /* shifting: bit `pulses` of the latched conversion, most significant first */
        return d->pulses <= 24 ? (int)(((uint32_t)d->latched >> (24 - d->pulses)) & 1u) : 1;
    n = ready_index(d);
    if (n > d->read_index) {
        d->latched = value_of(d, n);
        return 0;
    }
    return 1;
}

static void sim_sck(void *context, int level)
{
    hx711_sim *d = (hx711_sim *)context;
    if (level && !d->sck) {
        d->sck_high_us = *d->clock;
        if (d->pulses == 0) {
            long n = ready_index(d);
            if (n > d->read_index) {  /* the newest conversion is the one shifted out */
                d->read_index = n;
                d->latched = value_of(d, n);
            }
        }
        d->pulses++;
    }
    if (!level && d->sck && *d->clock - d->sck_high_us > 60u) {  /* powered down, now reset */
        d->powered = 1;
        d->reset_us = *d->clock;
        d->read_index = -1;
        d->pulses = 0;
    }
    d->sck = level;
}

static unsigned long sim_micros(void *context)
{
    hx711_sim *d = (hx711_sim *)context;
    return ++*d->clock;
}

static void sim_init(hx711_sim *d, uint32_t *clock, uint32_t period_us, int32_t settled_value)
{
    memset(d, 0, sizeof *d);
    d->clock = clock;
    d->period_us = period_us;
    d->settle_us = SAIL_HX711_SETTLE_80SPS_US;
    d->settled_value = settled_value;
    d->garbage = -2000000;
    d->read_index = -1;
    d->powered = 1;      /* on since power-up, at some unknown phase */
    d->reset_us = *clock - 7777u;
}

static sail_cell_config config_of(hx711_sim *d)
{
    sail_cell_config c;
    c.port.context = d;
    c.port.dout = sim_dout;
    c.port.sck = sim_sck;
    c.port.micros = sim_micros;
    c.gain = SAIL_HX711_A128;
    c.period_us = 12500u;
    c.settle_us = SAIL_HX711_SETTLE_80SPS_US;
    return c;
}

/* ---- the wire format -------------------------------------------------------------------- */

static void check_bytes(const uint8_t *got, size_t n, const uint8_t *want, size_t m, const char *what)
{
    CHECK(n == m && memcmp(got, want, m) == 0, "%s: %u bytes, expected %u", what, (unsigned)n, (unsigned)m);
}

static void test_crc_and_cobs(void)
{
    /* CRC-16/CCITT-FALSE's catalogued check value (Williams, "A painless guide to CRC", the CRC RevEng catalogue) */
    static const uint8_t digits[] = "123456789";
    /* COBS examples of Cheshire & Baker (1999): zeros become distances, a zero closes the frame */
    static const uint8_t in1[] = {0x00}, out1[] = {0x01, 0x01, 0x00};
    static const uint8_t in2[] = {0x11, 0x22, 0x00, 0x33}, out2[] = {0x03, 0x11, 0x22, 0x02, 0x33, 0x00};
    static const uint8_t in3[] = {0x11, 0x00, 0x00, 0x00}, out3[] = {0x02, 0x11, 0x01, 0x01, 0x01, 0x00};
    static const uint8_t in4[] = {0x11, 0x22, 0x33, 0x44}, out4[] = {0x05, 0x11, 0x22, 0x33, 0x44, 0x00};
    uint8_t out[SAIL_FRAME_MAX];
    size_t n;
    CHECK(sail_crc16(digits, 9) == 0x29B1u, "CRC of 123456789: 0x%04x", (unsigned)sail_crc16(digits, 9));
    n = sail_cobs_encode(in1, sizeof in1, out);
    check_bytes(out, n, out1, sizeof out1, "COBS 00");
    n = sail_cobs_encode(in2, sizeof in2, out);
    check_bytes(out, n, out2, sizeof out2, "COBS 11 22 00 33");
    n = sail_cobs_encode(in3, sizeof in3, out);
    check_bytes(out, n, out3, sizeof out3, "COBS 11 00 00 00");
    n = sail_cobs_encode(in4, sizeof in4, out);
    check_bytes(out, n, out4, sizeof out4, "COBS 11 22 33 44");
}

/* Each row: sequence,time_us,counts1,counts2,fresh,load1,load2,ready1,ready2,status,HEX from the Python encoder. */
static void test_frames_against_python(const char *path)
{
    char line[512];
    int rows = 0;
    FILE *f = fopen(path, "r");
    if (!f) {
        CHECK(0, "%s: cannot open", path);
        return;
    }
    if (!fgets(line, sizeof line, f)) {
        CHECK(0, "%s: empty", path);
        fclose(f);
        return;
    }
    while (fgets(line, sizeof line, f)) {
        long long v[10];
        char *p = line, *end;
        uint8_t want[64], got[SAIL_FRAME_MAX];
        size_t m = 0, n;
        sail_frame_tick t;
        int c;
        for (c = 0; c < 10; c++) {
            v[c] = strtoll(p, &end, 10); /* long long: a u32 field overflows a 32-bit long */
            p = end + 1;
        }
        while (isxdigit((unsigned char)p[0]) && isxdigit((unsigned char)p[1]) && m < sizeof want) {
            char hex[3] = {p[0], p[1], 0};
            want[m++] = (uint8_t)strtoul(hex, NULL, 16);
            p += 2;
        }
        t.sequence = (uint16_t)v[0];
        t.time_us = (uint32_t)v[1];
        t.counts[0] = (int32_t)v[2];
        t.counts[1] = (int32_t)v[3];
        t.fresh = (uint8_t)v[4];
        t.load[0] = (int32_t)v[5];
        t.load[1] = (int32_t)v[6];
        t.ready_us[0] = (int16_t)v[7];
        t.ready_us[1] = (int16_t)v[8];
        t.status = (uint8_t)v[9];
        if (t.sequence == 0xFFFFu && t.fresh == 0xFFu)  /* the hello row: counts per turn in counts1, counts2 */
            n = sail_frame_encode_hello((uint32_t)v[2], (uint32_t)v[3], got);
        else
            n = sail_frame_encode_tick(&t, got);
        check_bytes(got, n, want, m, "a frame from the Python encoder");
        CHECK(n <= SAIL_FRAME_MAX, "a frame of %u bytes", (unsigned)n);
        rows++;
    }
    fclose(f);
    CHECK(rows >= 8, "%s: %d frames", path, rows);
}

/* ---- acquisition ------------------------------------------------------------------------ */

typedef struct {
    uint32_t clock;
    hx711_sim dev[2];
    sail_cell_config config[2];
    sail_acq acq;
    int32_t counts[2];
    uint32_t missed;
} rig;

/* Two HX711s, one on a crystal (12,500 us) and one on its internal oscillator 0.5 % fast, powered since before
 * the start at a phase of their own; the board's clock starts near its 32-bit wrap, which it crosses. */
static void rig_init(rig *r, int32_t value1, int32_t value2, int counting)
{
    int i;
    memset(r, 0, sizeof *r);
    r->clock = 0xFFFFFFFFu - 3000000u;
    sim_init(&r->dev[0], &r->clock, 12500u, value1);
    sim_init(&r->dev[1], &r->clock, 12437u, value2);
    for (i = 0; i < 2; i++) {
        r->dev[i].counting = counting;
        r->config[i] = config_of(&r->dev[i]);
    }
}

/* Advance to the next tick; with `edges`, play the DOUT falling-edge interrupts that came since the last one. */
static void rig_tick(rig *r, int edges, sail_frame_tick *out)
{
    const uint32_t before = r->clock;
    int i;
    r->clock += TICK_US;
    for (i = 0; edges && i < 2; i++) {
        hx711_sim *d = &r->dev[i];
        const long n = ready_index(d);
        if (n > d->read_index && d->powered) {
            const uint32_t at = d->reset_us + (uint32_t)(n + 1) * d->period_us;
            if ((int32_t)(at - before) > 0)
                sail_cell_data_ready(&r->acq.cell[i], at);
        }
    }
    sail_acq_tick(&r->acq, r->clock, r->counts, r->missed, out);
}

static void test_acquisition(int edges)
{
    static rig r;
    const char *mode = edges ? "interrupt" : "polled";
    long next[2] = {-1, -1}, taken[2] = {0, 0};
    int both_settled_at = -1, k, i;
    uint32_t start;
    rig_init(&r, 100000, -50000, 1);
    sail_acq_start(&r.acq, r.config);
    start = r.clock;
    CHECK(r.dev[0].reset_us == r.dev[1].reset_us && start - r.dev[0].reset_us <= 1u,
          "%s: the two HX711s are reset together at the start", mode);
    for (k = 0; k < 10000; k++) {
        sail_frame_tick f;
        long reads[2];
        uint32_t discarded[2];
        for (i = 0; i < 2; i++) {
            reads[i] = r.dev[i].dout_reads;
            discarded[i] = r.acq.cell[i].discarded;
        }
        rig_tick(&r, edges, &f);
        CHECK(f.sequence == (uint16_t)k && f.time_us == r.clock, "%s: tick %d's sequence and time", mode, k);
        CHECK(!(f.status & SAIL_ACQ_TIMEOUT), "%s: tick %d: a timeout", mode, k);
        for (i = 0; i < 2; i++) {
            const long polls = r.dev[i].dout_reads - reads[i];
            const int read = ((f.fresh >> i) & 1) || r.acq.cell[i].discarded != discarded[i];
            /* never a wait: one look at DOUT, and the 24 bits only when a conversion is ready */
            CHECK(polls == (read ? 25 : 1), "%s: tick %d, cell %d: %ld reads of DOUT", mode, k, i + 1, polls);
            CHECK(!((f.fresh >> i) & 1) || r.acq.cell[i].discarded == discarded[i], "%s: a conversion both taken and "
                  "discarded", mode);
            if ((f.fresh >> i) & 1) {
                const long n = f.load[i] - r.dev[i].settled_value;
                const uint32_t truth = r.dev[i].reset_us + (uint32_t)(n + 1) * r.dev[i].period_us;
                const int32_t error = (int32_t)(f.time_us + (uint32_t)(int32_t)f.ready_us[i] - truth);
                CHECK(f.load[i] != r.dev[i].garbage && (n + 1) * (long)r.dev[i].period_us >= (long)SAIL_HX711_SETTLE_80SPS_US,
                      "%s: cell %d gave a conversion from within the settling time", mode, i + 1);
                CHECK(next[i] < 0 || n == next[i], "%s: cell %d: conversion %ld after %ld (lost or repeated)", mode, i + 1,
                      n, next[i] - 1);
                CHECK(edges ? error == 0 : abs(error) <= (int)(TICK_US / 2), "%s: cell %d: stamp %ld us off", mode,
                      i + 1, (long)error);
                CHECK(f.ready_us[i] <= 0 && f.ready_us[i] > -(int)TICK_US, "%s: stamp %d us from its tick", mode,
                      f.ready_us[i]);
                next[i] = n + 1;
                taken[i]++;
            }
        }
        if (both_settled_at < 0 && !(f.status & SAIL_ACQ_SETTLING))
            both_settled_at = k;
        CHECK(both_settled_at < 0 || !(f.status & SAIL_ACQ_SETTLING), "%s: settling again at tick %d", mode, k);
    }
    /* settled from the first conversion at or past 50 ms: 4 periods of the crystal's chip */
    CHECK(both_settled_at >= 49 && both_settled_at <= 63, "%s: settled at tick %d", mode, both_settled_at);
    for (i = 0; i < 2; i++) {
        const long expected = (long)((r.clock - start) / r.dev[i].period_us);  /* conversions in 10 s, at its rate */
        CHECK(labs(taken[i] + (long)r.acq.cell[i].discarded - expected) <= 1, "%s: cell %d: %ld taken + %lu discarded of %ld",
              mode, i + 1, taken[i], (unsigned long)r.acq.cell[i].discarded, expected);
        CHECK(r.acq.cell[i].discarded >= 3 && r.acq.cell[i].discarded <= 4, "%s: cell %d: %lu discarded", mode, i + 1,
              (unsigned long)r.acq.cell[i].discarded);
    }
    CHECK(r.dev[0].last_pulses == 25 && r.dev[1].last_pulses == 25, "the gain's 25 pulses: %d, %d",
          r.dev[0].last_pulses, r.dev[1].last_pulses);
}

static void test_tare_after_settling(void)
{
    static rig r;
    sail_acq_tare tare;
    sail_calibration cal;
    sail_real spread[2];
    int k;
    uint32_t pairs = 0;
    rig_init(&r, 123456, -65432, 0);
    sail_acq_start(&r.acq, r.config);
    sail_acq_tare_init(&tare);
    for (k = 0; pairs < 40 && k < 5000; k++) {
        sail_frame_tick f;
        rig_tick(&r, 0, &f);
        pairs = sail_acq_tare_feed(&tare, &f);
    }
    memset(&cal, 0, sizeof cal);
    CHECK(pairs == 40, "%u tare pairs", (unsigned)pairs);
    /* garbage in the tare (-2,000,000) would pull the means far off: they are the settled values exactly */
    CHECK(sail_tare_finish(&tare.state, &cal, spread) == SAIL_CHECK_OK, "the tare");
    CHECK(cal.offset[0] == (sail_real)123456 && cal.offset[1] == (sail_real)-65432, "offsets %g, %g",
          (double)cal.offset[0], (double)cal.offset[1]);
    CHECK(spread[0] == 0 && spread[1] == 0, "spreads %g, %g", (double)spread[0], (double)spread[1]);
}

static void test_timeouts(void)
{
    static rig r;
    int k, first_timeout = -1, last_fresh = -1;
    rig_init(&r, 1000, 2000, 0);
    r.dev[1].unplugged = 1;
    sail_acq_start(&r.acq, r.config);
    for (k = 0; k < 200; k++) {
        sail_frame_tick f;
        rig_tick(&r, 0, &f);
        CHECK(!(f.fresh & 2u), "an unplugged HX711 gave a conversion");
        if (first_timeout < 0 && (f.status & SAIL_ACQ_TIMEOUT))
            first_timeout = k;
    }
    /* settling (50 ms) and three periods (37.5 ms), counted from the start */
    CHECK(first_timeout == 87 || first_timeout == 88, "the unplugged cell timed out at tick %d", first_timeout);

    rig_init(&r, 1000, 2000, 0);
    r.dev[0].stop_after_us = 2000000u;  /* a cell that stops converting after 2 s */
    sail_acq_start(&r.acq, r.config);
    first_timeout = -1;
    for (k = 0; k < 3000; k++) {
        sail_frame_tick f;
        rig_tick(&r, 0, &f);
        if (f.fresh & 1u)
            last_fresh = k;
        if (first_timeout < 0 && (f.status & SAIL_ACQ_TIMEOUT))
            first_timeout = k;
    }
    CHECK(first_timeout > last_fresh && first_timeout - last_fresh >= 37 && first_timeout - last_fresh <= 39,
          "the stopped cell: last conversion at tick %d, timeout at %d", last_fresh, first_timeout);
}

static void test_status_bits(void)
{
    static rig r;
    sail_frame_tick f;
    int k, saturated = 0, fresh1 = 0;
    rig_init(&r, 8388607, 0, 0);  /* cell 1 at the top of its range */
    sail_acq_start(&r.acq, r.config);
    for (k = 0; k < 500; k++) {
        rig_tick(&r, 0, &f);
        fresh1 += f.fresh & 1;
        saturated += (f.status & SAIL_ACQ_SATURATED) != 0;
        CHECK(!(f.status & SAIL_ACQ_SATURATED) || (f.fresh & 1), "saturated on a tick without its conversion");
    }
    CHECK(saturated == fresh1 && fresh1 > 30, "%d saturated ticks, %d conversions", saturated, fresh1);

    r.missed = 1;  /* an encoder missed an edge: reported once */
    rig_tick(&r, 0, &f);
    CHECK(f.status & SAIL_ACQ_ENCODER, "the missed edge");
    rig_tick(&r, 0, &f);
    CHECK(!(f.status & SAIL_ACQ_ENCODER), "the missed edge, reported twice");

    k = f.sequence;
    sail_acq_dropped(&r.acq, 3);  /* the queue was full for three ticks */
    rig_tick(&r, 0, &f);
    CHECK(f.sequence == (uint16_t)(k + 4) && (f.status & SAIL_ACQ_OVERRUN), "after 3 dropped: sequence %u after %d",
          (unsigned)f.sequence, k);
    rig_tick(&r, 0, &f);
    CHECK(!(f.status & SAIL_ACQ_OVERRUN), "the overrun, reported twice");
}

static void test_reading(void)
{
    const sail_encoders enc = {{8192u, 4096u}, {1.5, -0.25}};
    sail_frame_tick f;
    sail_tick t;
    uint64_t clock = 0;
    memset(&f, 0, sizeof f);
    f.time_us = 0xFFFFFC18u;  /* 1 ms before the wrap */
    f.counts[0] = 2048;       /* a quarter turn */
    f.counts[1] = -1024;
    f.fresh = 2u;
    f.load[1] = -4321;
    f.ready_us[1] = -400;
    sail_acq_reading(&f, &enc, &clock, &t);
    CHECK_CLOSE(t.t, 4294.966296, 1.0, 1e-12);
    CHECK_CLOSE(t.theta1, 1.5 + 1.5707963267948966, 1.0, SAIL_TEST_RTOL);
    CHECK_CLOSE(t.theta2, -0.25 - 1.5707963267948966, 1.0, SAIL_TEST_RTOL);
    CHECK(isnan(t.load[0]) && isnan(t.ready[0]), "cell 1 has no conversion");
    CHECK(t.load[1] == (sail_real)-4321, "cell 2's load");
    CHECK_CLOSE(t.ready[1], 4294.966296 - 0.0004, 1.0, 1e-12);
    f.time_us = 1000u;  /* 2 ms later, past the wrap */
    f.fresh = 0;
    sail_acq_reading(&f, &enc, &clock, &t);
    CHECK_CLOSE(t.t, 4294.968296, 1.0, 1e-12);
    CHECK(clock == 4294968296ull, "the unwrapped clock: %llu", (unsigned long long)clock);
}

#ifdef SAIL_TEST_MULTIRATE
#include "cal_multirate.h"

/* The multi-rate estimator on the MCU, fed by the acquisition: held still, the two cells' asynchronous conversions
 * give the force that the static estimate gives for the same angles and loads (a different code path: no window,
 * no interpolation, no measured periods). */
static void test_multirate_on_the_mcu(void)
{
    static rig r;
    static sail_multirate_state state;
    const sail_encoders enc = {{8192u, 8192u}, {0.0, 0.0}};
    sail_timed_force out;
    sail_reading still;
    sail_force expected;
    uint64_t clock = 0;
    int k, estimates = 0;
    rig_init(&r, 200000, -150000, 0);
    r.counts[0] = 1565;  /* 68.8 deg */
    r.counts[1] = 134;   /* 5.9 deg */
    CHECK(sail_multirate_init(&state, &sail_cal_multirate, NULL, &sail_cal_multirate_adc) == SAIL_CHECK_OK, "init");
    sail_acq_start(&r.acq, r.config);
    memset(&out, 0, sizeof out);
    for (k = 0; k < 3000; k++) {
        sail_frame_tick f;
        sail_tick t;
        rig_tick(&r, 0, &f);
        sail_acq_reading(&f, &enc, &clock, &t);
        estimates += sail_multirate_step(&state, &t, &out, NULL);
    }
    still.theta1 = (sail_real)(6.283185307179586 * 1565 / 8192);
    still.theta2 = (sail_real)(6.283185307179586 * 134 / 8192);
    still.load1 = 200000;
    still.load2 = -150000;
    sail_estimate(&sail_cal_multirate, &still, &expected);
    CHECK(estimates == 3000, "%d estimates of 3000 ticks", estimates);
    CHECK(out.status == SAIL_OK && expected.status == SAIL_OK, "statuses %ld and %ld", (long)out.status,
          (long)expected.status);
    CHECK_CLOSE(out.fx, expected.fx, hypot(expected.fx, expected.fy), 1e-4);
    CHECK_CLOSE(out.fy, expected.fy, hypot(expected.fx, expected.fy), 1e-4);
    CHECK(out.force_t < (double)clock * 1e-6 && out.force_t > (double)clock * 1e-6 - 0.1, "force_t %.6f at %.6f",
          out.force_t, (double)clock * 1e-6);
}
#endif

int main(int argc, char **argv)
{
    test_crc_and_cobs();
    if (argc > 1)
        test_frames_against_python(argv[1]);
    test_acquisition(0);
    test_acquisition(1);
    test_tare_after_settling();
    test_timeouts();
    test_status_bits();
    test_reading();
#ifdef SAIL_TEST_MULTIRATE
    test_multirate_on_the_mcu();
#endif
    return check_report("sail_acq");
}

/*
 * The sketch's HX711 and encoder logic (c/examples/arduino/sail_hx711/sail_io.c) against bit
 * streams as a logic analyser shows them: an HX711 shifting a conversion out, most significant
 * bit first, DOUT valid after each SCK rising edge (Avia HX711 datasheet, "Serial Interface"),
 * and quadrature channel levels sampled at each edge.  Runs on the host and on the emulated
 * Cortex-M4F (make cross-test).
 */
#include <limits.h>
#include <string.h>

#include "check.h"
#include "sail_io.h"

/* ---- an HX711 replaying a recorded conversion ------------------------------------------ */

typedef struct {
    const char *stream;    /* DOUT after each rising edge: 24 characters '0'/'1' */
    int busy_polls;        /* DOUT stays high (converting) for this many reads before the data */
    int pulses;            /* SCK rising edges seen */
    int sck;               /* SCK's level */
    unsigned long clock;   /* us */
    unsigned long tick;    /* us per micros() call */
} hx711_device;

static int device_dout(void *context)
{
    hx711_device *d = (hx711_device *)context;
    if (d->pulses == 0 && d->busy_polls > 0) {
        d->busy_polls--;
        return 1;
    }
    if (d->pulses == 0)
        return 0;  /* ready: DOUT low */
    if (d->pulses <= 24)
        return d->stream[d->pulses - 1] == '1';
    return 1;      /* after the 24 bits DOUT goes high until the next conversion */
}

static void device_sck(void *context, int level)
{
    hx711_device *d = (hx711_device *)context;
    if (level && !d->sck)
        d->pulses++;
    d->sck = level;
}

static unsigned long device_micros(void *context)
{
    hx711_device *d = (hx711_device *)context;
    d->clock += d->tick;
    return d->clock;
}

static sail_hx711_port port_of(hx711_device *d)
{
    sail_hx711_port port;
    port.context = d;
    port.dout = device_dout;
    port.sck = device_sck;
    port.micros = device_micros;
    return port;
}

static void test_decode(void)
{
    /* 24-bit two's complement: the datasheet's limits 0x7FFFFF and 0x800000, and around zero */
    static const struct { uint32_t bits; int32_t value; } table[] = {
        {0x000000u, 0}, {0x000001u, 1}, {0x7FFFFFu, 8388607}, {0x800000u, -8388608},
        {0x800001u, -8388607}, {0xFFFFFFu, -1}, {0xFE1DC0u, -123456}, {0x01E240u, 123456},
    };
    size_t i;
    for (i = 0; i < sizeof table / sizeof table[0]; i++)
        CHECK(sail_hx711_decode(table[i].bits) == table[i].value, "0x%06lx -> %ld, expected %ld",
              (unsigned long)table[i].bits, (long)sail_hx711_decode(table[i].bits), (long)table[i].value);
    /* the libraries' lost sign: -1 kept as the raw 24-bit word reads as 16777215 */
    CHECK((long)0xFFFFFFu == 16777215L && sail_hx711_decode(0xFFFFFFu) == -1, "the sign bit must extend");
    CHECK(sail_hx711_decode(0xFF800000u) == -8388608, "bits above the 24th are ignored");
}

static void test_conversions(void)
{
    /* recorded conversions: a small negative load (-123456), full scale +, full scale -, zero */
    static const struct { const char *stream; int32_t value; } recorded[] = {
        {"111111100001110111000000", -123456},
        {"011111111111111111111111", 8388607},
        {"100000000000000000000000", -8388608},
        {"000000000000000000000000", 0},
    };
    static const sail_hx711_gain gains[] = {SAIL_HX711_A128, SAIL_HX711_B32, SAIL_HX711_A64};
    size_t i, g;
    for (i = 0; i < sizeof recorded / sizeof recorded[0]; i++) {
        for (g = 0; g < 3; g++) {
            hx711_device d;
            sail_hx711_port port;
            uint32_t bits;
            memset(&d, 0, sizeof d);
            d.stream = recorded[i].stream;
            d.busy_polls = 5;
            d.tick = 10;
            port = port_of(&d);
            CHECK(sail_hx711_wait(&port, 1000) == 0, "conversion %u: not ready", (unsigned)i);
            CHECK(d.pulses == 0, "no pulse before the data is ready");
            bits = sail_hx711_shift(&port, gains[g]);
            CHECK(sail_hx711_decode(bits) == recorded[i].value, "conversion %u, %d pulses: %ld, expected %ld",
                  (unsigned)i, (int)gains[g], (long)sail_hx711_decode(bits), (long)recorded[i].value);
            CHECK(d.pulses == (int)gains[g], "%d pulses sent for gain code %d", d.pulses, (int)gains[g]);
            CHECK(d.sck == 0, "SCK left high: the HX711 would power down");
        }
    }
}

static void test_timeout(void)
{
    hx711_device d;
    sail_hx711_port port;
    memset(&d, 0, sizeof d);
    d.stream = "000000000000000000000000";
    d.busy_polls = INT_MAX;  /* unplugged: DOUT pulled high for ever */
    d.tick = 7;
    port = port_of(&d);
    CHECK(sail_hx711_wait(&port, 200000) == -1, "a missing HX711 must time out");
    CHECK(d.clock >= 200000 && d.clock <= 200000 + 2 * 7, "timed out after %lu us", d.clock);
    CHECK(d.pulses == 0, "no pulse to a missing HX711");

    memset(&d, 0, sizeof d);  /* the clock wraps during the wait: still the full timeout */
    d.stream = "000000000000000000000000";
    d.busy_polls = INT_MAX;
    d.tick = 7;
    d.clock = ULONG_MAX - 1000;
    port = port_of(&d);
    CHECK(sail_hx711_wait(&port, 5000) == -1, "a missing HX711 must time out across the clock's wrap");
    CHECK(d.clock + 1000 >= 5000 - 7 && d.clock < 5000, "timed out at %lu after the wrap", d.clock);
}

/* ---- quadrature -------------------------------------------------------------------------- */

/* Feed levels "AB AB ..." (each two characters, space separated) to the decoder. */
static void feed(sail_quadrature *q, const char *levels)
{
    for (; levels[0] && levels[1]; levels += levels[2] ? 3 : 2)
        sail_quadrature_update(q, levels[0] == '1', levels[1] == '1');
}

static void test_quadrature(void)
{
    sail_quadrature q;
    sail_quadrature_init(&q, 0, 0);
    feed(&q, "01 11 10 00 01 11 10 00 01 11 10 00");  /* B leading A: three cycles, 12 edges forward */
    CHECK(q.count == 12 && q.missed == 0, "forward: count %ld, missed %lu", (long)q.count, (unsigned long)q.missed);
    feed(&q, "10 11 01 00 10");  /* the direction changes: 5 edges back */
    CHECK(q.count == 7 && q.missed == 0, "back: count %ld", (long)q.count);
    feed(&q, "11 10 11 10 11 10");  /* B chatters on an edge: back and forth, no net motion... */
    CHECK(q.count == 7, "chatter: count %ld", (long)q.count);
    feed(&q, "11");  /* ...then settles one edge back */
    CHECK(q.count == 6, "after chatter: count %ld", (long)q.count);
    feed(&q, "00");  /* 11 -> 00: both channels changed, an edge was missed */
    CHECK(q.count == 6 && q.missed == 1, "missed edge: count %ld, missed %lu", (long)q.count, (unsigned long)q.missed);
    feed(&q, "01 11");  /* decoding resumes from the new state */
    CHECK(q.count == 8 && q.missed == 1, "after the miss: count %ld", (long)q.count);
    feed(&q, "11 11");  /* an update without a change (a glitch that came back) counts nothing */
    CHECK(q.count == 8, "no change: count %ld", (long)q.count);

    sail_quadrature_init(&q, 1, 0);  /* starting mid-cycle */
    feed(&q, "00 01 11 10");
    CHECK(q.count == 4 && q.missed == 0, "from state 10: count %ld", (long)q.count);
}

int main(void)
{
    test_decode();
    test_conversions();
    test_timeout();
    test_quadrature();
    return check_report("sail_io");
}

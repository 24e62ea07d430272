/*
 * The sketch's hardware logic, apart from the hardware: HX711 conversions and quadrature
 * encoders.  Plain C99, so that the tests (c/tests/test_io.c) run it on the host and on the
 * emulated Cortex-M4F against recorded bit streams; the sketch supplies the pins.
 */
#ifndef SAIL_IO_H
#define SAIL_IO_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---- HX711 (Avia Semiconductor HX711 datasheet) ---------------------------------------- */

/* SCK pulses per conversion: the 24 data bits, then 1 to 3 more that choose the input and gain of
 * the next conversion. */
typedef enum {
    SAIL_HX711_A128 = 25, /* channel A, gain 128 */
    SAIL_HX711_B32 = 26,  /* channel B, gain 32 */
    SAIL_HX711_A64 = 27   /* channel A, gain 64 */
} sail_hx711_gain;

/* The pins, as the sketch drives them (digitalRead, digitalWrite with its 1 us waits, micros). */
typedef struct {
    void *context;
    int (*dout)(void *context);              /* DOUT's level, 0 or 1 */
    void (*sck)(void *context, int level);   /* drive SCK high (1) or low (0) */
    unsigned long (*micros)(void *context);  /* a microsecond clock; it may wrap */
} sail_hx711_port;

/* Wait for DOUT to go low (a conversion is ready): 0, or -1 after timeout_us [us]. */
int sail_hx711_wait(const sail_hx711_port *port, unsigned long timeout_us);

/* Clock a ready conversion out: 24 bits, most significant first, each read after SCK's rising edge,
 * then the pulses that choose the next conversion (`next` pulses in all).  Keep SCK's high times
 * short (interrupts off): SCK high for 60 us powers the HX711 down. */
uint32_t sail_hx711_shift(const sail_hx711_port *port, sail_hx711_gain next);

/* The 24 bits as the signed value they encode (two's complement: 0x800000 is -8388608, 0xFFFFFF
 * is -1).  A reading kept in an unsigned or 32-bit word without this sign extension turns every
 * negative load into one near 2^24. */
int32_t sail_hx711_decode(uint32_t bits);

/* ---- quadrature encoders --------------------------------------------------------------- */

/* x4 decoding: a count per edge of either channel; B leading A counts up (the sketch's convention
 * since its first, x2 version).  Both channels changing
 * between two updates is a missed edge: the direction is unknown, so the count is kept and
 * `missed` grows (the position may then be 2 counts off). */
typedef struct {
    uint8_t state;    /* (A << 1) | B at the last update */
    int32_t count;
    uint32_t missed;
} sail_quadrature;

void sail_quadrature_init(sail_quadrature *q, int a, int b);
/* The channels' levels after an edge of either (call it from both pins' change interrupts). */
void sail_quadrature_update(sail_quadrature *q, int a, int b);

#ifdef __cplusplus
}
#endif

#endif /* SAIL_IO_H */

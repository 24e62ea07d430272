/*
 * The rig's binary wire format, the device's side: one COBS frame per control tick, with the device's microsecond
 * time, a sequence number and a CRC-16 (docs/reference/frames.md, the byte table; the reader is
 * src/sailforce/io/frames.py).  Plain C99 and no allocation, so that c/tests/test_frame.c checks it byte for byte
 * against the Python encoder's frames on the host and on the emulated Cortex-M4F.
 */
#ifndef SAIL_FRAME_H
#define SAIL_FRAME_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Frame types and the format's version (sailforce.io.frames.TICK_TYPE, HELLO_TYPE, VERSION). */
#define SAIL_FRAME_TICK 1
#define SAIL_FRAME_HELLO 2
#define SAIL_FRAME_VERSION 1
/* A tick's fields before the CRC, and a hello's (sailforce.io.frames.TICK.size, HELLO.size). */
#define SAIL_FRAME_TICK_BYTES 29
#define SAIL_FRAME_HELLO_BYTES 10
/* The most a frame takes on the wire: the fields, the CRC, COBS's one byte per 254 and the closing zero. */
#define SAIL_FRAME_MAX (SAIL_FRAME_TICK_BYTES + 2 + 2)

/* One control tick as the device sends it. */
typedef struct {
    uint16_t sequence;    /* +1 a tick, wrapping */
    uint32_t time_us;     /* the tick's device time [us], wrapping */
    int32_t counts[2];    /* the encoders [counts] */
    uint8_t fresh;        /* bit 0: cell 1 has a new conversion this tick; bit 1: cell 2 */
    int32_t load[2];      /* each new conversion [raw] (0 without its bit) */
    int16_t ready_us[2];  /* its data-ready time less the tick's [us] (<= 0) */
    uint8_t status;       /* SAIL_ACQ_* bits (sail_acq.h), passed through to the reader's device_status */
} sail_frame_tick;

/* CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, no final XOR (check value 0x29B1 for "123456789"). */
uint16_t sail_crc16(const uint8_t *data, size_t n);

/* COBS (Cheshire & Baker, IEEE/ACM Trans. Networking 7(2), 1999) of n <= 254 bytes, then the frame's zero:
 * returns the bytes written to out, which holds n + 2. */
size_t sail_cobs_encode(const uint8_t *in, size_t n, uint8_t *out);

/* A tick's bytes on the wire (at most SAIL_FRAME_MAX): the fields little-endian, their CRC, COBS, a zero. */
size_t sail_frame_encode_tick(const sail_frame_tick *tick, uint8_t *out);
/* The hello sent at start-up: the format's version and each encoder's counts per turn. */
size_t sail_frame_encode_hello(uint32_t counts_per_turn1, uint32_t counts_per_turn2, uint8_t *out);

#ifdef __cplusplus
}
#endif

#endif /* SAIL_FRAME_H */

/* The rig's binary frames: see sail_frame.h and docs/reference/frames.md. */
#include "sail_frame.h"

uint16_t sail_crc16(const uint8_t *data, size_t n)
{
    uint16_t crc = 0xFFFFu;
    size_t i;
    int bit;
    for (i = 0; i < n; i++) {
        crc ^= (uint16_t)((uint16_t)data[i] << 8);
        for (bit = 0; bit < 8; bit++)
            crc = (uint16_t)((crc & 0x8000u) ? (crc << 1) ^ 0x1021u : crc << 1);
    }
    return crc;
}

size_t sail_cobs_encode(const uint8_t *in, size_t n, uint8_t *out)
{
    /* Each zero becomes the distance to the next one; a code byte opens each run and the first run's code is out[0]. */
    size_t code_at = 0, w = 1, i;
    uint8_t code = 1;
    for (i = 0; i < n; i++) {
        if (in[i] == 0) {
            out[code_at] = code;
            code_at = w++;
            code = 1;
        } else {
            out[w++] = in[i];
            code++;
        }
    }
    out[code_at] = code;
    out[w++] = 0;
    return w;
}

static size_t put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    return 2;
}

static size_t put_u32(uint8_t *p, uint32_t v)
{
    put_u16(p, (uint16_t)v);
    put_u16(p + 2, (uint16_t)(v >> 16));
    return 4;
}

static size_t seal(uint8_t *body, size_t n, uint8_t *out)
{
    n += put_u16(body + n, sail_crc16(body, n));
    return sail_cobs_encode(body, n, out);
}

size_t sail_frame_encode_tick(const sail_frame_tick *tick, uint8_t *out)
{
    uint8_t body[SAIL_FRAME_TICK_BYTES + 2];
    size_t n = 0;
    body[n++] = SAIL_FRAME_TICK;
    n += put_u16(body + n, tick->sequence);
    n += put_u32(body + n, tick->time_us);
    n += put_u32(body + n, (uint32_t)tick->counts[0]);
    n += put_u32(body + n, (uint32_t)tick->counts[1]);
    body[n++] = tick->fresh;
    n += put_u32(body + n, (uint32_t)tick->load[0]);
    n += put_u32(body + n, (uint32_t)tick->load[1]);
    n += put_u16(body + n, (uint16_t)tick->ready_us[0]);
    n += put_u16(body + n, (uint16_t)tick->ready_us[1]);
    body[n++] = tick->status;
    return seal(body, n, out);
}

size_t sail_frame_encode_hello(uint32_t counts_per_turn1, uint32_t counts_per_turn2, uint8_t *out)
{
    uint8_t body[SAIL_FRAME_HELLO_BYTES + 2];
    size_t n = 0;
    body[n++] = SAIL_FRAME_HELLO;
    body[n++] = SAIL_FRAME_VERSION;
    n += put_u32(body + n, counts_per_turn1);
    n += put_u32(body + n, counts_per_turn2);
    return seal(body, n, out);
}

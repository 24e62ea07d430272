/* HX711 and quadrature logic for the sketch: see sail_io.h. */
#include "sail_io.h"

int sail_hx711_wait(const sail_hx711_port *port, unsigned long timeout_us)
{
    const unsigned long start = port->micros(port->context);
    while (port->dout(port->context))
        if (port->micros(port->context) - start > timeout_us)  /* unsigned: right across the clock's wrap */
            return -1;
    return 0;
}

uint32_t sail_hx711_shift(const sail_hx711_port *port, sail_hx711_gain next)
{
    uint32_t bits = 0;
    int i;
    for (i = 0; i < (int)next; i++) {
        port->sck(port->context, 1);
        if (i < 24)
            bits = (bits << 1) | (uint32_t)(port->dout(port->context) != 0);
        port->sck(port->context, 0);
    }
    return bits;
}

int32_t sail_hx711_decode(uint32_t bits)
{
    bits &= 0xFFFFFFu;
    return (bits & 0x800000u) ? (int32_t)bits - 0x1000000 : (int32_t)bits;
}

void sail_quadrature_init(sail_quadrature *q, int a, int b)
{
    q->state = (uint8_t)(((a != 0) << 1) | (b != 0));
    q->count = 0;
    q->missed = 0;
}

void sail_quadrature_update(sail_quadrature *q, int a, int b)
{
    /* index (old << 2) | new; with state (A << 1) | B, B leading A runs 0 -> 1 -> 3 -> 2 -> 0 */
    static const int8_t step[16] = {
        0, +1, -1, 2,   /* from 0: to 1 forward, to 2 back, to 3 missed */
        -1, 0, 2, +1,   /* from 1: to 0 back, to 2 missed, to 3 forward */
        +1, 2, 0, -1,   /* from 2: to 0 forward, to 1 missed, to 3 back */
        2, -1, +1, 0    /* from 3: to 0 missed, to 1 back, to 2 forward */
    };
    const uint8_t state = (uint8_t)(((a != 0) << 1) | (b != 0));
    const int8_t s = step[(q->state << 2) | state];
    if (s == 2)
        q->missed++;
    else
        q->count += s;
    q->state = state;
}

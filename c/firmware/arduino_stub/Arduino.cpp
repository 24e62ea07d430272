/* No-op definitions behind Arduino.h, and the core's main(): the sketch links but is never run. */
#include "Arduino.h"

StubSerial Serial;
static volatile uint32_t pins, clock_us;

void pinMode(uint8_t pin, uint8_t mode) { pins ^= (uint32_t)mode << (pin & 31u); }
void digitalWrite(uint8_t pin, uint8_t value) { pins ^= (uint32_t)value << (pin & 31u); }
int digitalRead(uint8_t pin) { return (int)((pins >> (pin & 31u)) & 1u); }
unsigned long micros(void) { return clock_us += 100; }
void delayMicroseconds(unsigned int us) { clock_us += us; }
void attachInterrupt(uint8_t, void (*)(void), int) {}
uint8_t digitalPinToInterrupt(uint8_t pin) { return pin; }
void noInterrupts(void) {}
void interrupts(void) {}
void StubSerial::begin(unsigned long) {}
void StubSerial::print(const char *) {}
void StubSerial::print(char) {}
void StubSerial::print(long) {}
void StubSerial::print(double, int) {}
void StubSerial::println(const char *) {}
size_t StubSerial::write(const uint8_t *, size_t n) { return n; }

void setup(void);
void loop(void);

int main(void)
{
    setup();
    for (;;)
        loop();
}

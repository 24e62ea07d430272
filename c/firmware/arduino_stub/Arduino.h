/* Just enough of the Arduino API to compile a sketch for Cortex-M without a board core (make cross). */
#ifndef SAIL_ARDUINO_STUB_H
#define SAIL_ARDUINO_STUB_H

#include <stddef.h>
#include <stdint.h>

#define HIGH 1
#define LOW 0
#define INPUT 0
#define OUTPUT 1
#define INPUT_PULLUP 2
#define CHANGE 1
#define FALLING 2

void pinMode(uint8_t pin, uint8_t mode);
void digitalWrite(uint8_t pin, uint8_t value);
int digitalRead(uint8_t pin);
unsigned long micros(void);
void delayMicroseconds(unsigned int us);
void attachInterrupt(uint8_t interrupt, void (*handler)(void), int mode);
uint8_t digitalPinToInterrupt(uint8_t pin);
void noInterrupts(void);
void interrupts(void);

class StubSerial {
public:
    void begin(unsigned long baud);
    void print(const char *text);
    void print(char c);
    void print(long value);
    void print(double value, int digits = 2);
    void println(const char *text = "");
    size_t write(const uint8_t *data, size_t n);
};
extern StubSerial Serial;

#endif

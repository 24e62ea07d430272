/*
 * Reset and fault handling for libsail's tests on QEMU's mps2-an386 (Cortex-M4F): the
 * vector table, the FPU switched on before any float instruction runs, then newlib's
 * semihosting start-up (_start: .bss, stack and heap from the host, argv, main, exit).
 * A fault ends the run with a failing exit status rather than hanging.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

extern void _start(void);
extern uint32_t __stack;

#define SCB_CPACR (*(volatile uint32_t *)0xE000ED88u)
#define SCB_CFSR (*(volatile uint32_t *)0xE000ED28u)

void sail_reset(void)
{
    SCB_CPACR |= 0xFu << 20;  /* CP10 and CP11 (the FPU): full access */
    __asm volatile("dsb\n\tisb" ::: "memory");
    _start();
}

static void sail_fault(void)
{
    printf("fault: CFSR 0x%08lx\n", (unsigned long)SCB_CFSR);
    exit(70);
}

__attribute__((section(".vectors"), used)) static void (*const vectors[16])(void) = {
    (void (*)(void))(&__stack), sail_reset, sail_fault, sail_fault, sail_fault, sail_fault, sail_fault,
};

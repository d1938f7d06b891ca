/*
 * startup.c - minimal Cortex-M7 start-up for the QEMU replay and the example: vector table,
 * FPU enable (CPACR), .bss zeroed, newlib's semihosting handles, main, exit.
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

extern uint32_t __bss_start__, __bss_end__, __stack_top;
extern int main(void);
extern void initialise_monitor_handles(void);
void Reset_Handler(void);
void Default_Handler(void);
void SysTick_Handler(void) __attribute__((weak, alias("Default_Handler")));

#define CPACR (*(volatile uint32_t *)0xE000ED88u)

/* crti/crtn are not linked (-nostartfiles): newlib's init/fini arrays call these. */
void _init(void);
void _fini(void);
void _init(void) {}
void _fini(void) {}

void Default_Handler(void) {
    for (;;) {
    }
}

void Reset_Handler(void) {
    CPACR |= (0xFu << 20); /* CP10, CP11 full access: the FPU */
    __asm volatile("dsb\n\tisb" ::: "memory");
    memset(&__bss_start__, 0, (size_t)((char *)&__bss_end__ - (char *)&__bss_start__));
#ifdef BALLBOT_FW_SEMIHOSTING
    initialise_monitor_handles();
#endif
    exit(main());
}

typedef void (*vector)(void);
__attribute__((section(".vectors"), used)) const vector ballbot_fw_vectors[16] = {
    (vector)(uintptr_t)&__stack_top, Reset_Handler, Default_Handler, Default_Handler,
    Default_Handler, Default_Handler, Default_Handler, 0, 0, 0, 0, Default_Handler,
    Default_Handler, 0, Default_Handler, SysTick_Handler,
};

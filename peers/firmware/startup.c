/* Startup of the peers' C/C++ firmware on mps2-an386 (a Cortex-M4 with FPU), written by
 * the project for the embedded-QP peers that need a C/C++ runtime (TinyMPC's generated
 * C++: heap-allocated Eigen matrices built by static constructors). The reset handler
 * enables the FPU (CPACR: full access to CP10 and CP11), copies .data from flash, zeroes
 * .bss, runs the static constructors (newlib's __libc_init_array), calls main and leaves
 * through semihosting (librdimon's exit: SYS_EXIT, which ends QEMU with main's status). */

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

extern uint32_t _estack, __data_start, __data_end, __data_load, __bss_start, __bss_end;
extern int main(void);
extern void __libc_init_array(void);
extern void initialise_monitor_handles(void);

/* __libc_init_array calls _init and exit calls _fini (crti.o's, not linked with
 * -nostartfiles): nothing to do in either, the constructors are in .init_array. */
void _init(void) {}
void _fini(void) {}

/* The static objects' destructors are registered with __cxa_atexit against this handle
 * (crtbegin.o's, not linked either). */
void *__dso_handle = 0;

void Reset_Handler(void) {
    volatile uint32_t *cpacr = (volatile uint32_t *)0xE000ED88;
    *cpacr |= 0xFu << 20;
    __asm volatile("dsb\n\tisb" ::: "memory");
    memcpy(&__data_start, &__data_load,
           (size_t)((char *)&__data_end - (char *)&__data_start));
    memset(&__bss_start, 0, (size_t)((char *)&__bss_end - (char *)&__bss_start));
    initialise_monitor_handles();
    __libc_init_array();
    exit(main());
}

/* Any fault ends the run with a failure status (SYS_EXIT, not "application exit"). */
void Fault_Handler(void) {
    register uint32_t reason __asm("r0") = 0x18;     /* SYS_EXIT */
    register uint32_t code __asm("r1") = 0x20024;    /* ADP_Stopped_InternalError */
    __asm volatile("bkpt 0xab" : : "r"(reason), "r"(code) : "memory");
    for (;;) {
    }
}

typedef void (*Handler)(void);

/* The vector table at 0: the initial stack pointer, reset, then the core's exceptions
 * (NMI .. SysTick), every one a fault here (no interrupt is enabled). */
__attribute__((section(".vectors"), used)) const Handler vectors[16] = {
    (Handler)&_estack, Reset_Handler, Fault_Handler, Fault_Handler, Fault_Handler,
    Fault_Handler,     Fault_Handler, 0,             0,             0,
    0,                 Fault_Handler, Fault_Handler, 0,             Fault_Handler,
    Fault_Handler,
};

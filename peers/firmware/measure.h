/* Measuring in the C firmwares on mps2-an386, as the Rust firmware's harness measures
 * (model-codegen/firmware/measure.rs): SysTick counts down from the core clock over its
 * 24-bit range, and under QEMU's -icount shift=0 a tick is 40 instructions. Written by
 * the project for its C firmwares (the C API's, targets/c/main.c). */

#ifndef STATEFORGE_MEASURE_H
#define STATEFORGE_MEASURE_H

#include <stdint.h>

/* Instructions per SysTick tick on mps2-an386 under -icount shift=0. */
#define MEASURE_INSTRUCTIONS_PER_TICK 40u

/* The counter, read. */
static inline uint32_t measure_now(void) { return *(volatile uint32_t *)0xE000E018; }

/* Starts SysTick from the core clock, counting down over its full range, and waits for
 * its first reload (it reads 0 until then). */
static inline void measure_start(void) {
    *(volatile uint32_t *)0xE000E014 = 0x00FFFFFF; /* reload */
    *(volatile uint32_t *)0xE000E018 = 0;          /* clear */
    *(volatile uint32_t *)0xE000E010 = 5;          /* core clock, enabled, no interrupt */
    while (measure_now() == 0) {
    }
}

/* Instructions between two readings `start` and `end`, within 40 (one tick). */
static inline uint32_t measure_elapsed(uint32_t start, uint32_t end) {
    return ((start - end) & 0x00FFFFFFu) * MEASURE_INSTRUCTIONS_PER_TICK;
}

/* Waits for the counter's next tick, then runs about `j % 40` more instructions, so that
 * the reading that follows starts at a point of its tick set by `j` alone: over 40
 * consecutive `j` the 40-instruction steps of single readings average out (as
 * Clock::dither of the Rust harness). */
static __attribute__((noinline)) void measure_dither(uint32_t j) {
    uint32_t now = measure_now();
    while (measure_now() == now) {
    }
    uint32_t phase = j % 40u;
    uint32_t loops = phase / 2u;
    if (loops > 0) {
        __asm volatile("1: subs %0, #1\n\tbne 1b" : "+r"(loops) : : "cc");
    }
    if (phase % 2u == 1u) {
        __asm volatile("nop");
    }
}

/* The readings of one kernel's single calls (as Calls of the Rust harness): each call read
 * on its own after measure_dither, an empty reading made the same way before it. */
typedef struct measure_calls {
    uint32_t total;
    uint32_t empty;
    uint32_t count;
} measure_calls_t;

/* Mean instructions per call, the empty readings subtracted. */
static inline uint32_t measure_mean(const measure_calls_t *calls) {
    uint32_t count = calls->count > 0 ? calls->count : 1u;
    uint32_t total = calls->total > calls->empty ? calls->total - calls->empty : 0u;
    return (total + count / 2u) / count;
}

/* Reads one call, `call` (an expression), into `calls` (a measure_calls_t *); the
 * expression's value is kept in `result`. */
#define MEASURE_CALL(calls, result, call)                                                  \
    do {                                                                                   \
        uint32_t measure_j_ = 21u * (calls)->count;                                        \
        measure_dither(measure_j_);                                                        \
        uint32_t measure_start_ = measure_now();                                           \
        (calls)->empty += measure_elapsed(measure_start_, measure_now());                  \
        measure_dither(measure_j_);                                                        \
        measure_start_ = measure_now();                                                    \
        (result) = (call);                                                                 \
        (calls)->total += measure_elapsed(measure_start_, measure_now());                  \
        (calls)->count += 1u;                                                              \
    } while (0)

#endif

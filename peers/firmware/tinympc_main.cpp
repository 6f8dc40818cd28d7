/* TinyMPC's generated solver on the blade's MPC, run by the peers' C/C++ firmware
 * (written by the project; TinyMPC's code is generated into target/peers/tinympc at
 * benchmark time and never committed). The same measurement as the Rust firmware's
 * (targets/src/measure.rs, targets/src/peers.rs): SysTick from the core clock, 40
 * instructions per tick under QEMU's -icount shift=0, read around each call; the call of
 * an empty function subtracted; the 300 steps between the trace markers trace_begin and
 * trace_end, each solve one call of peers_tinympc_solve (the trace follows it).
 *
 * Each step: the estimate's regulated states become TinyMPC's x0, and its solve runs
 * warm-started from the last step's iterates (TinyMPC keeps its workspace between
 * solves). Output, as the Rust firmware's: `peer tinympc k iterations u1..u10`
 * (iterations negative when TinyMPC did not converge), `peerspread tinympc median worst
 * most-iterations mean`, then `done`. */

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "peer_steps.h"
#include "tinympc/admm.hpp"
#include "tinympc/tiny_data.hpp"

static uint32_t systick(void) { return *(volatile uint32_t *)0xE000E018; }

static void systick_start(void) {
    *(volatile uint32_t *)0xE000E014 = 0x00FFFFFF; /* reload */
    *(volatile uint32_t *)0xE000E018 = 0;          /* clear */
    *(volatile uint32_t *)0xE000E010 = 5;          /* core clock, enabled, no interrupt */
    while (systick() == 0) {
    }
}

static uint32_t elapsed(uint32_t start, uint32_t end) {
    return ((start - end) & 0x00FFFFFF) * 40;
}

extern "C" {

/* The trace markers (xtask/src/trace.rs). */
__attribute__((noinline)) void trace_begin(void) { __asm volatile("" ::: "memory"); }
__attribute__((noinline)) void trace_end(void) { __asm volatile("nop" ::: "memory"); }

/* One solve: x0 set, TinyMPC's ADMM run; its iterations, or minus them when it stopped
 * at max_iter. */
__attribute__((noinline)) int peers_tinympc_solve(const float *x0) {
    tiny_solver.work->x(0, 0) = x0[0];
    tiny_solver.work->x(1, 0) = x0[1];
    int status = solve(&tiny_solver);
    return status == 0 ? tiny_solver.solution->iter : -tiny_solver.solution->iter;
}

/* Does nothing: the cost of a call around a measured one, subtracted. */
__attribute__((noinline)) int peers_nothing(const float *x0) {
    __asm volatile("" ::: "memory");
    return (int)x0[0];
}
}

static int by_value(const void *a, const void *b) {
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

int main(void) {
    static uint32_t each[PEER_STEPS];
    static int iterations[PEER_STEPS];
    static float plans[PEER_STEPS][PEER_HORIZON];
    systick_start();
    uint32_t start = systick();
    peers_nothing(peer_x0[0]);
    uint32_t empty = elapsed(start, systick());
    trace_begin();
    for (int k = 0; k < PEER_STEPS; k++) {
        start = systick();
        iterations[k] = peers_tinympc_solve(peer_x0[k]);
        uint32_t count = elapsed(start, systick());
        each[k] = count > empty ? count - empty : 0;
        for (int i = 0; i < PEER_HORIZON; i++) {
            plans[k][i] = (float)tiny_solver.solution->u(0, i);
        }
    }
    trace_end();
    int most = 0;
    uint64_t total = 0;
    for (int k = 0; k < PEER_STEPS; k++) {
        printf("peer tinympc %d %d", k + 1, iterations[k]);
        for (int i = 0; i < PEER_HORIZON; i++) {
            printf(" %.9g", (double)plans[k][i]);
        }
        printf("\n");
        most = iterations[k] > most ? iterations[k] : most;
        total += each[k];
    }
    qsort(each, PEER_STEPS, sizeof each[0], by_value);
    printf("peerspread tinympc %lu %lu %d %.3f\n", (unsigned long)each[PEER_STEPS / 2],
           (unsigned long)each[PEER_STEPS - 1], most, (double)total / PEER_STEPS);
    printf("done\n");
    return 0;
}

/* TinyMPC, OSQP and DAQP on TinyMPC's quadrotor hover benchmark, run by the peers' C/C++
 * firmware (written by the project; the solvers' code is generated or unpacked into
 * target/peers at benchmark time and never committed). The same measurement as
 * tinympc_main.cpp's: SysTick from the core clock, 40 instructions per tick under QEMU's
 * -icount shift=0, read around each call; the call of an empty function subtracted; all
 * steps between the trace markers, each solve one call of peers_<name>_solve.
 *
 * Each solver goes from the state to the plan in its call: TinyMPC sets x0 and runs its
 * ADMM; OSQP and DAQP first compute the condensed QP's linear term F x0 (quad_data.h),
 * then update and solve. Each is warm-started from its own last solve (TinyMPC keeps its
 * iterates, OSQP its solution, DAQP its working set). DAQP's workspace is set up (the
 * Hessian factored) before the run, as TinyMPC's cache and OSQP's factorisation are made
 * before theirs.
 *
 * Output, as the Rust firmware's: `peer <name> k iterations u..` (move by move;
 * iterations negative: the solver did not report success), `peerspread <name> median
 * worst most-iterations mean`, `peerram <name> heap-bytes stack-bytes`, then `done`. */

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "quad_data.h"
#include "tinympc/admm.hpp"
#include "tinympc/tiny_data.hpp"

extern "C" {
#include "api.h"
#include "utils.h"
#include "osqp.h"
#include "quad_workspace.h"
}

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

enum { N = QUAD_UNKNOWNS };

/* The steps run: all of them, or (the build xtask traces instruction by instruction, whose
 * logged run would take long over OSQP's slowest steps) those from QUAD_RUN_FROM on. */
#ifndef QUAD_RUN_FROM
#define QUAD_RUN_FROM 0
#endif
enum { RUN = QUAD_STEPS - QUAD_RUN_FROM };

/* DAQP's problem: H and the bounds fixed, f rewritten each step. */
static c_float daqp_h[N * N];
static c_float daqp_f[N];
static c_float daqp_upper[N];
static c_float daqp_lower[N];
static int daqp_sense[N];
static DAQPProblem daqp_qp;
static DAQPWorkspace daqp_work;
static c_float daqp_x[N];
static c_float daqp_lam[N];

/* The linear term F x0 of the condensed QP. */
static void linear_term(const float *x0, c_float *f) {
    for (int i = 0; i < N; i++) {
        float sum = 0.0f;
        for (int j = 0; j < QUAD_NX; j++) {
            sum += quad_linear_map[i * QUAD_NX + j] * x0[j];
        }
        f[i] = sum;
    }
}

extern "C" {

/* The trace markers (xtask/src/trace.rs). */
__attribute__((noinline)) void trace_begin(void) { __asm volatile("" ::: "memory"); }
__attribute__((noinline)) void trace_end(void) { __asm volatile("nop" ::: "memory"); }

/* TinyMPC: x0 set, its ADMM run; its iterations, or minus them when it stopped at
 * max_iter. */
__attribute__((noinline)) int peers_tinympc_solve(const float *x0, float *plan) {
    for (int i = 0; i < QUAD_NX; i++) {
        tiny_solver.work->x(i, 0) = x0[i];
    }
    int status = solve(&tiny_solver);
    for (int k = 0; k < QUAD_HORIZON; k++) {
        for (int i = 0; i < QUAD_NU; i++) {
            plan[k * QUAD_NU + i] = tiny_solver.solution->u(i, k);
        }
    }
    return status == 0 ? tiny_solver.solution->iter : -tiny_solver.solution->iter;
}

/* OSQP: the linear term updated, solved; its iterations, or minus its status. */
static float osqp_q[N];

__attribute__((noinline)) int peers_osqp_solve(const float *x0, float *plan) {
    linear_term(x0, osqp_q);
    osqp_update_data_vec(&quad_solver, osqp_q, OSQP_NULL, OSQP_NULL);
    osqp_solve(&quad_solver);
    for (int i = 0; i < N; i++) {
        plan[i] = quad_solver.solution->x[i];
    }
    if (quad_solver.info->status_val != OSQP_SOLVED) {
        return -(int)quad_solver.info->status_val;
    }
    return (int)quad_solver.info->iter;
}

/* DAQP: the linear term updated (its LDP's v and bounds), solved; its iterations, or
 * minus its exit flag when that is not a solution. */
__attribute__((noinline)) int peers_daqp_solve(const float *x0, float *plan) {
    linear_term(x0, daqp_f);
    daqp_update_ldp(DAQP_UPDATE_v + DAQP_UPDATE_d, &daqp_work, &daqp_qp);
    DAQPResult result;
    result.x = daqp_x;
    result.lam = daqp_lam;
    daqp_solve(&result, &daqp_work);
    for (int i = 0; i < N; i++) {
        plan[i] = daqp_x[i];
    }
    return result.exitflag > 0 ? result.iter : -(result.exitflag < 0 ? -result.exitflag : 1000);
}

/* Does nothing: the cost of a call around a measured one, subtracted. */
__attribute__((noinline)) int peers_nothing(const float *x0, float *plan) {
    __asm volatile("" ::: "memory");
    plan[0] = x0[0];
    return 0;
}
}

/* DAQP's workspace, as daqp_quadprog sets it up, with the tolerances of
 * peers/quadrotor_codegen.py (DAQP_SETTINGS, printed under the table). */
static int daqp_setup(void) {
    for (int i = 0; i < N * N; i++) {
        daqp_h[i] = quad_hessian[i];
    }
    for (int i = 0; i < N; i++) {
        daqp_upper[i] = QUAD_U_MAX;
        daqp_lower[i] = -QUAD_U_MAX;
        daqp_sense[i] = 0;
    }
    linear_term(&quad_states[0], daqp_f);
    daqp_qp = DAQPProblem{N, N, N, daqp_h, daqp_f, NULL, daqp_upper, daqp_lower,
                          daqp_sense, NULL, 0, 0};
    memset(&daqp_work, 0, sizeof daqp_work);
    c_float setup_time = 0;
    int flag = setup_daqp(&daqp_qp, &daqp_work, &setup_time);
    daqp_work.settings->primal_tol = QUAD_DAQP_PRIMAL_TOL;
    daqp_work.settings->dual_tol = QUAD_DAQP_DUAL_TOL;
    daqp_work.settings->zero_tol = QUAD_DAQP_ZERO_TOL;
    daqp_work.settings->pivot_tol = QUAD_DAQP_PIVOT_TOL;
    return flag;
}

typedef int (*PeerSolve)(const float *, float *);

/* Stack bytes one call of `peer_solve` at `x0` used (painted below the stack pointer). */
__attribute__((noinline)) static uint32_t stack_depth(PeerSolve peer_solve, const float *x0,
                                                      float *plan) {
    enum { SPAN = 16 * 1024 };
    volatile uint32_t *sp;
    __asm volatile("mov %0, sp" : "=r"(sp));
    volatile uint32_t *bottom = sp - SPAN / 4, *top = sp - 32;
    for (volatile uint32_t *p = bottom; p < top; p++) {
        *p = 0xA5A5A5A5u;
    }
    peer_solve(x0, plan);
    volatile uint32_t *p = bottom;
    while (p < top && *p == 0xA5A5A5A5u) {
        p++;
    }
    return (uint32_t)((top - p) * 4) + 32 * 4;
}

static int by_value(const void *a, const void *b) {
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

static void run(const char *name, PeerSolve peer_solve, uint32_t heap) {
    static uint32_t each[QUAD_STEPS];
    static int iterations[QUAD_STEPS];
    static float plans[QUAD_STEPS][N];
    uint32_t start = systick();
    peers_nothing(&quad_states[0], plans[0]);
    uint32_t empty = elapsed(start, systick());
    trace_begin();
    for (int k = QUAD_RUN_FROM; k < QUAD_STEPS; k++) {
        start = systick();
        iterations[k] = peer_solve(&quad_states[k * QUAD_NX], plans[k]);
        uint32_t count = elapsed(start, systick());
        each[k - QUAD_RUN_FROM] = count > empty ? count - empty : 0;
    }
    trace_end();
    int most = 0;
    uint64_t total = 0;
    for (int k = QUAD_RUN_FROM; k < QUAD_STEPS; k++) {
        printf("peer %s %d %d", name, k + 1, iterations[k]);
        for (int i = 0; i < N; i++) {
            printf(" %.9g", (double)plans[k][i]);
        }
        printf("\n");
        most = iterations[k] > most ? iterations[k] : most;
        total += each[k - QUAD_RUN_FROM];
    }
    qsort(each, RUN, sizeof each[0], by_value);
    printf("peerspread %s %lu %lu %d %.3f\n", name, (unsigned long)each[RUN / 2],
           (unsigned long)each[RUN - 1], most, (double)total / RUN);
    float plan[N];
    uint32_t stack = stack_depth(peer_solve, &quad_states[(QUAD_STEPS - 1) * QUAD_NX], plan);
    printf("peerram %s %lu %lu\n", name, (unsigned long)heap, (unsigned long)stack);
}

int main(void) {
    systick_start();
    /* TinyMPC's Eigen matrices were allocated by static constructors before main: their
     * heap is what sbrk reached before DAQP's setup. */
    extern char end; /* the heap's start (link.ld) */
    char *before = (char *)sbrk(0);
    uint32_t tinympc_heap = (uint32_t)(before - &end);
    int flag = daqp_setup();
    uint32_t daqp_heap = (uint32_t)((char *)sbrk(0) - before);
    if (flag < 0) {
        printf("daqp setup failed: %d\n", flag);
    }
    /* Beside their own objects' static data (which xtask adds): the heap, and the
     * buffers this harness keeps for them. */
    uint32_t daqp_buffers = sizeof daqp_h + sizeof daqp_f + sizeof daqp_upper +
                            sizeof daqp_lower + sizeof daqp_sense + sizeof daqp_qp +
                            sizeof daqp_work + sizeof daqp_x + sizeof daqp_lam;
    run("tinympc", peers_tinympc_solve, tinympc_heap);
    run("osqp", peers_osqp_solve, sizeof osqp_q);
    run("daqp", peers_daqp_solve, daqp_heap + daqp_buffers);
    printf("done\n");
    return 0;
}

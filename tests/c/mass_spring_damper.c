/*
 * The mass-spring-damper (blade) model's C API from C (tests/tests/c_api.rs builds and runs
 * it under AddressSanitizer and UndefinedBehaviorSanitizer): each function of the MPC (its
 * solve's outcome a struct, its prediction model another), the hybrid EKF, the model
 * functions and the f64 MPC, on valid data and on each way a caller can get it wrong. A
 * failed check prints its line and makes the exit status nonzero. Results are printed as
 * bits (`name bits...`, integers in hexadecimal), which the Rust test compares with the
 * generated Rust code's.
 */
#include "mass_spring_damper.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "check.h"

/* The state the MPC is given at sample k: exact float arithmetic, as the Rust test
 * computes it; the inverse mass moves every tenth sample, so that the prediction model is
 * rebuilt. */
static void state_at(int k, float x[5]) {
    x[0] = 0.002f * (float)((k * 3) % 7) - 0.006f;
    x[1] = 0.05f * (float)((k * 5) % 9) - 0.2f;
    x[2] = 0.0f;
    x[3] = 0.0f;
    x[4] = 5.0f + 0.5f * (float)(k / 10);
}

static const float Q_MPC[2][2] = {{1e4f, 0.0f}, {0.0f, 1.0f}};
static const float R_MPC[1][1] = {{1e-4f}};
/* Tight enough that solves hold a bound. */
static const float U_MIN[1] = {-3.0f};
static const float U_MAX[1] = {3.0f};

/* The MPC: 30 solves, each outcome and control printed, then every getter; and its
 * refusals (printed as statuses, which the Rust test computes too). */
static void mpc_run(void) {
    static mass_spring_damper_mpc_t mpc;
    static mass_spring_damper_mpc_t unwritten;
    mass_spring_damper_mpc_status_t outcome;
    mass_spring_damper_prediction_model_t model;
    union {
        uint64_t words[4];
        unsigned char bytes[32];
    } unaligned; /* 8-aligned: bytes + 2 is not */
    float u[1] = {0.0f};
    float x[5];
    float plan[MASS_SPRING_DAMPER_MPC_HORIZON][1];
    float weight[2][2];
    float gain[1][2];
    const float x_ref[2] = {0.0f, 0.0f};
    const float u_ref[1] = {0.0f};
    const float nan_x[5] = {0.0f, NAN, 0.0f, 0.0f, 5.0f};
    const float nan_q[2][2] = {{NAN, 0.0f}, {0.0f, 1.0f}};
    const float negative_q[2][2] = {{-1.0f, 0.0f}, {0.0f, 1.0f}};
    const float low[1] = {1.0f};
    const float high[1] = {-1.0f};
    int k;
    memset(&unaligned, 0, sizeof unaligned);
    state_at(0, x);
    CHECK(mass_spring_damper_mpc_solve(&unwritten, x, u, &outcome) ==
          MASS_SPRING_DAMPER_STATUS_NOT_INITIALISED);
    CHECK(mass_spring_damper_mpc_new(&mpc, Q_MPC, R_MPC, U_MIN, U_MAX) == MASS_SPRING_DAMPER_STATUS_OK);
    CHECK(mass_spring_damper_mpc_solve(NULL, x, u, &outcome) == MASS_SPRING_DAMPER_STATUS_NULL_POINTER);
    CHECK(mass_spring_damper_mpc_solve(&mpc, x, NULL, &outcome) == MASS_SPRING_DAMPER_STATUS_NULL_POINTER);
    CHECK(mass_spring_damper_mpc_solve(&mpc, x, u,
                                       (mass_spring_damper_mpc_status_t *)(void *)(unaligned.bytes + 2)) ==
          MASS_SPRING_DAMPER_STATUS_MISALIGNED_POINTER);
    CHECK(mass_spring_damper_mpc_set_reference(&mpc, x_ref, u_ref) == MASS_SPRING_DAMPER_STATUS_OK);
    CHECK(mass_spring_damper_mpc_set_weights(&mpc, Q_MPC, R_MPC) == MASS_SPRING_DAMPER_STATUS_OK);
    CHECK(mass_spring_damper_mpc_set_input_limits(&mpc, U_MIN, U_MAX) == MASS_SPRING_DAMPER_STATUS_OK);
    {
        mass_spring_damper_status_t refusals[3];
        refusals[0] = mass_spring_damper_mpc_solve(&mpc, nan_x, u, &outcome);
        CHECK(refusals[0] == outcome.status);
        refusals[1] = mass_spring_damper_mpc_set_weights(&mpc, nan_q, R_MPC);
        refusals[2] = mass_spring_damper_mpc_set_input_limits(&mpc, low, high);
        printf("mpc_refusals %x %x %x\n", (unsigned)refusals[0], (unsigned)refusals[1],
               (unsigned)refusals[2]);
        CHECK(mass_spring_damper_mpc_set_weights(&mpc, negative_q, R_MPC) ==
              MASS_SPRING_DAMPER_STATUS_INVALID_WEIGHT);
        CHECK(mass_spring_damper_mpc_new(&unwritten, negative_q, R_MPC, U_MIN, U_MAX) ==
              MASS_SPRING_DAMPER_STATUS_INVALID_WEIGHT);
        /* A constructor that refused left the storage unwritten. */
        CHECK(mass_spring_damper_mpc_solve(&unwritten, x, u, NULL) ==
              MASS_SPRING_DAMPER_STATUS_NOT_INITIALISED);
    }
    printf("mpc_outcomes");
    for (k = 0; k < 30; k++) {
        mass_spring_damper_status_t status;
        state_at(k, x);
        memset(&outcome, 0xff, sizeof outcome);
        status = mass_spring_damper_mpc_solve(&mpc, x, u, &outcome);
        CHECK(status == outcome.status);
        printf(" %x %x %x %x %x", (unsigned)outcome.status, (unsigned)outcome.optimal,
               (unsigned)outcome.iterations, (unsigned)outcome.terminal_weight_converged,
               (unsigned)outcome.rebuilt);
        CHECK(mass_spring_damper_mpc_control(&mpc, u) == MASS_SPRING_DAMPER_STATUS_OK);
    }
    printf("\n");
    /* No outcome wanted: a null pointer is allowed. */
    CHECK(mass_spring_damper_mpc_solve(&mpc, x, u, NULL) == MASS_SPRING_DAMPER_STATUS_OK);
    CHECK(mass_spring_damper_mpc_control(&mpc, u) == MASS_SPRING_DAMPER_STATUS_OK);
    print_f32("mpc_control", u, 1);
    CHECK(mass_spring_damper_mpc_plan(&mpc, plan) == MASS_SPRING_DAMPER_STATUS_OK);
    print_f32("mpc_plan", &plan[0][0], MASS_SPRING_DAMPER_MPC_HORIZON);
    CHECK(mass_spring_damper_mpc_model(&mpc, &model) == MASS_SPRING_DAMPER_STATUS_OK);
    print_f32("mpc_model", &model.a[0][0], 4);
    print_f32("mpc_model_b", &model.b[0][0], 2);
    CHECK(mass_spring_damper_mpc_terminal_weight(&mpc, weight) == MASS_SPRING_DAMPER_STATUS_OK);
    print_f32("mpc_terminal_weight", &weight[0][0], 4);
    CHECK(mass_spring_damper_mpc_terminal_gain(&mpc, gain) == MASS_SPRING_DAMPER_STATUS_OK);
    print_f32("mpc_terminal_gain", &gain[0][0], 2);
    CHECK(mass_spring_damper_mpc_prediction_model(x, u, &model) == MASS_SPRING_DAMPER_STATUS_OK);
    print_f32("mpc_prediction_model", &model.a[0][0], 4);
    CHECK(mass_spring_damper_mpc_prediction_model(x, u, NULL) == MASS_SPRING_DAMPER_STATUS_NULL_POINTER);
    CHECK(mass_spring_damper_mpc_model(&mpc, (mass_spring_damper_prediction_model_t *)(void *)(unaligned.bytes + 2)) ==
          MASS_SPRING_DAMPER_STATUS_MISALIGNED_POINTER);
}

/* The hybrid EKF: 20 samples, then a predict and an update. */
static void hybrid_ekf_run(void) {
    static mass_spring_damper_hybrid_ekf_t ekf;
    const float x0[5] = {0.0f, 0.0f, 0.0f, 0.0f, 2.0f};
    const float p0[5][5] = {
        {1e-6f, 0.0f, 0.0f, 0.0f, 0.0f},
        {0.0f, 1e-4f, 0.0f, 0.0f, 0.0f},
        {0.0f, 0.0f, 1e-4f, 0.0f, 0.0f},
        {0.0f, 0.0f, 0.0f, 1e-2f, 0.0f},
        {0.0f, 0.0f, 0.0f, 0.0f, 1.0f},
    };
    const float q[2] = {1e-2f, 1e-3f};
    const float r[1][1] = {{1e-8f}};
    float state[5], covariance[5][5], innovation[1], nis;
    uint32_t refusals;
    int k;
    CHECK(mass_spring_damper_hybrid_ekf_new(&ekf, x0, p0, q, r) == MASS_SPRING_DAMPER_STATUS_OK);
    CHECK(mass_spring_damper_hybrid_ekf_set_process_noise(&ekf, q) == MASS_SPRING_DAMPER_STATUS_OK);
    CHECK(mass_spring_damper_hybrid_ekf_set_measurement_noise(&ekf, r) == MASS_SPRING_DAMPER_STATUS_OK);
    printf("hybrid_statuses");
    for (k = 1; k <= 20; k++) {
        const float u_prev[1] = {(float)(k % 5) - 2.0f};
        const float y[1] = {1e-4f * (float)((k * 7) % 11) - 5e-4f};
        printf(" %x", (unsigned)mass_spring_damper_hybrid_ekf_step(&ekf, u_prev, y));
    }
    printf("\n");
    CHECK(mass_spring_damper_hybrid_ekf_predict(&ekf, (const float[]){1.0f}) == MASS_SPRING_DAMPER_STATUS_OK);
    CHECK(mass_spring_damper_hybrid_ekf_update(&ekf, (const float[]){2e-4f}) == MASS_SPRING_DAMPER_STATUS_OK);
    CHECK(mass_spring_damper_hybrid_ekf_state(&ekf, state) == MASS_SPRING_DAMPER_STATUS_OK);
    print_f32("hybrid_state", state, 5);
    CHECK(mass_spring_damper_hybrid_ekf_covariance(&ekf, covariance) == MASS_SPRING_DAMPER_STATUS_OK);
    print_f32("hybrid_covariance", &covariance[0][0], 25);
    CHECK(mass_spring_damper_hybrid_ekf_innovation(&ekf, innovation) == MASS_SPRING_DAMPER_STATUS_OK);
    CHECK(mass_spring_damper_hybrid_ekf_normalised_innovation_squared(&ekf, &nis) == MASS_SPRING_DAMPER_STATUS_OK);
    print_f32("hybrid_innovation", (const float[]){innovation[0], nis}, 2);
    CHECK(mass_spring_damper_hybrid_ekf_refusals(&ekf, &refusals) == MASS_SPRING_DAMPER_STATUS_OK);
    printf("hybrid_refusals %x\n", (unsigned)refusals);
    CHECK(mass_spring_damper_hybrid_ekf_reset(&ekf, x0, p0) == MASS_SPRING_DAMPER_STATUS_OK);
    CHECK(mass_spring_damper_hybrid_ekf_state(&ekf, state) == MASS_SPRING_DAMPER_STATUS_OK);
    CHECK(memcmp(state, x0, sizeof state) == 0);
    CHECK(mass_spring_damper_hybrid_ekf_step(&ekf, NULL, (const float[]){0.0f}) ==
          MASS_SPRING_DAMPER_STATUS_NULL_POINTER);
}

static void model_functions(void) {
    const float x[5] = {0.01f, -0.2f, 0.5f, -1.0f, 5.0f};
    const float u[1] = {10.0f};
    float next[5], y[1], c[1][5];
    CHECK(mass_spring_damper_f(x, u, next) == MASS_SPRING_DAMPER_STATUS_OK);
    print_f32("f", next, 5);
    CHECK(mass_spring_damper_h(x, y) == MASS_SPRING_DAMPER_STATUS_OK);
    print_f32("h", y, 1);
    CHECK(mass_spring_damper_jacobian_h_wrt_x(x, c) == MASS_SPRING_DAMPER_STATUS_OK);
    print_f32("jacobian_h_wrt_x", &c[0][0], 5);
}

/* The f64 MPC: every function once, 10 solves. */
static void f64_mpc_run(void) {
    static mass_spring_damper_f64_mpc_t mpc;
    mass_spring_damper_f64_mpc_status_t outcome;
    mass_spring_damper_f64_prediction_model_t model;
    const double q[2][2] = {{1e4, 0.0}, {0.0, 1.0}};
    const double r[1][1] = {{1e-4}};
    const double u_min[1] = {-100.0};
    const double u_max[1] = {100.0};
    const double x_ref[2] = {0.0, 0.0};
    const double u_ref[1] = {0.0};
    double u[1] = {0.0};
    double x[5];
    double plan[MASS_SPRING_DAMPER_F64_MPC_HORIZON][1];
    double weight[2][2];
    double gain[1][2];
    int k;
    CHECK(mass_spring_damper_f64_mpc_new(&mpc, q, r, u_min, u_max) == MASS_SPRING_DAMPER_STATUS_OK);
    CHECK(mass_spring_damper_f64_mpc_set_reference(&mpc, x_ref, u_ref) == MASS_SPRING_DAMPER_STATUS_OK);
    CHECK(mass_spring_damper_f64_mpc_set_weights(&mpc, q, r) == MASS_SPRING_DAMPER_STATUS_OK);
    CHECK(mass_spring_damper_f64_mpc_set_input_limits(&mpc, u_min, u_max) == MASS_SPRING_DAMPER_STATUS_OK);
    printf("f64_mpc_outcomes");
    for (k = 0; k < 10; k++) {
        float x32[5];
        int i;
        mass_spring_damper_status_t status;
        state_at(k, x32);
        for (i = 0; i < 5; i++) {
            x[i] = (double)x32[i];
        }
        memset(&outcome, 0xff, sizeof outcome);
        status = mass_spring_damper_f64_mpc_solve(&mpc, x, u, &outcome);
        CHECK(status == outcome.status);
        printf(" %x %x %x %x %x", (unsigned)outcome.status, (unsigned)outcome.optimal,
               (unsigned)outcome.iterations, (unsigned)outcome.terminal_weight_converged,
               (unsigned)outcome.rebuilt);
        CHECK(mass_spring_damper_f64_mpc_control(&mpc, u) == MASS_SPRING_DAMPER_STATUS_OK);
    }
    printf("\n");
    print_f64("f64_mpc_control", u, 1);
    CHECK(mass_spring_damper_f64_mpc_plan(&mpc, plan) == MASS_SPRING_DAMPER_STATUS_OK);
    print_f64("f64_mpc_plan", &plan[0][0], MASS_SPRING_DAMPER_F64_MPC_HORIZON);
    CHECK(mass_spring_damper_f64_mpc_model(&mpc, &model) == MASS_SPRING_DAMPER_STATUS_OK);
    print_f64("f64_mpc_model", &model.a[0][0], 4);
    CHECK(mass_spring_damper_f64_mpc_terminal_weight(&mpc, weight) == MASS_SPRING_DAMPER_STATUS_OK);
    CHECK(mass_spring_damper_f64_mpc_terminal_gain(&mpc, gain) == MASS_SPRING_DAMPER_STATUS_OK);
    print_f64("f64_mpc_terminal", (const double[]){weight[0][0], weight[1][1], gain[0][0], gain[0][1]}, 4);
    CHECK(mass_spring_damper_f64_mpc_prediction_model(x, u, &model) == MASS_SPRING_DAMPER_STATUS_OK);
}

int main(void) {
    mpc_run();
    hybrid_ekf_run();
    model_functions();
    f64_mpc_run();
    printf("failures %d\n", failures);
    return failures == 0 ? 0 : 1;
}

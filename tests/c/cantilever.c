/*
 * The cantilever model's C API from C (tests/tests/c_api.rs builds and runs it under
 * AddressSanitizer and UndefinedBehaviorSanitizer): each function of the EKF, the gated
 * EKF, the DKF, the LQR, the model functions and the f64 EKF, on valid data and on each way a
 * caller can get it wrong (null, misaligned and uninitialised pointers, non-finite
 * inputs, invalid covariances). A failed check prints its line and makes the exit status
 * nonzero. The results of the valid calls are printed as the bits of each float
 * (`name bits...`), which the Rust test compares with the generated Rust code's.
 */
#include "cantilever.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "check.h"

/* The run's input and measurement at sample k: exact float arithmetic, as the Rust test
 * computes them. */
static float input_at(int k) { return 0.25f * (float)(k % 7) - 0.75f; }
static float measurement_at(int k) { return 0.01f * (float)((k * 37) % 19) - 0.09f; }

/* Storage that zeroed statics leave unwritten: every call refuses it. */
static cantilever_ekf_t never_written;

static const float X0[5] = {0.0f, 0.0f, -400.0f, -1.0f, 50.0f};
static const float P0[5][5] = {
    {1.0f, 0.0f, 0.0f, 0.0f, 0.0f},
    {0.0f, 1.0f, 0.0f, 0.0f, 0.0f},
    {0.0f, 0.0f, 100.0f, 0.0f, 0.0f},
    {0.0f, 0.0f, 0.0f, 1.0f, 0.0f},
    {0.0f, 0.0f, 0.0f, 0.0f, 10.0f},
};
static const float Q[5] = {1e-6f, 1e-4f, 1e-2f, 1e-4f, 1e-3f};
static const float R[1][1] = {{1e-4f}};

/* A method checks its storage with its arguments, in one test, before the storage's tag:
 * a refused pointer is reported as such even on storage no constructor wrote. */
static void storage_checked_with_arguments(void) {
    static cantilever_ekf_t ekf;
    uint32_t count;
    const float u[1] = {0.0f};
    const float y[1] = {0.0f};
    union {
        uint64_t words[4];
        unsigned char bytes[32];
    } unaligned; /* 8-aligned: bytes + 4 is not */
    memset(&unaligned, 0, sizeof unaligned);
    CHECK(cantilever_ekf_new(&ekf, X0, P0, Q, R) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_ekf_step(NULL, u, y) == CANTILEVER_STATUS_NULL_POINTER);
    CHECK(cantilever_ekf_step((cantilever_ekf_t *)(void *)(unaligned.bytes + 4), u, y) ==
          CANTILEVER_STATUS_MISALIGNED_POINTER);
    CHECK(cantilever_ekf_step(&ekf, u, (const float *)(const void *)(unaligned.bytes + 1)) ==
          CANTILEVER_STATUS_MISALIGNED_POINTER);
    CHECK(cantilever_ekf_step(&never_written, u, NULL) == CANTILEVER_STATUS_NULL_POINTER);
    CHECK(cantilever_ekf_state(&never_written, (float *)(void *)(unaligned.bytes + 2)) ==
          CANTILEVER_STATUS_MISALIGNED_POINTER);
    CHECK(cantilever_ekf_state(&never_written, NULL) == CANTILEVER_STATUS_NULL_POINTER);
    /* Results through null or misaligned pointers are refused. */
    CHECK(cantilever_ekf_state(&ekf, NULL) == CANTILEVER_STATUS_NULL_POINTER);
    CHECK(cantilever_ekf_covariance(&ekf, NULL) == CANTILEVER_STATUS_NULL_POINTER);
    CHECK(cantilever_ekf_innovation(&ekf, NULL) == CANTILEVER_STATUS_NULL_POINTER);
    CHECK(cantilever_ekf_normalised_innovation_squared(&ekf, NULL) == CANTILEVER_STATUS_NULL_POINTER);
    CHECK(cantilever_ekf_refusals(&ekf, NULL) == CANTILEVER_STATUS_NULL_POINTER);
    CHECK(cantilever_ekf_refusals(NULL, &count) == CANTILEVER_STATUS_NULL_POINTER);
    CHECK(cantilever_ekf_state(&ekf, (float *)(void *)(unaligned.bytes + 2)) ==
          CANTILEVER_STATUS_MISALIGNED_POINTER);
}

static void ekf_refusals(void) {
    static cantilever_ekf_t ekf;
    const float u[1] = {0.0f};
    const float y[1] = {0.0f};
    const float nan_x0[5] = {0.0f, NAN, 0.0f, 0.0f, 0.0f};
    const float negative_q[5] = {1e-6f, -1e-4f, 1e-2f, 1e-4f, 1e-3f};
    const float asymmetric[5][5] = {
        {1.0f, 0.5f, 0.0f, 0.0f, 0.0f},
        {0.0f, 1.0f, 0.0f, 0.0f, 0.0f},
        {0.0f, 0.0f, 1.0f, 0.0f, 0.0f},
        {0.0f, 0.0f, 0.0f, 1.0f, 0.0f},
        {0.0f, 0.0f, 0.0f, 0.0f, 1.0f},
    };
    const float negative_variance[5][5] = {
        {-1.0f, 0.0f, 0.0f, 0.0f, 0.0f},
        {0.0f, 1.0f, 0.0f, 0.0f, 0.0f},
        {0.0f, 0.0f, 1.0f, 0.0f, 0.0f},
        {0.0f, 0.0f, 0.0f, 1.0f, 0.0f},
        {0.0f, 0.0f, 0.0f, 0.0f, 1.0f},
    };
    union {
        uint64_t words[4];
        unsigned char bytes[32];
    } unaligned; /* 8-aligned: bytes + 4 is not */
    float state[5];
    memset(&unaligned, 0, sizeof unaligned);

    /* Storage no constructor wrote. */
    CHECK(cantilever_ekf_step(&never_written, u, y) == CANTILEVER_STATUS_NOT_INITIALISED);
    CHECK(cantilever_ekf_state(&never_written, state) == CANTILEVER_STATUS_NOT_INITIALISED);
    /* Null and misaligned pointers, arguments and storage. */
    CHECK(cantilever_ekf_new(NULL, X0, P0, Q, R) == CANTILEVER_STATUS_NULL_POINTER);
    CHECK(cantilever_ekf_new(&ekf, NULL, P0, Q, R) == CANTILEVER_STATUS_NULL_POINTER);
    CHECK(cantilever_ekf_new(&ekf, X0, NULL, Q, R) == CANTILEVER_STATUS_NULL_POINTER);
    CHECK(cantilever_ekf_new(&ekf, X0, P0, Q, NULL) == CANTILEVER_STATUS_NULL_POINTER);
    CHECK(cantilever_ekf_new(&ekf, (const float *)(const void *)(unaligned.bytes + 1), P0, Q, R) ==
          CANTILEVER_STATUS_MISALIGNED_POINTER);
    CHECK(cantilever_ekf_new((cantilever_ekf_t *)(void *)(unaligned.bytes + 4), X0, P0, Q, R) ==
          CANTILEVER_STATUS_MISALIGNED_POINTER);
    /* Non-finite inputs and invalid covariances: the storage is left unwritten. */
    CHECK(cantilever_ekf_new(&ekf, nan_x0, P0, Q, R) == CANTILEVER_STATUS_REJECTED_INPUT);
    CHECK(cantilever_ekf_new(&ekf, X0, P0, negative_q, R) == CANTILEVER_STATUS_INVALID_COVARIANCE);
    CHECK(cantilever_ekf_new(&ekf, X0, asymmetric, Q, R) == CANTILEVER_STATUS_INVALID_COVARIANCE);
    CHECK(cantilever_ekf_new(&ekf, X0, negative_variance, Q, R) == CANTILEVER_STATUS_INVALID_COVARIANCE);
    CHECK(cantilever_ekf_step(&ekf, u, y) == CANTILEVER_STATUS_NOT_INITIALISED);
    /* Written: each refusal leaves the filter as it was. */
    CHECK(cantilever_ekf_new(&ekf, X0, P0, Q, R) == CANTILEVER_STATUS_OK);
    {
        const float nan_y[1] = {NAN};
        const float infinite_u[1] = {INFINITY};
        const float nan_r[1][1] = {{NAN}};
        const float negative_r[1][1] = {{-1.0f}};
        float before[5][5];
        float after[5][5];
        CHECK(cantilever_ekf_covariance(&ekf, before) == CANTILEVER_STATUS_OK);
        CHECK(cantilever_ekf_step(&ekf, u, nan_y) == CANTILEVER_STATUS_REJECTED_INPUT);
        CHECK(cantilever_ekf_step(&ekf, infinite_u, y) == CANTILEVER_STATUS_REJECTED_INPUT);
        CHECK(cantilever_ekf_predict(&ekf, infinite_u) == CANTILEVER_STATUS_REJECTED_INPUT);
        CHECK(cantilever_ekf_update(&ekf, nan_y) == CANTILEVER_STATUS_REJECTED_INPUT);
        CHECK(cantilever_ekf_step(&ekf, NULL, y) == CANTILEVER_STATUS_NULL_POINTER);
        CHECK(cantilever_ekf_step(&ekf, u, NULL) == CANTILEVER_STATUS_NULL_POINTER);
        CHECK(cantilever_ekf_predict(NULL, u) == CANTILEVER_STATUS_NULL_POINTER);
        CHECK(cantilever_ekf_update(&ekf, NULL) == CANTILEVER_STATUS_NULL_POINTER);
        CHECK(cantilever_ekf_set_process_noise(&ekf, negative_q) == CANTILEVER_STATUS_INVALID_COVARIANCE);
        CHECK(cantilever_ekf_set_process_noise(&ekf, NULL) == CANTILEVER_STATUS_NULL_POINTER);
        CHECK(cantilever_ekf_set_measurement_noise(&ekf, nan_r) == CANTILEVER_STATUS_REJECTED_INPUT);
        CHECK(cantilever_ekf_set_measurement_noise(&ekf, negative_r) == CANTILEVER_STATUS_INVALID_COVARIANCE);
        CHECK(cantilever_ekf_reset(&ekf, X0, asymmetric) == CANTILEVER_STATUS_INVALID_COVARIANCE);
        CHECK(cantilever_ekf_reset(&ekf, nan_x0, P0) == CANTILEVER_STATUS_REJECTED_INPUT);
        CHECK(cantilever_ekf_covariance(&ekf, after) == CANTILEVER_STATUS_OK);
        CHECK(memcmp(before, after, sizeof before) == 0);
    }
}

/* The EKF's run: 40 steps, then a predict and an update; printed for the Rust test. */
static void ekf_run(void) {
    cantilever_ekf_t ekf;
    float state[5];
    float covariance[5][5];
    float innovation[1];
    float nis;
    uint32_t refusals;
    int k;
    CHECK(cantilever_ekf_new(&ekf, X0, P0, Q, R) == CANTILEVER_STATUS_OK);
    for (k = 1; k <= 40; k++) {
        const float u[1] = {input_at(k - 1)};
        const float y[1] = {measurement_at(k)};
        cantilever_status_t status = cantilever_ekf_step(&ekf, u, y);
        CHECK(status == CANTILEVER_STATUS_OK);
    }
    {
        const float u[1] = {input_at(40)};
        const float y[1] = {measurement_at(41)};
        CHECK(cantilever_ekf_predict(&ekf, u) == CANTILEVER_STATUS_OK);
        CHECK(cantilever_ekf_update(&ekf, y) == CANTILEVER_STATUS_OK);
    }
    CHECK(cantilever_ekf_state(&ekf, state) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_ekf_covariance(&ekf, covariance) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_ekf_innovation(&ekf, innovation) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_ekf_normalised_innovation_squared(&ekf, &nis) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_ekf_refusals(&ekf, &refusals) == CANTILEVER_STATUS_OK);
    CHECK(refusals == 0u);
    print_f32("ekf_state", state, 5);
    print_f32("ekf_covariance", &covariance[0][0], 25);
    print_f32("ekf_innovation", innovation, 1);
    print_f32("ekf_nis", &nis, 1);
    /* Restarted, with new noise: as new. */
    CHECK(cantilever_ekf_set_process_noise(&ekf, Q) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_ekf_set_measurement_noise(&ekf, R) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_ekf_reset(&ekf, X0, P0) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_ekf_state(&ekf, state) == CANTILEVER_STATUS_OK);
    CHECK(memcmp(state, X0, sizeof state) == 0);
}

/* The gated EKF: its gate, and a spike it rejects. */
static void gated_ekf_run(void) {
    cantilever_gated_ekf_t gated;
    float gate;
    float state[5];
    float innovation[1];
    float nis;
    uint32_t refusals;
    const float u[1] = {0.0f};
    const float spike[1] = {1000.0f};
    CHECK(cantilever_gated_ekf_new(&gated, X0, P0, Q, R) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_gated_ekf_innovation_gate(&gated, &gate) == CANTILEVER_STATUS_OK);
    CHECK(gate == 10.83f);
    CHECK(cantilever_gated_ekf_set_innovation_gate(&gated, NAN) == CANTILEVER_STATUS_REJECTED_INPUT);
    CHECK(cantilever_gated_ekf_set_innovation_gate(&gated, 9.0f) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_gated_ekf_innovation_gate(&gated, &gate) == CANTILEVER_STATUS_OK);
    CHECK(gate == 9.0f);
    CHECK(cantilever_gated_ekf_step(&gated, u, spike) == CANTILEVER_STATUS_OUTLIER_REJECTED);
    CHECK(cantilever_gated_ekf_refusals(&gated, &refusals) == CANTILEVER_STATUS_OK);
    CHECK(refusals == 1u);
    CHECK(cantilever_gated_ekf_normalised_innovation_squared(&gated, &nis) == CANTILEVER_STATUS_OK);
    CHECK(nis > 9.0f);
    CHECK(cantilever_gated_ekf_innovation(&gated, innovation) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_gated_ekf_predict(&gated, u) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_gated_ekf_update(&gated, spike) == CANTILEVER_STATUS_OUTLIER_REJECTED);
    CHECK(cantilever_gated_ekf_set_process_noise(&gated, Q) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_gated_ekf_set_measurement_noise(&gated, R) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_gated_ekf_reset(&gated, X0, P0) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_gated_ekf_state(&gated, state) == CANTILEVER_STATUS_OK);
    CHECK(memcmp(state, X0, sizeof state) == 0);
    {
        float covariance[5][5];
        CHECK(cantilever_gated_ekf_covariance(&gated, covariance) == CANTILEVER_STATUS_OK);
        CHECK(covariance[2][2] == 100.0f);
    }
    CHECK(cantilever_gated_ekf_step(NULL, u, spike) == CANTILEVER_STATUS_NULL_POINTER);
}

/* The LQR: solved at the initial estimate, its gain and controls printed. */
static void lqr_run(void) {
    static cantilever_lqr_t unwritten;
    cantilever_lqr_t lqr;
    const float q[2][2] = {{100.0f, 0.0f}, {0.0f, 1.0f}};
    const float nan_q[2][2] = {{NAN, 0.0f}, {0.0f, 1.0f}};
    const float r[1][1] = {{0.1f}};
    const float u_max[1] = {2.0f};
    const float infinite_limit[1] = {INFINITY};
    const float x[5] = {0.5f, -1.0f, -400.0f, -1.0f, 50.0f};
    const float x_ref[5] = {0.2f, 0.0f, -400.0f, -1.0f, 50.0f};
    const float u[1] = {0.0f};
    const float nan_x[5] = {0.5f, -1.0f, NAN, -1.0f, 50.0f};
    float gain[1][2];
    float control[1];
    float tracked[1];
    float u_ref[1];
    CHECK(cantilever_lqr_solve(&unwritten, x, u) == CANTILEVER_STATUS_NOT_INITIALISED);
    CHECK(cantilever_lqr_new(&lqr, nan_q, r, NULL) == CANTILEVER_STATUS_REJECTED_INPUT);
    CHECK(cantilever_lqr_new(&lqr, q, r, infinite_limit) == CANTILEVER_STATUS_REJECTED_INPUT);
    CHECK(cantilever_lqr_new(&lqr, q, NULL, NULL) == CANTILEVER_STATUS_NULL_POINTER);
    /* Without limits (a null u_max), then with. */
    CHECK(cantilever_lqr_new(&lqr, q, r, NULL) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_lqr_solve(&lqr, x, u) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_lqr_control(&lqr, x, control) == CANTILEVER_STATUS_OK);
    print_f32("lqr_unlimited_control", control, 1);
    CHECK(cantilever_lqr_new(&lqr, q, r, u_max) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_lqr_solve(&lqr, nan_x, u) == CANTILEVER_STATUS_REJECTED_INPUT);
    CHECK(cantilever_lqr_solve(&lqr, x, u) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_lqr_gain(&lqr, gain) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_lqr_control(&lqr, x, control) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_lqr_steady_state_input(&lqr, x_ref, u, u_ref) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_lqr_steady_state_input(&lqr, nan_x, u, u_ref) == CANTILEVER_STATUS_REJECTED_INPUT);
    CHECK(cantilever_lqr_track(&lqr, x, x_ref, u_ref, tracked) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_lqr_track(&lqr, x, x_ref, NULL, tracked) == CANTILEVER_STATUS_NULL_POINTER);
    CHECK(cantilever_lqr_control(&lqr, x, NULL) == CANTILEVER_STATUS_NULL_POINTER);
    CHECK(control[0] >= -2.0f && control[0] <= 2.0f);
    print_f32("lqr_gain", &gain[0][0], 2);
    print_f32("lqr_control", control, 1);
    print_f32("lqr_u_ref", u_ref, 1);
    print_f32("lqr_track", tracked, 1);
}

/* The model functions. */
static void model_functions(void) {
    const float x[5] = {0.5f, -1.0f, -400.0f, -1.0f, 50.0f};
    const float u[1] = {0.25f};
    float next[5];
    float y[1];
    float a[5][5];
    float b[5][1];
    float c[1][5];
    CHECK(cantilever_f(x, u, next) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_h(x, y) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_jacobian_f_wrt_x(x, u, a) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_jacobian_f_wrt_u(x, u, b) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_jacobian_h_wrt_x(x, c) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_f(x, NULL, next) == CANTILEVER_STATUS_NULL_POINTER);
    CHECK(cantilever_h(x, NULL) == CANTILEVER_STATUS_NULL_POINTER);
    print_f32("f", next, 5);
    print_f32("h", y, 1);
    print_f32("jacobian_f_wrt_x", &a[0][0], 25);
    print_f32("jacobian_f_wrt_u", &b[0][0], 5);
    print_f32("jacobian_h_wrt_x", &c[0][0], 5);
}

/* The f64 EKF: the same run in double precision. */
static void f64_ekf_run(void) {
    cantilever_f64_ekf_t ekf;
    const double x0[5] = {0.0, 0.0, -400.0, -1.0, 50.0};
    const double p0[5][5] = {
        {1.0, 0.0, 0.0, 0.0, 0.0},
        {0.0, 1.0, 0.0, 0.0, 0.0},
        {0.0, 0.0, 100.0, 0.0, 0.0},
        {0.0, 0.0, 0.0, 1.0, 0.0},
        {0.0, 0.0, 0.0, 0.0, 10.0},
    };
    const double q[5] = {1e-6, 1e-4, 1e-2, 1e-4, 1e-3};
    const double r[1][1] = {{1e-4}};
    const double negative_r[1][1] = {{-1e-4}};
    double state[5];
    double covariance[5][5];
    double innovation[1];
    double nis;
    uint32_t refusals;
    int k;
    CHECK(cantilever_f64_ekf_new(&ekf, x0, p0, q, negative_r) == CANTILEVER_STATUS_INVALID_COVARIANCE);
    CHECK(cantilever_f64_ekf_new(&ekf, x0, p0, q, r) == CANTILEVER_STATUS_OK);
    for (k = 1; k <= 40; k++) {
        const double u[1] = {(double)input_at(k - 1)};
        const double y[1] = {(double)measurement_at(k)};
        CHECK(cantilever_f64_ekf_step(&ekf, u, y) == CANTILEVER_STATUS_OK);
    }
    {
        const double u[1] = {(double)input_at(40)};
        const double y[1] = {(double)measurement_at(41)};
        const double nan_y[1] = {NAN};
        CHECK(cantilever_f64_ekf_predict(&ekf, u) == CANTILEVER_STATUS_OK);
        CHECK(cantilever_f64_ekf_update(&ekf, nan_y) == CANTILEVER_STATUS_REJECTED_INPUT);
        CHECK(cantilever_f64_ekf_update(&ekf, y) == CANTILEVER_STATUS_OK);
    }
    CHECK(cantilever_f64_ekf_state(&ekf, state) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_f64_ekf_covariance(&ekf, covariance) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_f64_ekf_innovation(&ekf, innovation) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_f64_ekf_normalised_innovation_squared(&ekf, &nis) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_f64_ekf_refusals(&ekf, &refusals) == CANTILEVER_STATUS_OK);
    print_f64("f64_ekf_state", state, 5);
    print_f64("f64_ekf_covariance", &covariance[0][0], 25);
    CHECK(cantilever_f64_ekf_set_process_noise(&ekf, q) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_f64_ekf_set_measurement_noise(&ekf, negative_r) == CANTILEVER_STATUS_INVALID_COVARIANCE);
    CHECK(cantilever_f64_ekf_reset(&ekf, x0, p0) == CANTILEVER_STATUS_OK);
}

/* The DKF: a 40-sample run whose outcomes (the window's status and each stage's) are
 * printed, a predict, every getter and setter, and the ways an outcome's pointer can be
 * wrong. */
static void dkf_run(void) {
    static cantilever_dkf_t dkf;
    static cantilever_dkf_t unwritten;
    cantilever_dkf_status_t outcome;
    union {
        uint64_t words[2];
        unsigned char bytes[16];
    } unaligned; /* 8-aligned: bytes + 1 is not */
    float state[5], covariance[5][5], innovation[1], nis, gate, noise, excitation, theta[3];
    uint32_t refusals;
    int k;
    const float u[1] = {0.0f};
    memset(&unaligned, 0, sizeof unaligned);
    CHECK(cantilever_dkf_step(&unwritten, u, u, &outcome) == CANTILEVER_STATUS_NOT_INITIALISED);
    CHECK(cantilever_dkf_new(&dkf, X0, P0, Q, P0, Q, R) == CANTILEVER_STATUS_OK);
    /* The outcome is bytes, so any address of one is aligned (a misaligned outcome of the
     * MPC, which holds a count, is refused: tests/c/mass_spring_damper.c); a misaligned
     * argument is refused. */
    CHECK(cantilever_dkf_step(&dkf, (const float *)(const void *)(unaligned.bytes + 1), u,
                              &outcome) == CANTILEVER_STATUS_MISALIGNED_POINTER);
    CHECK(cantilever_dkf_step(&dkf, NULL, u, &outcome) == CANTILEVER_STATUS_NULL_POINTER);
    printf("dkf_outcomes");
    for (k = 1; k <= 40; k++) {
        const float u_prev[1] = {input_at(k - 1)};
        const float y[1] = {measurement_at(k)};
        cantilever_status_t status;
        memset(&outcome, 0xff, sizeof outcome);
        status = cantilever_dkf_step(&dkf, u_prev, y, &outcome);
        /* The status returned is the first stage's that is not OK. */
        CHECK(status == (outcome.akf != CANTILEVER_STATUS_OK ? outcome.akf : outcome.lkf));
        printf(" %x %x %x", (unsigned)outcome.window, (unsigned)outcome.akf, (unsigned)outcome.lkf);
    }
    printf("\n");
    {
        const float u_prev[1] = {input_at(40)};
        /* No outcome wanted: a null pointer is allowed. */
        CHECK(cantilever_dkf_predict(&dkf, u_prev, NULL) == CANTILEVER_STATUS_OK);
    }
    CHECK(cantilever_dkf_state(&dkf, state) == CANTILEVER_STATUS_OK);
    print_f32("dkf_state", state, 5);
    CHECK(cantilever_dkf_covariance(&dkf, covariance) == CANTILEVER_STATUS_OK);
    print_f32("dkf_covariance", &covariance[0][0], 25);
    CHECK(cantilever_dkf_akf_state(&dkf, state) == CANTILEVER_STATUS_OK);
    print_f32("dkf_akf_state", state, 5);
    CHECK(cantilever_dkf_akf_covariance(&dkf, covariance) == CANTILEVER_STATUS_OK);
    print_f32("dkf_akf_covariance", &covariance[0][0], 25);
    CHECK(cantilever_dkf_innovation(&dkf, innovation) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_dkf_normalised_innovation_squared(&dkf, &nis) == CANTILEVER_STATUS_OK);
    print_f32("dkf_innovation", (const float[]){innovation[0], nis}, 2);
    CHECK(cantilever_dkf_akf_innovation(&dkf, innovation) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_dkf_akf_normalised_innovation_squared(&dkf, &nis) == CANTILEVER_STATUS_OK);
    print_f32("dkf_akf_innovation", (const float[]){innovation[0], nis}, 2);
    CHECK(cantilever_dkf_window_equation_noise(&dkf, &noise) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_dkf_excitation(&dkf, &excitation) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_dkf_window_parameters(&dkf, theta) == CANTILEVER_STATUS_OK);
    print_f32("dkf_window", (const float[]){noise, excitation, theta[0], theta[1], theta[2]}, 5);
    CHECK(cantilever_dkf_refusals(&dkf, &refusals) == CANTILEVER_STATUS_OK);
    CHECK(refusals == 0);
    CHECK(cantilever_dkf_akf_refusals(&dkf, &refusals) == CANTILEVER_STATUS_OK);
    CHECK(refusals == 0);
    /* A tight gate: the stages judge a measurement each by its own innovation, and the
     * status returned is the first stage's that is not OK, whichever it is. */
    CHECK(cantilever_dkf_set_innovation_gate(&dkf, 4.0f) == CANTILEVER_STATUS_OK);
    printf("dkf_gated");
    for (k = 41; k <= 42; k++) {
        const float u_prev[1] = {input_at(k)};
        const float y[1] = {k == 41 ? 0.1f : 0.0f};
        cantilever_status_t status = cantilever_dkf_step(&dkf, u_prev, y, &outcome);
        CHECK(status == (outcome.akf != CANTILEVER_STATUS_OK ? outcome.akf : outcome.lkf));
        printf(" %x %x %x", (unsigned)status, (unsigned)outcome.akf, (unsigned)outcome.lkf);
    }
    printf("\n");
    /* The setters, then a reset to where the run started. */
    CHECK(cantilever_dkf_innovation_gate(&dkf, &gate) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_dkf_set_innovation_gate(&dkf, 16.0f) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_dkf_innovation_gate(&dkf, &gate) == CANTILEVER_STATUS_OK && gate == 16.0f);
    CHECK(cantilever_dkf_set_min_excitation(&dkf, 1e-5f) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_dkf_set_process_noise(&dkf, Q) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_dkf_set_akf_process_noise(&dkf, Q) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_dkf_set_measurement_noise(&dkf, R) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_dkf_reset(&dkf, X0, P0, P0) == CANTILEVER_STATUS_OK);
    CHECK(cantilever_dkf_state(&dkf, state) == CANTILEVER_STATUS_OK);
    CHECK(memcmp(state, X0, sizeof state) == 0);
    {
        const float nan_y[1] = {NAN};
        memset(&outcome, 0, sizeof outcome);
        CHECK(cantilever_dkf_step(&dkf, u, nan_y, &outcome) == CANTILEVER_STATUS_REJECTED_INPUT);
        CHECK(outcome.akf == CANTILEVER_STATUS_REJECTED_INPUT);
    }
}

int main(void) {
    ekf_refusals();
    storage_checked_with_arguments();
    dkf_run();
    ekf_run();
    gated_ekf_run();
    lqr_run();
    model_functions();
    f64_ekf_run();
    printf("constants %u %u %u %u\n", (unsigned)CANTILEVER_X_LEN, (unsigned)CANTILEVER_EKF_STEP_CYCLES,
           (unsigned)CANTILEVER_LQR_HORIZON, (unsigned)CANTILEVER_EKF_STEP_OPS_MUL);
    print_f32("ts", (const float[]){CANTILEVER_TS}, 1);
    printf("failures %d\n", failures);
    return failures == 0 ? 0 : 1;
}

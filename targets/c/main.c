/* The C firmware: the cantilever's EKF and LQR and the navigation EKF, called from C
 * through their C API (the static libraries and headers `stateforge-codegen c-api`
 * writes), on the emulated Cortex-M4F the Rust firmware runs on. Built with
 * arm-none-eabi-gcc on the peers' startup and linker script (peers/firmware/) by
 * `cargo xtask` (xtask/src/c_firmware.rs), which writes the data both firmwares run on
 * (targets/data.rs) into firmware_data.h.
 *
 * Output (semihosting), read by `cargo xtask`:
 * - the lines the Rust firmware prints for the same runs (targets/src/c_api.rs), which
 *   must be the same bit for bit: `bits cantilever k <x1..x5> <K1 K2> <u>` every tenth
 *   sample, `bits navigation k <x1..x24>` every hundredth IMU sample, `bits
 *   navigation_covariance 1000 <P>`;
 * - `capi <kernel> <instructions>`: instructions per call through the C API, measured as
 *   the Rust firmware measures its calls of the same kernels on the same data
 *   (`ekf_step`, `lqr_solve`, `navigation_predict`, `navigation_update_gnss`,
 *   `navigation_update_magnetometer`);
 * - `done`, and a zero exit status, unless a call returned a status it should not. */

#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "cantilever.h"
#include "firmware_data.h"
#include "measure.h"
#include "navigation.h"

/* The close guess and the tuning of the Rust firmware (targets/src/main.rs). */
static const float X0_CLOSE[5] = {0.01f, 0.0f, -400.0f, -1.0f, 0.01f};
static const float P0_CLOSE[5] = {0.1f, 1.0f, 2e4f, 1000.0f, 0.1f};
static const float Q[5] = {0.0f, 0.0f, 100.0f, 300.0f, 1e-3f};
static const float R[1][1] = {{0.001f}};
static const float U_MAX[1] = {100.0f};
static const float LQR_Q[2][2] = {{1.0f, 0.0f}, {0.0f, 1.0f}};
static const float LQR_R[1][1] = {{0.001f}};
/* Calls measured per kernel, after as many warm-up samples (as the Rust firmware). */
#define WARM_UP 100
#define MEASURED 800

/* Calls that returned a status they should not. */
static int failures;

static void expect(int ok, const char *what, int status) {
    if (!ok) {
        printf("failed %s: status %d\n", what, status);
        failures++;
    }
}

/* `bits <run> <k> <bits..>`. */
static void bits_line(const char *run, int k, const float *values, int n) {
    printf("bits %s %d", run, k);
    for (int i = 0; i < n; i++) {
        uint32_t bits;
        memcpy(&bits, &values[i], sizeof bits);
        printf(" %08lx", (unsigned long)bits);
    }
    printf("\n");
}

static void diagonal(const float *d, float *m, int n) {
    memset(m, 0, sizeof(float) * (size_t)(n * n));
    for (int i = 0; i < n; i++) {
        m[i * n + i] = d[i];
    }
}

static void cantilever_filter(cantilever_ekf_t *ekf) {
    float p0[5][5];
    diagonal(P0_CLOSE, &p0[0][0], 5);
    cantilever_status_t status =
        cantilever_ekf_new(ekf, X0_CLOSE, (const float(*)[5])p0, Q, R);
    expect(status == CANTILEVER_STATUS_OK, "cantilever_ekf_new", status);
}

static void cantilever_controller(cantilever_lqr_t *lqr) {
    cantilever_status_t status = cantilever_lqr_new(lqr, LQR_Q, LQR_R, U_MAX);
    expect(status == CANTILEVER_STATUS_OK, "cantilever_lqr_new", status);
}

/* The EKF on the measured sequence, and the LQR solved at its estimate each sample. */
static void cantilever_run(void) {
    static cantilever_ekf_t ekf;
    static cantilever_lqr_t lqr;
    cantilever_filter(&ekf);
    cantilever_controller(&lqr);
    for (int k = 1; k < SEQUENCE_SAMPLES; k++) {
        /* The statuses are the Rust run's too: a refused sample is part of the run. */
        (void)cantilever_ekf_step(&ekf, &sequence_u[k - 1], &sequence_y[k]);
        float x[5], gain[1][2], u[1];
        int status = cantilever_ekf_state(&ekf, x);
        (void)cantilever_lqr_solve(&lqr, x, &sequence_u[k - 1]);
        status |= cantilever_lqr_gain(&lqr, gain);
        status |= cantilever_lqr_control(&lqr, x, u);
        expect(status == CANTILEVER_STATUS_OK, "reading the cantilever's filters", status);
        /* The estimate, the gain and the control, as the Rust firmware's line. */
        float line[8];
        memcpy(line, x, sizeof x);
        memcpy(&line[5], gain, sizeof gain);
        line[7] = u[0];
        if (k % 10 == 0) {
            bits_line("cantilever", k, line, 8);
        }
    }
}

static void navigation_filter(navigation_ekf_t *ekf) {
    static float p0[23][23], r[9][9];
    diagonal(flight_p0, &p0[0][0], 23);
    diagonal(flight_r, &r[0][0], 9);
    navigation_status_t status = navigation_ekf_new(ekf, flight_x0, (const float(*)[23])p0,
                                                    flight_q, (const float(*)[9])r);
    expect(status == NAVIGATION_STATUS_OK, "navigation_ekf_new", status);
    status = navigation_ekf_set_magnetometer_innovation_gate(ekf, FLIGHT_MAGNETOMETER_GATE);
    expect(status == NAVIGATION_STATUS_OK, "the magnetometer's gate", status);
}

/* A call of the flight: used, or an outlier rejected by the experiment's gates. */
static void flown(navigation_status_t status, const char *call) {
    expect(status == NAVIGATION_STATUS_OK || status == NAVIGATION_STATUS_OUTLIER_REJECTED, call,
           status);
}

/* The kernels of the navigation flight, each call read (NULL: unread). */
typedef struct flight_calls {
    measure_calls_t predict, magnetometer, gnss;
} flight_calls_t;

/* The navigation flight: each IMU sample's prediction, then the magnetometer's update and
 * the GNSS's where they arrive; the estimate printed every hundredth sample (if `print`),
 * each call read into `calls` (if not NULL). */
static void navigation_flight(navigation_ekf_t *ekf, flight_calls_t *calls, int print) {
    int magnetometer = 0, gnss = 0;
    navigation_status_t status;
    for (int k = 0; k < FLIGHT_SAMPLES; k++) {
        if (calls) {
            MEASURE_CALL(&calls->predict, status,
                         navigation_ekf_predict(ekf, flight_interval[k], flight_imu[k]));
        } else {
            status = navigation_ekf_predict(ekf, flight_interval[k], flight_imu[k]);
        }
        flown(status, "navigation_ekf_predict");
        if (magnetometer < FLIGHT_MAGNETOMETER_READINGS &&
            flight_magnetometer_at[magnetometer] == k) {
            const float *y = flight_magnetometer[magnetometer++];
            if (calls) {
                MEASURE_CALL(&calls->magnetometer, status,
                             navigation_ekf_update_magnetometer(ekf, y));
            } else {
                status = navigation_ekf_update_magnetometer(ekf, y);
            }
            flown(status, "navigation_ekf_update_magnetometer");
        }
        if (gnss < FLIGHT_GNSS_FIXES && flight_gnss_at[gnss] == k) {
            const float *y = flight_gnss[gnss++];
            if (calls) {
                MEASURE_CALL(&calls->gnss, status, navigation_ekf_update_gnss(ekf, y));
            } else {
                status = navigation_ekf_update_gnss(ekf, y);
            }
            flown(status, "navigation_ekf_update_gnss");
        }
        if (print && (k + 1) % 100 == 0) {
            float x[24];
            expect(navigation_ekf_state(ekf, x) == NAVIGATION_STATUS_OK, "navigation_ekf_state",
                   0);
            bits_line("navigation", k + 1, x, 24);
        }
    }
}

static void navigation_run(void) {
    static navigation_ekf_t ekf;
    static float p[23][23];
    navigation_filter(&ekf);
    navigation_flight(&ekf, NULL, 1);
    expect(navigation_ekf_covariance(&ekf, p) == NAVIGATION_STATUS_OK,
           "navigation_ekf_covariance", 0);
    bits_line("navigation_covariance", FLIGHT_SAMPLES, &p[0][0], 23 * 23);
}

/* Does nothing with a call's arguments: the harness loop's own cost, subtracted. */
__attribute__((noinline)) static int nothing(void *self, const float *a, const float *b) {
    __asm volatile("" : : "r"(self), "r"(a), "r"(b) : "memory");
    return 0;
}

/* Instructions per call of `call` over the samples j = first .. first + calls - 1, the
 * same loop calling `nothing` with the same arguments subtracted (as the Rust harness's
 * per_call). */
#define PER_CALL(result, first, calls, self, a, b, call)                                   \
    do {                                                                                   \
        uint32_t per_call_start_ = measure_now();                                          \
        for (int j = (first); j < (first) + (calls); j++) {                                \
            (void)nothing((self), (a), (b));                                               \
        }                                                                                  \
        uint32_t per_call_overhead_ = measure_elapsed(per_call_start_, measure_now());     \
        per_call_start_ = measure_now();                                                   \
        for (int j = (first); j < (first) + (calls); j++) {                                \
            (void)(call);                                                                  \
        }                                                                                  \
        uint32_t per_call_total_ = measure_elapsed(per_call_start_, measure_now());        \
        uint32_t per_call_spent_ = per_call_total_ > per_call_overhead_                    \
                                       ? per_call_total_ - per_call_overhead_              \
                                       : 0u;                                               \
        (result) = (per_call_spent_ + (uint32_t)(calls) / 2u) / (uint32_t)(calls);         \
    } while (0)

/* The EKF step on the EKF warmed up on the first samples, then the LQR solve at its
 * estimate, over the samples the Rust firmware measures its calls on. */
static void cantilever_costs(void) {
    static cantilever_ekf_t ekf;
    static cantilever_lqr_t lqr;
    cantilever_filter(&ekf);
    for (int k = 1; k < WARM_UP; k++) {
        (void)cantilever_ekf_step(&ekf, &sequence_u[k - 1], &sequence_y[k]);
    }
    uint32_t step;
    PER_CALL(step, WARM_UP, MEASURED - 1, &ekf, &sequence_u[j], &sequence_y[j + 1],
             cantilever_ekf_step(&ekf, &sequence_u[j], &sequence_y[j + 1]));
    printf("capi ekf_step %lu\n", (unsigned long)step);

    static const float u0[1] = {0.0f};
    float estimate[5];
    expect(cantilever_ekf_state(&ekf, estimate) == CANTILEVER_STATUS_OK, "cantilever_ekf_state",
           0);
    cantilever_controller(&lqr);
    uint32_t solve;
    PER_CALL(solve, WARM_UP, MEASURED - 1, &lqr, estimate, u0,
             cantilever_lqr_solve(&lqr, estimate, u0));
    printf("capi lqr_solve %lu\n", (unsigned long)solve);
}

/* The navigation flight, every call read (as the Rust firmware reads its calls). */
static void navigation_costs(void) {
    static navigation_ekf_t ekf;
    static flight_calls_t calls;
    navigation_filter(&ekf);
    navigation_flight(&ekf, &calls, 0);
    printf("capi navigation_predict %lu\n", (unsigned long)measure_mean(&calls.predict));
    printf("capi navigation_update_gnss %lu\n", (unsigned long)measure_mean(&calls.gnss));
    printf("capi navigation_update_magnetometer %lu\n",
           (unsigned long)measure_mean(&calls.magnetometer));
}

int main(void) {
    measure_start();
    cantilever_run();
    navigation_run();
    cantilever_costs();
    navigation_costs();
    if (failures > 0) {
        printf("%d calls failed\n", failures);
        return 1;
    }
    printf("done\n");
    return 0;
}

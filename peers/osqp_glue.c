/* The firmware's call into OSQP's generated solver (written by the project; OSQP's code is
 * generated into target/peers/osqp at benchmark time and never committed).
 *
 * One step of the blade's MPC: the condensed QP's Hessian (upper triangle, column by
 * column, already multiplied by PEER_OBJECTIVE_SCALE) and linear term replace the
 * workspace's (embedded mode 2: the KKT matrix is refactored), then OSQP solves,
 * warm-started from the last step's solution. */

#include "osqp.h"
#include "peer_scale.h"
#include "peer_workspace.h"

/* Writes the plan (PEER_HORIZON moves); returns OSQP's iterations, or minus its status
 * (or of a failed update) when it did not solve. */
int osqp_peer_step(const float *hessian_upper, const float *linear, float *plan) {
    enum { N = PEER_HORIZON, PACKED = PEER_HORIZON * (PEER_HORIZON + 1) / 2 };
    if (osqp_update_data_mat(&peer_solver, hessian_upper, OSQP_NULL, PACKED, OSQP_NULL,
                             OSQP_NULL, 0) != 0) {
        return -1000;
    }
    if (osqp_update_data_vec(&peer_solver, linear, OSQP_NULL, OSQP_NULL) != 0) {
        return -1001;
    }
    osqp_solve(&peer_solver);
    for (int i = 0; i < N; i++) {
        plan[i] = peer_solver.solution->x[i];
    }
    if (peer_solver.info->status_val != OSQP_SOLVED) {
        return -(int)peer_solver.info->status_val;
    }
    return (int)peer_solver.info->iter;
}

//! The blade's MPC problem at every step of the run, as the embedded-QP peers' code
//! generators take it (`target/peers/problem.json`): the generated `f32` `Mpc` solves at
//! each estimate of `generated_demo::mpc_sequence`, and its public API gives the QP it
//! solved: the prediction model `(A, B)` the solve used (`Mpc::model`: the one at the estimate, or one kept while within the MPC's `MODEL_TOLERANCE`), the
//! terminal weight of that solve (`Mpc::terminal_weight`), the initial state (the
//! estimate's regulated states; the reference is zero), the weights and the bounds.
//!
//! The generators use the first step's problem to lay out their code (OSQP: the sparsity
//! of its matrices; TinyMPC: its fixed model and cached Riccati gain); the firmware
//! rebuilds each step's data on the target from the same API (`targets/src/peers.rs`).

use generated_demo::mass_spring_damper::{Mpc, Status};
use generated_demo::mpc_sequence::{mpc_tuning, BladeEstimates};
use serde_json::{json, Value};

/// Steps of the firmware's MPC run (`targets/src/mpc.rs`).
pub const SAMPLES: usize = 300;

/// The problem of every step, as JSON.
pub fn problem() -> Result<Value, String> {
    let mut mpc = Mpc::new(
        &mpc_tuning::Q,
        &mpc_tuning::R,
        &[-mpc_tuning::U_MAX],
        &[mpc_tuning::U_MAX],
    )
    .map_err(|s| format!("the MPC rejected its tuning: {s:?}"))?;
    let mut steps = Vec::new();
    for (k, x) in BladeEstimates::new().take(SAMPLES).enumerate() {
        let status = mpc.solve(&x, &[0.0]);
        if status.status != Status::Ok {
            return Err(format!("the MPC at step {}: {status:?}", k + 1));
        }
        // The model the solve used (a kept one while it is within `MODEL_TOLERANCE`).
        let model = mpc.model();
        steps.push(json!({
            "x0": [x[0], x[1]],
            "a": model.a,
            "b": model.b,
            "p": mpc.terminal_weight(),
            "plan": mpc.plan().iter().map(|u| u[0]).collect::<Vec<f32>>(),
        }));
    }
    Ok(json!({
        "horizon": Mpc::HORIZON,
        "q": mpc_tuning::Q,
        "r": mpc_tuning::R,
        "u_max": mpc_tuning::U_MAX,
        "steps": steps,
    }))
}

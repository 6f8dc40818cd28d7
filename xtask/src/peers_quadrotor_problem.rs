//! TinyMPC's quadrotor hover benchmark as the peers take it (`target/peers/quadrotor.json`)
//! and the closed-loop run every solver is measured on. The model is
//! `generated_demo::quadrotor` (TinyMPC's 20 Hz Crazyflie matrices); the weights, the
//! input limits and the first state are TinyMPC's own:
//!
//! - `Q`, `R`: `Q_data`, `R_data` of `examples/problem_data/quadrotor_20hz_params.hpp` in
//!   TinyMPC's C++ library (the same diagonals as its Python package's
//!   `examples/quadrotor_hover_code_generation.py`);
//! - `|u| <= 0.5` on each motor (thrust less hover thrust), and the first state
//!   `x0 = (0, 1, 0, 0.2, 0, 0, 0.1, 0, ..)` held to the reference `z = 2`, of its
//!   `examples/quadrotor_hovering.cpp` (here as the error `x0 - xref`, regulated to zero);
//!   that example's state box `|x| <= 5` is left out (the problem stays the one first
//!   measured, before the MPC stated state limits): the table says the largest `|x|` the
//!   exact plans predict, which show it inactive;
//! - the horizon: that example's NHORIZON = 10 knot points are 9 moves; the run takes
//!   `quadrotor::Mpc::HORIZON`, those 9.
//!
//! The run: the generated `f32` `Mpc` closes the loop on the model's own `f32` dynamics
//! (`quadrotor::f`) for [`STEPS`] samples, from TinyMPC's first state, and a gust at
//! [`GUST_STEP`] kicks the velocities and rates so the inputs saturate again. Before the
//! run the MPC solves at the first state until its terminal weight has converged (the
//! DARE solution), as TinyMPC's cache and DAQP's factorisation are made before theirs:
//! each solve of the run is then the same QP for every solver, the condensed
//!
//! ```text
//! min sum_{k<N} x_k' Q x_k + u_k' R u_k + x_N' P x_N,  x_{k+1} = A x_k + B u_k,  |u_k| <= 0.5
//! ```
//!
//! with `P` that terminal weight, at the run's state `x_0` of each step. The states are
//! the host's; the firmware reads them (`quadrotor_states.rs`, written beside the JSON)
//! and every solver, ours included, solves at exactly those states.

use generated_demo::quadrotor::{self, Mpc, Status};
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::Path;

/// Samples of the run (10 s at 20 Hz).
pub const STEPS: usize = 200;
use generated_demo::quadrotor_tuning::{FIRST, GUST};
pub use generated_demo::quadrotor_tuning::{GUST_STEP, Q_DIAGONAL, R_DIAGONAL, U_MAX};
/// Solves at the first state before the run, at most.
const PRIMING: usize = 200;

/// A diagonal matrix.
fn diagonal<const N: usize>(d: [f32; N]) -> [[f32; N]; N] {
    core::array::from_fn(|i| core::array::from_fn(|j| if i == j { d[i] } else { 0.0 }))
}

/// The MPC, primed: solved at the first state until its terminal weight converged and
/// a solve no longer moves it.
/// The firmware primes its own the same way (`targets/src/peers_quadrotor.rs`).
pub fn primed() -> Result<Mpc, String> {
    let mut mpc = Mpc::new(
        &diagonal(Q_DIAGONAL),
        &diagonal(R_DIAGONAL),
        &[-U_MAX; 4],
        &[U_MAX; 4],
    )
    .map_err(|s| format!("the quadrotor's MPC rejected its tuning: {s:?}"))?;
    for _ in 0..PRIMING {
        let before = mpc.terminal_weight();
        let status = mpc.solve(&FIRST, &[0.0; 4]);
        if status.status != Status::Ok {
            return Err(format!("the quadrotor's MPC while priming: {status:?}"));
        }
        // Converged, and settled: a solve no longer moves it.
        if status.terminal_weight_converged && mpc.terminal_weight() == before {
            return Ok(mpc);
        }
    }
    Err(format!(
        "the quadrotor's terminal weight did not converge in {PRIMING} solves"
    ))
}

/// The run's states and the generated MPC's plans there, as JSON; writes the states for
/// the firmware into `dir/quadrotor_states.rs`.
pub fn problem(dir: &Path) -> Result<Value, String> {
    let mut mpc = primed()?;
    let p = mpc.terminal_weight();
    let model = mpc.model();
    let mut x = FIRST;
    let mut u = [0.0_f32; 4];
    let mut steps = Vec::new();
    for k in 0..STEPS {
        if k == GUST_STEP {
            for (xi, gi) in x.iter_mut().zip(GUST) {
                *xi += gi;
            }
        }
        let status = mpc.solve(&x, &u);
        if status.status != Status::Ok {
            return Err(format!("the quadrotor's MPC at step {}: {status:?}", k + 1));
        }
        if mpc.terminal_weight() != p {
            return Err(format!(
                "the quadrotor's terminal weight moved at step {}",
                k + 1
            ));
        }
        let plan: Vec<f32> = mpc.plan().iter().flatten().copied().collect();
        let rebuilt = format!("{:?}", status.rebuilt);
        steps.push(json!({ "x0": x, "plan": plan, "rebuilt": rebuilt }));
        u = mpc.control();
        x = quadrotor::f(&x, &u);
    }
    write_states(dir, &steps)?;
    Ok(json!({
        "horizon": Mpc::HORIZON,
        "a": model.a,
        "b": model.b,
        "p": p,
        "q": Q_DIAGONAL,
        "r": R_DIAGONAL,
        "u_max": U_MAX,
        "first": FIRST,
        "steps": steps,
    }))
}

/// The run's states as a Rust constant, which the firmware includes.
fn write_states(dir: &Path, steps: &[Value]) -> Result<(), String> {
    let mut text = format!(
        "// Written by `cargo xtask peers` (xtask/src/peers_quadrotor_problem.rs): the \
         quadrotor benchmark's tuning and its run's states.\n\
         pub const Q_DIAGONAL: [f32; 12] = {Q_DIAGONAL:?};\n\
         pub const R_DIAGONAL: [f32; 4] = {R_DIAGONAL:?};\n\
         pub const U_MAX: f32 = {U_MAX:?};\n\
         pub const FIRST: [f32; 12] = {FIRST:?};\n\
         pub const PRIMING: usize = {PRIMING};\n\
         pub const STATES: [[f32; 12]; {}] = [\n",
        steps.len()
    );
    for step in steps {
        let x: Vec<String> = step["x0"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|v| format!("{:?}", v.as_f64().unwrap_or(f64::NAN) as f32))
            .collect();
        let _ = writeln!(text, "    [{}],", x.join(", "));
    }
    text.push_str("];\n");
    let path = dir.join("quadrotor_states.rs");
    std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))
}

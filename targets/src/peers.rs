//! Embedded-QP peers of the blade's MPC on the same target (`--features peers`, built by
//! `cargo xtask peers`, never by the normal build): OSQP's generated C solver, linked as
//! `libpeers.a` (TinyMPC's generated C++ needs a C/C++ runtime and runs in its own
//! firmware instead: `peers/firmware/`, `xtask/src/peers_tinympc.rs`), on the QP the generated
//! `Mpc` solves at each of the 300 estimates of `generated_demo::mpc_sequence`.
//!
//! Each step, the generated `f32` `Mpc` solves first; its public API then gives the QP it
//! solved (the prediction model at the estimate, the terminal weight of that solve, the
//! estimate's regulated states, `Q`, `R` and the bounds), which this module condenses as
//! the generator does (eqs. 42-44 of Takacs, Polóni and Rohal'-Ilkiv, "Adaptive predictive
//! control of transient vibrations of cantilevers with changing weight") outside the
//! measured call and hands to OSQP. The generated solve's count covers its whole `solve`
//! (prediction model, Riccati steps, condensing and QP); OSQP's covers its update (the KKT
//! matrix refactored) and its solve only.
//!
//! Output: `peer <name> k <iterations> <u1..u10>` after every step (iterations negative:
//! the peer's failure status), then `peerspread <name> <median> <worst> <most
//! iterations> <mean>` of the instructions per call over the run.

use crate::measure::{per_call, Clock};
use crate::mpc::controller;
use core::hint::black_box;
use cortex_m_semihosting::{hprint, hprintln};
use generated_demo::mass_spring_damper::{Mpc, MpcStatus, Status};
use generated_demo::mpc_sequence::{mpc_tuning, BladeEstimates};

/// Steps of the run, as `crate::mpc`.
const SAMPLES: usize = 300;
/// Moves of the plan.
const N: usize = Mpc::HORIZON;
/// The condensed Hessian's upper triangle, column by column (OSQP's CSC order).
const PACKED: usize = N * (N + 1) / 2;
/// The objective's factor handed to the peers, `1 / R` (the minimiser is unchanged; their
/// absolute tolerances assume costs of order one).
const SCALE: f32 = 1.0 / mpc_tuning::R[0][0];

type Plan = [f32; N];

#[allow(unsafe_code)]
mod ffi {
    extern "C" {
        /// `peers/osqp_glue.c`.
        pub fn osqp_peer_step(hessian_upper: *const f32, linear: *const f32, plan: *mut f32)
            -> i32;
    }

    /// OSQP on one condensed QP: its iterations, or minus its status.
    pub fn osqp(
        hessian_upper: &[f32; super::PACKED],
        linear: &super::Plan,
        plan: &mut super::Plan,
    ) -> i32 {
        // SAFETY: the pointers are to arrays of the lengths the glue reads and writes
        // (PEER_HORIZON = N, packed N (N + 1) / 2), alive for the call; the glue keeps none.
        unsafe { osqp_peer_step(hessian_upper.as_ptr(), linear.as_ptr(), plan.as_mut_ptr()) }
    }
}

/// One step's QP as the generated MPC states it.
struct Step {
    a: [[f32; 2]; 2],
    b: [f32; 2],
    p: [[f32; 2]; 2],
    x0: [f32; 2],
}

fn mul(m: &[[f32; 2]; 2], v: [f32; 2]) -> [f32; 2] {
    [
        m[0][0] * v[0] + m[0][1] * v[1],
        m[1][0] * v[0] + m[1][1] * v[1],
    ]
}

fn dot(u: [f32; 2], v: [f32; 2]) -> f32 {
    u[0] * v[0] + u[1] * v[1]
}

/// `Q + A' S A`.
fn propagate(q: &[[f32; 2]; 2], a: &[[f32; 2]; 2], s: &[[f32; 2]; 2]) -> [[f32; 2]; 2] {
    let mut out = *q;
    for (i, row) in out.iter_mut().enumerate() {
        for (j, entry) in row.iter_mut().enumerate() {
            let column_j = [a[0][j], a[1][j]];
            let s_a = mul(s, column_j);
            *entry += a[0][i] * s_a[0] + a[1][i] * s_a[1];
        }
    }
    out
}

/// The condensed QP (eqs. 42-44), objective times [`SCALE`]: with `S_n = P_f`,
/// `S_k = Q + A' S_(k+1) A`, `H_ij = (A^(j-i) B)' S_(j+1) B + R [i = j]` and
/// `c_i = (S_(i+1) B)' A^(i+1) x_0`, as `predictive::condensed_qp` derives them.
fn condense(step: &Step) -> ([f32; PACKED], Plan) {
    let scaled = |m: [[f32; 2]; 2]| m.map(|row| row.map(|v| v * SCALE));
    let q = scaled(mpc_tuning::Q);
    let r = mpc_tuning::R[0][0] * SCALE;
    // cost_to_go[k] = S_(k+1), k = 0..N-1.
    let mut cost_to_go = [scaled(step.p); N];
    for k in (0..N - 1).rev() {
        cost_to_go[k] = propagate(&q, &step.a, &cost_to_go[k + 1]);
    }
    // responses[d] = A^d B; free[i] = A^(i+1) x0.
    let mut responses = [step.b; N];
    let mut free = [mul(&step.a, step.x0); N];
    for d in 1..N {
        responses[d] = mul(&step.a, responses[d - 1]);
        free[d] = mul(&step.a, free[d - 1]);
    }
    let weighted: [[f32; 2]; N] = core::array::from_fn(|j| mul(&cost_to_go[j], step.b));
    let mut hessian = [0.0; PACKED];
    let mut at = 0;
    for j in 0..N {
        for i in 0..=j {
            hessian[at] = dot(responses[j - i], weighted[j]) + if i == j { r } else { 0.0 };
            at += 1;
        }
    }
    let linear = core::array::from_fn(|i| dot(weighted[i], free[i]));
    (hessian, linear)
}

/// The generated solve. The estimate goes through `black_box` so that this wrapper's
/// body differs from `mpc::generated_mpc_solve`'s, which rustc would otherwise merge it
/// with (and the trace would not find it); that costs a store and a load.
#[inline(never)]
fn peers_mpc_solve(mpc: &mut Mpc, x: &[f32; 5]) -> MpcStatus {
    mpc.solve(black_box(x), &[0.0])
}

#[inline(never)]
fn peers_osqp_solve(hessian: &[f32; PACKED], linear: &Plan, plan: &mut Plan) -> i32 {
    ffi::osqp(hessian, linear, plan)
}

/// Does nothing: the cost of a call around a measured one, subtracted.
#[inline(never)]
fn peers_nothing(plan: &mut Plan) -> i32 {
    plan[0] as i32
}

/// Instructions of each call of one solver over the run, and its most iterations.
struct Counts {
    name: &'static str,
    each: [u32; SAMPLES],
    most: i32,
}

impl Counts {
    fn new(name: &'static str) -> Counts {
        Counts {
            name,
            each: [0; SAMPLES],
            most: 0,
        }
    }

    /// Records call `k`, prints its plan.
    fn record(&mut self, k: usize, instructions: u32, iterations: i32, plan: &Plan) {
        self.each[k] = instructions;
        self.most = self.most.max(iterations);
        hprint!("peer {} {} {}", self.name, k + 1, iterations);
        for u in plan {
            hprint!(" {:?}", u);
        }
        hprintln!();
    }

    fn report(mut self) {
        let total: u32 = self.each.iter().sum();
        self.each.sort_unstable();
        hprintln!(
            "peerspread {} {} {} {} {}",
            self.name,
            self.each[SAMPLES / 2],
            self.each[SAMPLES - 1],
            self.most,
            total as f32 / SAMPLES as f32
        );
    }
}

/// The run: every step solved by the generated MPC, then by each peer on its QP, each
/// call counted (the call of an empty function subtracted) and its plan printed. The
/// whole run lies between the trace markers, so the trace follows each solver's calls.
pub fn run(clock: &Clock) {
    let mut mpc = controller();
    let mut ours = Counts::new("mpc");
    let mut osqp = Counts::new("osqp");
    let mut scratch = [0.0; N];
    let empty = clock.instructions(|| {
        black_box(peers_nothing(black_box(&mut scratch)));
    });
    // The estimates computed first, so that the run between the trace markers does not
    // simulate the blade.
    let mut estimates = [[0.0; 5]; SAMPLES];
    for (slot, x) in estimates.iter_mut().zip(BladeEstimates::new()) {
        *slot = x;
    }
    let steps = estimates.iter().copied().enumerate();
    let _ = per_call(clock, steps, |(k, x)| {
        let mut status = None;
        let count = clock.instructions(|| status = Some(peers_mpc_solve(&mut mpc, black_box(&x))));
        let iterations = match status {
            Some(s) if s.status == Status::Ok => s.iterations as i32,
            _ => -1,
        };
        let plan = mpc.plan().map(|u| u[0]);
        ours.record(k, count.saturating_sub(empty), iterations, &plan);
        // The model the solve used: with `model_tolerance` it may be one kept from an
        // earlier solve rather than the one at this estimate.
        let model = mpc.model();
        let step = Step {
            a: model.a,
            b: [model.b[0][0], model.b[1][0]],
            p: mpc.terminal_weight(),
            x0: [x[0], x[1]],
        };
        let (hessian, linear) = condense(&step);
        let mut plan = [0.0; N];
        let mut iterations = 0;
        let count = clock.instructions(|| {
            iterations = peers_osqp_solve(black_box(&hessian), black_box(&linear), &mut plan);
        });
        osqp.record(k, count.saturating_sub(empty), iterations, &plan);
    });
    ours.report();
    osqp.report();
}

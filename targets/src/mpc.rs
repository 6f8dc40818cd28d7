//! The blade's MPC (the blade paper) on the target: `Mpc::solve` in `f32` on the deterministic
//! estimates of `generated_demo::mpc_sequence` (impacts every second, 54 g added half-way),
//! its plans printed for the host to check, and its cost per solve over the run.
//!
//! Output: `mpc k <iterations> <u1..u10>` for every sample (the plan after solving at
//! estimate `k`), then the `cost`/`stack` lines of `mpc_solve` (instructions per solve
//! averaged over the run, no nalgebra baseline: printed as 0), and
//! `spread mpc_solve <median> <worst> <most iterations>` over the run's solves, and
//! `paths mpc_solve <solves> <model rebuilds> <problem rebuilds> <iterations>`: what the
//! run's solves recomputed, in all, for the host to weigh the static estimates by.

use crate::measure::{per_call, report, stack_depth, Clock};
use core::hint::black_box;
use cortex_m_semihosting::{hprint, hprintln};
use generated_demo::mass_spring_damper::{Mpc, MpcRebuild, MpcStatus, Status};
use generated_demo::mpc_sequence::{mpc_tuning, BladeEstimates};

/// Samples of the run (3 s: three impacts, the mass change at 1.5 s).
pub const SAMPLES: usize = 300;

/// The blade's MPC with the run's tuning (shared with the peers' benchmark, which runs the
/// same controller beside them).
pub fn controller() -> Mpc {
    match Mpc::new(
        &mpc_tuning::Q,
        &mpc_tuning::R,
        &[-mpc_tuning::U_MAX],
        &[mpc_tuning::U_MAX],
    ) {
        Ok(mpc) => mpc,
        Err(status) => panic!("MPC rejected its tuning: {:?}", status),
    }
}

/// The estimates of the run, computed once so that no measured loop simulates the blade.
fn estimates() -> [[f32; 5]; SAMPLES] {
    let mut out = [[0.0; 5]; SAMPLES];
    for (slot, x) in out.iter_mut().zip(BladeEstimates::new()) {
        *slot = x;
    }
    out
}

#[inline(never)]
fn generated_mpc_solve(mpc: &mut Mpc, x: &[f32; 5]) -> MpcStatus {
    mpc.solve(x, &[0.0])
}

/// Does nothing with an estimate: the cost of the call around a solve, subtracted.
#[inline(never)]
fn no_solve(_mpc: &mut Mpc, x: &[f32; 5]) -> f32 {
    x[0]
}

/// Solves at every estimate of the run, printing each plan; panics if a solve is
/// rejected (a panic exits non-zero).
pub fn plans() {
    let mut mpc = controller();
    for (k, x) in estimates().iter().enumerate() {
        let status = generated_mpc_solve(&mut mpc, x);
        assert!(
            status.status == Status::Ok,
            "MPC at {}: {:?}",
            k + 1,
            status
        );
        hprint!("mpc {} {}", k + 1, status.iterations);
        for u in mpc.plan() {
            hprint!(" {:?}", u[0]);
        }
        hprintln!();
    }
}

/// Instructions of every solve over the run (one SysTick reading around each, the call of
/// an empty function subtracted): the median, the worst and the most iterations; and the
/// average over the same run through [`per_call`], which the trace checks.
pub fn costs(clock: &Clock) {
    let xs = estimates();
    let mut mpc = controller();
    let empty = clock.instructions(|| {
        black_box(no_solve(&mut mpc, black_box(&xs[0])));
    });
    let mut each = [0_u32; SAMPLES];
    let mut most_iterations = 0;
    let mut paths = Paths::default();
    for (slot, x) in each.iter_mut().zip(&xs) {
        let mut status = None;
        *slot = clock
            .instructions(|| status = Some(generated_mpc_solve(&mut mpc, black_box(x))))
            .saturating_sub(empty);
        if let Some(status) = status {
            most_iterations = most_iterations.max(status.iterations);
            paths.add(&status);
        }
    }
    each.sort_unstable();
    let (median, worst) = (each[SAMPLES / 2], each[SAMPLES - 1]);

    let mut mpc = controller();
    let average = per_call(clock, xs.iter(), |x| {
        let _ = black_box(generated_mpc_solve(&mut mpc, x));
    });
    let stack = stack_depth(|| {
        let _ = black_box(generated_mpc_solve(&mut mpc, &xs[0]));
    });
    report("mpc_solve", (average, 0), (stack, 0));
    hprintln!("spread mpc_solve {} {} {}", median, worst, most_iterations);
    hprintln!(
        "paths mpc_solve {} {} {} {}",
        paths.solves,
        paths.model_rebuilds,
        paths.problem_rebuilds,
        paths.iterations
    );
}

/// What a run's solves recomputed, in all: every solve runs its plan and iterations; some
/// also rebuild the prediction model, or the terminal weight and the condensed Hessian.
#[derive(Default)]
struct Paths {
    solves: usize,
    model_rebuilds: usize,
    problem_rebuilds: usize,
    iterations: usize,
}

impl Paths {
    fn add(&mut self, status: &MpcStatus) {
        self.solves += 1;
        let (model, problem) = match status.rebuilt {
            MpcRebuild::Nothing => (0, 0),
            MpcRebuild::Problem => (0, 1),
            MpcRebuild::ModelAndProblem => (1, 1),
        };
        self.model_rebuilds += model;
        self.problem_rebuilds += problem;
        self.iterations += status.iterations;
    }
}

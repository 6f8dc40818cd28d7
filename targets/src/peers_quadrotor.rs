//! The generated MPC on TinyMPC's quadrotor hover benchmark (`--features peers`, built by
//! `cargo xtask peers`, never by the normal build): `generated_demo::quadrotor`'s `f32`
//! `Mpc`, tuned as TinyMPC's example and primed as the host's
//! (`xtask/src/peers_quadrotor_problem.rs`), solves at each state of the host's
//! closed-loop run, which `cargo xtask peers` writes into `$PEERS_LIB_DIR` with the
//! tuning (`quadrotor_states.rs`). Its peers (TinyMPC, OSQP, DAQP) solve the same QP at
//! the same states in their own C/C++ firmware (`peers/firmware/quadrotor_main.cpp`).
//!
//! Output: `peer quadmpc k <iterations> <u..>` after every step (the plan move by move;
//! iterations negative: the solve failed), `peerspread quadmpc <median> <worst> <most
//! iterations> <mean>`, and `peerram quadmpc <state bytes> <stack bytes>`.

use crate::measure::{per_call, stack_depth, Clock};
use core::hint::black_box;
use cortex_m_semihosting::{hprint, hprintln};
use generated_demo::quadrotor::{Mpc, MpcStatus, Status};

/// The run's states and the benchmark's tuning, written by `cargo xtask peers`.
mod run {
    include!(concat!(env!("PEERS_LIB_DIR"), "/quadrotor_states.rs"));
}

const STEPS: usize = run::STATES.len();

fn diagonal<const N: usize>(d: [f32; N]) -> [[f32; N]; N] {
    core::array::from_fn(|i| core::array::from_fn(|j| if i == j { d[i] } else { 0.0 }))
}

/// The MPC, primed as the host's: solved at the first state until its terminal weight
/// converged and a solve no longer moves it.
fn primed() -> Mpc {
    let mut mpc = Mpc::new(
        &diagonal(run::Q_DIAGONAL),
        &diagonal(run::R_DIAGONAL),
        &[-run::U_MAX; 4],
        &[run::U_MAX; 4],
    )
    .expect("the benchmark's tuning is finite and u_min < u_max");
    for _ in 0..run::PRIMING {
        let before = mpc.terminal_weight();
        if mpc.solve(&run::FIRST, &[0.0; 4]).terminal_weight_converged
            && mpc.terminal_weight() == before
        {
            break;
        }
    }
    mpc
}

#[inline(never)]
fn peers_quadmpc_solve(mpc: &mut Mpc, x: &[f32; 12], u: &[f32; 4]) -> MpcStatus {
    mpc.solve(black_box(x), black_box(u))
}

/// Does nothing: the cost of a call around a measured one, subtracted.
#[inline(never)]
fn peers_quadnothing(x: &[f32; 12]) -> i32 {
    x[0] as i32
}

/// The run: every state solved, each call counted and its plan printed.
pub fn run(clock: &Clock) {
    let mut mpc = primed();
    let empty = clock.instructions(|| {
        black_box(peers_quadnothing(black_box(&run::STATES[0])));
    });
    let mut each = [0_u32; STEPS];
    let mut most = 0;
    let mut last = [0.0_f32; 4];
    let _ = per_call(clock, run::STATES.iter().enumerate(), |(k, x)| {
        let mut status = None;
        let count = clock.instructions(|| status = Some(peers_quadmpc_solve(&mut mpc, x, &last)));
        each[k] = count.saturating_sub(empty);
        let iterations = match status {
            Some(s) if s.status == Status::Ok => s.iterations as i32,
            _ => -1,
        };
        most = most.max(iterations);
        last = mpc.control();
        hprint!("peer quadmpc {} {}", k + 1, iterations);
        for u in mpc.plan().iter().flatten() {
            hprint!(" {:?}", u);
        }
        hprintln!();
    });
    let total: u32 = each.iter().sum();
    each.sort_unstable();
    hprintln!(
        "peerspread quadmpc {} {} {} {}",
        each[STEPS / 2],
        each[STEPS - 1],
        most,
        total as f32 / STEPS as f32
    );
    // The stack of a solve at the run's last state, from the controller as it ended.
    let stack = stack_depth(|| {
        let _ = black_box(peers_quadmpc_solve(
            &mut mpc,
            &run::STATES[STEPS - 1],
            &last,
        ));
    });
    hprintln!("peerram quadmpc {} {}", core::mem::size_of::<Mpc>(), stack);
}

//! TinyMPC's quadrotor (Nguyen, Schoedel, Alavilli, Plancher and Manchester, "TinyMPC:
//! Model-Predictive Control on Resource-Constrained Microcontrollers") held by the
//! generated MPC with limits besides the motors' bounds (`quadrotor_limited`): each
//! motor's change between moves (hard), the tilt `phi`, `theta` (hard) and the horizontal
//! speed `dx`, `dy` (soft, an exact penalty). The loop is closed on the model's own
//! dynamics (`quadrotor_limited::f`) from TinyMPC's first state, with TinyMPC's weights
//! and `|u| <= 0.5`; at [`GUST_STEP`] a gust kicks the velocities and attitude rates (the
//! benchmark's, `cargo xtask peers`) and pushes the speed past its limit, which the MPC
//! then holds while it brings the vehicle back. Run in `f64` (the host's) and `f32` (what
//! a microcontroller runs), each solve's own scalar throughout.

use super::report::{self, Line, Trace};
use generated_demo::quadrotor_limited;
use generated_demo::quadrotor_limited::index::{DX, DY, PHI, THETA};
use std::error::Error;
use std::path::Path;

/// Samples of the run (10 s at 20 Hz).
const STEPS: usize = 200;
/// The model's sample time \[s\] (TinyMPC's 20 Hz).
const TS: f64 = 0.05;
use generated_demo::quadrotor_tuning::GUST_STEP;
/// TinyMPC's weights, limits, first state and gust ([`generated_demo::quadrotor_tuning`]).
const Q_DIAGONAL: [f64; 12] = widen(generated_demo::quadrotor_tuning::Q_DIAGONAL);
const R_DIAGONAL: [f64; 4] = widen(generated_demo::quadrotor_tuning::R_DIAGONAL);
const U_MAX: f64 = generated_demo::quadrotor_tuning::U_MAX as f64;
const FIRST: [f64; 12] = widen(generated_demo::quadrotor_tuning::FIRST);
const GUST: [f64; 12] = widen(generated_demo::quadrotor_tuning::GUST);

/// The `f32` constants in `f64` (exactly).
const fn widen<const N: usize>(values: [f32; N]) -> [f64; N] {
    let mut wide = [0.0; N];
    let mut i = 0;
    while i < N {
        wide[i] = values[i] as f64;
        i += 1;
    }
    wide
}
/// The largest change of a motor's thrust between moves (hard).
const RATE: f64 = 0.1;
/// The largest tilt, `|phi|` and `|theta|` (Rodrigues parameters; hard).
const TILT: f64 = 0.2;
/// The largest horizontal speed, `|dx|` and `|dy|` \[m/s\] (soft).
const SPEED: f64 = 1.0;
/// The cost of a unit of speed beyond [`SPEED`] at a step, for `dx` and `dy`: large
/// enough that the slack is what the hard limits leave (`1e6` gives the same slack to
/// 4e-4 m/s in `f64`), small enough for `f32`: at `1e5` the `f32` loop diverges after
/// the gust (its solves at `MAX_ITERATIONS`), and at `1e6` one solve reaches it.
const SPEED_PENALTY: f64 = 1e4;
/// Solves at the first state before the run, at most (the terminal weight converges).
const PRIMING: usize = 200;

/// The generated MPC in one scalar, seen in `f64`.
trait LimitedMpc: Sized {
    /// The scalar's name, for the report.
    const SCALAR: &'static str;
    /// The MPC with the run's weights and limits.
    fn configured() -> Result<Self, String>;
    /// One solve at `x` with `u` applied now: whether the plan is optimal and its
    /// iterations, or why it failed.
    fn solve(&mut self, x: &[f64; 12], u: &[f64; 4]) -> Result<(bool, usize, bool), String>;
    /// The plan's first move.
    fn control(&self) -> [f64; 4];
    /// The model's sample step in the MPC's scalar.
    fn step(x: &[f64; 12], u: &[f64; 4]) -> [f64; 12];
}

macro_rules! limited_mpc {
    ($($module:ident)::+, $scalar:ty) => {
        impl LimitedMpc for $($module)::+::Mpc {
            const SCALAR: &'static str = stringify!($scalar);
            fn configured() -> Result<Self, String> {
                use $($module)::+::{Mpc, Status};
                let cast = |v: f64| v as $scalar;
                let mut mpc = Mpc::new(
                    &super::diag(Q_DIAGONAL.map(cast)),
                    &super::diag(R_DIAGONAL.map(cast)),
                    &[cast(-U_MAX); 4],
                    &[cast(U_MAX); 4],
                )
                .map_err(|s| format!("the tuning was rejected: {s:?}"))?;
                let set = [
                    mpc.set_rate_limits(&[cast(-RATE); 4], &[cast(RATE); 4]),
                    mpc.set_state_limits(
                        &[-TILT, -TILT, -SPEED, -SPEED].map(cast),
                        &[TILT, TILT, SPEED, SPEED].map(cast),
                    ),
                    mpc.set_limit_penalties(&[cast(SPEED_PENALTY); 2]),
                ];
                if set.iter().any(|s| *s != Status::Ok) {
                    return Err(format!("the limits were rejected: {set:?}"));
                }
                Ok(mpc)
            }
            fn solve(
                &mut self,
                x: &[f64; 12],
                u: &[f64; 4],
            ) -> Result<(bool, usize, bool), String> {
                let cast = |v: f64| v as $scalar;
                let status = $($module)::+::Mpc::solve(self, &x.map(cast), &u.map(cast));
                if status.status != $($module)::+::Status::Ok {
                    return Err(format!("{status:?}"));
                }
                Ok((
                    status.optimal,
                    status.iterations,
                    status.terminal_weight_converged,
                ))
            }
            fn control(&self) -> [f64; 4] {
                $($module)::+::Mpc::control(self).map(f64::from)
            }
            fn step(x: &[f64; 12], u: &[f64; 4]) -> [f64; 12] {
                let cast = |v: f64| v as $scalar;
                $($module)::+::f(&x.map(cast), &u.map(cast)).map(f64::from)
            }
        }
    };
}

limited_mpc!(quadrotor_limited, f32);
limited_mpc!(quadrotor_limited::in_f64, f64);

/// What one closed-loop run gave.
#[derive(Clone, Debug, Default)]
struct Run {
    /// Largest excess of a motor's change between moves over [`RATE`].
    pub rate_violation: f64,
    /// Largest excess of `|phi|` or `|theta|` over [`TILT`].
    pub tilt_violation: f64,
    /// Largest excess of `|dx|` and of `|dy|` over [`SPEED`] (the soft limits' slack).
    pub speed_violation: [f64; 2],
    /// Largest excess of `|dx|` and of `|dy|` over [`SPEED`] at the next sample that no
    /// move within the bounds and rate limits could have avoided.
    pub unavoidable_speed: [f64; 2],
    /// Samples at which a speed was beyond [`SPEED`] (by more than `1e-6` of it).
    pub speed_violated_samples: usize,
    /// Largest `|phi|` or `|theta|`.
    pub largest_tilt: f64,
    /// Largest `|dx|` or `|dy|` \[m/s\].
    pub largest_speed: f64,
    /// Largest `|u|` (the bounds clip the plan: at most [`U_MAX`]).
    pub largest_input: f64,
    /// Solves of the run (every one `Status::Ok`, or the run is an error).
    pub solves: usize,
    /// Solves whose plan is not the QP's minimiser (a hard limit that cannot be met, or
    /// the iterations' bound reached).
    pub not_optimal: usize,
    /// The solves' iterations: median.
    pub median_iterations: usize,
    /// The solves' iterations: largest.
    pub largest_iterations: usize,
    /// The run's states and inputs, one row per sample.
    pub trace: Trace,
}

/// The MPC, primed at the first state until its terminal weight converged (the DARE
/// solution), as the benchmark primes it.
fn primed<M: LimitedMpc>() -> Result<M, String> {
    let mut mpc = M::configured()?;
    for _ in 0..PRIMING {
        let (_, _, converged) = mpc.solve(&FIRST, &[0.0; 4])?;
        if converged {
            return Ok(mpc);
        }
    }
    Err(format!(
        "the terminal weight did not converge in {PRIMING} solves"
    ))
}

/// The closed loop: every solve must succeed (a failed one is an error, not a skipped
/// sample); the limits' excesses are measured on the states and moves the loop ran.
fn fly<M: LimitedMpc>() -> Result<Run, String> {
    let mut mpc = primed::<M>()?;
    let (mut x, mut u) = (FIRST, [0.0_f64; 4]);
    let mut run = Run::default();
    let mut iterations = Vec::with_capacity(STEPS);
    record(&mut run, 0.0, &x, &u);
    for k in 0..STEPS {
        if k == GUST_STEP {
            x = std::array::from_fn(|i| x[i] + GUST[i]);
        }
        let (optimal, taken, _) = mpc
            .solve(&x, &u)
            .map_err(|e| format!("{} solve at step {k}: {e}", M::SCALAR))?;
        run.solves += 1;
        run.not_optimal += usize::from(!optimal);
        iterations.push(taken);
        let least = least_speed_excess::<M>(&x, &u);
        let next = mpc.control();
        for (new, old) in next.iter().zip(&u) {
            run.rate_violation = run.rate_violation.max((new - old).abs() - RATE);
        }
        u = next;
        x = M::step(&x, &u);
        record(&mut run, (k + 1) as f64 * TS, &x, &u);
        for (unavoidable, least) in run.unavoidable_speed.iter_mut().zip(least) {
            *unavoidable = unavoidable.max(least);
        }
    }
    iterations.sort_unstable();
    run.median_iterations = iterations[iterations.len() / 2];
    run.largest_iterations = iterations.last().copied().unwrap_or(0);
    Ok(run)
}

/// The least excess of `|dx|` and of `|dy|` over [`SPEED`] at the next sample over every
/// move within the bounds and within [`RATE`] of `u`: the model is affine in the move,
/// so each speed spans an interval whose ends are the box's corners.
fn least_speed_excess<M: LimitedMpc>(x: &[f64; 12], u: &[f64; 4]) -> [f64; 2] {
    let free = M::step(x, &[0.0; 4]);
    let mut low = [free[DX], free[DY]];
    let mut high = low;
    for j in 0..4 {
        let mut unit = [0.0; 4];
        unit[j] = 1.0;
        let response = M::step(x, &unit);
        let (lo, hi) = ((u[j] - RATE).max(-U_MAX), (u[j] + RATE).min(U_MAX));
        for (i, index) in [DX, DY].into_iter().enumerate() {
            let b = response[index] - free[index];
            low[i] += (b * lo).min(b * hi);
            high[i] += (b * lo).max(b * hi);
        }
    }
    std::array::from_fn(|i| {
        let least = if low[i] > 0.0 {
            low[i]
        } else if high[i] < 0.0 {
            -high[i]
        } else {
            0.0
        };
        (least - SPEED).max(0.0)
    })
}

/// Adds the state `x` reached at `t` with the move `u` to the run's trace and excesses.
/// The state just after the gust is the gust's, not the loop's: it is recorded in the
/// next sample's state, which the MPC's plan reaches.
fn record(run: &mut Run, t: f64, x: &[f64; 12], u: &[f64; 4]) {
    let tilt = x[PHI].abs().max(x[THETA].abs());
    run.tilt_violation = run.tilt_violation.max(tilt - TILT);
    run.largest_tilt = run.largest_tilt.max(tilt);
    for (i, speed) in [x[DX].abs(), x[DY].abs()].into_iter().enumerate() {
        run.speed_violation[i] = run.speed_violation[i].max(speed - SPEED);
        run.largest_speed = run.largest_speed.max(speed);
    }
    if x[DX].abs().max(x[DY].abs()) > SPEED * (1.0 + 1e-6) {
        run.speed_violated_samples += 1;
    }
    for v in u {
        run.largest_input = run.largest_input.max(v.abs());
    }
    let trace = &mut run.trace;
    trace.begin(t);
    for (name, index) in [("phi", PHI), ("theta", THETA), ("dx", DX), ("dy", DY)] {
        trace.set(name, x[index]);
    }
    for (name, index) in [("x", 0), ("y", 1), ("z", 2)] {
        trace.set(name, x[index]);
    }
    for (i, v) in u.iter().enumerate() {
        trace.set(&format!("u{}", i + 1), *v);
    }
    trace.set("tilt limit", TILT);
    trace.set("-tilt limit", -TILT);
    trace.set("speed limit", SPEED);
    trace.set("-speed limit", -SPEED);
    trace.set("input bound", U_MAX);
    trace.set("-input bound", -U_MAX);
}

/// Runs the `f64` and `f32` loops, prints their table and writes
/// `out/quadrotor_limits.csv` and the plots of the `f64` run.
pub fn run(out: &Path) -> Result<(), Box<dyn Error>> {
    let double = fly::<quadrotor_limited::in_f64::Mpc>()?;
    let single = fly::<quadrotor_limited::Mpc>()?;
    print_table(&[("f64", &double), ("f32", &single)]);
    report::write_csv(
        &double.trace,
        std::fs::File::create(out.join("quadrotor_limits.csv"))?,
    )?;
    plot(out, &double.trace)
}

/// The table: per scalar, the hard limits' largest excesses, the soft ones' slack (and
/// how much of it no move could avoid), the largest tilt, speed and input, the solves.
fn print_table(runs: &[(&str, &Run)]) {
    println!(
        "\nTinyMPC's quadrotor held by the generated MPC with limits (horizon 8: 32 unknowns):"
    );
    println!(
        "TinyMPC's weights, |u| <= {U_MAX}; hard: |du| <= {RATE} per move, |phi|, |theta| <= \
         {TILT}; soft: |dx|, |dy| <= {SPEED} m/s (penalty {SPEED_PENALTY:e});"
    );
    println!(
        "{STEPS} samples at 20 Hz from TinyMPC's first state, the gust at sample {GUST_STEP} \
         (dx +1.5, dy -1.0, dz +1.0 m/s, rates kicked);"
    );
    println!(
        "excess: the largest amount by which the closed loop went beyond a limit (a soft \
         limit's slack), and of that the part no move within the bounds could avoid:\n"
    );
    println!(
        "{:<7} {:>10} {:>10} {:>17} {:>17} {:>7} {:>8} {:>8} {:>8} {:>12}",
        "scalar",
        "du exc.",
        "tilt exc.",
        "dx slack (unav.)",
        "dy slack (unav.)",
        "beyond",
        "max tilt",
        "max |v|",
        "max |u|",
        "iter. med/max"
    );
    for (scalar, run) in runs {
        let slack = |i: usize| {
            format!(
                "{:.4} ({:.4})",
                run.speed_violation[i], run.unavoidable_speed[i]
            )
        };
        println!(
            "{:<7} {:>10.1e} {:>10.1e} {:>17} {:>17} {:>7} {:>8.4} {:>8.4} {:>8.4} {:>12}",
            scalar,
            run.rate_violation,
            run.tilt_violation,
            slack(0),
            slack(1),
            run.speed_violated_samples,
            run.largest_tilt,
            run.largest_speed,
            run.largest_input,
            format!("{}/{}", run.median_iterations, run.largest_iterations),
        );
    }
    for (scalar, run) in runs {
        println!(
            "{scalar}: {} solves, every one Ok, {} not optimal",
            run.solves, run.not_optimal
        );
    }
}

fn plot(out: &Path, trace: &Trace) -> Result<(), Box<dyn Error>> {
    let figures: [(&str, &str, &str, &[&str]); 3] = [
        (
            "quadrotor_limits_tilt.svg",
            "Tilt against its hard limit",
            "Rodrigues parameter",
            &["tilt limit", "phi", "theta", "-tilt limit"],
        ),
        (
            "quadrotor_limits_speed.svg",
            "Horizontal speed against its soft limit (gust at 5 s)",
            "speed [m/s]",
            &["speed limit", "dx", "dy", "-speed limit"],
        ),
        (
            "quadrotor_limits_inputs.svg",
            "Motors' thrusts less hover, within their bounds",
            "u",
            &["input bound", "u1", "u2", "u3", "u4", "-input bound"],
        ),
    ];
    for (file, title, label, names) in figures {
        let lines: Vec<Line> = names.iter().filter_map(|n| trace.line(n)).collect();
        report::plot_lines(&out.join(file), title, label, &lines, None)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The loop in a scalar: every solve `Ok` (`fly` is an error otherwise) and optimal, the bounds
    /// held, the gust really pushing the speed past its soft limit and the tilt reaching
    /// its hard one (so the limits were active).
    fn check<M: LimitedMpc>() -> Run {
        let run = fly::<M>().expect("every solve Ok");
        print_table(&[(M::SCALAR, &run)]);
        assert_eq!(run.solves, STEPS);
        assert_eq!(run.not_optimal, 0, "{}", M::SCALAR);
        assert!(
            run.largest_input <= U_MAX,
            "{}: {}",
            M::SCALAR,
            run.largest_input
        );
        assert!(
            run.speed_violated_samples > 0,
            "the gust never reached the speed limit"
        );
        assert!(
            run.largest_tilt >= TILT * (1.0 - 1e-4),
            "the tilt limit was never reached"
        );
        run
    }

    #[test]
    fn hard_limits_hold_through_the_gust_in_f64() {
        let run = check::<quadrotor_limited::in_f64::Mpc>();
        assert!(run.rate_violation <= 1e-4 * RATE, "{}", run.rate_violation);
        assert!(run.tilt_violation <= 1e-4 * TILT, "{}", run.tilt_violation);
    }

    /// In `f32` as in `f64`: the solver refines the held limits at its optimum.
    #[test]
    fn hard_limits_hold_through_the_gust_in_f32() {
        let run = check::<quadrotor_limited::Mpc>();
        assert!(run.rate_violation <= 1e-4 * RATE, "{}", run.rate_violation);
        assert!(run.tilt_violation <= 1e-4 * TILT, "{}", run.tilt_violation);
    }
}

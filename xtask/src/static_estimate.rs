//! The compiler's static cycle estimates (the `*_CYCLES` constants of the generated
//! modules) of the cost table's kernels, against the instruction trace: the check that
//! the estimate a budget (`max_cycles = ..`) is compared with stays close to what the
//! core does.

use generated_demo::{cantilever, helicopter, mass_spring_damper, piecewise_beam, polynomial};

/// The largest relative difference allowed between the static estimate and the trace.
pub const TOLERANCE: f64 = 0.15;

/// The static estimate of a call of the firmware's kernel `name`, if it has one. The
/// MPC's calls differ by their iterations: its constant is a bound
/// (`MPC_SOLVE_WORST_CYCLES`), compared in the spread line, not here.
pub fn cycles(name: &str) -> Option<f64> {
    let reinit_every = polynomial::PolynomialKf::REINIT_EVERY as f64;
    let cycles = match name {
        "ekf_step" => cantilever::EKF_STEP_CYCLES,
        "dkf_step" => cantilever::DKF_STEP_CYCLES,
        "lqr_solve" => cantilever::LQR_SOLVE_CYCLES,
        "loop" => cantilever::DKF_STEP_CYCLES + cantilever::LQR_SOLVE_CYCLES,
        "continuous_ekf_step" => helicopter::CONTINUOUS_EKF_STEP_CYCLES,
        "hybrid_ekf_step" => mass_spring_damper::HYBRID_EKF_STEP_CYCLES,
        "switched_observer_step" => piecewise_beam::SWITCHED_OBSERVER_STEP_CYCLES,
        // One re-initialisation every REINIT_EVERY steps, on top of the recursive step.
        "polynomial_kf_step" => {
            return Some(
                f64::from(polynomial::POLYNOMIAL_KF_STEP_CYCLES)
                    + f64::from(polynomial::POLYNOMIAL_KF_FIT_CYCLES) / reinit_every,
            )
        }
        _ => return None,
    };
    Some(f64::from(cycles))
}

/// `(static - traced) / traced`.
pub fn difference(estimate: f64, traced: f64) -> f64 {
    (estimate - traced) / traced.max(1.0)
}

/// The kernels whose static estimate differs from the trace by more than [`TOLERANCE`],
/// as an error naming each; `rows` are (label, kernel name, traced cycles per call).
pub fn check(rows: &[(&str, &str, f64)]) -> Result<(), String> {
    let off: Vec<String> = rows
        .iter()
        .filter_map(|&(label, name, traced)| {
            let estimate = cycles(name)?;
            let d = difference(estimate, traced);
            (d.abs() > TOLERANCE).then(|| {
                format!(
                    "{label}: static {estimate:.0}, traced {traced:.0} cycles ({:+.0} %)",
                    100.0 * d
                )
            })
        })
        .collect();
    if off.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "the static cycle estimate is more than {:.0} % from the trace: {}",
            100.0 * TOLERANCE,
            off.join("; ")
        ))
    }
}

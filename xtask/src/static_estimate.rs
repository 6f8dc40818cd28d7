//! The compiler's static cycle estimates (the `*_CYCLES` constants of the generated
//! modules) of the cost table's kernels, against the instruction trace: the check that
//! the estimate a budget (`max_cycles = ..`) is compared with stays close to what the
//! core does.

use crate::firmware::MpcPaths;
use generated_demo::{
    cantilever, cantilever_long_window, helicopter, mass_spring_damper, navigation, piecewise_beam,
    polynomial,
};

/// The largest relative difference allowed between the static estimate and the trace.
pub const TOLERANCE: f64 = 0.15;

/// The static estimate of a call of the firmware's kernel `name`, if it has one, on
/// average over the firmware's run. The MPC's solves differ by what they recompute:
/// theirs is weighed by what the run's solves did (`paths`).
pub fn cycles(name: &str, paths: &MpcPaths) -> Option<f64> {
    let reinit_every = f64::from(polynomial::PolynomialKf::REINIT_EVERY as u32);
    let cycles = match name {
        "ekf_step" => cantilever::EKF_STEP_CYCLES,
        "dkf_step" => cantilever::DKF_STEP_CYCLES,
        "dkf_long_window_step" => cantilever_long_window::DKF_STEP_CYCLES,
        "lqr_solve" => cantilever::LQR_SOLVE_CYCLES,
        "loop" => cantilever::DKF_STEP_CYCLES + cantilever::LQR_SOLVE_CYCLES,
        "continuous_ekf_step" => helicopter::CONTINUOUS_EKF_STEP_CYCLES,
        "hybrid_ekf_step" => mass_spring_damper::HYBRID_EKF_STEP_CYCLES,
        "switched_observer_step" => piecewise_beam::SWITCHED_OBSERVER_STEP_CYCLES,
        // One step in REINIT_EVERY re-initialises instead of recursing.
        "polynomial_kf_step" => {
            let recursive = f64::from(polynomial::POLYNOMIAL_KF_STEP_CYCLES);
            let fit = f64::from(polynomial::POLYNOMIAL_KF_FIT_CYCLES);
            return Some((recursive * (reinit_every - 1.0) + fit) / reinit_every);
        }
        "mpc_solve" => return mpc_solve(paths),
        "navigation_predict" => navigation::EKF_PREDICT_CYCLES,
        "navigation_update_gnss" => navigation::EKF_UPDATE_GNSS_CYCLES,
        "navigation_update_magnetometer" => navigation::EKF_UPDATE_MAGNETOMETER_CYCLES,
        // The worst prediction: one that fuses a waiting magnetometer sample (a prediction
        // that fuses nothing has no constant of its own).
        "navigation_delayed_predict_fusing" => navigation::DELAYED_EKF_PREDICT_CYCLES,
        "navigation_delayed_update_gnss" => navigation::DELAYED_EKF_UPDATE_GNSS_CYCLES,
        "navigation_delayed_update_magnetometer" => {
            navigation::DELAYED_EKF_UPDATE_MAGNETOMETER_CYCLES
        }
        _ => return None,
    };
    Some(f64::from(cycles))
}

/// The MPC's solves on average: every one's plan, the rebuilds where they happened, and
/// the iterations run.
fn mpc_solve(paths: &MpcPaths) -> Option<f64> {
    use mass_spring_damper as blade;
    if paths.solves == 0 {
        return None;
    }
    let all = |count: u32, cycles: u32| f64::from(count) * f64::from(cycles);
    let rebuilds = all(paths.model_rebuilds, blade::MPC_PREDICTION_CYCLES)
        + all(
            paths.problem_rebuilds,
            blade::MPC_RICCATI_CYCLES + blade::MPC_CONDENSE_CYCLES,
        );
    let iterations = all(paths.iterations, blade::MPC_ITERATION_CYCLES);
    Some(f64::from(blade::MPC_PLAN_CYCLES) + (rebuilds + iterations) / f64::from(paths.solves))
}

/// `(static - traced) / traced`.
pub fn difference(estimate: f64, traced: f64) -> f64 {
    (estimate - traced) / traced.max(1.0)
}

/// The kernels whose static estimate differs from the trace by more than [`TOLERANCE`],
/// as an error naming each; `rows` are (label, kernel name, traced cycles per call), and
/// `paths` what the run's MPC solves recomputed.
pub fn check(rows: &[(&str, &str, f64)], paths: &MpcPaths) -> Result<(), String> {
    let off: Vec<String> = rows
        .iter()
        .filter_map(|&(label, name, traced)| {
            let estimate = cycles(name, paths)?;
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

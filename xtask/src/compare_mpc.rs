//! The firmware's `f32` MPC plans against the host's `f64` run of the same generated
//! controller on the same estimates (`generated_demo::mpc_sequence`, computed in `f32` on
//! both sides and widened here).

use generated_demo::mass_spring_damper::in_f64::Mpc;
use generated_demo::mass_spring_damper::Status;
use generated_demo::mpc_sequence::{mpc_tuning, BladeEstimates};

/// Agreement required of every move, as a fraction of the input range (200 V): 0.02 V,
/// the relative agreement (1e-4) of the filters' checks with the range as the scale. The
/// moves minimise a QP whose weight `R = 1e-10` is tiny beside the prediction terms, so
/// the Hessian's conditioning amplifies `f32` rounding (6e-8) well beyond it: the host's
/// `f32` run and both firmware builds differ from the `f64` run by up to 4e-5 of the range
/// (7.9e-3 V) on this sequence.
pub const RANGE_FRACTION: f64 = 1e-4;

/// The host's plans (moves) after every sample, and the most iterations of a solve.
fn host_run(samples: usize) -> Result<(Vec<Vec<f64>>, usize), String> {
    let widen = |m: [[f32; 2]; 2]| m.map(|row| row.map(f64::from));
    let r = [[f64::from(mpc_tuning::R[0][0])]];
    let limit = f64::from(mpc_tuning::U_MAX);
    let mut mpc = Mpc::new(&widen(mpc_tuning::Q), &r, &[-limit], &[limit])
        .map_err(|s| format!("the host's MPC rejected its tuning: {s:?}"))?;
    let (mut plans, mut most) = (Vec::new(), 0);
    for (k, x) in BladeEstimates::new().take(samples).enumerate() {
        let status = mpc.solve(&x.map(f64::from), &[0.0]);
        if status.status != Status::Ok {
            return Err(format!("the host's MPC at {}: {status:?}", k + 1));
        }
        most = most.max(status.iterations);
        plans.push(mpc.plan().iter().map(|u| u[0]).collect());
    }
    Ok((plans, most))
}

/// Checks every printed plan (`mpc k iterations u1..`) against the host; a summary or the
/// first disagreement.
pub fn check(target: &[(usize, Vec<f64>)]) -> Result<String, String> {
    let last = target.iter().map(|(k, _)| *k).max().unwrap_or(0);
    if last == 0 {
        return Err("the firmware printed no MPC plans".into());
    }
    let (host, most) = host_run(last)?;
    let allowed = RANGE_FRACTION * 2.0 * f64::from(mpc_tuning::U_MAX);
    let (mut worst_first, mut worst_plan) = (0.0_f64, 0.0_f64);
    for (k, values) in target {
        let expected = host
            .get(k.wrapping_sub(1))
            .ok_or_else(|| format!("MPC: the host has no sample {k}"))?;
        let moves = values.get(1..).unwrap_or_default();
        if moves.len() != expected.len() {
            return Err(format!("MPC at sample {k}: {} moves", moves.len()));
        }
        for (i, (&t, &h)) in moves.iter().zip(expected).enumerate() {
            let error = (t - h).abs();
            if error.is_nan() || error > allowed {
                return Err(format!(
                    "MPC move {} at sample {k}: target {t} V vs host {h} V (allowed {allowed} V)",
                    i + 1
                ));
            }
            worst_plan = worst_plan.max(error);
            if i == 0 {
                worst_first = worst_first.max(error);
            }
        }
    }
    Ok(format!(
        "the MPC's plans ({} solves, up to {most} active-set iterations on the host) agree \
         with the host's f64 run within {worst_first:.1e} V (first moves) and \
         {worst_plan:.1e} V (whole plans) (allowed {allowed} V)",
        target.len()
    ))
}

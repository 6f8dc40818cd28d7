//! The firmware's `f32` continuous filters against the host's `f64` run of the same
//! generated code on the same sequences (`generated_demo::continuous_sequence`, computed
//! in `f32` on both sides and widened here).

use generated_demo::continuous_sequence::{blade_tuning, helicopter_tuning, Blade, Helicopter};
use generated_demo::helicopter::in_f64::ContinuousEkf;
use generated_demo::mass_spring_damper::in_f64::HybridEkf;

/// Relative agreement required between target (`f32`) and host (`f64`).
pub const RTOL: f64 = 1e-4;
/// Per state, the magnitude below which the tolerance stops shrinking: about a tenth of
/// the state's peak over the run (helicopter: 0.04-0.15 rad, rad/s and rotor units;
/// blade: 1.2 mm, 0.07 m/s, 0.03 and 1.2 for the shaping filter, 5 1/kg), as the
/// cantilever's check uses 0.1 mm for a tip moving by millimetres.
const HELICOPTER_FLOORS: [f64; 6] = [0.01, 0.01, 0.01, 0.01, 0.01, 0.01];
const BLADE_FLOORS: [f64; 5] = [1e-4, 1e-2, 3e-3, 0.1, 0.1];

fn diag<const N: usize>(d: [f32; N]) -> [[f64; N]; N] {
    std::array::from_fn(|i| std::array::from_fn(|j| if i == j { f64::from(d[i]) } else { 0.0 }))
}

/// The host's estimates after every sample of each sequence.
fn host_runs(helicopter: usize, blade: usize) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
    let r = [
        [f64::from(helicopter_tuning::R[0]), 0.0],
        [0.0, f64::from(helicopter_tuning::R[1])],
    ];
    let mut filter = ContinuousEkf::new(
        &helicopter_tuning::X0.map(f64::from),
        &diag(helicopter_tuning::P0),
        &helicopter_tuning::Q.map(f64::from),
        &r,
    )
    .expect("the tuning is finite");
    let mut continuous = Vec::new();
    for sample in Helicopter::new().take(helicopter) {
        let _ = filter.step(
            f64::from(sample.t_prev),
            &sample.u_prev.map(f64::from),
            &sample.y.map(f64::from),
        );
        continuous.push(filter.state().to_vec());
    }
    let mut filter = HybridEkf::new(
        &blade_tuning::X0.map(f64::from),
        &diag(blade_tuning::P0),
        &blade_tuning::Q.map(f64::from),
        &[[f64::from(blade_tuning::R)]],
    )
    .expect("the tuning is finite");
    let mut hybrid = Vec::new();
    for sample in Blade::new().take(blade) {
        let _ = filter.step(&sample.u_prev.map(f64::from), &sample.y.map(f64::from));
        hybrid.push(filter.state().to_vec());
    }
    (continuous, hybrid)
}

/// Checks every printed estimate against the host; a one-line summary or the first
/// disagreement.
pub fn check(
    continuous: &[(usize, Vec<f64>)],
    hybrid: &[(usize, Vec<f64>)],
) -> Result<String, String> {
    if continuous.is_empty() || hybrid.is_empty() {
        return Err("the firmware printed no continuous or hybrid EKF estimates".into());
    }
    let last = |lines: &[(usize, Vec<f64>)]| lines.iter().map(|(k, _)| *k).max().unwrap_or(0);
    let (host_continuous, host_hybrid) = host_runs(last(continuous), last(hybrid));
    let mut worst = (0.0f64, 0.0f64);
    for (name, target, host, floors, worst) in [
        (
            "continuous EKF",
            continuous,
            &host_continuous,
            &HELICOPTER_FLOORS[..],
            &mut worst.0,
        ),
        (
            "hybrid EKF",
            hybrid,
            &host_hybrid,
            &BLADE_FLOORS[..],
            &mut worst.1,
        ),
    ] {
        for (k, values) in target {
            let expected = host
                .get(k.wrapping_sub(1))
                .ok_or_else(|| format!("{name}: the host has no sample {k}"))?;
            if values.len() != floors.len() {
                return Err(format!("{name} at sample {k}: {} values", values.len()));
            }
            for (i, ((&t, &h), &floor)) in values.iter().zip(expected).zip(floors).enumerate() {
                let error = (t - h).abs() / h.abs().max(floor);
                *worst = worst.max(error);
                if error.is_nan() || error > RTOL {
                    return Err(format!(
                        "{name} x{} at sample {k}: target {t} vs host {h} (relative {error:.1e}, allowed {RTOL:e})",
                        i + 1
                    ));
                }
            }
        }
    }
    Ok(format!(
        "the continuous EKF ({} estimates) and the hybrid EKF ({}) agree with the host's f64 run \
         within {:.1e} and {:.1e} relative (allowed {RTOL:e})",
        continuous.len(),
        hybrid.len(),
        worst.0,
        worst.1
    ))
}

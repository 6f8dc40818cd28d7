//! The firmware's `f32` runs of the compile-time designed observers (the piecewise beam's
//! linear-error-dynamics observer, the polynomial Kalman filter) against the host's `f64`
//! runs of the same generated code on the same `f32` samples.

use crate::firmware::Report;
use generated_demo::observer_sequences::{BeamMeasured, HubMeasured};
use generated_demo::piecewise_beam::in_f64::LinearErrorObserver;
use generated_demo::polynomial::in_f64::PolynomialKf;

/// Samples of each embedded sequence (`targets/build.rs`).
const SAMPLES: usize = 1000;
/// Relative agreement required between target and host.
const RTOL: f64 = 1e-4;
/// Magnitudes below which the tolerance stops shrinking: the beam's displacements [m]
/// and velocities [m/s] at a twentieth of their amplitude in this run, and the polynomial
/// filter's scaled state at about its noise (sigma T^j for x_j).
const OBSERVER_FLOORS: [f64; 6] = [1e-5, 1e-5, 1e-5, 1e-3, 1e-3, 1e-3];
const POLYKF_FLOORS: [f64; 4] = [1e-2, 1e-3, 1e-4, 1e-5];

fn host_observer() -> Vec<[f64; 6]> {
    let mut observer = LinearErrorObserver::new(&[0.0; 6]).expect("the start is finite");
    BeamMeasured::new()
        .take(SAMPLES)
        .map(|s| {
            let y = [f64::from(s.y[0]), f64::from(s.y[1])];
            let _ = observer.step(&[f64::from(s.u)], &y);
            observer.state()
        })
        .collect()
}

fn host_polykf() -> Vec<[f64; 4]> {
    // The firmware's prior (`targets/src/observers.rs`), widened exactly from f32.
    let variances = [1.0_f32, 1e-4, 2.5e-7, 2.78e-10].map(f64::from);
    let p0 =
        core::array::from_fn(|i| core::array::from_fn(|j| if i == j { variances[i] } else { 0.0 }));
    let mut kf = PolynomialKf::new(&[0.0; 4], &p0).expect("the prior is finite");
    HubMeasured::new()
        .take(SAMPLES)
        .map(|y| {
            let _ = kf.step(f64::from(y));
            kf.state()
        })
        .collect()
}

fn worst(
    target: &[(usize, Vec<f64>)],
    host: &[&[f64]],
    floors: &[f64],
    what: &str,
    from: usize,
) -> Result<f64, String> {
    if target.is_empty() {
        return Err(format!("the firmware printed no {what} estimates"));
    }
    let mut worst = 0.0_f64;
    for (k, values) in target.iter().filter(|(k, _)| *k >= from) {
        let h = host
            .get(*k)
            .ok_or_else(|| format!("the host has no {what} sample {k}"))?;
        if values.len() != h.len() {
            return Err(format!(
                "{what} sample {k}: {} values, expected {}",
                values.len(),
                h.len()
            ));
        }
        for (i, (t, h)) in values.iter().zip(h.iter()).enumerate() {
            let error = (t - h).abs() / h.abs().max(floors[i]);
            worst = worst.max(error);
            if error.is_nan() || error > RTOL {
                return Err(format!(
                    "{what} x{i} at sample {k}: target {t} vs host {h} (relative {error:.1e}, allowed {RTOL:e})"
                ));
            }
        }
    }
    Ok(worst)
}

/// Checks both runs; a one-line summary, or the first disagreement.
pub fn check(report: &Report) -> Result<String, String> {
    let observer = host_observer();
    let observer: Vec<&[f64]> = observer.iter().map(|x| &x[..]).collect();
    let polykf = host_polykf();
    let polykf: Vec<&[f64]> = polykf.iter().map(|x| &x[..]).collect();
    let a = worst(
        &report.observer,
        &observer,
        &OBSERVER_FLOORS,
        "switched observer",
        0,
    )?;
    // From the first re-initialisation: before it the filter runs from its prior, whose
    // first updates (a 4-state estimate from a handful of noisy samples) lose digits in
    // f32 (3e-4 relative at sample 9); the fit is what puts the filter on its footing.
    let first_fit = PolynomialKf::REINIT_EVERY - 1;
    let b = worst(
        &report.polykf,
        &polykf,
        &POLYKF_FLOORS,
        "polynomial KF",
        first_fit,
    )?;
    Ok(format!(
        "{} switched-observer estimates and the polynomial KF's from its first \
         re-initialisation (sample {first_fit}) agree with the host's f64 run within {a:.1e} \
         and {b:.1e} relative (allowed {RTOL:e})",
        report.observer.len()
    ))
}

//! The twin-rotor helicopter of Kulkarni and Purwar ("Nonlinear experimental
//! estimation and verification of a MIMO system through EKF", sect. 6) on a simulation of
//! its own model (eq. 2, `generated-demo/models/helicopter.rs`) with the generated
//! continuous-time EKF: the standard filter (eq. 5, `alpha = 0`) against the one with a
//! prescribed degree of stability (eq. 26), from the paper's wrong initial estimate, with
//! the paper's multi-sine input, `Q`, `R` and `P0`; then a run with an unmodelled surge of
//! the motors' supply at 25 s (sect. 6.2), which the filters do not see.

use super::metrics::rms;
use super::report::{self, Line, Trace};
use generated_demo::helicopter::in_f64::{f, h, ContinuousEkf, Status, TS};
use generated_demo::noise::GaussianNoise;
use std::error::Error;
use std::path::Path;

/// The paper's run time \[s\] (sect. 6.1).
const END: f64 = 30.0;
/// The paper's tuning (sect. 4): `Q`, `R` (diagonals) and `P0 = gamma diag(..)`, gamma = 1.
const Q: [f64; 6] = [0.0099, 0.0022, 0.0894, 0.0017, 1.2678, 1.2700];
const R: [f64; 2] = [0.0007, 0.00193];
const P0: [f64; 6] = [1.05, 0.05, 1.0, 1.0, 1.0, 1.0];
/// The paper's initial states of plant and estimator (sect. 6.1).
const X0_ESTIMATE: [f64; 6] = [0.05, 0.0, -0.05, 0.0, 0.0, 0.0];
/// Encoder noise standard deviations \[rad\], the paper's "measurement noise1" values.
const NOISE: [f64; 2] = [0.000235, 0.0008];
/// The surge: an unmodelled extra voltage on both motors from 25 s for 1 s.
const SURGE: (f64, f64, f64) = (25.0, 26.0, 0.2);

/// The paper's multi-sine control signal, on both rotors (sect. 6.1).
fn multi_sine(t: f64) -> [f64; 2] {
    let u = 0.2 * (0.4 * t).sin() + 0.4 * (0.6 * t).sin() + 0.05 * (0.8 * t).sin();
    [u, u]
}

/// One run: the plant, and a standard and a prescribed-stability filter on its outputs.
fn run_once(alpha: f64, surge: bool, trace: &mut Trace, tag: &str) -> Result<(), Box<dyn Error>> {
    let p0: [[f64; 6]; 6] =
        std::array::from_fn(|i| std::array::from_fn(|j| if i == j { P0[i] } else { 0.0 }));
    let r = [[R[0], 0.0], [0.0, R[1]]];
    let filter = ContinuousEkf::new(&X0_ESTIMATE, &p0, &Q, &r)
        .map_err(|status| format!("the filter's tuning was rejected: {status:?}"))?;
    let mut filters = [0.0, alpha].map(|a| {
        let mut filter = filter;
        (filter.set_alpha(a), filter)
    });
    if filters.iter().any(|(status, _)| *status != Status::Ok) {
        return Err("the degree of stability was rejected".into());
    }
    let noise = [
        GaussianNoise::new(NOISE[0], 41),
        GaussianNoise::new(NOISE[1], 42),
    ];
    let mut truth = [0.0; 6];
    let samples = (END / TS).round() as u64;
    for k in 1..=samples {
        let t_prev = (k - 1) as f64 * TS;
        let commanded = multi_sine(t_prev);
        let extra = if surge && (SURGE.0..SURGE.1).contains(&t_prev) {
            SURGE.2
        } else {
            0.0
        };
        truth = f(t_prev, &truth, &commanded.map(|u| u + extra));
        let t = t_prev + TS;
        let clean = h(t, &truth);
        let y = [clean[0] + noise[0].sample(k), clean[1] + noise[1].sample(k)];
        if k % 10 == 0 {
            trace.begin(t);
            trace.set(&format!("{tag} psi true"), truth[0]);
            trace.set(&format!("{tag} phi true"), truth[2]);
        }
        for (i, (_, filter)) in filters.iter_mut().enumerate() {
            let status = filter.step(t_prev, &commanded, &y);
            if status != Status::Ok {
                return Err(format!("{tag}: filter {i} at {t:.3} s: {status:?}").into());
            }
            if k % 10 == 0 {
                let label = if i == 0 { "standard" } else { "alpha" };
                let x = filter.state();
                for (name, index) in [("psi", 0), ("dpsi", 1), ("phi", 2), ("dphi", 3)] {
                    trace.set(
                        &format!("{tag} {label} {name} error"),
                        x[index] - truth[index],
                    );
                }
                trace.set(&format!("{tag} {label} psi"), x[0]);
            }
        }
    }
    Ok(())
}

/// Runs both experiments, prints the table, writes `out/helicopter.csv` and
/// `out/helicopter_pitch.svg`.
pub fn run(out: &Path) -> Result<(), Box<dyn Error>> {
    let alpha = ContinuousEkf::ALPHA;
    let mut trace = Trace::new();
    run_once(alpha, false, &mut trace, "nominal")?;
    let mut surged = Trace::new();
    run_once(alpha, true, &mut surged, "surge")?;
    print_errors(&trace, &surged, alpha);
    write_figures(out, &trace, &surged)
}

/// The table: each observer's RMS estimation errors, over the run and over 25-30 s, in the
/// nominal and the surge runs, with the paper's.
fn print_errors(trace: &Trace, surged: &Trace, alpha: f64) {
    println!("\nHelicopter (TRMS) of Kulkarni and Purwar, \"Nonlinear experimental estimation and");
    println!("verification of a MIMO system through EKF\": continuous-time EKF (eq. 5, RK4 of");
    println!("the whole equations per 1 ms, split while stiff), multi-sine input, estimate");
    println!(
        "from x0 = [0.05 0 -0.05 0 0 0], encoder noise sigma [{} {}] rad, the paper's Q, R, P0;",
        NOISE[0], NOISE[1]
    );
    println!("RMS estimation errors (rad, rad/s):\n");
    println!(
        "{:<40} {:>9} {:>9} {:>9} {:>9}   {:>9} {:>9}",
        "observer", "E1rms", "E3rms", "psi'", "phi'", "E1 25-30", "E3 25-30"
    );
    for (run, tag, name) in [(trace, "nominal", ""), (surged, "surge", ", surge at 25 s")] {
        for (label, title) in [("standard", "standard Pdot"), ("alpha", "modified Pdot")] {
            let error = |state: &str, from: f64, to: f64| {
                let column = run
                    .column(&format!("{tag} {label} {state} error"))
                    .unwrap_or(&[]);
                rms(run.time(), column, from, to)
            };
            let title = if label == "alpha" {
                format!("{title} (alpha {alpha}){name}")
            } else {
                format!("{title}{name}")
            };
            println!(
                "{title:<40} {:>9.5} {:>9.5} {:>9.5} {:>9.5}   {:>9.5} {:>9.5}",
                error("psi", 0.0, END),
                error("phi", 0.0, END),
                error("dpsi", 0.0, END),
                error("dphi", 0.0, END),
                error("psi", 25.0, END),
                error("phi", 25.0, END),
            );
        }
    }
    println!(
        "{:<40} {:>9.5} {:>9.5}",
        "paper, standard Pdot", 0.0016, 0.0017
    );
    println!(
        "{:<40} {:>9.5} {:>9.5}",
        "paper, modified Pdot", 0.0016, 0.0018
    );
    println!(
        "(surge: +{} on both motors' voltage from {} to {} s, unknown to the filters)",
        SURGE.2, SURGE.0, SURGE.1
    );
}

/// `out/helicopter.csv`, `out/helicopter_surge.csv` and the figures: the pitch error of
/// both observers, and the pitch through the supply surge.
fn write_figures(out: &Path, trace: &Trace, surged: &Trace) -> Result<(), Box<dyn Error>> {
    report::write_csv(trace, std::fs::File::create(out.join("helicopter.csv"))?)?;
    report::write_csv(
        surged,
        std::fs::File::create(out.join("helicopter_surge.csv"))?,
    )?;
    let names = ["nominal standard psi error", "nominal alpha psi error"];
    let lines: Vec<Line> = names.iter().filter_map(|n| trace.line(n)).collect();
    report::plot_lines(
        &out.join("helicopter_pitch.svg"),
        "Pitch estimation error, standard and modified Pdot",
        "psi error [rad]",
        &lines,
        Some((-0.01, 0.01)),
    )?;
    let names = ["surge psi true", "surge standard psi", "surge alpha psi"];
    let lines: Vec<Line> = names.iter().filter_map(|n| surged.line(n)).collect();
    report::plot_lines(
        &out.join("helicopter_surge.svg"),
        "Pitch with a supply surge at 25 s",
        "psi [rad]",
        &lines,
        None,
    )?;
    Ok(())
}

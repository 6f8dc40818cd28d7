//! The blade of Takács, Polóni and Rohal-Ilkiv ("Adaptive predictive control of
//! transient vibrations of cantilevers with changing weight", sect. 4) on a simulated
//! mass-spring-damper with the generated hybrid EKFs (500 Euler sub-steps per 10 ms
//! sample, as the paper's `dt = T/500`):
//!
//! - identification mode, 0-20 s: white-noise input, no disturbance, the six-state filter
//!   of eq. (19) (`blade_identification`) from the paper's `x0`, `P0`, `R`, `Q~`;
//! - control mode, 20-80 s: the five-state filter of eq. (20) (`mass_spring_damper`, `k`,
//!   `b`, `c` fixed, a second-order shaping filter for the disturbance) on a blade hit
//!   every 4 s whose mass rises by 54 g between 40 and 60 s.
//!
//! Here the blade runs open loop with a small white-noise dither in control mode; the
//! controllers of sect. 4 are compared in `blade_control`, with the same control filter.

use super::blade_plant::{
    mass, median_of_last, plant_step, ADDED_MASS, B, C, END, HIT_EVERY, HIT_FORCE,
    IDENTIFICATION_END, K, LOADED, M, NOISE_SIGMA,
};
use super::diag;
use super::metrics::mean;
use super::report::{self, Line, Trace};
use generated_demo::noise::GaussianNoise;
use generated_demo::{blade_identification as ident, mass_spring_damper as control};
use std::error::Error;
use std::path::Path;

/// White input: sigma 50 V clipped to +-100 V in identification; a 5 V dither after.
const INPUT_SIGMA: f64 = 50.0;
const DITHER_SIGMA: f64 = 5.0;

/// Seconds after `from` until `series` enters and stays (for 2 s) within 5 % of `target`.
fn tracking_delay(t: &[f64], series: &[f64], from: f64, to: f64, target: f64) -> Option<f64> {
    let inside = |v: f64| (v / target - 1.0).abs() <= 0.05;
    let start = t.iter().position(|&s| s >= from)?;
    let end = t.iter().position(|&s| s >= to).unwrap_or(t.len());
    (start..end)
        .find(|&i| {
            let hold = t[i] + 2.0;
            (i..end)
                .take_while(|&j| t[j] <= hold)
                .all(|j| inside(series[j]))
        })
        .map(|i| t[i] - from)
}

/// The control-mode filter of eq. (20) with the paper's tuning (sect. 4.1): x0 = [0 0 2 0
/// 0], P0 = diag\[1e-5 1 1e-4 0 0\], R_C = 1e-6, Q~_C = diag[2 alpha_n (0.63 F_e)^2, 1e2] on
/// the shaping filter's drive and on 1/m (the filter's process noise enters `eta2` and
/// `inv_m` only), Q = Q~ / T.
pub fn control_ekf() -> control::in_f64::HybridEkf {
    let ts = control::in_f64::TS;
    let alpha_n = control::in_f64::ALPHA_N;
    let q_control = [2.0 * alpha_n * (0.63 * HIT_FORCE).powi(2) / ts, 1e2 / ts];
    control::in_f64::HybridEkf::new(
        &[0.0, 0.0, 0.0, 0.0, 2.0],
        &diag([1e-5, 1.0, 0.0, 0.0, 1e-4]),
        &q_control,
        &[[1e-6]],
    )
    .expect("the prior and the noise densities are finite")
}

/// Runs both modes, prints the tables, writes `out/blade.csv`, `out/blade_mass.svg` and
/// `out/blade_identification.svg`.
pub fn run(out: &Path) -> Result<(), Box<dyn Error>> {
    let (trace, rejected) = simulate();
    let time = trace.time().to_vec();
    let column = |name: &str| trace.column(name).unwrap_or(&[]).to_vec();
    print_identification(&time, &column);
    print_control(&time, &column);
    if rejected > 0 {
        println!("{rejected} filter steps were rejected");
    }
    write_figures(out, &trace)
}

/// The experiment: identification mode until `IDENTIFICATION_END`, then control mode, each
/// sample's truth and estimates traced; and how many filter steps were rejected.
fn simulate() -> (Trace, u32) {
    let ts = ident::in_f64::TS;
    // sect. 4.1: x0, P0, R_I; Q~_I has five entries for six states in the text: read as
    // [q', k, b, c, 1/m] with no noise on the position, Q = Q~ / T.
    let q_ident = [0.0, 1e-4, 10.0, 1e-5, 1e-11, 1e-2].map(|q| q / ts);
    let mut identification = ident::in_f64::HybridEkf::new(
        &[0.0, 0.0, 450.0, 0.1, 5e-4, 2.0],
        &diag([1e-5, 1.0, 1e4, 1e-2, 1e-6, 0.1]),
        &q_ident,
        &[[1e-10]],
    )
    .expect("the prior and the noise densities are finite");
    let mut controlled: Option<control::in_f64::HybridEkf> = None;
    let input = GaussianNoise::new(1.0, 11);
    let noise = GaussianNoise::new(NOISE_SIGMA, 12);
    let mut trace = Trace::new();
    let mut x = [0.0; 2];
    let mut u_prev = 0.0;
    let mut rejected = 0;
    let mut raw_masses = Vec::new();
    let samples = (END / ts).round() as u64;
    for k in 1..=samples {
        let t_prev = (k - 1) as f64 * ts;
        let t = k as f64 * ts;
        x = plant_step(t_prev, x, u_prev, ts, HIT_FORCE);
        let y = x[0] + noise.sample(k);
        trace.begin(t);
        trace.set("q true", x[0]);
        trace.set("m true", mass(t));
        trace.set("u", u_prev);
        let accepted = if t <= IDENTIFICATION_END + 1e-9 {
            identify(&mut identification, u_prev, y, &mut trace)
        } else {
            let filter = controlled.get_or_insert_with(control_ekf);
            track_mass(filter, u_prev, y, &mut raw_masses, &mut trace)
        };
        if !accepted {
            rejected += 1;
        }
        let sigma = if t < IDENTIFICATION_END {
            INPUT_SIGMA
        } else {
            DITHER_SIGMA
        };
        u_prev = (sigma * input.sample(k)).clamp(-100.0, 100.0);
    }
    (trace, rejected)
}

/// One identification-mode sample (eq. 19): the filter's step, its estimates traced;
/// whether the step was accepted.
fn identify(filter: &mut ident::in_f64::HybridEkf, u_prev: f64, y: f64, trace: &mut Trace) -> bool {
    let accepted = filter.step(&[u_prev], &[y]) == ident::in_f64::Status::Ok;
    let [q, _, k_hat, b_hat, c_hat, inv_m] = filter.state();
    for (name, v) in [
        ("q id", q),
        ("k id", k_hat),
        ("b id", b_hat),
        ("c id", c_hat),
    ] {
        trace.set(name, v);
    }
    trace.set("m id", 1.0 / inv_m);
    accepted
}

/// One control-mode sample (eq. 20): the filter's step, its mass estimate traced raw and
/// as the median of the last 50; whether the step was accepted.
fn track_mass(
    filter: &mut control::in_f64::HybridEkf,
    u_prev: f64,
    y: f64,
    raw_masses: &mut Vec<f64>,
    trace: &mut Trace,
) -> bool {
    let accepted = filter.step(&[u_prev], &[y]) == control::in_f64::Status::Ok;
    let [q, _, _, _, inv_m] = filter.state();
    trace.set("q control", q);
    trace.set("m control", 1.0 / inv_m);
    raw_masses.push(1.0 / inv_m);
    trace.set("m median", median_of_last(raw_masses, 50));
    accepted
}

/// The identification mode's table: the truth, the EKF's means over 15-20 s, the paper's.
fn print_identification(time: &[f64], column: &dyn Fn(&str) -> Vec<f64>) {
    println!(
        "\nBlade of Takács, Polóni and Rohal-Ilkiv, \"Adaptive predictive control of transient"
    );
    println!(
        "vibrations of cantilevers with changing weight\", identification mode (eq. 19, hybrid"
    );
    println!("EKF, 500 Euler sub-steps per 10 ms sample; white input sigma {INPUT_SIGMA} V, laser");
    println!("noise {NOISE_SIGMA} m), means over 15-20 s:\n");
    println!(
        "{:<10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10}",
        "", "k", "b", "c", "m", "k/m", "b/m", "c/m"
    );
    let at = |name: &str| mean(time, &column(name), 15.0, IDENTIFICATION_END);
    let (k_hat, b_hat, c_hat, m_hat) = (at("k id"), at("b id"), at("c id"), at("m id"));
    println!(
        "{:<10} {:>10.1} {:>10.4} {:>10.3e} {:>10.4} {:>10.1} {:>10.4} {:>10.3e}",
        "truth",
        K,
        B,
        C,
        M,
        K / M,
        B / M,
        C / M
    );
    println!(
        "{:<10} {:>10.1} {:>10.4} {:>10.3e} {:>10.4} {:>10.1} {:>10.4} {:>10.3e}",
        "EKF",
        k_hat,
        b_hat,
        c_hat,
        m_hat,
        k_hat / m_hat,
        b_hat / m_hat,
        c_hat / m_hat
    );
    println!(
        "{:<10} {:>10.1} {:>10.4} {:>10.3e} {:>10.4}",
        "paper", 533.0, 0.11, 8.0e-4, 0.20
    );
    println!("(eq. 19 determines k/m, b/m and c/m; how they split into k, b, c and m rests on");
    println!("the prior x0, P0, as in the paper.)");
}

/// The control mode's table: the mass estimate, raw and median, per window of the added
/// mass, and how long the median took to follow each change.
fn print_control(time: &[f64], column: &dyn Fn(&str) -> Vec<f64>) {
    let median = column("m median");
    let m_loaded = M + ADDED_MASS;
    println!("\nControl mode (eq. 20: 1/m and a shaping filter; k, b, c fixed), hits every {HIT_EVERY} s,");
    println!(
        "+{:.0} g from {} to {} s; mass estimate m = 1/x3, raw and 50-sample median:\n",
        ADDED_MASS * 1e3,
        LOADED.0,
        LOADED.1
    );
    println!(
        "{:<22} {:>8} {:>8} {:>8} {:>14}",
        "window", "true m", "raw", "median", "tracking delay"
    );
    let windows = [
        ("nominal 25-40 s", 25.0, LOADED.0, M, None),
        (
            "loaded 40-60 s",
            LOADED.0,
            LOADED.1,
            m_loaded,
            Some(LOADED.0),
        ),
        ("nominal again 60-80 s", LOADED.1, END, M, Some(LOADED.1)),
    ];
    for (label, from, to, truth, change) in windows {
        let raw = mean(
            time,
            &column("m control"),
            from.max(from + 5.0 * f64::from(change.is_some())),
            to,
        );
        let filtered = mean(
            time,
            &median,
            from.max(from + 5.0 * f64::from(change.is_some())),
            to,
        );
        let delay = change
            .and_then(|c| tracking_delay(time, &median, c, to, truth))
            .map_or_else(|| "-".to_owned(), |d| format!("{d:.2} s"));
        println!("{label:<22} {truth:>8.4} {raw:>8.4} {filtered:>8.4} {delay:>14}");
    }
    println!("(means after the first 5 s of each window; delay: until the median stays within 5 % for 2 s)");
}

/// `out/blade.csv` and the figures: the mass estimate, and the identified spring constant.
fn write_figures(out: &Path, trace: &Trace) -> Result<(), Box<dyn Error>> {
    report::write_csv(trace, std::fs::File::create(out.join("blade.csv"))?)?;
    let lines: Vec<Line> = ["m true", "m control", "m median"]
        .iter()
        .filter_map(|n| trace.line(n))
        .collect();
    report::plot_lines(
        &out.join("blade_mass.svg"),
        "Blade mass estimate (control mode)",
        "m [kg]",
        &lines,
        Some((0.0, 0.6)),
    )?;
    let lines: Vec<Line> = ["k id"].iter().filter_map(|n| trace.line(n)).collect();
    report::plot_lines(
        &out.join("blade_identification.svg"),
        "Identified spring constant",
        "k [N/m]",
        &lines,
        None,
    )?;
    Ok(())
}

//! The piecewise linear beam report (observers for a beam with a one-sided spring: linear
//! error dynamics, a switched Kalman filter; our copy has lost its title page): the
//! generated switched observers on a simulated piecewise-linear beam, and the two-regime
//! example of its Fig. 3.1.
//!
//! The true beam is the continuous 3-DOF model (eq. 2.1-2.2, the reconstructed matrices of
//! `models/piecewise_beam.rs`) integrated by RK4 with 20 steps per 0.5 ms sample (the
//! paper simulates with RK4), driven by the mass-unbalance force of eq. (2.3); the
//! observers see LVDT displacements with white noise of variance `R_LVDT` and the force
//! sampled and held. They are switched on after a 2 s run-in from a zero estimate (a wrong
//! initial state, as in sect. 5.2), and the errors are measured over the last two response
//! periods, as the report's Tables 5.1-6.2: `SSE = 1/T int e^2 dt` and `|e|max`.

use super::report::{self, Line, Trace};
use generated_demo::noise::GaussianNoise;
use generated_demo::piecewise_beam::in_f64 as beam;
use std::error::Error;
use std::path::Path;

/// RK4 steps per sample for the true beam.
const SUBSTEPS: usize = 20;
/// Run-in before the observers start \[s\].
const RUN_IN: f64 = 2.0;
/// Observer run \[s\].
const RUN: f64 = 1.0;
/// The three generated observers, in table order.
const OBSERVERS: [&str; 3] = ["common gain", "linear error", "switched Kalman"];

/// `M^-1 (h u - h f_nl - B q' - K q)`, eq. (2.1)-(2.2), for `x = [q; q']`.
fn derivative(x: &[f64; 6], u: f64) -> [f64; 6] {
    use beam::*;
    let [q_act, q_mid, xi, v_act, v_mid, v_xi] = *x;
    let f_nl = if q_mid > 0.0 { K_NL * q_mid } else { 0.0 };
    let f_act = -(B11 * v_act + B12 * v_mid + B13 * v_xi) - (K11 * q_act + K12 * q_mid + K13 * xi);
    let f_mid = u
        - f_nl
        - (B12 * v_act + B22 * v_mid + B23 * v_xi)
        - (K12 * q_act + K22 * q_mid + K23 * xi);
    let f_xi = -(B13 * v_act + B23 * v_mid + B33 * v_xi) - (K13 * q_act + K23 * q_mid + K33 * xi);
    [
        v_act,
        v_mid,
        v_xi,
        MI11 * f_act + MI12 * f_mid + MI13 * f_xi,
        MI12 * f_act + MI22 * f_mid + MI23 * f_xi,
        MI13 * f_act + MI23 * f_mid + MI33 * f_xi,
    ]
}

/// The mass-unbalance force at time `t`, eq. (2.3): `c_h (2 pi f)^2 sin(2 pi f t)`.
fn force(freq: f64, t: f64) -> f64 {
    let w = 2.0 * std::f64::consts::PI * freq;
    beam::C_H * w * w * (w * t).sin()
}

/// One sample of the true beam by RK4 substeps.
fn advance(x: &mut [f64; 6], t: f64, freq: f64) {
    let h = beam::TS / SUBSTEPS as f64;
    for s in 0..SUBSTEPS {
        let t0 = t + s as f64 * h;
        let at = |x: &[f64; 6], k: &[f64; 6], a: f64| -> [f64; 6] {
            core::array::from_fn(|i| x[i] + a * k[i])
        };
        let k1 = derivative(x, force(freq, t0));
        let k2 = derivative(&at(x, &k1, h / 2.0), force(freq, t0 + h / 2.0));
        let k3 = derivative(&at(x, &k2, h / 2.0), force(freq, t0 + h / 2.0));
        let k4 = derivative(&at(x, &k3, h), force(freq, t0 + h));
        for i in 0..6 {
            x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    }
}

/// Error measures of one observer over the evaluation window: SSE and |e|max of q_act,
/// q_mid, v_act, v_mid.
struct Errors {
    sse: [f64; 4],
    max: [f64; 4],
}

/// The largest |value| of the true q_act, q_mid, v_act, v_mid over the window, to read
/// the errors against.
type Amplitudes = [f64; 4];

/// One frequency: the beam, the three observers, the trace and the errors.
fn run(freq: f64, response_periods: f64) -> (Trace, Vec<Errors>, Amplitudes) {
    let noise = [
        GaussianNoise::new(beam::R_LVDT.sqrt(), 31),
        GaussianNoise::new(beam::R_LVDT.sqrt(), 32),
    ];
    let mut x = [0.0; 6];
    let mut t = 0.0;
    let run_in = (RUN_IN / beam::TS).round() as usize;
    for _ in 0..run_in {
        advance(&mut x, t, freq);
        t += beam::TS;
    }
    let start = [0.0; 6];
    let finite = "the start is finite";
    let mut common = beam::CommonGainObserver::new(&start).expect(finite);
    let mut linear = beam::LinearErrorObserver::new(&start).expect(finite);
    let mut kalman = beam::SwitchedKalmanObserver::new(&start).expect(finite);
    let steps = (RUN / beam::TS).round() as usize;
    // Two response periods at the end: T = response_periods / f.
    let window = 2.0 * response_periods / freq;
    let mut sums = [[0.0; 4]; 3];
    let mut maxima = [[0.0_f64; 4]; 3];
    let mut amplitudes = [0.0_f64; 4];
    let mut trace = Trace::new();
    for k in 0..steps {
        let tk = t - RUN_IN;
        let y = [
            x[0] + noise[0].sample(k as u64),
            x[1] + noise[1].sample(k as u64),
        ];
        let u = force(freq, t);
        trace.begin(tk);
        trace.set("q_mid", x[1]);
        trace.set("v_mid", x[4]);
        trace.set("u", u);
        let estimates = [common.state(), linear.state(), kalman.state()];
        for (name, xhat) in OBSERVERS.iter().zip(&estimates) {
            trace.set(&format!("{name} q_mid"), xhat[1]);
            trace.set(&format!("{name} v_mid"), xhat[4]);
        }
        if tk >= RUN - window {
            for (j, &i) in [0, 1, 3, 4].iter().enumerate() {
                amplitudes[j] = amplitudes[j].max(x[i].abs());
            }
            for (o, xhat) in estimates.iter().enumerate() {
                for (j, &i) in [0, 1, 3, 4].iter().enumerate() {
                    let e = x[i] - xhat[i];
                    sums[o][j] += e * e * beam::TS;
                    maxima[o][j] = maxima[o][j].max(e.abs());
                }
            }
        }
        let _ = common.step(&[u], &y);
        let _ = linear.step(&[u], &y);
        let _ = kalman.step(&[u], &y);
        advance(&mut x, t, freq);
        t += beam::TS;
    }
    let errors = (0..3)
        .map(|o| Errors {
            sse: sums[o].map(|s| s / window),
            max: maxima[o],
        })
        .collect();
    (trace, errors, amplitudes)
}

/// Runs the piecewise linear beam experiment: prints the tables, writes CSV and SVG into `out`.
pub fn experiment(out: &Path) -> Result<(), Box<dyn Error>> {
    println!("\nSwitched observers, the piecewise linear beam report (linear error dynamics,");
    println!("switched Kalman filter): true beam by RK4, LVDT");
    println!(
        "noise sigma {:.0e} m, sample time {} s; observers start from a zero estimate after a {RUN_IN} s run-in.",
        beam::R_LVDT.sqrt(),
        beam::TS
    );
    println!(
        "Errors over the last two response periods of a {RUN} s run (the report's Tables 5.1-6.2):"
    );
    for (freq, periods, file) in [(20.0, 1.0, "beam_20hz.csv"), (35.0, 2.0, "beam_35hz.csv")] {
        let (trace, errors, amplitudes) = run(freq, periods);
        println!(
            "\n{freq} Hz ({}-periodic response assumed for the window)",
            periods as u32
        );
        println!(
            "{:<16} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10} {:>10}",
            "observer",
            "SSE q_act",
            "SSE q_mid",
            "max q_act",
            "max q_mid",
            "SSE v_act",
            "SSE v_mid",
            "max v_act",
            "max v_mid"
        );
        for (name, e) in OBSERVERS.iter().zip(&errors) {
            println!(
                "{:<16} {:>10.2e} {:>10.2e} {:>10.2e} {:>10.2e} {:>10.2e} {:>10.2e} {:>10.2e} {:>10.2e}",
                name, e.sse[0], e.sse[1], e.max[0], e.max[1], e.sse[2], e.sse[3], e.max[2], e.max[3]
            );
        }
        let a = amplitudes;
        println!(
            "{:<16} {:>10} {:>10} {:>10.2e} {:>10.2e} {:>10} {:>10} {:>10.2e} {:>10.2e}",
            "(truth, max |.|)", "", "", a[0], a[1], "", "", a[2], a[3]
        );
        report::write_csv(&trace, std::fs::File::create(out.join(file))?)?;
        if freq == 35.0 {
            let names = [
                "v_mid",
                "common gain v_mid",
                "linear error v_mid",
                "switched Kalman v_mid",
            ];
            let lines: Vec<Line> = names.iter().filter_map(|n| trace.line(n)).collect();
            report::plot_lines(
                &out.join("beam_velocity.svg"),
                "Piecewise linear beam: velocity of the middle at 35 Hz, observers from a zero estimate",
                "v_mid [m/s]",
                &lines,
                None,
            )?;
        }
    }
    println!("(SSE in m^2 and (m/s)^2, max in m and m/s.)");
    switching_example(out)
}

/// Fig. 3.1: two stable linear systems whose switching on the sign of `x1 x2` diverges.
/// As error dynamics: the common gain leaves the error switching between them; an
/// observer with linear error dynamics keeps it in one of them (`A1`) whatever the
/// switching. Integrated by RK4 with a 1 ms step.
fn switching_example(out: &Path) -> Result<(), Box<dyn Error>> {
    // The report's matrices (OCR-damaged; this reading is the one where both are stable and
    // their switching diverges, as the figure shows).
    const A1: [[f64; 2]; 2] = [[-0.4, 10.0], [-10.0, -1.0]];
    const A2: [[f64; 2]; 2] = [[-1.2, 1.0], [-10.0, -1.0]];
    let rhs = |a: &[[f64; 2]; 2], e: [f64; 2]| {
        [
            a[0][0] * e[0] + a[0][1] * e[1],
            a[1][0] * e[0] + a[1][1] * e[1],
        ]
    };
    let switched = |e: [f64; 2]| {
        if e[0] * e[1] > 0.0 {
            rhs(&A1, e)
        } else {
            rhs(&A2, e)
        }
    };
    let linear = |e: [f64; 2]| rhs(&A1, e);
    let dt = 1e-3;
    let rk4 = |f: &dyn Fn([f64; 2]) -> [f64; 2], e: [f64; 2]| {
        let at = |k: [f64; 2], a: f64| [e[0] + a * k[0], e[1] + a * k[1]];
        let k1 = f(e);
        let k2 = f(at(k1, dt / 2.0));
        let k3 = f(at(k2, dt / 2.0));
        let k4 = f(at(k3, dt));
        [0, 1].map(|i| e[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
    };
    let mut e_common = [1.0, 0.5];
    let mut e_linear = e_common;
    let mut e_a2 = e_common;
    let mut trace = Trace::new();
    println!("\nFig. 3.1 example: error norm |e| from e(0) = [1, 0.5]");
    println!(
        "{:>6} {:>14} {:>14} {:>14}",
        "t [s]", "common gain", "linear error", "A2 alone"
    );
    let norm = |e: [f64; 2]| e[0].hypot(e[1]);
    for k in 0..=10_000 {
        let t = k as f64 * dt;
        if k % 2000 == 0 {
            println!(
                "{t:>6.1} {:>14.3e} {:>14.3e} {:>14.3e}",
                norm(e_common),
                norm(e_linear),
                norm(e_a2)
            );
        }
        trace.begin(t);
        trace.set("log10 |e| common gain", norm(e_common).log10());
        trace.set("log10 |e| linear error", norm(e_linear).log10());
        trace.set("log10 |e| A2 alone", norm(e_a2).log10());
        e_common = rk4(&switched, e_common);
        e_linear = rk4(&linear, e_linear);
        e_a2 = rk4(&|e| rhs(&A2, e), e_a2);
    }
    report::write_csv(
        &trace,
        std::fs::File::create(out.join("switching_example.csv"))?,
    )?;
    let names = [
        "log10 |e| common gain",
        "log10 |e| linear error",
        "log10 |e| A2 alone",
    ];
    let lines: Vec<Line> = names.iter().filter_map(|n| trace.line(n)).collect();
    report::plot_lines(
        &out.join("switching_example.svg"),
        "Piecewise linear beam report, Fig. 3.1: switching two stable error dynamics diverges",
        "log10 |e|",
        &lines,
        None,
    )?;
    Ok(())
}

//! The main job (`cargo run --release -p generated-demo`): the cantilever experiment of
//! the double Kalman filter paper (EKF against DKF, adaptive LQR) run on a simulated beam
//! with the generated filters and controller, then the experiments of the other papers.
//!
//! 1. Parameter estimation (Table 1 of the paper): the generated EKF and DKF (with its
//!    AKF) from the paper's close and wrong initial guesses, on PRBS excitation with
//!    measurement noise; the tip mass is detached at 20 s.
//! 2. Adaptive LQR (Alg. 3) closed loop with two stinger hits: RMS tip displacement for
//!    open loop, EKF-LQR and DKF-LQR.
//! 3. Traces as CSV and plots as SVG in `out/`, and what the generated code costs.
//! 4. The blade of Takács, Polóni and Rohal-Ilkiv ("Adaptive predictive control of
//!    transient vibrations of cantilevers with changing weight") with the generated hybrid
//!    EKFs (`experiment::blade`), its controller comparison (adaptive EKF-MPC, nominal LQ,
//!    PPF, open loop: `experiment::blade_control`) repeated on a blade more like the
//!    experiment, feature by feature (`experiment::blade_ablation`), and the helicopter of Kulkarni and
//!    Purwar ("Nonlinear experimental estimation and verification of a MIMO system through
//!    EKF") with the continuous-time EKF, standard and with a prescribed degree of
//!    stability (`experiment::trms`).
//! 5. The piecewise linear beam report (observers with linear error dynamics, a switched
//!    Kalman filter): the generated switched observers on a piecewise-linear beam, and
//!    the switching example of its Fig. 3.1 ([`experiment::switched_beam`]).
//! 6. Shults, Brubaker and Lee ("A fast algorithm for control and estimation using a
//!    polynomial state-space structure"): the generated polynomial Kalman filter on a hub
//!    signal for several fading factors and re-initialisation periods
//!    ([`experiment::hub_polynomial`]).
//! 7. TinyMPC's quadrotor held by the generated MPC with limits on its motors' changes,
//!    tilt (hard) and speed (soft) through a gust ([`experiment::quadrotor_limits`]).
//!
//! The host runs the generated `f64` code; the `f32` code is what runs on the MCU.

mod experiment;

use experiment::excitation::Prbs;
use experiment::metrics::rms;
use experiment::plant::{saturate, Kick, MassChange, Physical, Plant, PlantConfig};
use experiment::report::{self, Line, Trace};
use experiment::tuning::{p0, Q_DIAG, R, X0_CLOSE, X0_WRONG};
use experiment::TS;
use generated_demo::cantilever;
use generated_demo::cantilever::in_f64::{Dkf, Ekf, Lqr, Status};
use std::error::Error;
use std::path::Path;
use std::time::Instant;

/// In the closed loop a stinger hit is a jump of the tip velocity the model cannot
/// predict: with no process noise on `x2` the filters would explain it by the parameters
/// (the gain's sign flips, and so does the feedback). 100 (mm/s)^2 per sample lets it be
/// a velocity disturbance, as it is.
const Q_DIAG_CONTROL: [f64; 5] = [0.0, 100.0, 100.0, 300.0, 1e-3];
/// The LQR of Alg. 3: N = 50, Q = I, R = 0.001, actuator limit +-100 V.
const LQR_R: f64 = 0.001;
const U_MAX: f64 = 100.0;

/// Length of the estimation runs and when the tip mass comes off \[s\].
const ESTIMATION_END: f64 = 30.0;
const MASS_REMOVED_AT: f64 = 20.0;
/// The closed loop: PRBS identification until `CONTROL_FROM`, then the LQR; stinger hits.
const CONTROL_FROM: f64 = 10.0;
const CONTROL_END: f64 = 25.0;
const STINGER_AT: [f64; 2] = [12.0, 18.0];
/// Why the filters' and controllers' constructors cannot fail here.
const FINITE_TUNING: &str = "the tuning is finite";

fn main() -> Result<(), Box<dyn Error>> {
    let started = Instant::now();
    let out = Path::new("out");
    std::fs::create_dir_all(out)?;

    let estimation = estimation_runs();
    println!("Parameter estimation, cantilever of the double Kalman filter (DKF) paper, EKF");
    println!("against DKF: simulated beam wn = 20 rad/s, zeta = 0.026, alpha = 0.5 mm/(s^2 V);");
    println!("PRBS +-100 V; noise sigma 1e-4 mm; tip mass detached at {MASS_REMOVED_AT} s");
    println!("(wn -> 50 rad/s). Table 1 of the paper:\n");
    let labels = [
        "EKF close",
        "AKF close",
        "DKF close",
        "EKF wrong",
        "AKF wrong",
        "DKF wrong",
    ];
    print!(
        "{}",
        report::parameter_table(&estimation, &labels, 2.0, 15.0)
    );
    for label in labels {
        if let Some(t) = report::divergence_time(&estimation, label) {
            println!("{label}: diverged at t = {t:.2} s");
        }
    }
    report::write_csv(
        &estimation,
        std::fs::File::create(out.join("estimation.csv"))?,
    )?;
    plot_estimates(&estimation, &out.join("wn.svg"))?;

    experiment::sensitivity::table();
    experiment::sensitivity::monte_carlo();

    let closed = closed_loop_runs();
    println!("\nAdaptive LQR closed loop (N = 50, Q = I, R = {LQR_R}, |u| <= {U_MAX} V):");
    println!(
        "identification with PRBS until {CONTROL_FROM} s, then control; stinger hits at {:?} s",
        STINGER_AT
    );
    println!("RMS tip displacement over {CONTROL_FROM}-{CONTROL_END} s:");
    for label in ["open loop", "EKF-LQR", "DKF-LQR"] {
        let y = closed.column(&format!("{label} x1")).unwrap_or(&[]);
        let value = rms(closed.time(), y, CONTROL_FROM, CONTROL_END);
        println!("  {label:<10} {value:8.4} mm");
    }
    report::write_csv(&closed, std::fs::File::create(out.join("closed_loop.csv"))?)?;
    plot_displacement(&closed, &out.join("displacement.svg"))?;

    experiment::outliers::run(out)?;
    experiment::blade::run(out)?;
    let (designs, baseline) = experiment::blade_control::run(out)?;
    experiment::blade_ablation::run(out, &designs, baseline)?;
    experiment::trms::run(out)?;
    experiment::flight::run(out)?;
    experiment::flight_delay::run()?;
    experiment::quadrotor_limits::run(out)?;

    print_generated_costs();
    experiment::switched_beam::experiment(out)?;
    experiment::hub_polynomial::experiment(out)?;
    println!(
        "\nWrote out/estimation.csv, out/closed_loop.csv, out/wn.svg, out/displacement.svg, \
         out/outliers.csv, out/outliers.svg, out/blade.csv, out/blade_mass.svg, out/blade_identification.svg, \
         out/blade_control.csv, out/blade_control_table.txt, out/blade_control_position.svg, \
         out/blade_control_voltage.svg, out/blade_control_run.svg, out/blade_ablation.txt, \
         out/blade_full_plant.csv, out/blade_full_plant_position.svg, \
         out/blade_full_plant_voltage.svg, out/blade_full_plant_run.svg, out/helicopter.csv, \
         out/helicopter_surge.csv, out/helicopter_pitch.svg, out/helicopter_surge.svg, \
         out/beam_20hz.csv, out/beam_35hz.csv, out/beam_velocity.svg, \
         out/switching_example.csv, out/switching_example.svg, out/hub_estimates.csv, \
         out/hub_velocity.svg, out/navigation.csv, out/navigation_yaw.svg, \
         out/navigation_position.svg, out/navigation_velocity.svg, \
         out/navigation_gyro_bias.svg, out/quadrotor_limits.csv, out/quadrotor_limits_tilt.svg, \
         out/quadrotor_limits_speed.svg, out/quadrotor_limits_inputs.svg in {:.2} s.",
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// EKF and DKF from both guesses on one simulated run.
fn estimation_runs() -> Trace {
    let config = PlantConfig {
        mass_change: Some(MassChange::remove_tip_mass(
            MASS_REMOVED_AT,
            Physical::WITH_TIP_MASS,
        )),
        ..PlantConfig::default()
    };
    let mut plant = Plant::new(config);
    let mut filters = [(X0_CLOSE, 2e4, "close"), (X0_WRONG, 2e6, "wrong")].map(|(x0, p3, name)| {
        (
            Ekf::new(&x0, &p0(p3), &Q_DIAG, &[[R]]).expect(FINITE_TUNING),
            Dkf::new(&x0, &p0(p3), &Q_DIAG, &p0(p3), &Q_DIAG, &[[R]]).expect(FINITE_TUNING),
            name,
        )
    });
    let mut prbs = Prbs::paper();
    let mut trace = Trace::new();
    let mut u_prev = 0.0;
    let steps = (ESTIMATION_END / TS).round() as usize;
    for _ in 0..=steps {
        let y = plant.output();
        trace.begin(plant.time());
        trace.set_truth(plant.params());
        trace.set("y", y);
        for (ekf, dkf, name) in &mut filters {
            // Steps that fail leave a filter as it was: its estimate is recorded as is.
            let _: Status = ekf.step(&[u_prev], &[y]);
            let _ = dkf.step(&[u_prev], &[y]);
            trace.set_estimate(&format!("EKF {name}"), &ekf.state());
            trace.set_estimate(&format!("AKF {name}"), &dkf.akf_state());
            trace.set_estimate(&format!("DKF {name}"), &dkf.state());
            trace.set(&format!("DKF {name} excitation"), dkf.excitation());
        }
        let u = prbs.next().unwrap_or(0.0);
        trace.set("u", u);
        plant.step(u);
        u_prev = u;
    }
    for label in ["EKF", "AKF", "DKF"] {
        for guess in ["close", "wrong"] {
            trace.add_readout(&format!("{label} {guess}"));
        }
    }
    trace
}

/// Open loop, EKF-LQR and DKF-LQR on the same beam, noise and stinger hits.
fn closed_loop_runs() -> Trace {
    let config = || PlantConfig {
        stinger: STINGER_AT
            .iter()
            .map(|&time| Kick {
                time,
                velocity: experiment::plant::STINGER_VELOCITY,
            })
            .collect(),
        ..PlantConfig::default()
    };
    let mut open = Plant::new(config());
    let mut with_ekf = (
        Plant::new(config()),
        Ekf::new(&X0_CLOSE, &p0(2e4), &Q_DIAG_CONTROL, &[[R]]).expect(FINITE_TUNING),
    );
    let mut with_dkf = (
        Plant::new(config()),
        Dkf::new(
            &X0_CLOSE,
            &p0(2e4),
            &Q_DIAG_CONTROL,
            &p0(2e4),
            &Q_DIAG_CONTROL,
            &[[R]],
        )
        .expect(FINITE_TUNING),
    );
    let lqr =
        || Lqr::new(&[[1.0, 0.0], [0.0, 1.0]], &[[LQR_R]], Some(&[U_MAX])).expect(FINITE_TUNING);
    let (mut lqr_ekf, mut lqr_dkf) = (lqr(), lqr());
    let mut prbs = Prbs::paper();
    let (mut u_ekf, mut u_dkf) = (0.0, 0.0);
    let mut trace = Trace::new();
    let steps = (CONTROL_END / TS).round() as usize;
    for _ in 0..=steps {
        let t = open.time();
        let identifying = t < CONTROL_FROM;
        let dither = prbs.next().unwrap_or(0.0);
        trace.begin(t);

        trace.set("open loop x1", open.state()[0]);
        open.step(if identifying { dither } else { 0.0 });

        let (plant, ekf) = &mut with_ekf;
        let _ = ekf.step(&[u_ekf], &[plant.output()]);
        u_ekf = control(&mut lqr_ekf, &ekf.state(), u_ekf, (identifying, dither));
        trace.set("EKF-LQR x1", plant.state()[0]);
        trace.set("EKF-LQR u", u_ekf);
        trace.set_estimate("EKF-LQR", &ekf.state());
        plant.step(u_ekf);

        let (plant, dkf) = &mut with_dkf;
        let _ = dkf.step(&[u_dkf], &[plant.output()]);
        u_dkf = control(&mut lqr_dkf, &dkf.state(), u_dkf, (identifying, dither));
        trace.set("DKF-LQR x1", plant.state()[0]);
        trace.set("DKF-LQR u", u_dkf);
        trace.set_estimate("DKF-LQR", &dkf.state());
        plant.step(u_dkf);
    }
    trace
}

/// The PRBS while identifying; then the adaptive LQR's control for `estimate` (the gain
/// is re-solved every sample at the estimate and the last input `u_prev`; if that fails
/// the last gain stays in use).
fn control(
    lqr: &mut Lqr,
    estimate: &[f64; 5],
    u_prev: f64,
    (identifying, dither): (bool, f64),
) -> f64 {
    if identifying {
        return dither;
    }
    let _: Status = lqr.solve(estimate, &[u_prev]);
    saturate(lqr.control(estimate)[0])
}

fn plot_estimates(trace: &Trace, path: &Path) -> Result<(), Box<dyn Error>> {
    let names = [
        "true wn",
        "EKF close wn",
        "DKF close wn",
        "AKF close wn",
        "DKF wrong wn",
    ];
    let lines: Vec<Line> = names.iter().filter_map(|name| trace.line(name)).collect();
    report::plot_lines(
        path,
        "Natural frequency read from the estimated poles",
        "wn [rad/s]",
        &lines,
        Some((0.0, 70.0)),
    )
}

fn plot_displacement(trace: &Trace, path: &Path) -> Result<(), Box<dyn Error>> {
    let names = ["open loop x1", "EKF-LQR x1", "DKF-LQR x1"];
    let lines: Vec<Line> = names.iter().filter_map(|name| trace.line(name)).collect();
    report::plot_lines(path, "Tip displacement", "x1 [mm]", &lines, None)
}

/// What the generated cantilever code computes per call, counted from the code.
fn print_generated_costs() {
    println!("\nGenerated cantilever code, arithmetic per call (from the generated code):");
    println!(
        "{:<22} {:>5} {:>5} {:>5} {:>5} {:>5}",
        "function", "add", "mul", "div", "call", "cmp"
    );
    let rows = [
        ("f", cantilever::F_OPS),
        ("jacobian_f_wrt_x", cantilever::JACOBIAN_F_WRT_X_OPS),
        ("Ekf::predict", cantilever::EKF_PREDICT_OPS),
        ("Ekf::update", cantilever::EKF_UPDATE_OPS),
        ("Ekf::step (fused)", cantilever::EKF_STEP_OPS),
        ("GatedEkf::step", cantilever::GATED_EKF_STEP_OPS),
        ("Dkf transform", cantilever::DKF_TRANSFORM_OPS),
        ("Dkf filters", cantilever::DKF_FILTERS_OPS),
        ("Lqr::solve (N = 50)", cantilever::LQR_SOLVE_OPS),
    ];
    for (name, ops) in rows {
        println!(
            "{:<22} {:>5} {:>5} {:>5} {:>5} {:>5}",
            name, ops.add, ops.mul, ops.div, ops.call, ops.compare
        );
    }
}

//! Measurement faults on the cantilever: the generated EKF without a gate and the same
//! filter with an innovation gate (`GatedEkf`, chi-square 99.9% quantile 10.83) through a
//! 1 mm spike (30 times the filter's measurement sigma), a sensor stuck for 20 samples and
//! one wild value (1e30), in `f32` as on the MCU. The ungated filter is also shown
//! recovering through `reset` after a run of failed steps.

use super::excitation::Prbs;
use super::plant::{Plant, PlantConfig};
use super::readout;
use super::report::{self, Line, Trace};
use super::tuning::{p0, Q_DIAG, R, X0_CLOSE};
use super::TS;
use generated_demo::cantilever::{Ekf, GatedEkf, Status};
use generated_demo::noise::GaussianNoise;
use std::error::Error;
use std::path::Path;

/// When the fault starts and how long the run lasts \[s\].
const FAULT_AT: f64 = 10.0;
const RUN_END: f64 = 20.0;
/// The beam's natural frequency in these runs \[rad/s\].
const TRUE_WN: f64 = 20.0;
/// Failed steps in a row after which the ungated filter with recovery is reset.
const RESET_AFTER: u32 = 5;

/// A fault of the measured tip displacement.
#[derive(Clone, Copy)]
enum Fault {
    /// `y` plus this many mm at one sample.
    Spike(f64),
    /// `y` held at its value for this many samples.
    Stuck(usize),
    /// `y` replaced by this value at one sample.
    Wild(f64),
}

impl Fault {
    fn label(self) -> String {
        match self {
            Fault::Spike(mm) => format!("spike of {mm} mm"),
            Fault::Stuck(n) => format!("stuck for {n} samples"),
            Fault::Wild(v) => format!("one value of {v:e}"),
        }
    }

    /// The measured `y` at sample `k` given the true reading, `held` the reading at the
    /// fault's start.
    fn apply(self, k: usize, start: usize, y: f64, held: f64) -> f64 {
        match self {
            Fault::Spike(mm) if k == start => y + mm,
            Fault::Stuck(n) if (start..start + n).contains(&k) => held,
            Fault::Wild(v) if k == start => v,
            _ => y,
        }
    }
}

/// What one filter did over a run.
#[derive(Default)]
struct Outcome {
    rejected: u32,
    failed: u32,
    resets: u32,
    wn: Vec<f64>,
}

impl Outcome {
    fn record(&mut self, status: Status, x: [f32; 5]) {
        match status {
            Status::Ok => {}
            Status::OutlierRejected => self.rejected += 1,
            _ => self.failed += 1,
        }
        let [_, _, x3, x4, x5] = x.map(f64::from);
        self.wn
            .push(readout::or_nan(readout::from_poles(x3, x4, x5)).wn);
    }
}

/// The three filters of a run: ungated, ungated with reset after failures, gated.
struct Filters {
    ungated: Ekf,
    recovering: Ekf,
    failed_in_a_row: u32,
    gated: GatedEkf,
}

impl Filters {
    fn new() -> Self {
        let (x0, p0, q, r) = tuning_f32();
        let finite = "the tuning is finite";
        Filters {
            ungated: Ekf::new(&x0, &p0, &q, &[[r]]).expect(finite),
            recovering: Ekf::new(&x0, &p0, &q, &[[r]]).expect(finite),
            failed_in_a_row: 0,
            gated: GatedEkf::new(&x0, &p0, &q, &[[r]]).expect(finite),
        }
    }

    fn step(&mut self, u_prev: f32, y: f32, outcomes: &mut [Outcome; 3]) {
        let status = self.ungated.step(&[u_prev], &[y]);
        outcomes[0].record(status, self.ungated.state());

        let status = self.recovering.step(&[u_prev], &[y]);
        self.failed_in_a_row = if status == Status::Ok {
            0
        } else {
            self.failed_in_a_row + 1
        };
        outcomes[1].record(status, self.recovering.state());
        if self.failed_in_a_row >= RESET_AFTER {
            // The documented way back: start again from the prior.
            let (x0, p0, ..) = tuning_f32();
            let reset = self.recovering.reset(&x0, &p0);
            assert_eq!(reset, Status::Ok, "the prior is finite");
            self.failed_in_a_row = 0;
            outcomes[1].resets += 1;
        }

        let status = self.gated.step(&[u_prev], &[y]);
        outcomes[2].record(status, self.gated.state());
    }
}

const LABELS: [&str; 3] = ["EKF", "EKF, reset after 5 failures", "gated EKF"];

/// One run of the beam with `fault`, all three filters on the same measurements.
fn run_fault(fault: Fault) -> (Vec<f64>, [Outcome; 3]) {
    let mut plant = Plant::new(PlantConfig {
        noise: GaussianNoise::new(1e-4, 3),
        ..PlantConfig::default()
    });
    let mut prbs = Prbs::paper();
    let mut filters = Filters::new();
    let mut outcomes: [Outcome; 3] = Default::default();
    let mut times = Vec::new();
    let start = (FAULT_AT / TS).round() as usize;
    let mut held = 0.0;
    let mut u_prev = 0.0;
    for k in 0..=(RUN_END / TS).round() as usize {
        let reading = plant.output();
        if k == start {
            held = reading;
        }
        let y = fault.apply(k, start, reading, held);
        // The filters run in f32, as on the MCU: 1e30 is still a finite f32.
        filters.step(u_prev as f32, y as f32, &mut outcomes);
        times.push(plant.time());
        let u = prbs.next().unwrap_or(0.0);
        plant.step(u);
        u_prev = u;
    }
    (times, outcomes)
}

/// Runs each fault, prints a table and writes `out/outliers.csv` and `out/outliers.svg`
/// (the wn estimates through the spike).
pub fn run(out: &Path) -> Result<(), Box<dyn Error>> {
    println!(
        "\nMeasurement faults at {FAULT_AT} s, cantilever (wn = 20 rad/s), f32 EKF from the \
         close guess,\nR = {R} (sigma {:.3} mm); gate 10.83 (chi-square 99.9%, 1 dof). wn from \
         poles [rad/s]:\n",
        R.sqrt()
    );
    println!(
        "{:<22} {:<29} {:>8} {:>6} {:>6} {:>11} {:>10} {:>10}",
        "fault",
        "filter",
        "rejected",
        "failed",
        "resets",
        "worst after",
        "wn at 15 s",
        "wn at 20 s"
    );
    let mut spike_trace = Trace::new();
    for fault in [Fault::Spike(1.0), Fault::Stuck(20), Fault::Wild(1e30)] {
        let (times, outcomes) = run_fault(fault);
        let at = |t: f64| ((t / TS).round() as usize).min(times.len() - 1);
        for (label, outcome) in LABELS.iter().zip(&outcomes) {
            // The largest departure from the true 20 rad/s once the fault has begun.
            let worst = outcome.wn[at(FAULT_AT)..]
                .iter()
                .map(|wn| (wn - TRUE_WN).abs())
                .fold(0.0, |a: f64, b| if b.is_nan() { b } else { a.max(b) });
            println!(
                "{:<22} {:<29} {:>8} {:>6} {:>6} {:>11.2} {:>10.2} {:>10.2}",
                fault.label(),
                label,
                outcome.rejected,
                outcome.failed,
                outcome.resets,
                worst,
                outcome.wn[at(15.0)],
                outcome.wn[at(RUN_END)],
            );
        }
        if let Fault::Spike(_) = fault {
            for (k, &t) in times.iter().enumerate() {
                spike_trace.begin(t);
                for (label, outcome) in LABELS.iter().zip(&outcomes) {
                    spike_trace.set(&format!("{label} wn"), outcome.wn[k]);
                }
            }
        }
    }
    println!(
        "(rejected: Status::OutlierRejected; failed: any other status than Ok, the filter \
         left unchanged;\n worst after: largest |wn - 20| from the fault on, NaN once the \
         estimate has no oscillating mode)"
    );
    report::write_csv(
        &spike_trace,
        std::fs::File::create(out.join("outliers.csv"))?,
    )?;
    let names = LABELS.map(|label| format!("{label} wn"));
    let lines: Vec<Line> = names
        .iter()
        .filter_map(|name| spike_trace.line(name))
        .collect();
    report::plot_lines(
        &out.join("outliers.svg"),
        "Natural frequency read from the estimated poles, 1 mm spike at 10 s",
        "wn [rad/s]",
        &lines,
        Some((0.0, 70.0)),
    )?;
    Ok(())
}

/// The estimation runs' tuning from the close guess, in `f32`: `x0`, `p0`, `q`, `r`.
fn tuning_f32() -> ([f32; 5], [[f32; 5]; 5], [f32; 5], f32) {
    let narrow = |v: f64| v as f32;
    (
        X0_CLOSE.map(narrow),
        p0(2e4).map(|row| row.map(narrow)),
        Q_DIAG.map(narrow),
        narrow(R),
    )
}

//! Takács et al.'s controller comparison (sect. 4, Figs. 3-4) on the simulated blade over 80 s:
//! 0-20 s identification (white-noise input, no hits), then control of the nominal blade
//! (20-40 s), with 54 g added (40-60 s) and nominal again (60-80 s), a stinger hit every
//! 4 s from 22 s. Four runs on the same noise and hits: the adaptive EKF-MPC, the nominal
//! LQ and PPF clipped at +-100 V, and open loop. The MPC and LQ act from 20 s on the
//! estimate of the control-mode hybrid EKF of eq. (20) (500 Euler sub-steps a sample), PPF
//! on the measurement; the controllers use the model's `k`, `b`, `c` (the paper's
//! identified values; `blade` reports what the identification filter finds for them). The
//! blade is `blade_rig`'s: the single-mode blade here, more like the experiment in
//! `blade_ablation`.

use super::blade::control_ekf;
use super::blade_plant::{mass, END, HIT_FORCE, IDENTIFICATION_END};
use super::blade_rig::{Features, Rig, RigDesign};
use super::controllers::{nominal_lq_gain, Controller, Kind, MpcStats, U_MAX};
use super::metrics::{mean, rms};
use super::ppf::PpfTuning;
use super::report::{self, Line, Trace};
use generated_demo::mass_spring_damper::in_f64::{Mpc, Status, TS};
use generated_demo::noise::GaussianNoise;
use std::error::Error;
use std::path::Path;

/// The white input of the identification phase: sigma 50 V, clipped to +-100 V (as in
/// `blade`, with the same sequence).
const INPUT_SIGMA: f64 = 50.0;
/// The phases compared (sect. 4): nominal, loaded, nominal again.
pub const PHASES: [(f64, f64); 3] = [(20.0, 40.0), (40.0, 60.0), (60.0, 80.0)];
/// Fig. 4's detail: a 1.5 s transient after the hit at 42 s, with the weight added.
const DETAIL: (f64, f64) = (41.9, 43.4);

/// One run's record: time, true tip position \[m\], input \[V\] applied from each sample,
/// and the MPC's statistics for the MPC run.
pub struct Run {
    /// The controller.
    pub kind: Kind,
    /// Sample times \[s\].
    pub t: Vec<f64>,
    /// True tip position \[m\].
    pub q: Vec<f64>,
    /// Input applied from each sample on \[V\].
    pub u: Vec<f64>,
    /// The MPC's solves, for the MPC run.
    pub mpc: Option<MpcStats>,
    /// The median-filtered mass the MPC used \[kg\] (NaN in other runs and before 20 s).
    pub mass: Vec<f64>,
    /// Control-filter steps that were rejected.
    pub rejected_steps: u64,
    /// Samples at which the blade touched the resting stinger (with the stinger's contact).
    pub stinger_touches: u64,
}

impl Run {
    /// RMS tip displacement \[mm\] and RMS input \[V\] over `(from, to]` (a phase's first
    /// sample belongs to the one before).
    pub fn rms(&self, (from, to): (f64, f64)) -> (f64, f64) {
        let from = from + 0.5 * TS;
        (
            1e3 * rms(&self.t, &self.q, from, to),
            rms(&self.t, &self.u, from, to),
        )
    }
}

/// The designs shared by all runs: the nominal LQ gain and the optimal PPF.
pub struct Designs {
    /// `u = -K x` at the nominal mass.
    pub lq_gain: [f64; 2],
    /// PPF tuned by Friswell and Inman's cost.
    pub ppf: PpfTuning,
}

impl Designs {
    /// Designs both on the host.
    pub fn new() -> Result<Self, Box<dyn Error>> {
        Ok(Self {
            lq_gain: nominal_lq_gain()?,
            ppf: PpfTuning::optimal(),
        })
    }
}

/// Simulates 0-`end` s of the blade `rig` with `kind` in control from 20 s (the control
/// filter runs from 20 s for the controllers that use its estimate).
pub fn simulate(
    kind: Kind,
    designs: &Designs,
    rig: &RigDesign,
    end: f64,
) -> Result<Run, Box<dyn Error>> {
    let mut controller = Controller::new(kind, designs.lq_gain, designs.ppf)
        .map_err(|s| format!("{kind:?}: {s:?}"))?;
    let input = GaussianNoise::new(1.0, 11);
    let mut plant = Rig::new(rig);
    let mut filter = control_ekf();
    let mut run = Run {
        kind,
        t: Vec::new(),
        q: Vec::new(),
        u: Vec::new(),
        mpc: None,
        mass: Vec::new(),
        rejected_steps: 0,
        stinger_touches: 0,
    };
    let mut u_prev = 0.0;
    for k in 1..=(end / TS).round() as u64 {
        let t = k as f64 * TS;
        let y = plant.step(u_prev);
        let u = if t <= IDENTIFICATION_END + 1e-9 {
            (INPUT_SIGMA * input.sample(k)).clamp(-U_MAX, U_MAX)
        } else {
            // PPF feeds back the measurement, open loop nothing: only the MPC and LQ need
            // the filter's estimate (its 500 sub-steps a sample are most of a run's cost).
            if kind.uses_estimate() && filter.step(&[u_prev], &[y]) != Status::Ok {
                run.rejected_steps += 1;
            }
            controller.input(&filter.state(), y, u_prev)
        };
        run.t.push(t);
        run.q.push(plant.tip());
        run.u.push(u);
        run.mass.push(match &controller {
            Controller::Mpc(mpc) if t > IDENTIFICATION_END + 1e-9 => mpc.mass(),
            _ => f64::NAN,
        });
        u_prev = u;
    }
    if let Controller::Mpc(mpc) = &controller {
        run.mpc = Some(mpc.stats);
    }
    run.stinger_touches = plant.touches_at_rest;
    Ok(run)
}

/// The four runs over 80 s on the single-mode blade; with the paper's 4 N hits (`F_e`,
/// sect. 4.1) and with hits ten times smaller, after which the loops leave saturation
/// sooner. Prints the tables and the MPC's statistics; writes `out/blade_control.csv`,
/// `out/blade_control_table.txt` and the SVG plots (of the 4 N runs). Returns the
/// designs and the 4 N runs, the ablation's first row.
pub fn run(out: &Path) -> Result<(Designs, Vec<Run>), Box<dyn Error>> {
    let designs = Designs::new()?;
    let mut text = describe(&designs);
    let mut paper_runs = Vec::new();
    for (hit_peak, name) in [(HIT_FORCE, "the paper's"), (0.1 * HIT_FORCE, "smaller")] {
        let rig = RigDesign::new(Features::NONE, hit_peak);
        let runs = Kind::ALL
            .into_iter()
            .map(|kind| simulate(kind, &designs, &rig, END))
            .collect::<Result<Vec<_>, _>>()?;
        text.push_str(&format!(
            "\nHits of {hit_peak} N peak ({name}); RMS per phase:\n"
        ));
        text.push_str(&summary(&runs));
        if paper_runs.is_empty() {
            paper_runs = runs;
        }
    }
    print!("{text}");
    std::fs::write(out.join("blade_control_table.txt"), &text)?;
    let csv = std::fs::File::create(out.join("blade_control.csv"))?;
    report::write_csv(&trace(&paper_runs), csv)?;
    plot(&paper_runs, out, "blade_control", "single-mode blade")?;
    Ok((designs, paper_runs))
}

/// The tables and the MPC's statistics of one set of runs.
fn summary(runs: &[Run]) -> String {
    let mut text = table(runs);
    text.push_str(&relative_table(runs));
    if let Some(stats) = runs.iter().find_map(|r| r.mpc) {
        text.push_str(&mpc_statistics(&stats));
        text.push_str(&mpc_masses(&runs[0]));
    }
    for run in runs.iter().filter(|r| r.rejected_steps > 0) {
        let label = run.kind.label();
        text.push_str(&format!(
            "{label}: {} filter steps rejected\n",
            run.rejected_steps
        ));
    }
    text
}

fn describe(designs: &Designs) -> String {
    let [k1, k2] = designs.lq_gain;
    let p = designs.ppf;
    format!(
        "\nBlade of Takács, Polóni and Rohal-Ilkiv, \"Adaptive predictive control of transient\n\
         vibrations of cantilevers with changing weight\", control (sect. 4): identification\n\
         0-20 s, then hits every 4 s, +54 g over 40-60 s; MPC n = {}, Q = C'C, R = 1e-10,\n\
         |u| <= {U_MAX} V at the 50-sample median mass; nominal LQ K = [{k1:.4e}, {k2:.4e}]\n\
         (m = 0.20 kg), clipped;\n\
         PPF g = {:.4e} V/m, w_p = {:.2} rad/s, xi_p = {:.4} (optimal for alpha = 1.7e8,\n\
         delta = 1e-10, a unit velocity impact), clipped.\n",
        Mpc::HORIZON,
        p.gain,
        p.omega,
        p.xi
    )
}

/// RMS tip displacement \[mm\] and input \[V\] per phase and controller.
fn table(runs: &[Run]) -> String {
    let mut text = format!("{:<12}", "RMS");
    for (from, to) in PHASES {
        text.push_str(&format!(
            " {:>20}",
            format!("{from:.0}-{to:.0} s q [mm], u [V]")
        ));
    }
    text.push('\n');
    for run in runs {
        text.push_str(&format!("{:<12}", run.kind.label()));
        for phase in PHASES {
            let (q, u) = run.rms(phase);
            text.push_str(&format!(" {:>11.4} {:>8.2}", q, u));
        }
        text.push('\n');
    }
    text
}

/// The paper's RSS indicators (sect. 4.2, its two tables) relative to the EKF-MPC [%],
/// per controller in `Kind::ALL`'s order: nominal q, nominal u, loaded q, loaded u (NaN
/// where the paper gives none).
pub const PAPER_RSS: [[f64; 4]; 4] = [
    [100.0, 100.0, 100.0, 100.0],
    [110.0, 104.0, 142.0, 124.0],
    [107.0, 144.0, 120.0, 189.0],
    [567.0, f64::NAN, 742.0, f64::NAN],
];
/// The paper's windows for them: 20-37.5 s (nominal) and 40-57.5 s (loaded).
pub const RSS_WINDOWS: [(f64, f64); 2] = [(20.0, 37.5), (40.0, 57.5)];

/// `run`'s RSS relative to `base`'s \[%\]: nominal q, nominal u, loaded q, loaded u
/// (over one window both have the same samples, so RMS ratios are RSS ratios).
pub fn relative_rss(run: &Run, base: &Run) -> [f64; 4] {
    let mut cells = [0.0; 4];
    for (i, window) in RSS_WINDOWS.into_iter().enumerate() {
        let (q, u) = run.rms(window);
        let (q0, u0) = base.rms(window);
        cells[2 * i] = 100.0 * q / q0;
        cells[2 * i + 1] = 100.0 * u / u0;
    }
    cells
}

/// "value (paper)", or the value alone where the paper gives none.
pub fn cell(value: f64, paper: f64) -> String {
    if paper.is_nan() {
        format!("{value:.0}")
    } else {
        format!("{value:.0} ({paper:.0})")
    }
}

/// The paper's RSS indicators (sect. 4.2): each controller relative to the EKF-MPC over
/// 20-37.5 s (nominal) and 40-57.5 s (loaded), beside the paper's measured values.
fn relative_table(runs: &[Run]) -> String {
    let mut text = String::from(
        "\nRSS relative to EKF-MPC [%] (paper's measurement in brackets):\n\
         controller   nominal q       nominal u       loaded q        loaded u\n",
    );
    for (run, paper) in runs.iter().zip(PAPER_RSS) {
        text.push_str(&format!("{:<12}", run.kind.label()));
        for (value, paper) in relative_rss(run, &runs[0]).into_iter().zip(paper) {
            text.push_str(&format!(" {:>15}", cell(value, paper)));
        }
        text.push('\n');
    }
    text
}

fn mpc_statistics(stats: &MpcStats) -> String {
    let [kept, problem, model] = Mpc::ITERATIONS_WITHIN_BUDGET;
    format!(
        "\nMPC over the run: {} solves, {} failed; active-set iterations worst {} (bound {}; \
         within the cycle budget {kept} / {problem} / {model} after rebuilding nothing / the \
         problem / the model), mean {:.2};\n{:.2} % optimal (the others stopped at the \
         budget's bound), terminal weight converged in {:.2} %.\n",
        stats.solves,
        stats.failures,
        stats.worst_iterations,
        Mpc::MAX_ITERATIONS,
        stats.mean_iterations(),
        100.0 * stats.fraction(stats.optimal),
        100.0 * stats.fraction(stats.converged),
    )
}

/// The median mass the MPC used, averaged over each phase after its first 5 s.
fn mpc_masses(run: &Run) -> String {
    let mut text = String::from("MPC's median mass [kg] (truth):");
    for (from, to) in PHASES {
        let used = mean(&run.t, &run.mass, from + 5.0, to);
        text.push_str(&format!(" {used:.4} ({:.4})", mass(to - 1.0)));
    }
    text.push('\n');
    text
}

/// All runs' position \[mm\] and input \[V\] in one trace.
pub fn trace(runs: &[Run]) -> Trace {
    let mut trace = Trace::new();
    for (i, &t) in runs[0].t.iter().enumerate() {
        trace.begin(t);
        for run in runs {
            trace.set(&format!("{} q [mm]", run.kind.label()), 1e3 * run.q[i]);
            trace.set(&format!("{} u [V]", run.kind.label()), run.u[i]);
        }
        trace.set("EKF-MPC median mass [kg]", runs[0].mass[i]);
    }
    trace
}

/// Fig. 4: position and voltage over `DETAIL`, all controllers superimposed; and the
/// whole control phase's position: `out/{stem}_position.svg`, `_voltage.svg`, `_run.svg`,
/// titled after `plant`.
pub fn plot(runs: &[Run], out: &Path, stem: &str, plant: &str) -> Result<(), Box<dyn Error>> {
    let trace = trace(runs);
    let t = trace.time();
    let within = |(from, to): (f64, f64)| {
        let start = t.iter().position(|&s| s >= from).unwrap_or(t.len());
        let end = t.iter().position(|&s| s > to).unwrap_or(t.len());
        start..end
    };
    let names = |suffix: &str| -> Vec<String> {
        runs.iter()
            .map(|r| format!("{} {suffix}", r.kind.label()))
            .collect()
    };
    let figures = [
        (
            "q [mm]",
            "position",
            DETAIL,
            "Tip position, 54 g added (Fig. 4a)",
        ),
        (
            "u [V]",
            "voltage",
            DETAIL,
            "Input voltage, 54 g added (Fig. 4b)",
        ),
        (
            "q [mm]",
            "run",
            (IDENTIFICATION_END, END),
            "Tip position, control phases",
        ),
    ];
    for (suffix, file, window, title) in figures {
        let file = format!("{stem}_{file}.svg");
        let title = format!("{title}, {plant}");
        let range = within(window);
        let names = names(suffix);
        let lines: Vec<Line> = names
            .iter()
            .filter_map(|name| trace.line(name))
            .map(|line| Line {
                t: &line.t[range.clone()],
                v: &line.v[range.clone()],
                ..line
            })
            .collect();
        report::plot_lines(&out.join(file), &title, suffix, &lines, None)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A short run (the identification and the first two hits, at 22 and 26 s) checks the
    /// experiment's claims: the MPC's inputs stay within +-100 V, every solve succeeds,
    /// and each controller lowers the RMS tip displacement during the hits.
    #[test]
    fn closed_loops_damp_the_hits_within_the_limits() {
        let designs = Designs::new().unwrap();
        let rig = RigDesign::new(Features::NONE, HIT_FORCE);
        let end = 28.0;
        let runs: Vec<Run> = Kind::ALL
            .into_iter()
            .map(|kind| simulate(kind, &designs, &rig, end).unwrap())
            .collect();
        let window = (22.0, end);
        let open = runs[3].rms(window).0;
        for run in &runs[..3] {
            let closed = run.rms(window).0;
            assert!(
                closed < 0.8 * open,
                "{:?}: {closed} mm vs open loop {open} mm",
                run.kind
            );
            assert!(run.u.iter().all(|u| u.abs() <= U_MAX));
            if run.kind.uses_estimate() {
                assert_eq!(run.rejected_steps, 0);
            }
        }
        let stats = runs[0].mpc.unwrap();
        assert_eq!(stats.failures, 0);
        assert_eq!(
            stats.solves,
            ((end - IDENTIFICATION_END) / TS).round() as u64
        );
        assert!(stats.worst_iterations <= Mpc::MAX_ITERATIONS);
    }
}

//! Which feature of Takács et al.'s experiment makes the adaptive EKF-MPC's advantage
//! appear: `blade_control`'s comparison (the paper's tuning, the filters' and
//! controllers' single-mode models unchanged) repeated on `blade_rig`'s blade with each of
//! its features alone and with all together, against the single-mode blade the
//! controllers assume. Prints the ablation table (RSS relative to the EKF-MPC, the paper's
//! measurement in brackets) and what each run did to its limits, writes
//! `out/blade_ablation.txt` and the full plant's closed loops as `out/blade_full_plant_*.svg`.

use super::blade_control::{
    cell, plot, relative_rss, simulate, trace, Designs, Run, PAPER_RSS, PHASES, RSS_WINDOWS,
};
use super::blade_modes::{coupling_ratio, first_mode_of_bare_blade, frequency_ratio};
use super::blade_plant::{ADDED_MASS, END, FIRST_HIT, HIT_FORCE, IDENTIFICATION_END, K, M};
use super::blade_rig::{Features, LowPass, RigDesign, MEAN_WINDOW, SUBSTEPS};
use super::butterworth::Butterworth;
use super::controllers::{Kind, U_MAX};
use super::metrics::mean;
use super::report;
use std::error::Error;
use std::path::Path;

/// One plant's four runs, in `Kind::ALL`'s order.
struct Row {
    label: &'static str,
    features: Features,
    runs: Vec<Run>,
}

/// Runs the ablation; `baseline` holds the four 4 N runs on the single-mode blade already
/// run by `blade_control`, its first row. The other plants run in parallel, one thread
/// each (every run is independent and deterministic).
pub fn run(out: &Path, designs: &Designs, baseline: Vec<Run>) -> Result<(), Box<dyn Error>> {
    let design = RigDesign::new(Features::NONE, HIT_FORCE);
    let (first, rest) = Features::ABLATION
        .split_first()
        .expect("the ablation has rows");
    let others: Vec<Result<Vec<Run>, String>> = std::thread::scope(|scope| {
        let threads: Vec<_> = rest
            .iter()
            .map(|&(_, features)| {
                let rig = design.with(features);
                scope.spawn(move || {
                    Kind::ALL
                        .into_iter()
                        .map(|kind| simulate(kind, designs, &rig, END).map_err(|e| e.to_string()))
                        .collect()
                })
            })
            .collect();
        threads
            .into_iter()
            .map(|t| {
                t.join()
                    .unwrap_or_else(|_| Err("a run panicked".to_owned()))
            })
            .collect()
    });
    let mut rows = vec![Row {
        label: first.0,
        features: first.1,
        runs: baseline,
    }];
    for (&(label, features), runs) in rest.iter().zip(others) {
        rows.push(Row {
            label,
            features,
            runs: runs?,
        });
    }
    let mut text = describe(&design);
    text.push_str(&relative_table(&rows));
    text.push_str(&limits_table(&rows));
    print!("{text}");
    std::fs::write(out.join("blade_ablation.txt"), &text)?;
    let full = rows
        .iter()
        .find(|row| row.features == Features::ALL)
        .expect("the ablation has the full plant");
    let csv = std::fs::File::create(out.join("blade_full_plant.csv"))?;
    report::write_csv(&trace(&full.runs), csv)?;
    plot(
        &full.runs,
        out,
        "blade_full_plant",
        "blade like the experiment",
    )
}

/// What the rig simulates, each value with its source ("ours": an assumption).
fn describe(design: &RigDesign) -> String {
    let gentle = LowPass::Gentle.design().expect("a filter");
    let steep = LowPass::Steep.design().expect("a filter");
    let filter = |f: Butterworth| {
        format!(
            "order {} at {:.1} Hz ({:.1} dB at 50 Hz, {:.0} deg lag at 8.2 Hz)",
            f.order,
            f.corner_hz,
            f.loss_db(50.0),
            f.phase_lag(8.2).to_degrees()
        )
    };
    let stinger = design.stinger;
    let lines = [
        "The blade like the experiment (ablation): the same controllers and filters (single-mode"
            .to_owned(),
        "models, the paper's tuning) on a blade with, each alone and all together:".to_owned(),
        format!(
            "- first mode: the paper's k/m, {:.1} rad/s ({:.1} from the blade's dimensions for aluminium);",
            (K / M).sqrt(),
            first_mode_of_bare_blade()
        ),
        format!(
            "- second mode at {:.3} x the first (Euler-Bernoulli), input gain {:.2} x the first's",
            frequency_ratio(),
            coupling_ratio()
        ),
        "  (patches over the first 50.8 mm: ours), same damping ratio (ours), 54 g at the tip on both;"
            .to_owned(),
        "- laser low-pass, edges 30 / 50 Hz (the paper), losses ours: a Butterworth of".to_owned(),
        format!("  {};", filter(gentle)),
        format!("  steeper: {};", filter(steep)),
        format!(
            "- the paper's running mean over {MEAN_WINDOW} samples (0.1 Hz) subtracted from the measurement;"
        ),
        "  with or without the 54 g weight's sag at the tip (the blade bending vertically: ours);"
            .to_owned(),
        "- amplifier: 16-bit card over +-10 V times the paper's 20x gain (rails +-200 V);".to_owned(),
        format!(
            "- stinger: raised-cosine stroke of {:.2} s (the paper's T_e) reaching {:.1} mm past the blade",
            stinger.stroke,
            1e3 * stinger.reach
        ),
        format!(
            "  from {:.0} mm behind it, contact {:.0} N/m (gap and stiffness ours), hitting the blade",
            1e3 * stinger.gap,
            stinger.stiffness
        ),
        "  at rest as the paper's F_e = 4 N half-sine over T_e does.".to_owned(),
        format!(
            "RK4 with {SUBSTEPS} steps a sample; hits every 4 s from 22 s, +54 g over 40-60 s."
        ),
    ];
    format!("\n{}\n", lines.join("\n"))
}

/// Each plant's LQ, PPF and open loop relative to its EKF-MPC, the paper's in brackets.
fn relative_table(rows: &[Row]) -> String {
    let mut text = String::from(
        "\nRSS relative to EKF-MPC [%] per plant (paper's measurement in brackets; nominal\n\
         20-37.5 s, loaded 40-57.5 s):\n\
         plant                controller   nominal q   nominal u    loaded q    loaded u\n",
    );
    for row in rows {
        for (i, (run, paper)) in row.runs.iter().zip(PAPER_RSS).enumerate().skip(1) {
            let label = if i == 1 { row.label } else { "" };
            let mut line = format!("{label:<20} {:<11}", run.kind.label());
            for (value, paper) in relative_rss(run, &row.runs[0]).into_iter().zip(paper) {
                // The open loop has no input to compare.
                let shown = if run.kind == Kind::OpenLoop && paper.is_nan() {
                    String::new()
                } else {
                    cell(value, paper)
                };
                line.push_str(&format!(" {shown:>11}"));
            }
            text.push_str(line.trim_end());
            text.push('\n');
        }
    }
    text
}

/// Per plant: the EKF-MPC's RMS position over the paper's windows, its median mass when
/// loaded, its failed solves, the largest input of any controller, each closed loop's RMS
/// input before the first hit (a loop that is not stable shows there, with nothing to
/// damp but the identification's residue), the open loop's largest swing and touches of
/// the resting stinger.
fn limits_table(rows: &[Row]) -> String {
    let mut text = format!(
        "\n{:<20} {:>15} {:>11} {:>13} {:>7} {:>17} {:>11} {:>8}\n",
        "plant",
        "EKF-MPC q [mm]",
        "MPC m [kg]",
        "MPC solves",
        "max |u|",
        "RMS u 20-22 s [V]",
        "open loop",
        "stinger"
    );
    text.push_str(&format!(
        "{:<20} {:>8} {:>6} {:>11} {:>13} {:>7} {:>5} {:>5} {:>5} {:>11} {:>8}\n",
        "",
        "nominal",
        "loaded",
        "loaded",
        "failed",
        "[V]",
        "MPC",
        "LQ",
        "PPF",
        "swing [mm]",
        "touches"
    ));
    text.push_str(&format!(
        "{:<20} {:>8} {:>6} {:>11} {:>13} {:>7}\n",
        "(truth, limit)",
        "",
        "",
        format!("({:.3})", M + ADDED_MASS),
        "",
        format!("({U_MAX})")
    ));
    for row in rows {
        let mpc = &row.runs[0];
        let (nominal, _) = mpc.rms(RSS_WINDOWS[0]);
        let (loaded, _) = mpc.rms(RSS_WINDOWS[1]);
        let (from, to) = PHASES[1];
        let mass = mean(&mpc.t, &mpc.mass, from + 5.0, to);
        let stats = mpc.mpc.unwrap_or_default();
        let max_u = row
            .runs
            .iter()
            .flat_map(|r| r.u.iter())
            .fold(0.0f64, |m, u| m.max(u.abs()));
        let quiet = |i: usize| row.runs[i].rms((IDENTIFICATION_END, FIRST_HIT)).1;
        let open = &row.runs[3];
        let swing = open.q.iter().fold(0.0f64, |m, q| m.max(q.abs()));
        let touches: u64 = row.runs.iter().map(|r| r.stinger_touches).sum();
        text.push_str(&format!(
            "{:<20} {nominal:>8.3} {loaded:>6.3} {mass:>11.4} {:>5} / {:<5} {max_u:>7.2} \
             {:>5.1} {:>5.1} {:>5.1} {:>11.2} {touches:>8}\n",
            row.label,
            stats.failures,
            stats.solves,
            quiet(0),
            quiet(1),
            quiet(2),
            1e3 * swing,
        ));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use generated_demo::mass_spring_damper::in_f64::{Mpc, TS};

    /// The full plant, with and without the weight's sag, over the whole 80 s run: every
    /// closed loop's input within +-100 V, every MPC solve `Ok` within its iteration bound, no step of the filter the
    /// MPC and LQ act on rejected, the resting stinger never touched.
    #[test]
    fn the_full_plants_closed_loops_keep_their_limits_and_every_solve() {
        let designs = Designs::new().unwrap();
        let design = RigDesign::new(Features::NONE, HIT_FORCE);
        for features in [Features::ALL, Features::ALL_AND_SAG] {
            let rig = design.with(features);
            for kind in [Kind::Mpc, Kind::Lq, Kind::Ppf] {
                let run = simulate(kind, &designs, &rig, END).unwrap();
                assert_eq!(run.u.len(), (END / TS).round() as usize);
                for &u in &run.u {
                    assert!(u.abs() <= U_MAX, "{kind:?}: {u} V");
                }
                if kind.uses_estimate() {
                    assert_eq!(run.rejected_steps, 0, "{kind:?}");
                }
                assert_eq!(run.stinger_touches, 0, "{kind:?}");
                if kind == Kind::Mpc {
                    let stats = run.mpc.unwrap();
                    assert_eq!(stats.failures, 0);
                    assert_eq!(
                        stats.solves,
                        ((END - IDENTIFICATION_END) / TS).round() as u64
                    );
                    assert!(stats.worst_iterations <= Mpc::MAX_ITERATIONS);
                }
            }
        }
    }
}

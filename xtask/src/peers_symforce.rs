//! SymForce as the navigation EKF's peer (issue 19): the same model derived with SymForce
//! (`peers/symforce_codegen.py`, the pinned `symforce` package in the peers' venv, its C++
//! code generation), the model's constants handed over from the Rust model
//! (`target/peers/navigation.json`), the generated templates compiled for `float` with
//! `arm-none-eabi-g++`, the project's flags plus `-fno-exceptions -fno-rtti` and Debian's
//! Eigen headers (`libeigen3-dev`, installed with apt-get when missing) with the glue
//! (`peers/symforce_glue.cpp`) into the peers' `libpeers.a`; the firmware built with
//! `--features symforce` runs it beside the generated filter of the same model
//! (`targets/src/peers_navigation.rs`), and this module reads what it printed and makes
//! the navigation table.
//!
//! The model is the error-state navigation filter (issue 40): SymForce's derivation keeps
//! the attitude an `sf.Rot3` and the covariance over its 23 tangent coordinates, as PX4
//! EKF2's does, and the firmware runs it beside `generated_demo::navigation` itself. Its
//! constants (24 entries, 23 tangent coordinates, gravity) are those of
//! `generated_demo::navigation`, which `constants` reads.

use crate::peers_build;
use stateforge_cli::measure::program::Program;
use stateforge_cli::measure::trace::Traced;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Where Debian's `libeigen3-dev` puts Eigen, and the header that shows it is there.
const EIGEN: &str = "/usr/include/eigen3";
const EIGEN_PACKAGE: &str = "libeigen3-dev";

/// The goals: ours at most this fraction of SymForce's instructions, and agreement
/// to this relative difference in `f32`.
const RATIO_GOAL: f64 = 0.8;
const AGREEMENT_GOAL: f64 = 1e-5;

/// The kernels, as the firmware names them, with their labels.
const KERNELS: [(&str, &str); 3] = [
    ("predict", "prediction"),
    ("update_gnss", "GNSS update (6)"),
    ("update_magnetometer", "magnetometer update (3)"),
];

/// What each side was given, printed under the table.
pub const TERMS: &str = "Both sides from the same estimate at every call: before each \
     call of ours, SymForce is handed our filter's state and covariance (the packed \
     upper triangle over the 23 tangent coordinates, read through Ekf::covariance), the \
     same IMU sample with its interval, or the same measurement, and Q's diagonal (a \
     density, scaled by the interval) or the sensor's part of R's (R is diagonal). Ours: the generated f32 error-state navigation filter's predict, \
     update_gnss and update_magnetometer as generated (each update a joint update of the \
     sensor's outputs through an L D L' factor, gated at 22.46 and 16.27, with its input \
     and divergence checks, its innovation and NIS stored, then the injection and the \
     covariance reset; the wind's covariance with the other coordinates, zero by the \
     model's structure, neither computed nor stored, COVARIANCE_BLOCKS: with it computed, \
     ours were 2708, 5840 and 4259, 0.78, 0.84 and 0.82 of SymForce's). SymForce: the \
     same error-state filter (every entry of the covariance computed) on its Rot3 (global angular \
     error), x_new = f(x, u) with the exact Rot3.from_tangent, P_new = F P F' + diag(q) dt on \
     the packed triangle, F the Jacobian of the tangent error at zero; each sensor fused as \
     sequential scalar updates of the error linearised at the prior (PX4 EKF2's scheme), \
     then Rot3.from_tangent(dtheta) * q and G P G', G = I + [dtheta/2]x; each new attitude \
     renormalised by one Newton step as ours; no gate and no checks; generated C++ \
     templates for float, called through extern \"C\" wrappers with separate output \
     arrays. A measurement ours rejects is not compared, only counted (skipped)";

/// Builds SymForce's peer: generates its code and compiles it with the glue; its objects.
pub fn build(root: &Path, python: &Path, dir: &Path) -> Result<Vec<PathBuf>, String> {
    let constants = constants(dir)?;
    let script = root.join("peers/symforce_codegen.py");
    let said = peers_build::generate(python, &script, &constants, dir)
        .map_err(|e| format!("SymForce's code generation: {e}"))?;
    print!("xtask: {said}");
    let eigen = Path::new(EIGEN);
    stateforge_cli::measure::setup::debian_file(
        &eigen.join("Eigen/Core"),
        EIGEN_PACKAGE,
        "SymForce's C++",
    )?;
    let options = vec![
        "-fno-exceptions".to_owned(),
        "-fno-rtti".to_owned(),
        format!("-I{}", eigen.display()),
        format!("-I{}", dir.join("symforce").display()),
    ];
    peers_build::compile(
        "arm-none-eabi-g++",
        &[root.join("peers/symforce_glue.cpp")],
        &options,
        &dir.join("obj/symforce"),
    )
    .map_err(|e| format!("SymForce's code cannot be built here: {e}"))
}

/// The exponential map's epsilon, `sqrt(|θ|² + ε²)` for the angle: the square root of
/// the compiler's `geometry::ANGLE_EPSILON_SQUARED` (1e-18), which the generated code
/// holds only as a literal. It moves no result above rounding unless the angle is near
/// 1e-9 rad; SymForce's `Rot3.from_tangent` pads the angle the same way.
const ANGLE_EPSILON: f64 = 1e-9;

/// The model's constants as the generator takes them (`navigation.json`), from the
/// generated Rust model itself.
fn constants(dir: &Path) -> Result<PathBuf, String> {
    use generated_demo::navigation;
    let json = serde_json::json!({
        "states": navigation::X_LEN,
        "tangent": navigation::TANGENT_LEN,
        "gravity": navigation::in_f64::GRAVITY,
        "epsilon": ANGLE_EPSILON,
    });
    let path = dir.join("navigation.json");
    std::fs::write(&path, json.to_string()).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(path)
}

/// The firmware wrappers of each side of each kernel, for the trace.
pub fn wrappers(program: &Program) -> Vec<String> {
    KERNELS
        .iter()
        .flat_map(|(kernel, _)| [ours(kernel), symforce(kernel)])
        .filter_map(|w| program.function(&w))
        .collect()
}

fn ours(kernel: &str) -> String {
    format!("generated_navigation_{kernel}")
}

fn symforce(kernel: &str) -> String {
    format!("peers_symforce_{kernel}")
}

/// One side of a kernel as the firmware printed it.
#[derive(Clone, Copy, Debug, Default)]
struct Counts {
    median: f64,
    worst: f64,
    mean: f64,
    stack: Option<f64>,
}

/// One kernel's comparison: calls compared and skipped, largest differences (state,
/// covariance) and the calls where they were.
#[derive(Clone, Copy, Debug, Default)]
struct Agreement {
    compared: f64,
    skipped: f64,
    state: f64,
    covariance: f64,
    at: (f64, f64),
}

/// What the firmware printed of the navigation peer.
#[derive(Debug, Default)]
struct Printed {
    counts: BTreeMap<(String, String), Counts>,
    agreement: BTreeMap<String, Agreement>,
}

/// The `navpeer`, `navstack` and `navdiff` lines.
fn parse(text: &str) -> Result<Printed, String> {
    let mut printed = Printed::default();
    for line in text.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let numbers = |values: &[&str]| -> Result<Vec<f64>, String> {
            values
                .iter()
                .map(|w| w.parse::<f64>())
                .collect::<Result<_, _>>()
                .map_err(|_| format!("bad number in `{line}`"))
        };
        match words.as_slice() {
            ["navpeer", side, kernel, values @ ..] if values.len() == 4 => {
                let v = numbers(values)?;
                let counts = printed
                    .counts
                    .entry(((*side).to_owned(), (*kernel).to_owned()))
                    .or_default();
                (counts.median, counts.worst, counts.mean) = (v[0], v[1], v[2]);
            }
            ["navstack", side, kernel, bytes] => {
                let v = numbers(&[bytes])?;
                printed
                    .counts
                    .entry(((*side).to_owned(), (*kernel).to_owned()))
                    .or_default()
                    .stack = Some(v[0]);
            }
            ["navdiff", kernel, values @ ..] if values.len() == 6 => {
                let v = numbers(values)?;
                printed.agreement.insert(
                    (*kernel).to_owned(),
                    Agreement {
                        compared: v[0],
                        skipped: v[1],
                        state: v[2],
                        covariance: v[3],
                        at: (v[4], v[5]),
                    },
                );
            }
            _ => {}
        }
    }
    Ok(printed)
}

/// The navigation table from the peers' firmware output, its image and its trace; or,
/// when SymForce could not be built (`built`), one line saying why.
pub fn report(
    built: &Result<Vec<PathBuf>, String>,
    text: &str,
    program: &Program,
    traced: &BTreeMap<String, Traced>,
    versions: &str,
) -> String {
    let mut out = format!(
        "SymForce's error-state navigation EKF beside the generated one (24 entries, 23 tangent coordinates), same Cortex-M4F, \
         same 4 s of the navigation flight ({versions}, {}):\n",
        peers_build::CFLAGS.join(" ")
    );
    if let Err(e) = built {
        out.push_str(&format!("  SymForce: cannot run here: {e}\n"));
        return out;
    }
    let printed = match parse(text) {
        Ok(printed) => printed,
        Err(e) => return format!("{out}  SymForce: {e}\n"),
    };
    out.push_str(&header());
    for (kernel, label) in KERNELS {
        match rows(kernel, label, &printed, program, traced) {
            Ok(rows) => out.push_str(&rows),
            Err(e) => out.push_str(&format!("{label:<24} cannot be reported: {e}\n")),
        }
    }
    out.push_str(NOTE);
    let places: Vec<String> = KERNELS
        .iter()
        .filter_map(|(kernel, label)| {
            let a = printed.agreement.get(*kernel)?;
            Some(format!("{label} {:.0} and {:.0}", a.at.0, a.at.1))
        })
        .collect();
    out.push_str(&format!(
        "  The largest differences (state, covariance) were at these calls of the flight's \
         1220: {}.\n",
        places.join("; ")
    ));
    out.push_str(&format!("  {TERMS}.\n"));
    out
}

/// The table's header.
fn header() -> String {
    format!(
        "{:<24} {:<9} {:>7} {:>7} {:>8} {:>9} {:>7} {:>6} {:>15} {:>9} {:>9} {:>8}\n",
        "kernel",
        "side",
        "median",
        "worst",
        "cyc med",
        "cyc worst",
        "text B",
        "stack",
        "ours/SF med/wst",
        "d state",
        "d cov",
        "skipped"
    )
}

/// What the columns mean.
const NOTE: &str = "  Instructions per call over the flight (every call read by \
     SysTick under -icount, the read of an empty call subtracted; 1000 predictions, 200 \
     magnetometer and 20 GNSS updates); cycles estimated at each side's traced cycles per \
     instruction; text: bytes of code the call can reach; stack: bytes. ours/SF: our \
     median and worst instructions over SymForce's (goal: at most 0.8). d state, d cov: the \
     largest difference of SymForce's result from ours over the calls compared, a state \
     entry scaled by max(|x_i|, sigma_k) (sigma_k = sqrt(P_kk) of its tangent coordinate), \
     the attitude as the rotation vector from ours to SymForce's scaled by sigma_k, and a \
     covariance entry by sigma_i sigma_j, x and P ours after the call (goal: at most 1e-5). *: the goal is not met. skipped: \
     the calls ours rejected as outliers, of all.\n";

/// A kernel's two rows: ours, with the ratios and the agreement, then SymForce's.
fn rows(
    kernel: &str,
    label: &str,
    printed: &Printed,
    program: &Program,
    traced: &BTreeMap<String, Traced>,
) -> Result<String, String> {
    let side = |name: &str| {
        printed
            .counts
            .get(&(name.to_owned(), kernel.to_owned()))
            .copied()
            .ok_or_else(|| format!("the firmware printed no counts of {name} {kernel}"))
    };
    let (ours_counts, symforce_counts) = (side("ours")?, side("symforce")?);
    let agreement = printed
        .agreement
        .get(kernel)
        .copied()
        .ok_or_else(|| format!("the firmware printed no comparison of {kernel}"))?;
    let ours_row = row(&ours(kernel), ours_counts, program, traced)?;
    let symforce_row = row(&symforce(kernel), symforce_counts, program, traced)?;
    let ratio = |a: f64, b: f64| a / b.max(1.0);
    let (median, worst) = (
        ratio(ours_counts.median, symforce_counts.median),
        ratio(ours_counts.worst, symforce_counts.worst),
    );
    // A figure that misses its goal is starred (the note says so).
    let verdict = |met: bool| if met { "" } else { "*" };
    Ok(format!(
        "{label:<24} {:<9} {ours_row} {:>15} {:>9} {:>9} {:>8}\n{:<24} {:<9} {symforce_row}\n",
        "ours",
        format!(
            "{median:.3}/{worst:.3}{}",
            verdict(median <= RATIO_GOAL && worst <= RATIO_GOAL)
        ),
        format!(
            "{:.1e}{}",
            agreement.state,
            verdict(agreement.state <= AGREEMENT_GOAL)
        ),
        format!(
            "{:.1e}{}",
            agreement.covariance,
            verdict(agreement.covariance <= AGREEMENT_GOAL)
        ),
        format!(
            "{:.0}/{:.0}",
            agreement.skipped,
            agreement.skipped + agreement.compared
        ),
        "",
        "SymForce",
    ))
}

/// One side's figures: instructions, estimated cycles, code size and stack.
fn row(
    wrapper: &str,
    counts: Counts,
    program: &Program,
    traced: &BTreeMap<String, Traced>,
) -> Result<String, String> {
    let function = program
        .function(wrapper)
        .ok_or_else(|| format!("no `{wrapper}` in the firmware"))?;
    let trace = traced
        .get(&function)
        .filter(|t| t.calls > 0)
        .ok_or_else(|| format!("the trace saw no call of `{wrapper}`"))?;
    // Each call is read to within a tick (40 instructions); their mean, to within a few.
    if (trace.instructions_per_call() - counts.mean).abs() > 16.0 {
        return Err(format!(
            "`{wrapper}`: the trace saw {:.0} instructions per call, the counter {:.0}",
            trace.instructions_per_call(),
            counts.mean
        ));
    }
    let cpi = trace.cycles_per_call() / trace.instructions_per_call().max(1.0);
    Ok(format!(
        "{:>7.0} {:>7.0} {:>8.0} {:>9.0} {:>7} {:>6}",
        counts.median,
        counts.worst,
        counts.median * cpi,
        counts.worst * cpi,
        program
            .reachable_size(&function)
            .map_or("?".into(), |b| b.to_string()),
        counts.stack.map_or("?".into(), |b| format!("{b:.0}")),
    ))
}

//! Building and running the Cortex-M4F firmware (`targets/`) under QEMU, and reading
//! what it printed.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A build of the firmware: the generated code is the same, the compiler's options differ.
#[derive(Clone, Copy, Debug)]
pub struct Build {
    /// How the tables and messages name it.
    pub name: &'static str,
    /// Cargo's target directory, relative to `targets/`.
    target_dir: &'static str,
    /// Extra `rustflags` for the MCU target.
    rustflags: Option<&'static str>,
    /// Whether `a * b + c` must compile to one fused, singly rounded `vfma.f32`.
    pub fused: bool,
}

/// The builds measured: LLVM's default, whose multiply-adds are chained `vmla.f32` (rounded
/// after the multiply, as the source), and the fused multiply-add option, which lets LLVM
/// contract every `a * b + c` into `vfma.f32` (no source change, no `unsafe`).
pub const BUILDS: [Build; 2] = [
    Build {
        name: "without FMA",
        target_dir: "target",
        rustflags: None,
        fused: false,
    },
    Build {
        name: "with FMA (-C llvm-args=--fp-contract=fast)",
        target_dir: "target/fma",
        rustflags: Some("-C llvm-args=--fp-contract=fast"),
        fused: true,
    },
];

/// The variable that adds `rustflags` for the MCU target to those of
/// `targets/.cargo/config.toml`.
const RUSTFLAGS_VARIABLE: &str = "CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUSTFLAGS";

impl Build {
    /// The image it builds.
    pub fn elf(&self, targets: &Path) -> PathBuf {
        targets
            .join(self.target_dir)
            .join("thumbv7em-none-eabihf/release/firmware")
    }
}

/// Longest a firmware run may take before it counts as hung.
const TIMEOUT: Duration = Duration::from_secs(600);

/// One `estimate` line: the sample, the three filters' estimates, the gain and control.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    /// Sample index `k`.
    pub k: usize,
    /// EKF from the close guess.
    pub ekf: [f64; 5],
    /// DKF from the close guess.
    pub dkf: [f64; 5],
    /// DKF from the wrong guess.
    pub dkf_wrong: [f64; 5],
    /// LQR gain on the DKF's estimate.
    pub gain: [f64; 2],
    /// The control it gives.
    pub control: f64,
}

/// One measured kernel: instructions per call and stack bytes, generated and baseline.
#[derive(Clone, Debug, PartialEq)]
pub struct Cost {
    /// Kernel name as the firmware prints it (`ekf_step`, ...).
    pub kernel: String,
    /// Instructions per call: generated code, nalgebra baseline.
    pub instructions: (u32, u32),
    /// Deepest stack use in bytes: generated code, nalgebra baseline.
    pub stack: (u32, u32),
}

/// How the instructions of a kernel's calls spread over its run.
#[derive(Clone, Debug, PartialEq)]
pub struct Spread {
    /// Kernel name as the firmware prints it.
    pub kernel: String,
    /// Median instructions per call (the typical call).
    pub median: u32,
    /// Most instructions of one call.
    pub worst: u32,
    /// Most solver iterations of one call.
    pub iterations: u32,
}

/// What a run's MPC solves recomputed, in all (`paths mpc_solve ..`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MpcPaths {
    /// Solves.
    pub solves: u32,
    /// Solves that rebuilt the prediction model.
    pub model_rebuilds: u32,
    /// Solves that ran the Riccati steps and condensed the Hessian.
    pub problem_rebuilds: u32,
    /// Active-set iterations of all solves.
    pub iterations: u32,
}

/// What the firmware reported.
#[derive(Debug, Default)]
pub struct Report {
    /// The estimate lines in order.
    pub estimates: Vec<Estimate>,
    /// The cost lines in order.
    pub costs: Vec<Cost>,
    /// The `continuous` lines (the helicopter's continuous-time EKF): sample, estimate.
    pub continuous: Vec<(usize, Vec<f64>)>,
    /// The `hybrid` lines (the blade's hybrid EKF): sample, estimate.
    pub hybrid: Vec<(usize, Vec<f64>)>,
    /// `observer k x..`: the piecewise beam's linear-error-dynamics observer.
    pub observer: Vec<(usize, Vec<f64>)>,
    /// `polykf k x..`: the polynomial Kalman filter.
    pub polykf: Vec<(usize, Vec<f64>)>,
    /// `mpc k iterations u1..`: the blade's MPC, its iterations and plan after sample `k`.
    pub mpc: Vec<(usize, Vec<f64>)>,
    /// `spread <kernel> <median> <worst> <most iterations>`: per-call instructions over a
    /// run whose calls differ in cost.
    pub spreads: Vec<Spread>,
    /// `paths mpc_solve <solves> <model rebuilds> <problem rebuilds> <iterations>`.
    pub mpc_paths: Option<MpcPaths>,
    /// `ram <what> <bytes>`: RAM a filter takes beside its estimate and covariance (a
    /// delayed horizon's buffers).
    pub ram: Vec<(String, u32)>,
    /// Of the multiply-adds compared with `libm::fmaf`: how many differed, of how many.
    pub fused: Option<(u32, u32)>,
    /// `math <function> <argument bits> <result bits>`: `stateforge_math::f32` on the
    /// target, for the host to compare bit for bit.
    pub math: Vec<(String, u32, u32)>,
    /// `bits <run> <k> <bits..>`: the runs the C firmware repeats through the C API, as
    /// printed, compared line for line.
    pub bits: Vec<String>,
}

/// Builds the firmware in release mode and runs it under QEMU (the runner in
/// `targets/.cargo/config.toml`); fails on a non-zero exit, a timeout or a missing `done`.
pub fn run(targets: &Path, build: Build) -> Result<Report, String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut command = Command::new(cargo);
    command
        .args(["run", "--release", "--quiet"])
        .current_dir(targets)
        .env("CARGO_TARGET_DIR", build.target_dir);
    match build.rustflags {
        Some(flags) => command.env(RUSTFLAGS_VARIABLE, flags),
        None => command.env_remove(RUSTFLAGS_VARIABLE),
    };
    let mut child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| format!("cannot start the firmware build: {e}"))?;
    // Read as it is printed: a firmware that prints more than a pipe holds (64 KiB) would
    // otherwise wait for a reader while this waits for it to exit.
    let mut stdout = child
        .stdout
        .take()
        .ok_or("the firmware's output is not piped")?;
    let reader = std::thread::spawn(move || {
        let mut bytes = Vec::new();
        std::io::Read::read_to_end(&mut stdout, &mut bytes).map(|_| bytes)
    });
    let started = Instant::now();
    loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            let bytes = reader
                .join()
                .map_err(|_| "the firmware's output reader panicked")?
                .map_err(|e| format!("cannot read the firmware's output: {e}"))?;
            let text = String::from_utf8_lossy(&bytes).into_owned();
            if !status.success() {
                return Err(format!(
                    "the firmware failed ({status}); it printed:\n{text}"
                ));
            }
            return parse(&text);
        }
        if started.elapsed() > TIMEOUT {
            let _ = child.kill();
            return Err(format!("the firmware did not finish within {TIMEOUT:?}"));
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The sample index and the numbers of a `<tag> k v1 v2 ..` line.
fn sample_line(line: &str, k: &str, values: &[&str]) -> Result<(usize, Vec<f64>), String> {
    let k = k.parse().map_err(|_| format!("bad sample in `{line}`"))?;
    let v = values
        .iter()
        .map(|w| w.parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("bad number in `{line}`"))?;
    Ok((k, v))
}

/// The firmware's report, read from its output: an error if it stopped before `done` or
/// printed no estimates or no costs.
fn parse(text: &str) -> Result<Report, String> {
    let mut report = Report::default();
    let mut done = false;
    for line in text.lines() {
        done |= read_line(&mut report, line)?;
    }
    if !done {
        return Err("the firmware stopped before `done`".into());
    }
    if report.estimates.is_empty() || report.costs.is_empty() {
        return Err("the firmware printed no estimates or no costs".into());
    }
    Ok(report)
}

/// A whole number `word` of `line`; the error names it as `what` ("count", "size").
fn whole(line: &str, word: &str, what: &str) -> Result<u32, String> {
    word.parse::<u32>()
        .map_err(|_| format!("bad {what} in `{line}`"))
}

/// Adds what `line` says to `report`, and says whether it is the last line, `done`.
/// Lines of no known tag are the firmware's prose, skipped.
fn read_line(report: &mut Report, line: &str) -> Result<bool, String> {
    let words: Vec<&str> = line.split_whitespace().collect();
    let count = |w: &str| whole(line, w, "count");
    match words.as_slice() {
        ["estimate", k, values @ ..] if values.len() == 18 => {
            report.estimates.push(estimate(line, k, values)?);
        }
        ["cost", kernel, generated, baseline] => report.costs.push(Cost {
            kernel: (*kernel).to_owned(),
            instructions: (count(generated)?, count(baseline)?),
            stack: (0, 0),
        }),
        ["stack", kernel, generated, baseline] => {
            let size = |w: &str| whole(line, w, "size");
            let stack = (size(generated)?, size(baseline)?);
            match report.costs.iter_mut().find(|c| c.kernel == *kernel) {
                Some(cost) => cost.stack = stack,
                None => return Err(format!("stack before cost for `{kernel}`")),
            }
        }
        ["ram", what, bytes] => report
            .ram
            .push(((*what).to_owned(), whole(line, bytes, "size")?)),
        ["spread", kernel, median, worst, iterations] => report.spreads.push(Spread {
            kernel: (*kernel).to_owned(),
            median: count(median)?,
            worst: count(worst)?,
            iterations: count(iterations)?,
        }),
        ["paths", "mpc_solve", solves, model_rebuilds, problem_rebuilds, iterations] => {
            report.mpc_paths = Some(MpcPaths {
                solves: count(solves)?,
                model_rebuilds: count(model_rebuilds)?,
                problem_rebuilds: count(problem_rebuilds)?,
                iterations: count(iterations)?,
            });
        }
        [tag @ ("continuous" | "hybrid" | "observer" | "polykf" | "mpc"), k, values @ ..] => {
            let sample = sample_line(line, k, values)?;
            match *tag {
                "continuous" => report.continuous.push(sample),
                "hybrid" => report.hybrid.push(sample),
                "observer" => report.observer.push(sample),
                "mpc" => report.mpc.push(sample),
                _ => report.polykf.push(sample),
            }
        }
        ["fused", differing, of] => report.fused = Some((count(differing)?, count(of)?)),
        ["math", function, x, y] => {
            let bits =
                |w: &str| u32::from_str_radix(w, 16).map_err(|_| format!("bad bits in `{line}`"));
            report
                .math
                .push(((*function).to_owned(), bits(x)?, bits(y)?));
        }
        ["bits", ..] => report.bits.push(line.to_owned()),
        ["done"] => return Ok(true),
        _ => {}
    }
    Ok(false)
}

/// An `estimate k ..` line: the EKF's and the DKF's estimates from the close guess, the
/// DKF's from the wrong guess, the LQR gain and the control.
fn estimate(line: &str, k: &str, values: &[&str]) -> Result<Estimate, String> {
    let (k, v) = sample_line(line, k, values)?;
    let five = |at: usize| [v[at], v[at + 1], v[at + 2], v[at + 3], v[at + 4]];
    Ok(Estimate {
        k,
        ekf: five(0),
        dkf: five(5),
        dkf_wrong: five(10),
        gain: [v[15], v[16]],
        control: v[17],
    })
}

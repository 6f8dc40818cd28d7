//! Embedded-QP peers of the generated MPC on the same emulated Cortex-M4F (`cargo xtask
//! peers`, and the end of `cargo xtask cost`; not part of `cargo xtask test`, which stays
//! offline and needs neither Python nor gcc): OSQP's and TinyMPC's code generators
//! (their Python packages, pinned, in a venv under `target/peers`) write their solvers
//! for the blade's QP into `target/peers`, `arm-none-eabi-gcc -O2` compiles them with the
//! project's glue (`peers/`) into `libpeers.a`, and the firmware built with
//! `--features peers` runs them beside the generated `Mpc` on the 300 steps of
//! `generated_demo::mpc_sequence` (`targets/src/peers.rs`). The rows: median and worst
//! instructions per solve (SysTick under -icount), estimated cycles (the traced calls'
//! cycles per instruction), code size, and the largest difference of each peer's plan from
//! the generated MPC's in the same run. A peer that cannot be built is reported with its
//! error. The same firmware runs SymForce's navigation EKF beside the generated one, and
//! a second table reports it (`peers_symforce`).

use crate::peers_build::{self, PACKAGES};
use crate::peers_table::{self, parse, Solver};
use crate::scratch::workspace_root;
use stateforge_cli::measure::program::Program;
use stateforge_cli::measure::trace::Traced;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Stdio;

/// The firmware crate, and where the peers' build of it goes (relative to it).
const TARGETS: &str = "targets";
const TARGET_DIR: &str = "target/peers";
const ELF: &str = "target/peers/thumbv7em-none-eabihf/release/firmware";

/// What each peer was handed and how it was tuned, printed under the rows.
const OSQP_TERMS: &str = "OSQP: the generated MPC's condensed QP (10 moves, H and c \
     condensed on the target from the Mpc's prediction model, terminal weight and \
     estimate, outside the measured call), objective times 1/R = 1e10; float, embedded \
     mode 2 (the update refactors the KKT matrix on the target), eps_abs = eps_rel = 1e-4, \
     max_iter 4000, rho 0.1 adaptive, sigma 1e-6, alpha 1.6, check every 25 iterations, \
     warm start from the last solution, scaling 10 Ruiz passes, no polishing (not in \
     embedded code)";

/// Builds what it can, runs the peers' firmware, and returns the tables: the QP peers',
/// then SymForce's beside the navigation EKF (`peers_symforce`).
pub fn report() -> Result<String, String> {
    let root = workspace_root();
    let dir = root.join("target/peers");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let problem = crate::peers_problem::problem()?;
    let problem_path = dir.join("problem.json");
    std::fs::write(&problem_path, problem.to_string())
        .map_err(|e| format!("{}: {e}", problem_path.display()))?;
    // The quadrotor's run (its states are the firmware's, written beside the JSON).
    let quadrotor = crate::peers_quadrotor_problem::problem(&dir)?;
    let quadrotor_path = dir.join("quadrotor.json");
    std::fs::write(&quadrotor_path, quadrotor.to_string())
        .map_err(|e| format!("{}: {e}", quadrotor_path.display()))?;
    let gcc = peers_build::arm_gcc()?;
    let python = peers_build::python(&dir)?;
    let versions = |names: &[&str]| -> String {
        let named: Vec<String> = PACKAGES
            .iter()
            .filter(|(name, _)| names.contains(name))
            .map(|(name, _)| {
                let v = peers_build::package_version(&python, name).unwrap_or_else(|e| e);
                format!("{name} {v}")
            })
            .collect();
        format!("{}; {gcc}", named.join(", "))
    };
    let osqp = build_osqp(&root, &python, &problem_path, &dir)?;
    let mut symforce = crate::peers_symforce::build(&root, &python, &dir);
    let text = build_and_run(&root, &dir, &osqp, &mut symforce)?;
    let mut solvers = parse(&text)?;
    if !solvers.contains_key("mpc") || !solvers.contains_key("osqp") {
        return Err("the peers' firmware printed no plans of the MPC or OSQP".into());
    }
    let (program, traced) = trace(&root, &osqp, symforce.is_ok())?;
    let mut rows = vec![
        row("mpc", &solvers, None, &program, &traced)?,
        row("osqp", &solvers, None, &program, &traced)?,
    ];
    // TinyMPC in its own C++ firmware (peers_tinympc.rs); a failure is its row's text.
    rows.push(
        tinympc(&root, &python, &problem_path, &dir, &mut solvers)
            .unwrap_or_else(|e| format!("{:<22} cannot run here: {e}\n", "TinyMPC (solve)")),
    );
    let mut out = format!(
        "Embedded-QP peers on the blade's MPC QP, same Cortex-M4F, same 300 steps \
         ({}, {}):\n",
        versions(&["osqp", "tinympc"]),
        peers_build::CFLAGS.join(" ")
    );
    out.push_str(&header());
    out.push_str(&rows.concat());
    out.push_str(NOTE);
    out.push_str(&format!(
        "  {OSQP_TERMS}.\n  {}.\n\n",
        crate::peers_tinympc::TERMS
    ));
    out.push_str(
        &crate::peers_quadrotor::report(
            &root,
            &python,
            &dir,
            &text,
            &program,
            &traced,
            &versions(&["osqp", "tinympc", "daqp"]),
        )
        .unwrap_or_else(|e| format!("TinyMPC's quadrotor benchmark: cannot run here: {e}\n\n")),
    );
    out.push_str(&crate::peers_symforce::report(
        &symforce,
        &text,
        &program,
        &traced,
        &versions(&["symforce"]),
    ));
    Ok(out)
}

/// Archives the peers' objects into `libpeers.a` and runs the firmware with them: with
/// SymForce's when they were built (feature `symforce`); if that firmware cannot be built
/// or run, SymForce's error becomes that, and the firmware runs without it.
fn build_and_run(
    root: &Path,
    dir: &Path,
    osqp: &[PathBuf],
    symforce: &mut Result<Vec<PathBuf>, String>,
) -> Result<String, String> {
    let targets = root.join(TARGETS);
    if let Ok(objects) = symforce.as_ref() {
        let all: Vec<PathBuf> = osqp.iter().chain(objects).cloned().collect();
        peers_build::archive(dir, &all)?;
        match run_firmware(&targets, dir, "peers,symforce") {
            Ok(text) => return Ok(text),
            Err(e) => *symforce = Err(format!("the firmware with SymForce's code: {e}")),
        }
    }
    if let Err(e) = symforce.as_ref() {
        println!("xtask: SymForce's peer cannot run here: {e}");
    }
    peers_build::archive(dir, osqp)?;
    run_firmware(&targets, dir, "peers")
}

/// The peers' firmware image and its traced run: the QP solvers' calls, and the
/// navigation kernels' when SymForce ran beside them.
fn trace(
    root: &Path,
    osqp: &[PathBuf],
    symforce: bool,
) -> Result<(Program, BTreeMap<String, Traced>), String> {
    let elf = root.join(TARGETS).join(ELF);
    let mut program = Program::read(&elf)?;
    peers_build::osqp_reaches_its_objects(&mut program, osqp)?;
    let mut wrappers: Vec<String> = ["mpc", "osqp", "quadmpc"]
        .iter()
        .filter_map(|n| program.function(&format!("peers_{n}_solve")))
        .collect();
    if symforce {
        wrappers.extend(crate::peers_symforce::wrappers(&program));
    }
    println!("xtask: the peers' firmware again, traced instruction by instruction");
    let traced = stateforge_cli::measure::trace::run(&elf, &program, &wrappers)?;
    Ok((program, traced))
}

/// TinyMPC's row: its own firmware built, run and traced.
fn tinympc(
    root: &Path,
    python: &Path,
    problem: &Path,
    dir: &Path,
    solvers: &mut BTreeMap<String, Solver>,
) -> Result<String, String> {
    let elf = crate::peers_tinympc::build(root, python, problem, dir)?;
    let text = crate::peers_tinympc::run(&elf)?;
    solvers.extend(parse(&text)?);
    let program = Program::read(&elf)?;
    let wrapper = vec!["peers_tinympc_solve".to_owned()];
    println!("xtask: TinyMPC's firmware again, traced instruction by instruction");
    let traced = stateforge_cli::measure::trace::run(&elf, &program, &wrapper)?;
    let own = crate::peers_tinympc::reference(dir)?;
    row("tinympc", solvers, Some(&own), &program, &traced)
}

/// OSQP's solver generated (`peers/osqp_codegen.py`) and compiled with the glue.
fn build_osqp(
    root: &Path,
    python: &Path,
    problem: &Path,
    dir: &Path,
) -> Result<Vec<PathBuf>, String> {
    let script = root.join("peers/osqp_codegen.py");
    let said = peers_build::generate(python, &script, problem, dir)
        .map_err(|e| format!("OSQP's code generation: {e}"))?;
    print!("xtask: {said}");
    let generated = dir.join("osqp");
    let mut sources = peers_build::sources(&generated.join("src"), "c")?;
    sources.push(generated.join("peer_workspace.c"));
    sources.push(root.join("peers/osqp_glue.c"));
    let includes =
        ["inc/public", "inc/private", ""].map(|sub| format!("-I{}", generated.join(sub).display()));
    peers_build::compile(
        "arm-none-eabi-gcc",
        &sources,
        &includes,
        &dir.join("obj/osqp"),
    )
    .map_err(|e| format!("OSQP cannot be built here: {e}"))
}

/// Builds and runs the firmware with the peers; its output.
fn run_firmware(targets: &Path, lib: &Path, features: &str) -> Result<String, String> {
    println!("xtask: the firmware with the peers ({features}) under QEMU");
    let mut command = crate::command::cargo();
    if features.contains("symforce") {
        command.env("PEERS_LIBM_DIR", peers_build::c_math_library()?);
    }
    let output = command
        .args(["run", "--release", "--quiet", "--features", features])
        .current_dir(targets)
        .env("CARGO_TARGET_DIR", TARGET_DIR)
        .env("PEERS_LIB_DIR", lib)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .output()
        .map_err(|e| format!("cannot start the peers' firmware: {e}"))?;
    peers_build::firmware_lines(&output, "the peers' firmware")
}

/// Largest difference of `solver`'s plans from `reference(k)`: first moves and whole plans
/// (V).
fn difference<'a>(solver: &Solver, reference: impl Fn(usize) -> Option<&'a [f64]>) -> (f64, f64) {
    let (mut first, mut whole) = (0.0_f64, 0.0_f64);
    for (k, (_, plan)) in &solver.plans {
        let Some(reference) = reference(*k) else {
            continue;
        };
        for (i, (a, b)) in plan.iter().zip(reference).enumerate() {
            let d = (a - b).abs();
            whole = whole.max(d);
            if i == 0 {
                first = first.max(d);
            }
        }
    }
    (first, whole)
}

/// The table's header.
fn header() -> String {
    peers_table::header(&[
        ("iters", 6),
        ("d first V", 10),
        ("d plan V", 10),
        ("d own V", 10),
        ("failed", 6),
    ])
}

/// What the columns mean.
const NOTE: &str =
    "  Instructions per solve over the 300 steps (SysTick under -icount, the call of \
     an empty function subtracted); cycles estimated at each solver's traced cycles per \
     instruction; us at 168 MHz; text: bytes of code the call can reach; d first, d plan: \
     largest difference from the generated MPC's plan at the same step (V, bounds +-100 \
     V); d own: from the exact solution of the QP the solver was given (OSQP's is the \
     generated MPC's own QP, so its d plan).\n";

/// One solver's row: `name`'s counts and plans from `solvers`, its cycles and size from
/// the firmware it ran in; `own`, the exact plans of its own QP where that differs from
/// the generated MPC's.
fn row(
    name: &str,
    solvers: &BTreeMap<String, Solver>,
    own: Option<&[Vec<f64>]>,
    program: &Program,
    traced: &BTreeMap<String, Traced>,
) -> Result<String, String> {
    let ours = solvers.get("mpc").ok_or("no plans of the generated MPC")?;
    let solver = solvers
        .get(name)
        .ok_or_else(|| format!("no plans of {name}"))?;
    let [median, worst, most, mean] = solver
        .spread
        .ok_or_else(|| format!("no spread line for {name}"))?;
    let (wrapper, trace) = peers_table::traced_call(name, program, traced)?;
    let cpi = peers_table::cycles_per_instruction(trace, mean)
        .map_err(|e| format!("`{wrapper}`: {e}"))?;
    let (first, whole) = difference(solver, |k| ours.plans.get(&k).map(|(_, p)| p.as_slice()));
    let (_, whole_own) = match own {
        // The exact plans are listed from step 1.
        Some(plans) => difference(solver, |k| {
            k.checked_sub(1)
                .and_then(|i| plans.get(i))
                .map(Vec::as_slice)
        }),
        None => (first, whole),
    };
    let label = match name {
        "mpc" => "generated Mpc::solve",
        "osqp" => "OSQP (update + solve)",
        _ => "TinyMPC (solve)",
    };
    let shown = |d: f64| {
        if name == "mpc" {
            "-".into()
        } else {
            format!("{d:.2e}")
        }
    };
    Ok(format!(
        "{label:<22} {} {most:>6.0} {:>10} {:>10} {:>10} {:>6}\n",
        peers_table::counts(median, worst, cpi, program.reachable_size(&wrapper)),
        shown(first),
        shown(whole),
        shown(whole_own),
        solver.failed(),
    ))
}

//! The cost table: per kernel, instructions per call (from the firmware), estimated cycles
//! (from an instruction trace of the same calls) and microseconds at the paper's 168 MHz,
//! code size and stack, generated code beside the nalgebra baseline, against the goals,
//! the C peer and the paper.

use crate::firmware::{MpcPaths, Report, Spread};
use crate::static_estimate;
use stateforge_cli::measure::program::Program;
use stateforge_cli::measure::timing;
use stateforge_cli::measure::trace::Traced;
use std::collections::BTreeMap;

/// The paper's clock: an STM32F407 at 168 MHz.
const CLOCK_MHZ: f64 = 168.0;

/// A measured kernel, as the firmware names it, with what it is compared against.
struct Kernel {
    /// The firmware's name (`dkf_step`): its wrappers are `generated_<name>` and
    /// `baseline_<name>`.
    name: &'static str,
    /// Row label.
    label: &'static str,
    /// Goal in instructions per call.
    goal: Option<u32>,
    /// The C peer's instructions per call (CasADi 3.8 C, arm-none-eabi-gcc 12 -O2, hard
    /// float, measured the same way, as the Cortex-M4F notes describe).
    c_peer: Option<u32>,
    /// The paper's time on its STM32F407 at 168 MHz, in milliseconds.
    paper_ms: Option<f64>,
}

/// The kernels, in table order.
const KERNELS: &[Kernel] = &[
    Kernel {
        name: "ekf_step",
        label: "EKF step",
        goal: Some(170),
        c_peer: Some(254),
        paper_ms: Some(6.92),
    },
    Kernel {
        name: "dkf_step",
        label: "DKF step",
        goal: Some(540),
        c_peer: Some(649),
        paper_ms: Some(11.67),
    },
    Kernel {
        name: "dkf_long_window_step",
        label: "DKF step, window 40 (LS)",
        goal: None,
        c_peer: None,
        paper_ms: None,
    },
    Kernel {
        name: "lqr_solve",
        label: "LQR solve (N = 50)",
        goal: Some(1300),
        c_peer: None,
        paper_ms: None,
    },
    Kernel {
        name: "loop",
        label: "whole loop (DKF + LQR + u)",
        goal: Some(3500),
        c_peer: None,
        paper_ms: None,
    },
    Kernel {
        name: "continuous_ekf_step",
        label: "continuous EKF step (heli)",
        // Issue 18: under 3000 once sin, cos and exp no longer compute in software f64.
        goal: Some(3000),
        c_peer: None,
        paper_ms: None,
    },
    Kernel {
        name: "hybrid_ekf_step",
        label: "hybrid EKF step (500 sub)",
        goal: Some(40000),
        c_peer: None,
        paper_ms: None,
    },
    Kernel {
        name: "switched_observer_step",
        label: "switched observer step",
        goal: None,
        c_peer: None,
        paper_ms: None,
    },
    Kernel {
        name: "polynomial_kf_step",
        label: "polynomial KF step (avg)",
        goal: None,
        c_peer: None,
        paper_ms: None,
    },
    Kernel {
        name: "mpc_solve",
        label: "MPC solve (n = 10, avg)",
        goal: None,
        c_peer: None,
        paper_ms: None,
    },
    // The navigation EKF over the first 4 s of the navigation flight (issue 19; since issue
    // 40 the error-state filter, 24 entries and a covariance over 23; SymForce's peer of
    // the same error-state filter is in the peers' table).
    Kernel {
        name: "navigation_predict",
        label: "navigation predict (24)",
        goal: None,
        c_peer: None,
        paper_ms: None,
    },
    Kernel {
        name: "navigation_update_gnss",
        label: "navigation GNSS update (6)",
        goal: None,
        c_peer: None,
        paper_ms: None,
    },
    Kernel {
        name: "navigation_update_magnetometer",
        label: "navigation mag update (3)",
        goal: None,
        c_peer: None,
        paper_ms: None,
    },
    // The same filter on a delayed horizon (issue 41): the GNSS 38 samples late, the
    // magnetometer's samples waiting for the horizon; a prediction that fuses one of them
    // re-propagates the current state through the buffered inputs.
    Kernel {
        name: "navigation_delayed_predict",
        label: "delayed nav predict",
        goal: None,
        c_peer: None,
        paper_ms: None,
    },
    Kernel {
        name: "navigation_delayed_predict_fusing",
        label: "delayed nav predict+mag",
        goal: None,
        c_peer: None,
        paper_ms: None,
    },
    Kernel {
        name: "navigation_delayed_update_gnss",
        label: "delayed nav GNSS update",
        goal: None,
        c_peer: None,
        paper_ms: None,
    },
    Kernel {
        name: "navigation_delayed_update_magnetometer",
        label: "delayed nav mag (buffered)",
        goal: None,
        c_peer: None,
        paper_ms: None,
    },
    // stateforge_math::f32, with libm's f32 function in the baseline column.
    math_kernel("sin_cos_f32", "sin_cos f32 (nalg: libm)"),
    math_kernel("tan_f32", "tan f32 (nalg: libm)"),
    math_kernel("exp_f32", "exp f32 (nalg: libm)"),
    math_kernel("ln_f32", "ln f32 (nalg: libm)"),
    math_kernel("atan2_f32", "atan2 f32 (nalg: libm)"),
    math_kernel("tanh_f32", "tanh f32 (nalg: libm)"),
    math_kernel("sqrt_f32", "sqrt f32 (nalg: libm)"),
];

/// A row of a `stateforge_math::f32` function: its baseline is `libm`'s, not nalgebra.
const fn math_kernel(name: &'static str, label: &'static str) -> Kernel {
    Kernel {
        name,
        label,
        goal: None,
        c_peer: None,
        paper_ms: None,
    }
}

/// The wrapper functions of every kernel the firmware measured, generated then
/// baseline, for the trace.
pub fn wrappers(costs: &[crate::firmware::Cost], program: &Program) -> Vec<String> {
    costs
        .iter()
        .flat_map(|c| ["generated", "baseline"].map(|side| format!("{side}_{}", c.kernel)))
        .filter_map(|w| program.function(&w))
        .collect()
}

/// Largest difference, in instructions per call, allowed between the trace's count and
/// the counter's: the trace follows the wrapper alone, the counter subtracts a harness
/// loop whose call of an empty function costs a few instructions.
const TRACE_SLACK: f64 = 8.0;

/// The table, as text. Fails if a kernel is missing or if the trace and the instruction
/// counter disagree (the trace then did not follow the calls the counter measured).
pub fn table(
    build: &str,
    full: bool,
    report: &Report,
    program: &Program,
    traced: &BTreeMap<String, Traced>,
) -> Result<String, String> {
    let (costs, spreads) = (&report.costs, &report.spreads);
    let paths = report
        .mpc_paths
        .ok_or("the firmware did not say what its MPC solves recomputed (`paths mpc_solve`)")?;
    let mut rows = Vec::new();
    for kernel in KERNELS {
        let Some(cost) = costs.iter().find(|c| c.kernel == kernel.name) else {
            return Err(format!("the firmware did not measure `{}`", kernel.name));
        };
        let side = |prefix: &str, instructions: u32| -> Result<Side, String> {
            let wrapper = program
                .function(&format!("{prefix}_{}", kernel.name))
                .ok_or_else(|| format!("no `{prefix}_{}` in the firmware", kernel.name))?;
            let trace = traced
                .get(&wrapper)
                .filter(|t| t.calls > 0)
                .ok_or_else(|| format!("the trace saw no call of `{wrapper}`"))?;
            let seen = trace.instructions_per_call();
            if (seen - f64::from(instructions)).abs() > TRACE_SLACK {
                return Err(format!(
                    "`{wrapper}`: the trace saw {seen:.1} instructions per call, the counter \
                     {instructions}"
                ));
            }
            let calls = trace.calls as f64;
            Ok(Side {
                instructions,
                cycles: trace.cycles_per_call(),
                groups: trace
                    .groups
                    .map(|(i, c)| (i as f64 / calls, c as f64 / calls)),
                text: program.reachable_size(&wrapper),
            })
        };
        rows.push(Row {
            kernel,
            generated: side("generated", cost.instructions.0)?,
            // A kernel without a nalgebra baseline reports 0 instructions for it.
            baseline: match cost.instructions.1 {
                0 => None,
                instructions => Some(side("baseline", instructions)?),
            },
            stack: cost.stack,
        });
    }
    // Cycles per instruction of each kernel over its traced calls, to estimate the cycles
    // of its median and worst calls.
    let cpi: BTreeMap<&str, f64> = rows
        .iter()
        .map(|r| {
            let g = &r.generated;
            (r.kernel.name, g.cycles / f64::from(g.instructions.max(1)))
        })
        .collect();
    let mut spread = spread_lines(spreads, &cpi, &paths);
    for (what, bytes) in &report.ram {
        spread.push_str(&format!("RAM of {what}: {bytes} bytes\n"));
    }
    if full {
        // The static estimate assumes the build without FMA (a `vmla` per multiply-add).
        let traced: Vec<(&str, &str, f64)> = rows
            .iter()
            .map(|r| (r.kernel.label, r.kernel.name, r.generated.cycles))
            .collect();
        static_estimate::check(&traced, &paths)?;
        Ok(format!("{}{spread}", render(build, &rows, program, &paths)))
    } else {
        Ok(format!(
            "The firmware {build}:\n{}{spread}",
            main_table(&rows, &paths)
        ))
    }
}

/// The typical and worst calls of the kernels whose calls differ in cost, and for the MPC
/// what its solves recomputed and the static estimate of its worst solve.
fn spread_lines(spreads: &[Spread], cpi: &BTreeMap<&str, f64>, paths: &MpcPaths) -> String {
    use generated_demo::mass_spring_damper as blade;
    let mut out = String::new();
    for spread in spreads {
        // The traced calls' cycles per instruction, applied to the median and worst call.
        let ratio = cpi.get(spread.kernel.as_str()).copied().unwrap_or(f64::NAN);
        let cycles = |instructions: u32| f64::from(instructions) * ratio;
        out.push_str(&format!(
            "{}: median {} and worst {} instructions per call over the run (about {:.0} and \
             {:.0} cycles, {:.1} and {:.1} us at 168 MHz, at the run's {ratio:.2} cycles per \
             instruction), at most {} solver iterations\n",
            spread.kernel,
            spread.median,
            spread.worst,
            cycles(spread.median),
            cycles(spread.worst),
            cycles(spread.median) / CLOCK_MHZ,
            cycles(spread.worst) / CLOCK_MHZ,
            spread.iterations
        ));
        if spread.kernel == "mpc_solve" {
            out.push_str(&format!(
                "  its {} solves: {} rebuilt the prediction model, {} the terminal weight and \
                 Hessian, {} active-set iterations in all; the static estimate at these \
                 counts is {:.0} cycles per solve\n",
                paths.solves,
                paths.model_rebuilds,
                paths.problem_rebuilds,
                paths.iterations,
                static_estimate::cycles("mpc_solve", paths).unwrap_or(f64::NAN),
            ));
            let [kept, problem, model] = blade::Mpc::ITERATIONS_WITHIN_BUDGET;
            out.push_str(&format!(
                "  static estimate of the worst solve (MPC_SOLVE_WORST_CYCLES: the costliest \
                 kind of solve with the iterations its cycle budget allows, {kept} / {problem} / \
                 {model} after rebuilding nothing / the problem / the model and problem): {} \
                 cycles, against {:.0} for the run's worst\n",
                blade::MPC_SOLVE_WORST_CYCLES,
                cycles(spread.worst)
            ));
        }
    }
    out
}

/// One side of a row: generated code or the baseline.
struct Side {
    instructions: u32,
    cycles: f64,
    /// Per call, instructions and cycles by group ([`timing::GROUPS`]).
    groups: [(f64, f64); timing::GROUPS.len()],
    text: Option<u64>,
}

struct Row<'k> {
    kernel: &'k Kernel,
    generated: Side,
    baseline: Option<Side>,
    stack: (u32, u32),
}

/// The table of instructions, cycles and microseconds.
fn main_table(rows: &[Row], paths: &MpcPaths) -> String {
    let us = |cycles: f64| cycles / CLOCK_MHZ;
    let show = |v: Option<u32>| v.map_or("-".to_owned(), |v| v.to_string());
    let mut out = String::new();
    out.push_str(&format!(
        "{:<28} {:>15} {:>27} {:>15}   {:>5} {:>6}   {:>9} {:>8}\n",
        "",
        "instructions",
        "cycles (est.) / static",
        "us at 168 MHz",
        "goal",
        "C peer",
        "nalg/gen",
        "peer/gen"
    ));
    out.push_str(&format!(
        "{:<28} {:>7} {:>7} {:>7} {:>11} {:>7} {:>7} {:>7}   {:>5} {:>6}   {:>4} {:>4} {:>8}\n",
        "kernel",
        "gen",
        "nalg",
        "gen",
        "static",
        "nalg",
        "gen",
        "nalg",
        "",
        "",
        "ins",
        "cyc",
        "ins"
    ));
    for row in rows {
        let (g, b) = (&row.generated, row.baseline.as_ref());
        let verdict = match row.kernel.goal {
            Some(goal) if g.instructions >= goal => "  (above the goal)",
            _ => "",
        };
        let peer = row.kernel.c_peer.map_or("-".to_owned(), |p| {
            format!("{:.2}", f64::from(p) / f64::from(g.instructions))
        });
        let baseline = |value: &dyn Fn(&Side) -> String| b.map_or("-".to_owned(), value);
        // The compiler's static estimate (`*_CYCLES`), and how far it is from the trace.
        let estimate =
            static_estimate::cycles(row.kernel.name, paths).map_or("-".to_owned(), |s| {
                format!(
                    "{s:.0} {:+.0}%",
                    100.0 * static_estimate::difference(s, g.cycles)
                )
            });
        out.push_str(&format!(
            "{:<28} {:>7} {:>7} {:>7.0} {:>11} {:>7} {:>7.2} {:>7}   {:>5} {:>6}   {:>4} {:>4} {:>8}{verdict}\n",
            row.kernel.label,
            g.instructions,
            baseline(&|b| b.instructions.to_string()),
            g.cycles,
            estimate,
            baseline(&|b| format!("{:.0}", b.cycles)),
            us(g.cycles),
            baseline(&|b| format!("{:.2}", us(b.cycles))),
            show(row.kernel.goal),
            show(row.kernel.c_peer),
            baseline(&|b| format!("{:.1}", f64::from(b.instructions) / f64::from(g.instructions))),
            baseline(&|b| format!("{:.1}", b.cycles / g.cycles)),
            peer,
        ));
    }
    out
}

fn render(build: &str, rows: &[Row], program: &Program, paths: &MpcPaths) -> String {
    let us = |cycles: f64| cycles / CLOCK_MHZ;
    let mut out = format!("The firmware {build}.\n");
    out.push_str(
        "Cortex-M4F under QEMU (mps2-an386): f32, opt-level 3, fat LTO. Instructions per call in\n\
         steady state (SysTick under -icount, call overhead excluded); cycles estimated from an\n\
         instruction trace of the same calls, each instruction weighted by the Cortex-M4 TRM's\n\
         timings (zero wait states, taken branch 3 cycles: xtask/src/timing.rs); microseconds\n\
         at 168 MHz, the paper's STM32F407 clock. gen: generated code, nalg: nalgebra.\n\n",
    );
    out.push_str(&main_table(rows, paths));
    out.push_str(&format!(
        "\n{:<28} {:>9} {:>9}   {:>9} {:>9}   {:>10}\n",
        "kernel", "text gen", "text nalg", "stack gen", "stack nalg", "cyc/ins gen"
    ));
    for row in rows {
        let text = |s: &Side| s.text.map_or("?".to_owned(), |b| b.to_string());
        out.push_str(&format!(
            "{:<28} {:>9} {:>9}   {:>9} {:>9}   {:>10.2}\n",
            row.kernel.label,
            text(&row.generated),
            row.baseline.as_ref().map_or("-".to_owned(), text),
            row.stack.0,
            if row.baseline.is_some() {
                row.stack.1.to_string()
            } else {
                "-".to_owned()
            },
            row.generated.cycles / f64::from(row.generated.instructions),
        ));
    }
    out.push_str(
        "\nWhere the generated code's estimated cycles go, per call (instructions / cycles):\n",
    );
    out.push_str(&format!("{:<28}", "kernel"));
    for group in timing::GROUPS {
        out.push_str(&format!(" {group:>11}"));
    }
    out.push('\n');
    for row in rows {
        out.push_str(&format!("{:<28}", row.kernel.label));
        for (instructions, cycles) in row.generated.groups {
            out.push_str(&format!(
                " {:>13}",
                format!("{instructions:.0} / {cycles:.0}")
            ));
        }
        out.push('\n');
    }
    let paper: Vec<String> = rows
        .iter()
        .filter_map(|row| {
            let ms = row.kernel.paper_ms?;
            let ours = us(row.generated.cycles);
            Some(format!(
                "{:<10} {ms:>6} ms   generated {ours:>6.2} us   ({:.0} times less)",
                row.kernel.label,
                ms * 1000.0 / ours
            ))
        })
        .collect();
    if !paper.is_empty() {
        out.push_str("\nThe paper's C on its STM32F407 at 168 MHz, against the estimate here:\n");
        for line in paper {
            out.push_str(&format!("  {line}\n"));
        }
    }
    out.push_str(
        "\nGenerated functions in the image (.text bytes; the rest is inlined into them):\n",
    );
    for (name, &(_, bytes)) in program
        .functions
        .iter()
        .filter(|(name, _)| name.starts_with("generated_demo::"))
    {
        out.push_str(&format!("  {bytes:>6}  {name}\n"));
    }
    out
}

/// The instructions a call through the C API should take at most beyond the Rust call it
/// wraps (issue 42): the wrapper checks its pointers (null, alignment, all at once) and
/// the storage's tag, and copies nothing. Rows above it are marked, not failed: beyond the
/// checks, what is left is how the compiler allocates the registers of the same Rust code
/// inlined into the C function, which the wrapper does not control.
const C_API_OVERHEAD: i64 = 12;

/// The instructions per call through the C API (the C firmware's) beside the Rust calls'
/// (the Rust firmware's, without FMA: the static libraries are built without it), and the
/// wrapper's overhead; fails if the Rust firmware did not measure a kernel.
pub fn c_api_table(rust: &[crate::firmware::Cost], c: &[(String, u32)]) -> Result<String, String> {
    let mut out = format!(
        "Through the C API (targets/c/main.c, arm-none-eabi-gcc -O2, against the static \
         libraries of stateforge-codegen c-api): instructions per call, measured as the Rust \
         firmware measures its calls, on the same data; the goal is an overhead of at most \
         {C_API_OVERHEAD}.\n"
    );
    out.push_str(&format!(
        "{:<32} {:>7} {:>7} {:>9}\n",
        "kernel", "Rust", "C API", "overhead"
    ));
    for (kernel, through_c) in c {
        let label = KERNELS
            .iter()
            .find(|k| k.name == kernel)
            .map_or(kernel.as_str(), |k| k.label);
        let Some(native) = rust.iter().find(|r| &r.kernel == kernel) else {
            return Err(format!("the Rust firmware did not measure `{kernel}`"));
        };
        let overhead = i64::from(*through_c) - i64::from(native.instructions.0);
        let verdict = if overhead > C_API_OVERHEAD {
            "  (above the goal)"
        } else {
            ""
        };
        out.push_str(&format!(
            "{label:<32} {:>7} {through_c:>7} {overhead:>+9}{verdict}\n",
            native.instructions.0
        ));
    }
    Ok(out)
}

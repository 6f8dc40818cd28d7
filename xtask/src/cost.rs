//! The cost table: instructions per call (from the firmware), code size and stack per
//! kernel, generated code beside the nalgebra baseline, against the goals.

use crate::firmware::Cost;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

/// Per kernel: label, goal in instructions, the C peer's figure (CasADi 3.8, -O2).
const KERNELS: [(&str, &str, Option<u32>, Option<u32>); 8] = [
    ("ekf_step", "EKF step", Some(210), Some(254)),
    ("dkf_step", "DKF step", Some(540), Some(649)),
    ("lqr_solve", "LQR solve (N = 50)", Some(2500), None),
    ("loop", "whole loop (DKF + LQR + u)", Some(3500), None),
    (
        "continuous_ekf_step",
        "continuous EKF step (heli)",
        None,
        None,
    ),
    ("hybrid_ekf_step", "hybrid EKF step (500 sub)", None, None),
    (
        "switched_observer_step",
        "switched observer step",
        None,
        None,
    ),
    ("polynomial_kf_step", "polynomial KF step (avg)", None, None),
];

/// The firmware's functions: their sizes and whom they call.
struct Program {
    size: BTreeMap<String, u64>,
    calls: BTreeMap<String, BTreeSet<String>>,
}

impl Program {
    fn read(elf: &Path) -> Result<Program, String> {
        let text = |args: &[&str], tool: &str| -> Result<String, String> {
            let out = Command::new(tool)
                .args(args)
                .arg(elf)
                .output()
                .map_err(|e| format!("cannot run {tool}: {e}"))?;
            Ok(String::from_utf8_lossy(&out.stdout).into_owned())
        };
        let mut size = BTreeMap::new();
        for line in text(&["-S", "--demangle", "--defined-only"], "arm-none-eabi-nm")?.lines() {
            let words: Vec<&str> = line.splitn(4, ' ').collect();
            if let [_, bytes, kind, name] = words[..] {
                if kind.eq_ignore_ascii_case("t") {
                    size.insert(name.to_owned(), u64::from_str_radix(bytes, 16).unwrap_or(0));
                }
            }
        }
        let mut calls: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        let mut current = String::new();
        for line in text(&["-d", "--demangle"], "arm-none-eabi-objdump")?.lines() {
            if let Some(name) = line.strip_suffix(">:").and_then(|l| l.split_once(" <")) {
                current = name.1.to_owned();
            } else if let Some((_, target)) = line.split_once(" <") {
                let is_branch = ["\tbl\t", "\tb.w\t", "\tb\t"]
                    .iter()
                    .any(|b| line.contains(b));
                if let Some(callee) = target.strip_suffix('>').filter(|_| is_branch) {
                    if !callee.contains('+') && callee != current {
                        calls
                            .entry(current.clone())
                            .or_default()
                            .insert(callee.to_owned());
                    }
                }
            }
        }
        Ok(Program { size, calls })
    }

    /// Bytes of code `root` can execute: itself and everything it calls, once each.
    fn reachable_size(&self, root: &str) -> Option<u64> {
        let mut seen = BTreeSet::new();
        let mut stack = vec![root.to_owned()];
        while let Some(f) = stack.pop() {
            if seen.insert(f.clone()) {
                stack.extend(self.calls.get(&f).into_iter().flatten().cloned());
            }
        }
        let sizes: Vec<u64> = seen
            .iter()
            .filter_map(|f| self.size.get(f))
            .copied()
            .collect();
        (!sizes.is_empty() && self.size.contains_key(root)).then(|| sizes.iter().sum())
    }

    /// The kernel wrapper whose demangled name ends with `::name`.
    fn function(&self, name: &str) -> Option<String> {
        let suffix = format!("::{name}");
        self.size.keys().find(|k| k.ends_with(&suffix)).cloned()
    }
}

/// The table, as text.
pub fn table(costs: &[Cost], elf: &Path) -> Result<String, String> {
    let program = Program::read(elf)?;
    let code = |kernel: &str, side: &str| {
        program
            .function(&format!("{side}_{kernel}"))
            .and_then(|f| program.reachable_size(&f))
            .map_or("?".to_owned(), |b| b.to_string())
    };
    let mut out = String::new();
    out.push_str(
        "Cortex-M4F under QEMU (mps2-an386, -icount): f32, opt-level 3, fat LTO; instructions\n\
         per call in steady state (call overhead excluded), code bytes reachable from the\n\
         kernel, deepest stack use. Instructions, not cycles: vdiv takes 14 cycles, loads 2.\n\n",
    );
    out.push_str(&format!(
        "{:<28} {:>9} {:>9} {:>6} {:>6}   {:>9} {:>9}   {:>9} {:>9}\n",
        "kernel",
        "generated",
        "nalgebra",
        "goal",
        "C peer",
        "text gen",
        "text nalg",
        "stack gen",
        "stack nalg"
    ));
    for (kernel, label, goal, peer) in KERNELS {
        let Some(cost) = costs.iter().find(|c| c.kernel == kernel) else {
            return Err(format!("the firmware did not measure `{kernel}`"));
        };
        let show = |v: Option<u32>| v.map_or("-".to_owned(), |v| v.to_string());
        let verdict = match goal {
            Some(g) if cost.instructions.0 < g => "",
            Some(_) => "  (above the goal)",
            None => "",
        };
        let loop_kernel = if kernel == "loop" { "loop" } else { kernel };
        out.push_str(&format!(
            "{:<28} {:>9} {:>9} {:>6} {:>6}   {:>9} {:>9}   {:>9} {:>9}{verdict}\n",
            label,
            cost.instructions.0,
            // Kernels without a nalgebra baseline report 0.
            show(Some(cost.instructions.1).filter(|&v| v > 0)),
            show(goal),
            show(peer),
            code(loop_kernel, "generated"),
            if cost.instructions.1 > 0 {
                code(loop_kernel, "baseline")
            } else {
                "-".to_owned()
            },
            cost.stack.0,
            show(Some(cost.stack.1).filter(|_| cost.instructions.1 > 0)),
        ));
    }
    out.push_str(
        "\nGenerated functions in the image (.text bytes; the rest is inlined into them):\n",
    );
    for (name, bytes) in program
        .size
        .iter()
        .filter(|(name, _)| name.starts_with("generated_demo::"))
    {
        out.push_str(&format!("  {bytes:>6}  {name}\n"));
    }
    Ok(out)
}

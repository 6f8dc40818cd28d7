//! The static cycle estimate: what a generated call costs on a target core, from what its
//! code does ([`OpCount`]: operations by kind, library calls by function, loads, stores
//! and branches), weighted by a small timing table per core.
//!
//! The Cortex-M4F's table follows ARM's Cortex-M4 Technical Reference Manual (r0p1,
//! tables 3-1 and 7-1) at zero wait states, the same source and simplifications as the
//! instruction trace of `cargo xtask cost` (`xtask/src/timing.rs`):
//!
//! | operation | cycles | why |
//! | --- | --- | --- |
//! | addition, subtraction, negation | 1 | `vadd`, `vsub`, `vneg` |
//! | multiplication | 1 | `vmul` |
//! | a multiplication and an addition | 3 | a product that feeds a sum is one `vmla` or `vmls`: as many pairs as the fewer of the two |
//! | division, square root | 14 | `vdiv`, `vsqrt` |
//! | comparison (a piecewise term, a guard) | 3 | `vcmp`, `vmrs`, and a conditional move or branch |
//! | load, store, literal | 2 | `vldr`, `vstr` (single) |
//! | branch taken | 3 | 1 and the pipeline refill (2) |
//! | a call's entry and return | 20 | saving and restoring the registers it uses, `bx lr` |
//! | `stateforge_math::f32` functions | measured | the `*_f32` rows of `cargo xtask cost`, rounded up |
//!
//! What it leaves out, and why the trace may differ: the order the compiler gives the
//! instructions (the loads and spills are estimated from the order the code is emitted
//! in, by [`crate::emit::registers`]), moves between registers, the integer arithmetic
//! of addresses and loop counters, caches and wait states (none on a Cortex-M4 at zero
//! wait states), interrupts.

use crate::emit::lower::{Callee, OpCount};

/// A core's timings, in cycles per operation.
#[derive(Clone, Copy, Debug)]
pub struct Target {
    /// The name a model gives (`cortex_m4f`).
    pub name: &'static str,
    /// How the core is described in docs and messages.
    pub description: &'static str,
    /// An addition, subtraction or negation.
    pub add: u32,
    /// A multiplication.
    pub mul: u32,
    /// A multiplication and the addition it feeds, one instruction.
    pub mul_add: u32,
    /// A division.
    pub div: u32,
    /// A comparison and what it selects.
    pub compare: u32,
    /// A load from memory (a literal from the constant pool included).
    pub load: u32,
    /// A store to memory.
    pub store: u32,
    /// A taken branch.
    pub branch: u32,
    /// A generated call's entry and return.
    pub entry: u32,
    /// Each library function, indexed by [`Callee`].
    pub calls: [u32; Callee::COUNT],
}

/// The Cortex-M4F (single-precision FPU), at zero wait states.
pub const CORTEX_M4F: Target = Target {
    name: "cortex_m4f",
    description: "Cortex-M4F",
    add: 1,
    mul: 1,
    mul_add: 3,
    div: 14,
    compare: 3,
    load: 2,
    store: 2,
    branch: 3,
    entry: 20,
    // sin cos tan exp ln sqrt abs tanh atan2 sin_cos: the measured rows (instructions
    // traced and weighted like the kernels'), `sqrt` inline as `vsqrt`, `abs` as `vabs`.
    calls: [114, 114, 122, 88, 106, 14, 1, 104, 137, 114],
};

/// The cores the estimate knows, by the name a model gives.
pub const TARGETS: &[Target] = &[CORTEX_M4F];

/// A call's estimated cycles, and where they go.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Estimate {
    /// Cycles per call.
    pub cycles: u64,
    /// The contributions, largest first: what (`"72 multiply-adds"`) and cycles.
    pub parts: Vec<(String, u64)>,
}

impl Estimate {
    /// The `n` largest contributions, as `72 multiply-adds 216 cycles, ..`.
    pub fn largest(&self, n: usize) -> String {
        let parts: Vec<String> = self
            .parts
            .iter()
            .take(n)
            .map(|(what, cycles)| format!("{what} {cycles} cycles"))
            .collect();
        parts.join(", ")
    }
}

impl Target {
    /// The estimate of one call of code that does `ops`.
    pub fn estimate(&self, ops: &OpCount) -> Estimate {
        self.tally(ops, true)
    }

    /// The estimate of code that does `ops` inside a call (a sub-step, one iteration):
    /// without the call's entry and return.
    pub fn estimate_part(&self, ops: &OpCount) -> Estimate {
        self.tally(ops, false)
    }

    fn tally(&self, ops: &OpCount, call: bool) -> Estimate {
        let count =
            |n: u32, one: &str, many: &str| format!("{n} {}", if n == 1 { one } else { many });
        // A product that feeds a sum is one multiply-add instruction.
        let fused = ops.mul.min(ops.add);
        let mut parts = vec![
            (
                count(fused, "multiply-add", "multiply-adds"),
                fused,
                self.mul_add,
            ),
            (
                count(ops.add - fused, "addition", "additions"),
                ops.add - fused,
                self.add,
            ),
            (
                count(ops.mul - fused, "multiplication", "multiplications"),
                ops.mul - fused,
                self.mul,
            ),
            (count(ops.div, "division", "divisions"), ops.div, self.div),
            (
                count(ops.compare, "comparison", "comparisons"),
                ops.compare,
                self.compare,
            ),
            (
                count(ops.load.saturating_add(ops.literal), "load", "loads"),
                ops.load.saturating_add(ops.literal),
                self.load,
            ),
            (count(ops.store, "store", "stores"), ops.store, self.store),
            (
                count(ops.branch, "branch", "branches"),
                ops.branch,
                self.branch,
            ),
            (
                "entry and return".to_owned(),
                u32::from(call).saturating_add(ops.entry),
                self.entry,
            ),
        ];
        for (i, &n) in ops.calls.iter().enumerate() {
            let name = Callee(i).name();
            parts.push((
                format!("{n} {} to {name}", if n == 1 { "call" } else { "calls" }),
                n,
                self.calls[i],
            ));
        }
        let mut parts: Vec<(String, u64)> = parts
            .into_iter()
            .filter(|&(_, n, _)| n > 0)
            .map(|(what, n, each)| (what, u64::from(n) * u64::from(each)))
            .filter(|&(_, cycles)| cycles > 0)
            .collect();
        parts.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        Estimate {
            cycles: parts.iter().map(|p| p.1).sum(),
            parts,
        }
    }

    /// The core named `name`.
    pub fn named(name: &str) -> Option<&'static Target> {
        TARGETS.iter().find(|t| t.name == name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_estimate_weighs_each_kind_and_names_the_largest_first() {
        let mut ops = OpCount {
            add: 10,
            mul: 20,
            div: 2,
            load: 5,
            store: 3,
            ..OpCount::default()
        };
        ops.calls[Callee::SIN_COS.0] = 1;
        let estimate = CORTEX_M4F.estimate(&ops);
        assert_eq!(estimate.cycles, 3 * 10 + 10 + 28 + 10 + 6 + 20 + 114);
        assert_eq!(
            estimate.largest(3),
            "1 call to sin_cos 114 cycles, 10 multiply-adds 30 cycles, 2 divisions 28 cycles"
        );
    }
}

//! Cycles per executed instruction on a Cortex-M4F, from the instruction timings in ARM's
//! Cortex-M4 Technical Reference Manual (r0p1: table 3-1, the processor's instructions,
//! and table 7-1, the FPU's), for a system with zero wait states.
//!
//! | instructions | cycles |
//! | --- | --- |
//! | data processing, `mul`, `mla`, `mls`, long multiplies, `it`, `nop` | 1 |
//! | `sdiv`, `udiv` | 12 (the TRM gives 2 to 12; the upper bound) |
//! | `ldr`/`str` (word, byte, halfword) | 2, or 1 right after a load (pipelined) |
//! | `ldrd`, `strd` | 3 |
//! | `ldm`, `stm`, `push`, `pop` of N registers | 1 + N |
//! | `b`, `bl`, `bx`, `blx`, a write to `pc` | 1 + P |
//! | `b<cond>`, `cbz`, `cbnz` | 1 + P if taken, else 1 |
//! | `tbb`, `tbh` | 2 + P |
//! | `vadd`, `vsub`, `vmul`, `vnmul`, `vneg`, `vabs`, `vcmp`, `vcvt`, `vmov` (FP registers, immediates), `vmrs`, `vmsr` | 1 |
//! | `vmov` to or from core registers | 2 |
//! | `vmla`, `vmls`, `vnmla`, `vnmls`, `vfma`, `vfms`, `vfnma`, `vfnms` | 3 |
//! | `vdiv`, `vsqrt` | 14 |
//! | `vldr`, `vstr` (single) | 2 |
//! | `vldm`, `vstm`, `vpush`, `vpop` of N single registers | 1 + N (a double counts twice) |
//!
//! Simplifications: P, the pipeline refill after a taken branch, is 1 to 3 cycles in the
//! TRM (by the target's alignment and width); 2 is used. Memory has no wait states (on the
//! paper's STM32F407 at 168 MHz the flash has 5, hidden by the ART accelerator when it
//! hits). No stalls are modelled: not a load whose address depends on the instruction
//! before it, not an FPU result used at once. Integer instructions after `vdiv` and
//! `vsqrt` may complete during them; all 14 cycles are counted. An instruction whose
//! condition fails inside an `it` block is counted as if it executed, and `it` itself is
//! counted although the core can fold it into the instruction before.

/// Pipeline refill after a taken branch (1 to 3 in the TRM).
pub const REFILL: u32 = 2;

/// What an instruction costs, by kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    /// A fixed number of cycles.
    Fixed(u32),
    /// A single load: 2 cycles, 1 right after another load.
    Load,
    /// A single store: 2 cycles, 1 right after a load.
    Store,
    /// A branch: 1 cycle, plus the refill when taken (always, if unconditional).
    Branch {
        /// Whether it may fall through.
        conditional: bool,
    },
}

/// Condition-code suffixes of ARM mnemonics.
const CONDITIONS: [&str; 16] = [
    "eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le",
];

/// Mnemonic bases that are not single-cycle, with their cost; the rest take 1 cycle.
const TABLE: &[(&str, Cost)] = &[
    ("vdiv", Cost::Cycles(14)),
    ("vsqrt", Cost::Cycles(14)),
    ("vmla", Cost::Cycles(3)),
    ("vmls", Cost::Cycles(3)),
    ("vnmla", Cost::Cycles(3)),
    ("vnmls", Cost::Cycles(3)),
    ("vfma", Cost::Cycles(3)),
    ("vfms", Cost::Cycles(3)),
    ("vfnma", Cost::Cycles(3)),
    ("vfnms", Cost::Cycles(3)),
    ("vldr", Cost::Cycles(2)),
    ("vstr", Cost::Cycles(2)),
    ("vmov", Cost::FpMove),
    ("vldmia", Cost::FpMultiple),
    ("vldmdb", Cost::FpMultiple),
    ("vstmia", Cost::FpMultiple),
    ("vstmdb", Cost::FpMultiple),
    ("vpush", Cost::FpMultiple),
    ("vpop", Cost::FpMultiple),
    ("ldrd", Cost::Cycles(3)),
    ("strd", Cost::Cycles(3)),
    ("ldrexb", Cost::Load),
    ("ldrexh", Cost::Load),
    ("ldrex", Cost::Load),
    ("ldrsb", Cost::Load),
    ("ldrsh", Cost::Load),
    ("ldrb", Cost::Load),
    ("ldrh", Cost::Load),
    ("ldr", Cost::Load),
    ("strexb", Cost::Store),
    ("strexh", Cost::Store),
    ("strex", Cost::Store),
    ("strb", Cost::Store),
    ("strh", Cost::Store),
    ("str", Cost::Store),
    ("ldmia", Cost::Multiple),
    ("ldmdb", Cost::Multiple),
    ("ldmfd", Cost::Multiple),
    ("ldm", Cost::Multiple),
    ("stmia", Cost::Multiple),
    ("stmdb", Cost::Multiple),
    ("stmfd", Cost::Multiple),
    ("stm", Cost::Multiple),
    ("push", Cost::Multiple),
    ("pop", Cost::Multiple),
    ("sdiv", Cost::Cycles(12)),
    ("udiv", Cost::Cycles(12)),
    ("tbb", Cost::Cycles(2 + REFILL)),
    ("tbh", Cost::Cycles(2 + REFILL)),
    ("cbnz", Cost::Branch),
    ("cbz", Cost::Branch),
    ("blx", Cost::Branch),
    ("bl", Cost::Branch),
    ("bx", Cost::Branch),
    ("b", Cost::Branch),
];

#[derive(Clone, Copy)]
enum Cost {
    Cycles(u32),
    Load,
    Store,
    /// `ldm`/`stm`/`push`/`pop`: 1 + N, + P if `pc` is loaded.
    Multiple,
    /// `vldm`/`vstm`/`vpush`/`vpop`: 1 + N singles.
    FpMultiple,
    /// `vmov`: 2 with a core register, else 1.
    FpMove,
    Branch,
}

/// The class of an instruction, from its mnemonic and operands as objdump prints them.
pub fn classify(mnemonic: &str, operands: &str) -> Class {
    let base = mnemonic.split('.').next().unwrap_or("");
    if base.len() >= 2 && base.starts_with("it") && base[2..].chars().all(|c| "te".contains(c)) {
        return Class::Fixed(1);
    }
    let writes_pc = operands.starts_with("pc");
    for &(name, cost) in TABLE {
        let Some(rest) = base.strip_prefix(name) else {
            continue;
        };
        let is_branch = matches!(cost, Cost::Branch);
        let conditional = CONDITIONS.contains(&rest);
        let plain = rest.is_empty()
            || conditional
            || (!is_branch
                && rest
                    .strip_prefix('s')
                    .is_some_and(|r| r.is_empty() || CONDITIONS.contains(&r)));
        if !plain {
            continue;
        }
        return match cost {
            Cost::Cycles(c) => Class::Fixed(c),
            Cost::Load if writes_pc => Class::Fixed(2 + REFILL),
            Cost::Load => Class::Load,
            Cost::Store => Class::Store,
            Cost::Multiple => {
                let n = registers(operands);
                let refill = if operands.contains("pc}") { REFILL } else { 0 };
                Class::Fixed(1 + n + refill)
            }
            Cost::FpMultiple => Class::Fixed(1 + registers(operands)),
            Cost::FpMove => Class::Fixed(if touches_core_register(operands) {
                2
            } else {
                1
            }),
            Cost::Branch => Class::Branch {
                conditional: conditional || name.starts_with("cb"),
            },
        };
    }
    if writes_pc {
        // `mov pc, ..`, `add pc, ..`: a branch.
        return Class::Fixed(1 + REFILL);
    }
    Class::Fixed(1)
}

/// Groups of instructions, for where the cycles go.
pub const GROUPS: [&str; 6] = [
    "mul-acc",
    "div/sqrt",
    "other FP",
    "load/store",
    "branch",
    "other",
];

/// The group (an index into [`GROUPS`]) of an instruction of `class` with `mnemonic`.
pub fn group(mnemonic: &str, class: Class) -> usize {
    let base = mnemonic.split('.').next().unwrap_or("");
    let starts = |prefixes: &[&str]| prefixes.iter().any(|p| base.starts_with(p));
    if starts(&[
        "vmla", "vmls", "vnmla", "vnmls", "vfma", "vfms", "vfnma", "vfnms",
    ]) {
        0
    } else if starts(&["vdiv", "vsqrt"]) {
        1
    } else if starts(&["vldr", "vstr", "vldm", "vstm", "vpush", "vpop"])
        || matches!(class, Class::Load | Class::Store)
        || starts(&["ldm", "stm", "push", "pop", "ldrd", "strd"])
    {
        3
    } else if base.starts_with('v') {
        2
    } else if matches!(class, Class::Branch { .. }) {
        4
    } else {
        5
    }
}

/// Registers in the list `{r4, r5, r8-r11, lr}` of single words (a `d` register counts
/// as two single-precision registers).
fn registers(operands: &str) -> u32 {
    let Some(list) = operands
        .split_once('{')
        .and_then(|(_, rest)| rest.split_once('}'))
        .map(|(list, _)| list)
    else {
        return 1;
    };
    list.split(',')
        .map(|item| {
            let item = item.trim();
            let width = if item.starts_with('d') { 2 } else { 1 };
            let number = |r: &str| {
                r.trim_start_matches(|c: char| c.is_ascii_alphabetic())
                    .parse::<u32>()
                    .ok()
            };
            match item.split_once('-') {
                Some((first, last)) => match (number(first), number(last)) {
                    (Some(a), Some(b)) if b >= a => width * (b - a + 1),
                    _ => width,
                },
                None => width,
            }
        })
        .sum()
}

/// Whether `vmov` operands name a core register (`r0`..`r12`, `sl`, `fp`, `ip`, `lr`),
/// other than as a lane of a double (`d0[1]`).
fn touches_core_register(operands: &str) -> bool {
    if operands.contains('[') {
        return false;
    }
    operands.split(',').any(|o| {
        let o = o.trim();
        matches!(o, "sl" | "fp" | "ip" | "lr" | "sb")
            || o.strip_prefix('r')
                .is_some_and(|n| n.parse::<u32>().is_ok())
    })
}

/// Cycles of one executed instruction of `class` at `address` (`size` bytes), given
/// whether the instruction before it was a single load and the address executed next.
pub fn cycles(class: Class, address: u32, size: u32, after_load: bool, next: Option<u32>) -> u32 {
    match class {
        Class::Fixed(c) => c,
        Class::Load | Class::Store => {
            if after_load {
                1
            } else {
                2
            }
        }
        Class::Branch { conditional } => {
            let taken = !conditional || next.is_some_and(|n| n != address + size);
            if taken {
                1 + REFILL
            } else {
                1
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mnemonics_are_classified_with_their_suffixes() {
        assert_eq!(classify("vmla.f32", "s20, s6, s2"), Class::Fixed(3));
        assert_eq!(classify("vdiv.f32", "s16, s29, s30"), Class::Fixed(14));
        assert_eq!(classify("vadd.f32", "s8, s8, s12"), Class::Fixed(1));
        assert_eq!(classify("vmov", "r1, s1"), Class::Fixed(2));
        assert_eq!(classify("vmov.f32", "s27, s0"), Class::Fixed(1));
        assert_eq!(classify("vmovgt.f32", "s1, s2"), Class::Fixed(1));
        assert_eq!(classify("vmov.f32", "s29, #112"), Class::Fixed(1));
        assert_eq!(classify("vldr", "s8, [r0, #180]"), Class::Fixed(2));
        assert_eq!(classify("vpush", "{d8-d15}"), Class::Fixed(17));
        assert_eq!(classify("vpop", "{s16-s18}"), Class::Fixed(4));
        assert_eq!(classify("push", "{r4, r5, r6, r7, lr}"), Class::Fixed(6));
        assert_eq!(
            classify("pop", "{r4, r5, r6, r7, pc}"),
            Class::Fixed(6 + REFILL)
        );
        assert_eq!(classify("ldmia.w", "sp!, {r8, r9, sl}"), Class::Fixed(4));
        assert_eq!(classify("ldr.w", "sl, [r0, #260]"), Class::Load);
        assert_eq!(classify("ldrb.w", "r1, [r0, #264]"), Class::Load);
        assert_eq!(classify("str", "r1, [r0, #4]"), Class::Store);
        assert_eq!(classify("strd", "r1, r1, [r0]"), Class::Fixed(3));
        assert_eq!(
            classify("bl", "ab04 <f>"),
            Class::Branch { conditional: false }
        );
        assert_eq!(
            classify("b.n", "b048 <f+0x538>"),
            Class::Branch { conditional: false }
        );
        assert_eq!(
            classify("bne.w", "addc <f>"),
            Class::Branch { conditional: true }
        );
        assert_eq!(
            classify("bls.n", "addc <f>"),
            Class::Branch { conditional: true }
        );
        assert_eq!(
            classify("blt.n", "b34 <f>"),
            Class::Branch { conditional: true }
        );
        assert_eq!(
            classify("cbz", "r1, 36 <f>"),
            Class::Branch { conditional: true }
        );
        assert_eq!(classify("bx", "lr"), Class::Branch { conditional: false });
        assert_eq!(classify("bic.w", "r1, r0, #4278190080"), Class::Fixed(1));
        assert_eq!(classify("bics", "r1, r2"), Class::Fixed(1));
        assert_eq!(classify("movs", "r0, #0"), Class::Fixed(1));
        assert_eq!(classify("itt", "ge"), Class::Fixed(1));
        assert_eq!(classify("strb.w", "r1, [r0, #260]"), Class::Store);
        assert_eq!(classify("mov", "pc, r1"), Class::Fixed(1 + REFILL));
    }

    #[test]
    fn branches_pay_the_refill_only_when_taken() {
        let conditional = Class::Branch { conditional: true };
        assert_eq!(cycles(conditional, 0x100, 2, false, Some(0x102)), 1);
        assert_eq!(
            cycles(conditional, 0x100, 2, false, Some(0x140)),
            1 + REFILL
        );
        let always = Class::Branch { conditional: false };
        assert_eq!(cycles(always, 0x100, 4, false, Some(0x104)), 1 + REFILL);
        assert_eq!(cycles(Class::Load, 0, 4, false, None), 2);
        assert_eq!(cycles(Class::Load, 0, 4, true, None), 1);
    }

    #[test]
    fn instructions_fall_into_groups() {
        let group_of = |m: &str, o: &str| GROUPS[group(m, classify(m, o))];
        assert_eq!(group_of("vmls.f32", "s3, s9, s24"), "mul-acc");
        assert_eq!(group_of("vdiv.f32", "s16, s29, s30"), "div/sqrt");
        assert_eq!(group_of("vmul.f32", "s5, s10, s19"), "other FP");
        assert_eq!(group_of("vpush", "{d8-d15}"), "load/store");
        assert_eq!(group_of("ldr.w", "sl, [r0, #260]"), "load/store");
        assert_eq!(group_of("pop", "{r4, pc}"), "load/store");
        assert_eq!(group_of("bne.w", "addc <f>"), "branch");
        assert_eq!(group_of("bic.w", "r1, r0, #1"), "other");
    }
}

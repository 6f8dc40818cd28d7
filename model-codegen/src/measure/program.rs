//! The firmware image as the ARM binutils show it: its functions (where they are, how
//! large, whom they call) and its instructions, for the size and cycle columns of the
//! cost table.

use super::timing::{self, Class};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

/// One instruction of the disassembly.
#[derive(Clone, Debug, PartialEq)]
pub struct Instruction {
    /// Its size in bytes (2 or 4).
    pub size: u32,
    /// The mnemonic as objdump prints it (`vmla.f32`, `bne.n`, `pop`).
    pub mnemonic: String,
    /// The operands, comments removed (`{r4, r5, pc}`).
    pub operands: String,
}

/// The firmware's functions and instructions.
pub struct Program {
    /// Function name (demangled) -> (start address, size in bytes).
    pub functions: BTreeMap<String, (u32, u32)>,
    /// Function -> the functions it branches to.
    calls: BTreeMap<String, BTreeSet<String>>,
    /// Address -> instruction.
    pub instructions: BTreeMap<u32, Instruction>,
}

impl Program {
    /// Reads the image's symbols (`arm-none-eabi-nm`) and disassembly
    /// (`arm-none-eabi-objdump`).
    pub fn read(elf: &Path) -> Result<Program, String> {
        let text = |args: &[&str], tool: &str| -> Result<String, String> {
            let out = Command::new(tool)
                .args(args)
                .arg(elf)
                .output()
                .map_err(|e| format!("cannot run {tool}: {e}"))?;
            Ok(String::from_utf8_lossy(&out.stdout).into_owned())
        };
        let mut functions = BTreeMap::new();
        for line in text(&["-S", "--demangle", "--defined-only"], "arm-none-eabi-nm")?.lines() {
            let words: Vec<&str> = line.splitn(4, ' ').collect();
            if let [address, bytes, kind, name] = words[..] {
                // Code: `t`/`T`, or `W`/`w` (C++ template functions are weak symbols).
                if kind.eq_ignore_ascii_case("t") || kind.eq_ignore_ascii_case("w") {
                    let hex = |w| u32::from_str_radix(w, 16).unwrap_or(0);
                    // Thumb symbols may carry the mode in bit 0.
                    functions.insert(name.to_owned(), (hex(address) & !1, hex(bytes)));
                }
            }
        }
        let mut calls: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        let mut instructions = BTreeMap::new();
        let mut current = String::new();
        for line in text(&["-d", "--demangle"], "arm-none-eabi-objdump")?.lines() {
            if let Some(name) = line.strip_suffix(">:").and_then(|l| l.split_once(" <")) {
                current = name.1.to_owned();
                continue;
            }
            let Some((address, instruction)) = parse_line(line) else {
                continue;
            };
            if timing::classify(&instruction.mnemonic, &instruction.operands).is_branch() {
                if let Some((_, target)) = line.split_once(" <") {
                    if let Some(callee) = target.strip_suffix('>') {
                        if !callee.contains('+') && callee != current {
                            calls
                                .entry(current.clone())
                                .or_default()
                                .insert(callee.to_owned());
                        }
                    }
                }
            }
            instructions.insert(address, instruction);
        }
        Ok(Program {
            functions,
            calls,
            instructions,
        })
    }

    /// The functions `root` can execute: itself and everything it branches to, transitively.
    pub fn reachable(&self, root: &str) -> BTreeSet<String> {
        let mut seen = BTreeSet::new();
        let mut stack = vec![root.to_owned()];
        while let Some(f) = stack.pop() {
            if seen.insert(f.clone()) {
                stack.extend(self.calls.get(&f).into_iter().flatten().cloned());
            }
        }
        seen
    }

    /// Records that `from` can call each of `callees` where the disassembly does not show
    /// it (calls through function pointers, as in C libraries' dispatch tables).
    pub fn add_calls(&mut self, from: &str, callees: impl IntoIterator<Item = String>) {
        self.calls
            .entry(from.to_owned())
            .or_default()
            .extend(callees);
    }

    /// Bytes of code `root` can execute: itself and everything it calls, once each.
    pub fn reachable_size(&self, root: &str) -> Option<u64> {
        self.functions.get(root)?;
        let sizes = self
            .reachable(root)
            .iter()
            .filter_map(|f| self.functions.get(f))
            .map(|&(_, size)| u64::from(size))
            .sum();
        Some(sizes)
    }

    /// The function named `name` (a C symbol), else the one whose demangled name ends
    /// with `::name` (a Rust path).
    pub fn function(&self, name: &str) -> Option<String> {
        if self.functions.contains_key(name) {
            return Some(name.to_owned());
        }
        let suffix = format!("::{name}");
        self.functions
            .keys()
            .find(|k| k.ends_with(&suffix))
            .cloned()
    }
}

/// `    ab10:\tb5f0      \tpush\t{r4, r5, lr}` -> (0xab10, the instruction); `None` for
/// anything else (labels, blank lines, literal-pool `.word`s).
fn parse_line(line: &str) -> Option<(u32, Instruction)> {
    let mut fields = line.split('\t');
    let address = fields.next()?.trim().strip_suffix(':')?;
    let address = u32::from_str_radix(address, 16).ok()?;
    let bytes = fields.next()?.split_whitespace().count();
    let mnemonic = fields.next()?.trim().to_owned();
    if mnemonic.is_empty() || mnemonic.starts_with('.') {
        return None;
    }
    let operands = fields.next().unwrap_or("");
    let operands = operands.split('@').next().unwrap_or("").trim().to_owned();
    let size = match bytes {
        1 => 2,
        2 => 4,
        _ => return None,
    };
    Some((
        address,
        Instruction {
            size,
            mnemonic,
            operands,
        },
    ))
}

impl Class {
    /// Whether the instruction can branch (and so name a callee).
    pub fn is_branch(self) -> bool {
        matches!(self, Class::Branch { .. })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disassembly_lines_give_address_size_and_operands() {
        let (address, i) =
            parse_line("    ab4c:\tf84d 8d04 \tstr.w\tr8, [sp, #-4]!").expect("an instruction");
        assert_eq!((address, i.size), (0xab4c, 4));
        assert_eq!(
            (i.mnemonic.as_str(), i.operands.as_str()),
            ("str.w", "r8, [sp, #-4]!")
        );
        let (_, i) = parse_line("    ab7e:\ted90 4a2d \tvldr\ts8, [r0, #180]\t@ 0xb4")
            .expect("an instruction");
        assert_eq!(i.operands, "s8, [r0, #180]");
        let (_, i) = parse_line("    ab48:\tb5f0      \tpush\t{r4, r5, r6, r7, lr}")
            .expect("an instruction");
        assert_eq!(i.size, 2);
        assert!(parse_line("0000ab48 <generated_demo::cantilever::Dkf::step>:").is_none());
        assert!(parse_line("    af34:\t3c75c28f \t.word\t0x3c75c28f").is_none());
    }
}

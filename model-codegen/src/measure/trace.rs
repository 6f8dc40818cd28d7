//! Estimated cycles per kernel call: the firmware is run again under QEMU, one instruction
//! per translation block, with every executed block logged (`-singlestep -d exec,nochain`;
//! this QEMU has no TCG plugins). The firmware brackets its measured calls with
//! `trace_begin` and `trace_end`; within them, each call of a kernel's wrapper is followed
//! instruction by instruction while execution stays in the functions the wrapper can
//! reach, and each executed instruction is weighted by [`super::timing`].

use super::program::Program;
use super::timing::{self, Class};
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::process::{Child, Command, Stdio};

/// An instruction's class, size and group.
type Kind = (Class, u32, usize);

/// What the trace saw of one kernel wrapper.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Traced {
    /// Calls seen between the markers.
    pub calls: u64,
    /// Instructions executed in them.
    pub instructions: u64,
    /// Their estimated cycles.
    pub cycles: u64,
    /// Instructions and cycles by group ([`timing::GROUPS`]).
    pub groups: [(u64, u64); timing::GROUPS.len()],
    /// Instructions and estimated cycles of each call, in order.
    pub each: Vec<(u64, u64)>,
}

impl Traced {
    /// Instructions per call.
    pub fn instructions_per_call(&self) -> f64 {
        self.instructions as f64 / self.calls.max(1) as f64
    }

    /// Estimated cycles per call.
    pub fn cycles_per_call(&self) -> f64 {
        self.cycles as f64 / self.calls.max(1) as f64
    }

    /// The median and the largest of the calls' instructions (`0`) or cycles (`1`).
    pub fn median_worst(&self, of: impl Fn(&(u64, u64)) -> u64) -> (u64, u64) {
        let mut values: Vec<u64> = self.each.iter().map(of).collect();
        values.sort_unstable();
        let median = values.get(values.len() / 2).copied().unwrap_or(0);
        (median, values.last().copied().unwrap_or(0))
    }
}

/// One kernel wrapper being followed: where it starts and the address ranges it can run.
struct Followed {
    entry: u32,
    ranges: Vec<(u32, u32)>,
}

impl Followed {
    fn contains(&self, address: u32) -> bool {
        let at = self.ranges.partition_point(|&(start, _)| start <= address);
        at > 0 && address < self.ranges[at - 1].1
    }
}

/// Runs `elf` under QEMU with the instruction log and returns, per wrapper function
/// named in `wrappers`, what its calls between the markers executed.
pub fn run(
    elf: &Path,
    program: &Program,
    wrappers: &[String],
) -> Result<BTreeMap<String, Traced>, String> {
    let (begin, end) = (
        marker(program, "trace_begin")?,
        marker(program, "trace_end")?,
    );
    let followed = wrappers
        .iter()
        .map(|wrapper| follow(program, wrapper))
        .collect::<Result<Vec<_>, _>>()?;
    let classes = instruction_kinds(program);
    let mut child = start_qemu(elf)?;
    // The firmware's own output goes to stdout: drain it so QEMU never blocks on it.
    let mut stdout = child.stdout.take().ok_or("no stdout")?;
    let drain = std::thread::spawn(move || {
        let mut text = String::new();
        let _ = stdout.read_to_string(&mut text);
        text
    });
    let log = BufReader::with_capacity(1 << 20, child.stderr.take().ok_or("no stderr")?);
    let traced = walk_log(log, (begin, end), &followed, &classes)?;
    let status = child.wait().map_err(|e| e.to_string())?;
    let output = drain.join().unwrap_or_default();
    if !status.success() || !output.contains("done") {
        return Err(format!("the traced firmware run failed ({status})"));
    }
    Ok(wrappers.iter().cloned().zip(traced).collect())
}

/// The address of the firmware's marker function `name` (`trace_begin`, `trace_end`).
fn marker(program: &Program, name: &str) -> Result<u32, String> {
    program
        .function(name)
        .and_then(|f| program.functions.get(&f))
        .map(|&(start, _)| start)
        .ok_or_else(|| format!("the firmware has no `{name}` marker"))
}

/// QEMU started on `elf`, logging every executed block (one instruction each) to its stderr.
fn start_qemu(elf: &Path) -> Result<Child, String> {
    Command::new("qemu-system-arm")
        .args(super::board::MACHINE)
        .args(["-singlestep", "-d", "exec,nochain", "-kernel"])
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start qemu-system-arm: {e}"))
}

/// What each `followed` wrapper executed, per QEMU's `log`, between markers `begin` and `end`.
fn walk_log(
    log: impl BufRead,
    (begin, end): (u32, u32),
    followed: &[Followed],
    classes: &BTreeMap<u32, Kind>,
) -> Result<Vec<Traced>, String> {
    let mut traced = vec![Traced::default(); followed.len()];
    let mut state = State::default();
    // A logged block that QEMU then abandoned ("Stopped execution of TB chain before" its
    // address) did not execute: each address is held back one line.
    let mut held: Option<u32> = None;
    for line in log.lines() {
        let line = line.map_err(|e| format!("reading the QEMU log: {e}"))?;
        if let Some(address) = logged_address(&line, "Trace ") {
            if let Some(a) = held.replace(address) {
                state.step(a, begin, end, followed, classes, &mut traced);
            }
        } else if let Some(address) = logged_address(&line, "Stopped execution") {
            if held == Some(address) {
                held = None;
            }
        }
    }
    if let Some(a) = held {
        state.step(a, begin, end, followed, classes, &mut traced);
    }
    Ok(traced)
}

/// The wrapper function `wrapper` of `program`: its entry, and the address ranges of every
/// function it can reach, sorted.
fn follow(program: &Program, wrapper: &str) -> Result<Followed, String> {
    let &(entry, _) = program
        .functions
        .get(wrapper)
        .ok_or_else(|| format!("the firmware has no function `{wrapper}`"))?;
    let mut ranges: Vec<(u32, u32)> = program
        .reachable(wrapper)
        .iter()
        .filter_map(|f| program.functions.get(f))
        .map(|&(start, size)| (start, start + size))
        .collect();
    ranges.sort_unstable();
    Ok(Followed { entry, ranges })
}

/// Each instruction's timing class, size and group, by address.
fn instruction_kinds(program: &Program) -> BTreeMap<u32, Kind> {
    program
        .instructions
        .iter()
        .map(|(&a, i)| {
            let class = timing::classify(&i.mnemonic, &i.operands);
            let group = timing::group(&i.mnemonic, class);
            (a, (class, i.size, group))
        })
        .collect()
}

/// The guest address of a QEMU log line starting with `prefix`:
/// `Trace 0: 0x7f.. [00800400/0000ab04/00000010/ff020201] name` or
/// `Stopped execution of TB chain before 0x7f.. [0000b0b2] name`.
fn logged_address(line: &str, prefix: &str) -> Option<u32> {
    let rest = line.strip_prefix(prefix)?;
    let inside = rest.split_once('[')?.1.split_once(']')?.0;
    let field = match inside.split('/').nth(1) {
        Some(pc) => pc,
        None => inside,
    };
    u32::from_str_radix(field, 16).ok()
}

/// Where the walk through the log is.
#[derive(Default)]
struct State {
    /// Between the markers.
    active: bool,
    /// The wrapper whose call is being followed.
    current: Option<usize>,
    /// Its last instruction, costed once the next address is known.
    pending: Option<u32>,
    /// Whether the instruction before `pending` was a single load.
    after_load: bool,
    /// The followed wrapper's instructions and cycles when its current call began.
    call_start: (u64, u64),
}

impl State {
    fn step(
        &mut self,
        address: u32,
        begin: u32,
        end: u32,
        followed: &[Followed],
        classes: &BTreeMap<u32, Kind>,
        traced: &mut [Traced],
    ) {
        if address == begin || address == end {
            self.settle(None, classes, traced);
            self.active = address == begin;
            return;
        }
        if !self.active {
            return;
        }
        if let Some(k) = followed.iter().position(|f| f.entry == address) {
            self.settle(Some(address), classes, traced);
            self.current = Some(k);
            traced[k].calls += 1;
            self.call_start = (traced[k].instructions, traced[k].cycles);
        } else if let Some(k) = self.current {
            if !followed[k].contains(address) {
                // Back in the harness: the call is over.
                self.settle(Some(address), classes, traced);
                return;
            }
            self.cost_pending(Some(address), classes, traced);
        } else {
            return;
        }
        if let Some(k) = self.current {
            traced[k].instructions += 1;
            self.pending = Some(address);
        }
    }

    /// Costs the pending instruction, `next` being the address executed after it.
    fn cost_pending(
        &mut self,
        next: Option<u32>,
        classes: &BTreeMap<u32, Kind>,
        traced: &mut [Traced],
    ) {
        let (Some(k), Some(address)) = (self.current, self.pending.take()) else {
            return;
        };
        let (class, size, group) = classes.get(&address).copied().unwrap_or((
            Class::Fixed(1),
            2,
            timing::GROUPS.len() - 1,
        ));
        let cycles = u64::from(timing::cycles(class, address, size, self.after_load, next));
        traced[k].cycles += cycles;
        traced[k].groups[group].0 += 1;
        traced[k].groups[group].1 += cycles;
        self.after_load = class == Class::Load;
    }

    /// Ends the call being followed.
    fn settle(&mut self, next: Option<u32>, classes: &BTreeMap<u32, Kind>, traced: &mut [Traced]) {
        self.cost_pending(next, classes, traced);
        if let Some(k) = self.current.take() {
            let (instructions, cycles) = self.call_start;
            let call = (
                traced[k].instructions - instructions,
                traced[k].cycles - cycles,
            );
            traced[k].each.push(call);
        }
        self.after_load = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_lines_give_the_guest_address() {
        let trace = "Trace 0: 0x7f41f002fc40 [00800400/0000ab04/00000010/ff020201] _ZN14generated";
        assert_eq!(logged_address(trace, "Trace "), Some(0xab04));
        let stopped = "Stopped execution of TB chain before 0x7f41f0045f40 [0000b0b2] _ZN14gen";
        assert_eq!(logged_address(stopped, "Stopped execution"), Some(0xb0b2));
        assert_eq!(logged_address("IN: main", "Trace "), None);
    }
}

//! The table `stateforge-codegen measure` prints: per call, the instructions the
//! firmware counted, the cycles of the traced calls beside the compiler's static estimate,
//! the stack and the code size.

use super::api::Api;
use super::firmware::Counted;
use super::harness::Call;
use super::program::Program;
use super::trace::Traced;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// Largest difference, in instructions per call, allowed between the trace's count and
/// the counter's mean: the trace follows the wrapper's own few instructions too (the
/// project's cost table allows the same).
const TRACE_SLACK: f64 = 8.0;

/// One row.
struct Row<'a> {
    call: &'a Call,
    counted: &'a Counted,
    /// Instructions of the median and the costliest call, traced.
    instructions: (u64, u64),
    /// Estimated cycles of the median and the costliest call, and their mean, traced.
    cycles: (u64, u64, f64),
    text: Option<u64>,
    estimate: Option<(String, u32)>,
}

impl Row<'_> {
    /// The static estimate, and how far it is from the traced cycles it estimates: those
    /// of the costliest call for a `*_WORST_CYCLES` constant, else their mean.
    fn estimate(&self) -> Option<(&str, u32, f64)> {
        let (name, cycles) = self.estimate.as_ref()?;
        let traced = match name.ends_with("_WORST_CYCLES") {
            true => self.cycles.1 as f64,
            false => self.cycles.2,
        };
        let diff = (f64::from(*cycles) - traced) / traced.max(1.0);
        Some((name, *cycles, diff))
    }
}

/// What the table is of.
pub struct Subject<'a> {
    /// The model's module name.
    pub model: &'a str,
    /// Samples of the run.
    pub samples: usize,
}

/// The table, or an error if a call is missing from the firmware's report or the trace
/// and the counter disagree (the trace then did not follow the calls the counter read).
pub fn render(
    subject: &Subject,
    api: &Api,
    calls: &[Call],
    counted: &[Counted],
    program: &Program,
    traced: &BTreeMap<String, Traced>,
) -> Result<String, String> {
    let mut rows = Vec::new();
    for (index, call) in calls.iter().enumerate() {
        let counted = counted
            .iter()
            .find(|c| c.index == index)
            .ok_or_else(|| format!("the firmware did not report `{}`", call.label))?;
        let wrapper = program
            .function(&call.wrapper)
            .ok_or_else(|| format!("no `{}` in the firmware", call.wrapper))?;
        let trace = traced
            .get(&wrapper)
            .filter(|t| t.calls > 0)
            .ok_or_else(|| format!("the trace saw no call of `{}`", call.label))?;
        let seen = trace.instructions_per_call();
        if (seen - f64::from(counted.mean)).abs() > TRACE_SLACK {
            return Err(format!(
                "`{}`: the trace saw {seen:.1} instructions per call, the counter {}",
                call.label, counted.mean
            ));
        }
        let (median, worst) = trace.median_worst(|&(_, cycles)| cycles);
        rows.push(Row {
            call,
            counted,
            instructions: trace.median_worst(|&(instructions, _)| instructions),
            cycles: (median, worst, trace.cycles_per_call()),
            text: program.reachable_size(&wrapper),
            estimate: api.static_estimate(&call.type_name, &call.method),
        });
    }
    Ok(format!(
        "{}{}{}",
        heading(subject),
        table(&rows),
        notes(&rows, subject)
    ))
}

fn heading(subject: &Subject) -> String {
    format!(
        "`{}` on an emulated Cortex-M4F (QEMU mps2-an386): its f32 code built at opt-level 3 \
         with fat LTO, each call run {} times on the model's own simulated run.\n\n",
        subject.model, subject.samples
    )
}

fn table(rows: &[Row]) -> String {
    let width = rows
        .iter()
        .map(|r| r.call.label.len())
        .chain([4])
        .max()
        .unwrap_or(4);
    let mut out = format!(
        "{:<width$}  {:^23}  {:^39}  {:>6} {:>7}\n{:<width$}  {:>7} {:>7} {:>7}  {:>7} {:>7} {:>7} \
         {:>7} {:>7}  {:>6} {:>7}  static estimate\n",
        "",
        "instructions per call",
        "cycles per call (estimated)",
        "stack",
        "text",
        "call",
        "median",
        "worst",
        "mean",
        "median",
        "worst",
        "mean",
        "static",
        "diff",
        "bytes",
        "bytes",
    );
    for row in rows {
        let (statics, diff, constant) = match row.estimate() {
            Some((name, cycles, diff)) => {
                (cycles.to_string(), format!("{:+.0}%", 100.0 * diff), name)
            }
            None => ("-".to_owned(), "-".to_owned(), "-"),
        };
        let _ = writeln!(
            out,
            "{:<width$}  {:>7} {:>7} {:>7}  {:>7} {:>7} {:>7.0} {:>7} {:>7}  {:>6} {:>7}  {constant}",
            row.call.label,
            row.instructions.0,
            row.instructions.1,
            row.counted.mean,
            row.cycles.0,
            row.cycles.1,
            row.cycles.2,
            statics,
            diff,
            row.counted.stack,
            row.text.map_or("?".to_owned(), |t| t.to_string()),
        );
    }
    out
}

fn notes(rows: &[Row], subject: &Subject) -> String {
    let mut out = String::from(
        "\ninstructions: median and worst of the calls as the instruction trace follows them; \
         mean: counted by SysTick under QEMU's -icount (one instruction per tick of its \
         virtual clock), which the trace matches to within 8.\ncycles: each traced \
         instruction weighted by the Cortex-M4 Technical Reference Manual's timings, zero \
         wait states; static: the generated module's estimate (the constant named, of the \
         worst call if it says so), diff: static against the traced mean (or worst).\n\
         stack: the deepest stack of one call; text: the bytes of code the call can reach.\n",
    );
    for row in rows.iter().filter(|r| r.counted.refused > 0) {
        let _ = writeln!(
            out,
            "{}: {} of {} calls did not take their data (the first returned {}): their \
             figures mix both paths.",
            row.call.label,
            row.counted.refused,
            subject.samples,
            row.counted.first_refused.as_deref().unwrap_or("?")
        );
    }
    out
}

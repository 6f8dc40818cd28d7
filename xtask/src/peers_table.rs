//! What the QP peers' tables share (`peers`: the blade's; `peers_quadrotor`: TinyMPC's
//! quadrotor): the firmware's `peer` and `peerspread` lines read by solver, the exact plans
//! a table compares with, and the columns every row opens with (instructions, estimated
//! cycles, time, code size).

use stateforge_cli::measure::program::Program;
use stateforge_cli::measure::trace::Traced;
use std::collections::BTreeMap;
use std::path::Path;

/// The paper's clock, as the cost table's.
pub const CLOCK_MHZ: f64 = 168.0;

/// How far the trace's instructions per call may stray from the counter's mean: the
/// counter reads SysTick to 40 instructions, once per call, and the trace also counts the
/// few instructions of the call around the solver.
const TRACE_SLACK: f64 = 48.0;

/// A solver's lines of a firmware's output: its plan at every step (1, 2, ..) with the
/// iterations it took (negative: it reported a failure), and its spread (median and worst
/// instructions per solve, most iterations, mean instructions per solve).
#[derive(Debug, Default, PartialEq)]
pub struct Solver {
    pub plans: BTreeMap<usize, (i64, Vec<f64>)>,
    pub spread: Option<[f64; 4]>,
}

impl Solver {
    /// The steps at which the solver reported a failure.
    pub fn failed(&self) -> usize {
        self.plans.values().filter(|(i, _)| *i < 0).count()
    }
}

/// The `peer <name> <k> <iterations> <moves..>` and `peerspread <name> <median> <worst>
/// <most> <mean>` lines of `text`, by solver; other lines are passed over.
pub fn parse(text: &str) -> Result<BTreeMap<String, Solver>, String> {
    let mut solvers: BTreeMap<String, Solver> = BTreeMap::new();
    for line in text.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let number = |w: &str| {
            w.parse::<f64>()
                .map_err(|_| format!("bad number in `{line}`"))
        };
        match words.as_slice() {
            ["peer", name, k, iterations, moves @ ..] => {
                let k = k.parse().map_err(|_| format!("bad step in `{line}`"))?;
                let iterations = iterations
                    .parse()
                    .map_err(|_| format!("bad iterations in `{line}`"))?;
                let plan = moves.iter().map(|w| number(w)).collect::<Result<_, _>>()?;
                let solver = solvers.entry((*name).to_owned()).or_default();
                solver.plans.insert(k, (iterations, plan));
            }
            ["peerspread", name, values @ ..] if values.len() == 4 => {
                let v: Vec<f64> = values.iter().map(|w| number(w)).collect::<Result<_, _>>()?;
                solvers.entry((*name).to_owned()).or_default().spread =
                    Some([v[0], v[1], v[2], v[3]]);
            }
            _ => {}
        }
    }
    Ok(solvers)
}

/// A JSON file the peers' scripts wrote.
pub fn json(path: &Path) -> Result<serde_json::Value, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// The plans under `key` of `value` (read from `path`): a list of plans, each a list of
/// moves.
pub fn plans(value: &serde_json::Value, key: &str, path: &Path) -> Result<Vec<Vec<f64>>, String> {
    value[key]
        .as_array()
        .ok_or_else(|| format!("{}: no {key}", path.display()))?
        .iter()
        .map(|plan| {
            plan.as_array()
                .map(|p| p.iter().filter_map(serde_json::Value::as_f64).collect())
                .ok_or_else(|| format!("{}: a plan is not a list", path.display()))
        })
        .collect()
}

/// The solver `name`'s wrapper in the firmware (`peers_<name>_solve`) and what the trace
/// saw of its calls.
pub fn traced_call<'a>(
    name: &str,
    program: &Program,
    traced: &'a BTreeMap<String, Traced>,
) -> Result<(String, &'a Traced), String> {
    let wrapper = program
        .function(&format!("peers_{name}_solve"))
        .ok_or_else(|| format!("no `peers_{name}_solve` in the firmware"))?;
    let trace = traced
        .get(&wrapper)
        .filter(|t| t.calls > 0)
        .ok_or_else(|| format!("the trace saw no call of `{wrapper}`"))?;
    Ok((wrapper, trace))
}

/// The traced calls' cycles per instruction; an error when the trace and the counter's
/// `mean` instructions per call disagree (the trace lost the call somewhere).
pub fn cycles_per_instruction(trace: &Traced, mean: f64) -> Result<f64, String> {
    let seen = trace.instructions_per_call();
    if (seen - mean).abs() > TRACE_SLACK {
        return Err(format!(
            "the trace saw {seen:.0} instructions per call, the counter {mean:.0}"
        ));
    }
    Ok(trace.cycles_per_call() / seen.max(1.0))
}

/// The columns every row opens with, after the solver's label: median and worst
/// instructions per solve, their cycles at `cpi` cycles per instruction (`?` where it is
/// not a number), the worst in microseconds, and `text`, the bytes of code the call can
/// reach.
pub fn counts(median: f64, worst: f64, cpi: f64, text: Option<u64>) -> String {
    let cycles = |v: f64, digits: usize| {
        if v.is_nan() {
            "?".to_owned()
        } else {
            format!("{v:.digits$}")
        }
    };
    format!(
        "{median:>8.0} {worst:>8.0} {:>9} {:>9} {:>8} {:>8}",
        cycles(median * cpi, 0),
        cycles(worst * cpi, 0),
        cycles(worst * cpi / CLOCK_MHZ, 1),
        text.map_or("?".into(), |b| b.to_string()),
    )
}

/// A table's header: the label and the columns of [`counts`], then the table's own, each
/// with its width.
pub fn header(own: &[(&str, usize)]) -> String {
    let mut line = format!(
        "{:<22} {:>8} {:>8} {:>9} {:>9} {:>8} {:>8}",
        "solver", "median", "worst", "cyc med", "cyc worst", "us worst", "text B"
    );
    for (name, width) in own {
        line.push_str(&format!(" {name:>width$}"));
    }
    line.push('\n');
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lines as the Rust firmware and the C/C++ peers print them, among others'.
    const OUTPUT: &str = "\
cost mpc 1234
peer mpc 1 3 0.5 -1.25e-2 100
peer osqp 1 -1 0.49 -0.0125 99.9
peer mpc 2 2 0.25 0 0
peerspread mpc 2100 4350 3 2210.5
peerspread osqp 9000 12000 4000
navpeer ours predict 1 2 3 4
";

    #[test]
    fn reads_plans_and_spreads_by_solver() {
        let solvers = parse(OUTPUT).unwrap();
        assert_eq!(solvers.keys().collect::<Vec<_>>(), ["mpc", "osqp"]);
        let mpc = &solvers["mpc"];
        assert_eq!(mpc.plans[&1], (3, vec![0.5, -0.0125, 100.0]));
        assert_eq!(mpc.plans[&2], (2, vec![0.25, 0.0, 0.0]));
        assert_eq!(mpc.spread, Some([2100.0, 4350.0, 3.0, 2210.5]));
        assert_eq!(mpc.failed(), 0);
        // OSQP's spread line lacks its mean: it is not a spread line.
        let osqp = &solvers["osqp"];
        assert_eq!(osqp.spread, None);
        assert_eq!(osqp.failed(), 1);
    }

    #[test]
    fn a_bad_number_is_an_error_naming_its_line() {
        for (line, what) in [
            ("peer mpc one 3 0.5", "bad step"),
            ("peer mpc -1 3 0.5", "bad step"),
            ("peer mpc 1 3.5 0.5", "bad iterations"),
            ("peer mpc 1 3 0.5x", "bad number"),
            ("peerspread mpc 1 2 three 4", "bad number"),
        ] {
            let e = parse(line).unwrap_err();
            assert!(e.starts_with(what) && e.contains(line), "{line}: {e}");
        }
    }

    #[test]
    fn a_plan_may_be_empty() {
        let solvers = parse("peer daqp 7 0").unwrap();
        assert_eq!(solvers["daqp"].plans[&7], (0, vec![]));
    }

    #[test]
    fn counts_show_unknown_cycles_and_size_as_question_marks() {
        let known = counts(1000.0, 1680.0, 1.5, Some(4096));
        let words: Vec<&str> = known.split_whitespace().collect();
        assert_eq!(words, ["1000", "1680", "1500", "2520", "15.0", "4096"]);
        let unknown = counts(1000.0, 1680.0, f64::NAN, None);
        let words: Vec<&str> = unknown.split_whitespace().collect();
        assert_eq!(words, ["1000", "1680", "?", "?", "?", "?"]);
        // The header's columns line up with the row's.
        let header = header(&[("failed", 6)]);
        assert_eq!(header.len(), 22 + 1 + known.len() + 7 + 1);
    }

    #[test]
    fn cycles_per_instruction_needs_trace_and_counter_to_agree() {
        let trace = Traced {
            calls: 4,
            instructions: 4000,
            cycles: 6000,
            ..Traced::default()
        };
        assert_eq!(cycles_per_instruction(&trace, 1040.0), Ok(1.5));
        let e = cycles_per_instruction(&trace, 1100.0).unwrap_err();
        assert_eq!(
            e,
            "the trace saw 1000 instructions per call, the counter 1100"
        );
    }

    #[test]
    fn plans_are_read_from_json() {
        let value: serde_json::Value =
            serde_json::from_str(r#"{"plans": [[1, -0.5], []], "bad": [3]}"#).unwrap();
        let path = Path::new("reference.json");
        assert_eq!(
            plans(&value, "plans", path).unwrap(),
            [vec![1.0, -0.5], vec![]]
        );
        assert!(plans(&value, "none", path).unwrap_err().contains("no none"));
        assert!(plans(&value, "bad", path)
            .unwrap_err()
            .contains("not a list"));
    }
}

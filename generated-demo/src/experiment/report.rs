//! What the experiment shows a reader: a Table-1-style table of mean estimates, the time
//! series as CSV, and SVG plots.
//!
//! The main program fills a [`Trace`] one row per sample: [`Trace::begin`] with the time,
//! then [`Trace::set`] for scalars (y, u, ...), [`Trace::set_truth`] for the true
//! parameters and [`Trace::set_estimate`] for each filter's state estimate under a label
//! such as "EKF wrong". Report functions find a filter's columns by that label.

use std::error::Error;
use std::fmt::Write as _;
use std::io::{self, BufWriter, Write};
use std::path::Path;

use plotters::prelude::*;

use super::plant::{euler_equivalent, Physical};
use super::readout::{self, or_nan};

/// Columns of the true physical parameters, set by [`Trace::set_truth`].
pub const TRUE_PHYSICAL: [&str; 3] = ["true wn", "true zeta", "true alpha"];
/// Columns of the true Euler-equivalent parameters, set by [`Trace::set_truth`].
pub const TRUE_EULER: [&str; 3] = ["true x3", "true x4", "true x5"];
/// A filter has diverged at the first sample whose estimate is not finite or has an entry
/// beyond this magnitude (mm, mm/s, 1/s^2, 1/s, mm/(s^2 V): 1e7 is far beyond anything
/// physical; for x3 = -wn^2, wn > 3000 rad/s).
pub const DIVERGENCE_LIMIT: f64 = 1e7;

/// Name of state `index` (0-based) of the estimate labelled `label`: "{label} x{index+1}".
pub fn estimate_column(label: &str, index: usize) -> String {
    format!("{label} x{}", index + 1)
}

/// Per-sample records: a time column and named value columns, filled row by row.
/// A value not set in a row is NaN, so columns can appear or stop at any time.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    time: Vec<f64>,
    names: Vec<String>,
    columns: Vec<Vec<f64>>,
}

impl Trace {
    /// An empty trace.
    pub fn new() -> Self {
        Self::default()
    }

    /// Starts the row of time `t` \[s\]; its values are NaN until set.
    pub fn begin(&mut self, t: f64) {
        self.time.push(t);
        for column in &mut self.columns {
            column.push(f64::NAN);
        }
    }

    /// Sets `name` in the current row, creating the column if needed.
    /// Panics if no row was begun.
    pub fn set(&mut self, name: &str, value: f64) {
        let row = self
            .time
            .len()
            .checked_sub(1)
            .expect("Trace::set before Trace::begin");
        let i = match self.names.iter().position(|n| n == name) {
            Some(i) => i,
            None => {
                self.names.push(name.to_owned());
                self.columns.push(vec![f64::NAN; self.time.len()]);
                self.names.len() - 1
            }
        };
        self.columns[i][row] = value;
    }

    /// Sets the estimate `x` of the filter labelled `label` ("{label} x1", ...).
    pub fn set_estimate(&mut self, label: &str, x: &[f64]) {
        for (i, v) in x.iter().enumerate() {
            self.set(&estimate_column(label, i), *v);
        }
    }

    /// Sets the true physical parameters ([`TRUE_PHYSICAL`]) and their Euler-equivalent
    /// values ([`TRUE_EULER`]), what a filter on the Euler model should converge to.
    pub fn set_truth(&mut self, p: Physical) {
        let euler = euler_equivalent(p.wn, p.zeta, p.alpha);
        for (name, v) in TRUE_PHYSICAL.iter().zip([p.wn, p.zeta, p.alpha]) {
            self.set(name, v);
        }
        for (name, v) in TRUE_EULER.iter().zip(euler) {
            self.set(name, v);
        }
    }

    /// Adds the columns "{label} wn", "{label} zeta", "{label} alpha": the from-poles
    /// read-out ([`readout::from_poles`]) of the estimate labelled `label`, NaN where the
    /// read-out is undefined. Call after the run; does nothing if the estimate is missing.
    pub fn add_readout(&mut self, label: &str) {
        let Some(params) = self.params(label) else {
            return;
        };
        let physical: Vec<Physical> = params
            .map(|(x3, x4, x5)| or_nan(readout::from_poles(x3, x4, x5)))
            .collect();
        for (suffix, get) in [
            ("wn", (|p: &Physical| p.wn) as fn(&Physical) -> f64),
            ("zeta", |p| p.zeta),
            ("alpha", |p| p.alpha),
        ] {
            let name = format!("{label} {suffix}");
            let values: Vec<f64> = physical.iter().map(get).collect();
            match self.names.iter().position(|n| *n == name) {
                Some(i) => self.columns[i] = values,
                None => {
                    self.names.push(name);
                    self.columns.push(values);
                }
            }
        }
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.time.len()
    }

    /// The time column \[s\].
    pub fn time(&self) -> &[f64] {
        &self.time
    }

    /// The column `name`, one value per row.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        let i = self.names.iter().position(|n| n == name)?;
        Some(&self.columns[i])
    }

    /// The column `name` against time, ready for [`plot_lines`] (legend = column name).
    pub fn line<'a>(&'a self, name: &'a str) -> Option<Line<'a>> {
        Some(Line {
            name,
            t: &self.time,
            v: self.column(name)?,
        })
    }

    /// Per-row (x3, x4, x5) of the estimate labelled `label`.
    fn params(&self, label: &str) -> Option<impl Iterator<Item = (f64, f64, f64)> + '_> {
        let x3 = self.column(&estimate_column(label, 2))?;
        let x4 = self.column(&estimate_column(label, 3))?;
        let x5 = self.column(&estimate_column(label, 4))?;
        Some(x3.iter().zip(x4).zip(x5).map(|((a, b), c)| (*a, *b, *c)))
    }
}

/// Time \[s\] of the first row where the estimate labelled `label` diverged: a state
/// ("{label} x1".. "x5", those present) not finite or beyond [`DIVERGENCE_LIMIT`].
/// None if it never did (or has no columns).
pub fn divergence_time(trace: &Trace, label: &str) -> Option<f64> {
    let columns: Vec<&[f64]> = (0..5)
        .filter_map(|i| trace.column(&estimate_column(label, i)))
        .collect();
    (0..trace.len())
        .find(|&row| {
            // A row before the filter started (all NaN) is not a divergence.
            let started = columns.iter().any(|c| !c[row].is_nan());
            started
                && columns
                    .iter()
                    .any(|c| c[row].is_nan() || c[row].abs() > DIVERGENCE_LIMIT)
        })
        .map(|row| trace.time[row])
}

/// Mean of the finite values over [from, to], and how many samples there were in all.
fn mean_of_finite(t: &[f64], v: &[f64], from: f64, to: f64) -> (f64, usize, usize) {
    let (mut sum, mut finite, mut total) = (0.0, 0, 0);
    for (_, v) in t.iter().zip(v).filter(|(t, _)| (from..=to).contains(*t)) {
        total += 1;
        if v.is_finite() {
            sum += v;
            finite += 1;
        }
    }
    let mean = if finite == 0 {
        f64::NAN
    } else {
        sum / finite as f64
    };
    (mean, finite, total)
}

/// A number in a table cell: fixed `decimals`, scientific if very large, "n/a" if NaN.
fn cell(v: f64, decimals: usize) -> String {
    if !v.is_finite() {
        "n/a".to_owned()
    } else if v.abs() >= 1e5 {
        format!("{v:.2e}")
    } else {
        format!("{v:.decimals$}")
    }
}

fn row(out: &mut String, label: &str, poles: [f64; 3], naive: [f64; 3]) {
    let _ = writeln!(
        out,
        "{label:<16} {:>9} {:>8} {:>8}   {:>9} {:>8} {:>8}",
        cell(poles[0], 2),
        cell(poles[1], 4),
        cell(poles[2], 4),
        cell(naive[0], 2),
        cell(naive[1], 4),
        cell(naive[2], 4),
    );
}

/// Table 1 of the paper, per run: mean wn \[rad/s\], zeta and alpha \[mm s^-2 V^-1\] over
/// [from, to] s, read out both from the poles and naively ([`readout`]). `labels` name
/// the estimates in the trace (one row each, e.g. "EKF close", "DKF wrong"). A run that
/// diverged ([`divergence_time`]) by `to` shows "diverged at t = ..s" instead. A truth row
/// comes first if the trace has the [`TRUE_PHYSICAL`] / [`TRUE_EULER`] columns; its naive
/// columns are the naive read-out of the true Euler-equivalent parameters, i.e. what a
/// perfect filter would show there. Samples whose read-out is undefined are left out of
/// the means and counted in a note under the table.
pub fn parameter_table(trace: &Trace, labels: &[&str], from: f64, to: f64) -> String {
    let t = trace.time();
    let mut out = String::new();
    let mut notes = String::new();
    let _ = writeln!(out, "Mean estimates over {from}-{to} s");
    let _ = writeln!(
        out,
        "{:<16} {:<28}   {:<28}",
        "", "from poles (s = ln z / Ts)", "naive (sqrt(-x3), -x4/2wn, x5)"
    );
    let _ = writeln!(
        out,
        "{:<16} {:>9} {:>8} {:>8}   {:>9} {:>8} {:>8}",
        "run", "wn", "zeta", "alpha", "wn", "zeta", "alpha"
    );
    let mean = |name: &str| {
        trace
            .column(name)
            .map_or(f64::NAN, |v| mean_of_finite(t, v, from, to).0)
    };
    if TRUE_PHYSICAL.iter().all(|n| trace.column(n).is_some()) {
        let poles = TRUE_PHYSICAL.map(mean);
        let naive = readout_means(
            trace,
            &TRUE_EULER.map(String::from),
            from,
            to,
            readout::naive,
        );
        row(&mut out, "truth", poles, naive.0);
    }
    for label in labels {
        let diverged = divergence_time(trace, label);
        if let Some(td) = diverged.filter(|td| *td <= to) {
            let _ = writeln!(out, "{label:<16} diverged at t = {td:.2} s");
            continue;
        }
        let names = [2, 3, 4].map(|i| estimate_column(label, i));
        if names.iter().any(|n| trace.column(n).is_none()) {
            let _ = writeln!(out, "{label:<16} no estimate in the trace");
            continue;
        }
        let (poles, poles_ok, total) = readout_means(trace, &names, from, to, readout::from_poles);
        let (naive, naive_ok, _) = readout_means(trace, &names, from, to, readout::naive);
        row(&mut out, label, poles, naive);
        for (kind, ok) in [("from-poles", poles_ok), ("naive", naive_ok)] {
            if ok < total {
                let _ = writeln!(
                    notes,
                    "  {label}: {kind} read-out undefined at {} of {total} samples (left out)",
                    total - ok
                );
            }
        }
        if let Some(td) = diverged {
            let _ = writeln!(notes, "  {label}: diverged later, at t = {td:.2} s");
        }
    }
    if !notes.is_empty() {
        let _ = write!(out, "Notes:\n{notes}");
    }
    out
}

/// Per-sample read-out of the (x3, x4, x5) columns `names` with `f`, then means over
/// [from, to] of the finite results; also returns (#defined, #samples) in the interval.
fn readout_means(
    trace: &Trace,
    names: &[String; 3],
    from: f64,
    to: f64,
    f: fn(f64, f64, f64) -> Option<Physical>,
) -> ([f64; 3], usize, usize) {
    let cols = names.each_ref().map(|n| trace.column(n).unwrap_or(&[]));
    let n = cols.iter().map(|c| c.len()).min().unwrap_or(0);
    let physical: Vec<Physical> = (0..n)
        .map(|i| or_nan(f(cols[0][i], cols[1][i], cols[2][i])))
        .collect();
    let t = &trace.time()[..n];
    let series = [
        physical.iter().map(|p| p.wn).collect::<Vec<_>>(),
        physical.iter().map(|p| p.zeta).collect(),
        physical.iter().map(|p| p.alpha).collect(),
    ];
    let (_, ok, total) = mean_of_finite(t, &series[0], from, to);
    (series.map(|s| mean_of_finite(t, &s, from, to).0), ok, total)
}

/// Writes the trace as CSV: a header "t,<column names...>" then one line per row
/// (full-precision numbers, NaN for unset values). Names containing a comma or a quote
/// are quoted.
pub fn write_csv<W: Write>(trace: &Trace, out: W) -> io::Result<()> {
    let mut out = BufWriter::new(out);
    let quote = |name: &str| {
        if name.contains([',', '"', '\n']) {
            format!("\"{}\"", name.replace('"', "\"\""))
        } else {
            name.to_owned()
        }
    };
    write!(out, "t")?;
    for name in &trace.names {
        write!(out, ",{}", quote(name))?;
    }
    writeln!(out)?;
    for (row, t) in trace.time.iter().enumerate() {
        write!(out, "{t}")?;
        for column in &trace.columns {
            write!(out, ",{}", column[row])?;
        }
        writeln!(out)?;
    }
    out.flush()
}

/// One curve of a plot: values `v` at times `t` \[s\], with a legend `name`.
#[derive(Clone, Copy, Debug)]
pub struct Line<'a> {
    /// Legend text.
    pub name: &'a str,
    /// Times \[s\].
    pub t: &'a [f64],
    /// Values, one per time.
    pub v: &'a [f64],
}

/// Colours of successive lines: put the truth or the reference first (black).
const COLOURS: [RGBColor; 8] = [
    RGBColor(0, 0, 0),
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(127, 127, 127),
];

/// The time axis, over the lines' finite times (one second wide at least), and the y axis:
/// `y_range`, or the finite values with a 5 % margin.
fn axes(lines: &[Line], y_range: Option<(f64, f64)>) -> ((f64, f64), (f64, f64)) {
    let finite = |s: &[f64]| {
        s.iter()
            .copied()
            .filter(|v| v.is_finite())
            .collect::<Vec<_>>()
    };
    let span = |values: Vec<f64>| {
        values
            .iter()
            .fold(None, |acc: Option<(f64, f64)>, &v| match acc {
                None => Some((v, v)),
                Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
            })
    };
    let (t0, t1) = span(lines.iter().flat_map(|l| finite(l.t)).collect()).unwrap_or((0.0, 1.0));
    let (y0, y1) = y_range.unwrap_or_else(|| {
        let (lo, hi) = span(lines.iter().flat_map(|l| finite(l.v)).collect()).unwrap_or((0.0, 1.0));
        let margin = ((hi - lo) * 0.05).max(1e-12);
        (lo - margin, hi + margin)
    });
    let t1 = if t1 > t0 { t1 } else { t0 + 1.0 };
    ((t0, t1), (y0, y1))
}

/// `line` split into runs of drawable points: finite, and within `(y0, y1)`.
fn drawable_runs(line: &Line, (y0, y1): (f64, f64)) -> Vec<Vec<(f64, f64)>> {
    let mut segments: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
    for (&t, &v) in line.t.iter().zip(line.v) {
        if t.is_finite() && v.is_finite() && (y0..=y1).contains(&v) {
            segments.last_mut().expect("never empty").push((t, v));
        } else if !segments.last().expect("never empty").is_empty() {
            segments.push(Vec::new());
        }
    }
    segments.retain(|s| !s.is_empty());
    segments
}

/// Draws `lines` against time into an SVG file at `path` (900x450 px). The y axis spans
/// `y_range`, or the finite values with a 5 % margin if None. Non-finite values and values
/// outside the y range break a line rather than being clamped, so a diverging estimate
/// leaves the chart instead of flattening the others.
pub fn plot_lines(
    path: &Path,
    title: &str,
    y_label: &str,
    lines: &[Line],
    y_range: Option<(f64, f64)>,
) -> Result<(), Box<dyn Error>> {
    let ((t0, t1), (y0, y1)) = axes(lines, y_range);
    let root = SVGBackend::new(path, (900, 450)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(t0..t1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc(y_label)
        .light_line_style(WHITE)
        .draw()?;
    for (i, line) in lines.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        let mut segments = drawable_runs(line, (y0, y1));
        // One legend entry per line, even when it is broken into segments or, having no
        // drawable point (e.g. a read-out undefined throughout), is not drawn at all.
        let legend = if segments.is_empty() {
            format!("{} (not on chart)", line.name)
        } else {
            line.name.to_owned()
        };
        if segments.is_empty() {
            segments.push(Vec::new());
        }
        for (j, segment) in segments.into_iter().enumerate() {
            let series = chart.draw_series(LineSeries::new(segment, colour.stroke_width(2)))?;
            if j == 0 {
                series.label(legend.clone()).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
            }
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_trace() -> Trace {
        let truth = Physical::WITH_TIP_MASS;
        let good = euler_equivalent(truth.wn, truth.zeta, truth.alpha);
        let mut trace = Trace::new();
        for k in 0..100 {
            let t = k as f64 * 0.1;
            trace.begin(t);
            trace.set("y", (t * 3.0).sin());
            trace.set_truth(truth);
            trace.set_estimate("EKF close", &[0.0, 0.0, good[0], good[1], good[2]]);
            let blow = if t < 5.0 { good[0] } else { -1e8 };
            trace.set_estimate("EKF wrong", &[0.0, 0.0, blow, good[1], good[2]]);
            if k >= 10 {
                trace.set("late", 1.0);
            }
        }
        trace
    }

    #[test]
    fn trace_pads_with_nan_and_writes_csv() {
        let trace = sample_trace();
        assert_eq!(trace.len(), 100);
        let late = trace.column("late").unwrap();
        assert!(late[9].is_nan() && late[10] == 1.0);
        let mut csv = Vec::new();
        write_csv(&trace, &mut csv).unwrap();
        let csv = String::from_utf8(csv).unwrap();
        let mut lines = csv.lines();
        let header = lines.next().unwrap();
        assert!(header.starts_with("t,y,true wn,true zeta,true alpha,true x3"));
        assert!(header.contains(",EKF wrong x3,"));
        assert_eq!(lines.clone().count(), 100);
        assert_eq!(
            lines.next().unwrap().split(',').count(),
            header.split(',').count()
        );
    }

    #[test]
    fn divergence_and_table() {
        let mut trace = sample_trace();
        assert_eq!(divergence_time(&trace, "EKF close"), None);
        assert_eq!(divergence_time(&trace, "EKF wrong"), Some(5.0));
        let table = parameter_table(&trace, &["EKF close", "EKF wrong"], 2.0, 15.0);
        assert!(
            table.contains("EKF wrong        diverged at t = 5.00 s"),
            "{table}"
        );
        let close = table.lines().find(|l| l.starts_with("EKF close")).unwrap();
        let truth = table.lines().find(|l| l.starts_with("truth")).unwrap();
        assert_eq!(close[16..], truth[16..], "{table}");
        assert!(close.contains("20.00") && close.contains("0.0260") && close.contains("19.85"));
        // Diverging after the interval: numbers plus a note.
        let table = parameter_table(&trace, &["EKF wrong"], 0.0, 4.0);
        assert!(table.contains("diverged later, at t = 5.00 s"), "{table}");
        trace.add_readout("EKF close");
        let wn = trace.column("EKF close wn").unwrap();
        assert!((wn[50] - 20.0).abs() < 1e-9);
    }

    #[test]
    fn plots_an_svg() {
        let mut trace = sample_trace();
        trace.add_readout("EKF wrong");
        let path = std::env::temp_dir().join("experiment_report_test.svg");
        let lines = [
            trace.line("true wn").unwrap(),
            Line {
                name: "EKF (wrong guess)",
                ..trace.line("EKF wrong wn").unwrap()
            },
        ];
        plot_lines(&path, "wn", "wn [rad/s]", &lines, Some((0.0, 60.0))).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("EKF (wrong guess)"));
        let _ = std::fs::remove_file(path);
    }
}

//! The sensors: named, disjoint groups of the declared outputs, which a filter corrects
//! with in one update each, and their options (`sensor gnss(gate = 22.46) = [..]`, a fixed
//! `delay = 38` or a `max_delay = 25` with each measurement's own delay given at run time).

use super::names::check_identifier;
use crate::ast::{ArgValue, GenerateArg, ModelDecl, Name, SensorDecl};
use crate::diagnostics::{closest, Diagnostics};
use crate::model::{Sensor, CHI_SQUARE_999};
use std::collections::{HashMap, HashSet};

/// How many output names an error lists before it stops.
const LISTED_OUTPUTS: usize = 12;

/// The options a sensor takes.
const SENSOR_OPTIONS: [&str; 3] = ["gate", "delay", "max_delay"];

/// The longest delay a sensor may declare, in samples: its filter keeps a buffer of as
/// many inputs, and re-propagates the estimate through them each sample.
pub const MAX_DELAY: usize = 1000;

/// Names a sensor may not take: its noise setter, `set_<sensor>_noise`, would be a filter's
/// own (`set_process_noise`, `set_measurement_noise`, `set_input_noise`).
const RESERVED: [&str; 3] = ["process", "measurement", "input"];

/// Resolves each sensor's outputs by name and reads its options. A sensor needs a name of
/// its own (not an output's, whose update would share it; a vector output's own sensor,
/// which lists it alone, excepted) and at least one output that exists; an output
/// belongs to one sensor at most, and appears in it once. Outputs are found among the
/// declared ones, so that one whose expression is wrong (reported already) is not also
/// unknown here. `entries[i]` are the positions of the `i`-th declared output's entries
/// among the model's outputs (three for a vector). A vector output in no sensor is a
/// sensor of its own, of its name (`update_mag`).
pub(super) fn check_sensors(
    decl: &ModelDecl,
    entries: &[std::ops::Range<usize>],
    diag: &mut Diagnostics,
) -> Vec<Sensor> {
    let outputs: Vec<&str> = decl.outputs.iter().map(|o| o.name.text.as_str()).collect();
    let mut owners: HashMap<usize, &str> = HashMap::new();
    let mut sensor_names: HashSet<&str> = HashSet::new();
    let mut sensors = Vec::new();
    for sensor in &decl.sensors {
        let name = &sensor.name;
        check_identifier(name, diag);
        check_not_reserved(name, diag);
        if let Some(i) = outputs.iter().position(|&o| o == name.text) {
            if !is_own_sensor(sensor, entries.get(i)) {
                diag.error(name.span, names_an_output(sensor, entries.get(i)));
            }
        }
        if !sensor_names.insert(&name.text) {
            diag.error(
                name.span,
                format!(
                    "the sensor `{}` is declared twice: merge the two lists",
                    name.text
                ),
            );
        }
        if sensor.outputs.is_empty() {
            diag.error(
                name.span,
                "a sensor measures at least one output: list them, `[y1, y2]`",
            );
        }
        let outputs: Vec<usize> = members(sensor, &outputs, &mut owners, diag)
            .into_iter()
            .flat_map(|i| entries.get(i).cloned().unwrap_or_default())
            .collect();
        let Options {
            gate,
            delay,
            delay_at_run_time,
        } = options(sensor, outputs.len(), diag);
        sensors.push(Sensor {
            docs: sensor.docs.clone(),
            name: name.text.clone(),
            gate,
            delay,
            delay_at_run_time,
            outputs,
        });
    }
    for (i, (output, entries)) in decl.outputs.iter().zip(entries).enumerate() {
        if entries.len() > 1
            && !owners.contains_key(&i)
            && !sensor_names.contains(output.name.text.as_str())
        {
            check_not_reserved(&output.name, diag);
            sensors.push(Sensor {
                docs: output.docs.clone(),
                name: output.name.text.clone(),
                outputs: entries.clone().collect(),
                gate: None,
                delay: 0,
                delay_at_run_time: false,
            });
        }
    }
    check_one_horizon(decl, &sensors, diag);
    sensors
}

/// A filter with a delayed sensor runs on one delayed horizon, where every measurement
/// is fused: a sensor that arrives sooner (of a shorter delay, or none) waits in a buffer
/// of its own until the horizon reaches it, so every output is in a sensor.
fn check_one_horizon(decl: &ModelDecl, sensors: &[Sensor], diag: &mut Diagnostics) {
    let Some(delayed) = sensors.iter().find(|s| s.delay > 0) else {
        return;
    };
    let Some(first) = decl.sensors.iter().find(|s| s.name.text == delayed.name) else {
        return;
    };
    let in_a_sensor = |name: &str| {
        decl.sensors
            .iter()
            .any(|s| s.outputs.iter().any(|o| o.text == name))
    };
    let undelayed: Vec<String> = decl
        .outputs
        .iter()
        .filter(|o| !in_a_sensor(&o.name.text))
        .map(|o| format!("`{}`", o.name.text))
        .collect();
    if !undelayed.is_empty() {
        diag.error(
            first.name.span,
            format!(
                "the sensor `{}` is {}{} samples late, so the filter runs on a delayed \
                 horizon, where every measurement is fused, each sensor's waiting in a \
                 buffer of its own until the horizon reaches it: the output{} {} must be \
                 in a sensor too, `sensor <name> = [..];` (current) or `sensor \
                 <name>(delay = N) = [..];` (N samples late)",
                delayed.name,
                if delayed.delay_at_run_time {
                    "up to "
                } else {
                    ""
                },
                delayed.delay,
                if undelayed.len() == 1 { "" } else { "s" },
                crate::diagnostics::phrase(&undelayed, "and")
            ),
        );
    }
}

/// A sensor's name (a vector output's, which is its own sensor) must leave its setter,
/// `set_<sensor>_noise`, to itself.
fn check_not_reserved(name: &Name, diag: &mut Diagnostics) {
    if RESERVED.contains(&name.text.as_str()) {
        diag.error(
            name.span,
            format!(
                "a sensor named `{0}` would set its measurement noise with \
                 `set_{0}_noise`, a method every filter has already: choose another name",
                name.text
            ),
        );
    }
}

/// Whether `sensor` is a vector output's own sensor, declared to give it options: named as
/// that output (whose entries are `entries`), which it lists alone. Its update is the one
/// the output has anyway, `update_<output>` with its three entries.
fn is_own_sensor(sensor: &SensorDecl, entries: Option<&std::ops::Range<usize>>) -> bool {
    let vector = entries.is_some_and(|e| e.len() > 1);
    vector && matches!(sensor.outputs.as_slice(), [only] if only.text == sensor.name.text)
}

/// Why a sensor may not be named as an output (whose entries are `entries`), and what to
/// write.
fn names_an_output(sensor: &SensorDecl, entries: Option<&std::ops::Range<usize>>) -> String {
    let name = &sensor.name.text;
    if entries.is_some_and(|e| e.len() > 1) {
        return format!(
            "`{name}` names a vector output, whose own sensor lists it alone: write `sensor \
             {name} = [{name}];` for that sensor's options, or give a sensor of several \
             outputs a name of its own (its update is `update_<sensor>`)"
        );
    }
    format!(
        "`{name}` names a scalar output, which is no sensor: `update_{name}(y)` corrects \
         with it alone, judged by the filter's gate. A sensor of it needs a name of its own \
         (its update is `update_<sensor>`), `sensor {name}_sensor(gate = 10.83) = [{name}];`"
    )
}

/// A sensor's options, as read.
struct Options {
    /// Its own gate, if it declares one.
    gate: Option<f64>,
    /// Its delay (`delay = 38`), or the most it may be (`max_delay = 25`); zero if none.
    delay: usize,
    /// Whether each measurement's delay is given at run time (`max_delay`).
    delay_at_run_time: bool,
}

/// The options of `sensor`, of `len` outputs: its gate, if it declares one, and its delay
/// (zero if none), fixed or at most (`max_delay`). A value that is not a gate or a delay,
/// an option given twice, both kinds of delay, or an option a sensor does not take is
/// reported.
fn options(sensor: &SensorDecl, len: usize, diag: &mut Diagnostics) -> Options {
    let mut read = Options {
        gate: None,
        delay: 0,
        delay_at_run_time: false,
    };
    let mut seen: HashSet<&str> = HashSet::new();
    for option in &sensor.options {
        let key = option.name.text.as_str();
        if !seen.insert(key) {
            diag.error(option.name.span, format!("`{key}` is given twice"));
            continue;
        }
        match key {
            "gate" => read.gate = read_gate(option, len, diag),
            "delay" | "max_delay" if seen.contains("delay") && seen.contains("max_delay") => {
                diag.error(option.name.span, both_delays(&sensor.name.text));
            }
            "delay" => read.delay = read_delay(option, false, diag),
            "max_delay" => {
                read.delay = read_delay(option, true, diag);
                read.delay_at_run_time = read.delay > 0;
            }
            _ => diag.error(option.name.span, unknown_option(key)),
        }
    }
    read
}

/// A sensor's delay is fixed (`delay`) or given at run time up to a maximum
/// (`max_delay`), not both.
fn both_delays(sensor: &str) -> String {
    format!(
        "a sensor's delay is fixed, `delay = 38` (every measurement that many samples \
         late), or given with each measurement up to a maximum, `max_delay = 25` \
         (`update_{sensor}(delay, y)`): keep one"
    )
}

/// `delay = 38` (`at_run_time` false): how many samples (calls of `predict`) late the
/// sensor's measurements arrive; `max_delay = 25`: the most they may be, each
/// measurement's own given to its update at run time. A whole number from 1 to
/// [`MAX_DELAY`]; 0 (reported otherwise) on error.
fn read_delay(option: &GenerateArg, at_run_time: bool, diag: &mut Diagnostics) -> usize {
    match &option.value {
        ArgValue::Number(v, _) if v.fract() == 0.0 && *v >= 1.0 && *v <= MAX_DELAY as f64 => {
            // A whole number in range: exact as a usize.
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let samples = *v as usize;
            samples
        }
        other if at_run_time => {
            diag.error(
                other.span(),
                format!(
                    "a sensor's `max_delay` is the most samples (calls of `predict`) late \
                     its measurements may arrive, each one's own delay given to its update \
                     at run time; a whole number from 1 to {MAX_DELAY} (the filter's \
                     buffers hold as many samples): an optical-flow fix up to 100 ms late \
                     in a filter sampled at 250 Hz is `max_delay = 25`"
                ),
            );
            0
        }
        other => {
            diag.error(
                other.span(),
                format!(
                    "a sensor's `delay` is how many samples (calls of `predict`) late its \
                     measurements arrive, a whole number from 1 to {MAX_DELAY}: a GNSS fix \
                     150 ms late in a filter sampled at 250 Hz is `delay = 38` (0.15 s \
                     times 250 Hz, rounded)"
                ),
            );
            0
        }
    }
}

/// `gate = 22.46` (a positive finite number) or `gate = off` (generated open, infinite).
fn read_gate(option: &GenerateArg, len: usize, diag: &mut Diagnostics) -> Option<f64> {
    match &option.value {
        ArgValue::Number(v, _) if *v > 0.0 && v.is_finite() => Some(*v),
        ArgValue::Name(n) if n.text == "off" => Some(f64::INFINITY),
        other => {
            let quantile = match CHI_SQUARE_999.get(len.wrapping_sub(1)) {
                Some(q) => format!(
                    "for this sensor's {len} output{}, {q} rejects one in a thousand \
                     consistent measurements",
                    if len == 1 { "" } else { "s" }
                ),
                None => "16.27 rejects one in a thousand consistent measurements of 3 \
                         outputs, 22.46 of 6"
                    .to_owned(),
            };
            diag.error(
                other.span(),
                format!(
                    "a sensor's `gate` is a threshold on its normalised innovation squared, \
                     a positive number: the chi-square quantile for as many degrees of \
                     freedom as it has outputs ({quantile}), or `off` to set it at run time"
                ),
            );
            None
        }
    }
}

/// What an option a sensor does not take is told.
fn unknown_option(key: &str) -> String {
    let listed: Vec<String> = SENSOR_OPTIONS.iter().map(|o| format!("`{o}`")).collect();
    match closest(key, SENSOR_OPTIONS) {
        Some(near) => format!("a sensor takes no option `{key}`: did you mean `{near}`?"),
        None => format!(
            "a sensor takes no option `{key}`; its options are {} (its measurement noise \
             is given at run time, to the filter's `new` and `set_<sensor>_noise`)",
            crate::diagnostics::phrase(&listed, "and")
        ),
    }
}

/// The indices of `sensor`'s outputs, each claimed for it in `owners`; an output that does
/// not exist or is claimed already is reported and left out.
fn members<'a>(
    sensor: &'a SensorDecl,
    outputs: &[&str],
    owners: &mut HashMap<usize, &'a str>,
    diag: &mut Diagnostics,
) -> Vec<usize> {
    let mut members = Vec::new();
    for output in &sensor.outputs {
        let Some(i) = outputs.iter().position(|&o| o == output.text) else {
            diag.error(output.span, unknown_output(output, outputs));
            continue;
        };
        match owners.get(&i) {
            Some(&other) if other == sensor.name.text => diag.error(
                output.span,
                format!("`{}` is listed twice in this sensor", output.text),
            ),
            Some(&other) => diag.error(
                output.span,
                format!(
                    "`{}` is measured by the sensor `{other}` already: an output belongs to \
                     one sensor",
                    output.text
                ),
            ),
            None => {
                owners.insert(i, &sensor.name.text);
                members.push(i);
            }
        }
    }
    members
}

/// What to write instead of an output that does not exist.
fn unknown_output(output: &Name, outputs: &[&str]) -> String {
    let text = &output.text;
    if outputs.is_empty() {
        return format!(
            "no output is named `{text}`: declare it first, `output {text} = <expression>;`"
        );
    }
    let mut names: Vec<String> = outputs
        .iter()
        .take(LISTED_OUTPUTS)
        .map(|o| format!("`{o}`"))
        .collect();
    if outputs.len() > LISTED_OUTPUTS {
        names.push(format!("and {} more", outputs.len() - LISTED_OUTPUTS));
    }
    format!(
        "no output is named `{text}`: a sensor lists declared outputs ({})",
        names.join(", ")
    )
}

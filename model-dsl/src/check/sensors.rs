//! The sensors: named, disjoint groups of the declared outputs, which a filter corrects
//! with in one update each.

use super::names::check_identifier;
use crate::ast::{ModelDecl, Name, SensorDecl};
use crate::diagnostics::Diagnostics;
use crate::model::Sensor;
use std::collections::{HashMap, HashSet};

/// How many output names an error lists before it stops.
const LISTED_OUTPUTS: usize = 12;

/// Resolves each sensor's outputs by name. A sensor needs a name of its own (not an
/// output's, whose update would share it) and at least one output that exists; an output
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
        if outputs.contains(&name.text.as_str()) {
            diag.error(
                name.span,
                format!(
                    "`{}` names an output: give the sensor a name of its own (its update is \
                     `update_<sensor>`, an output's `update_<output>`)",
                    name.text
                ),
            );
        } else if !sensor_names.insert(&name.text) {
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
        sensors.push(Sensor {
            docs: sensor.docs.clone(),
            name: name.text.clone(),
            outputs: members(sensor, &outputs, &mut owners, diag)
                .into_iter()
                .flat_map(|i| entries.get(i).cloned().unwrap_or_default())
                .collect(),
        });
    }
    for (i, (output, entries)) in decl.outputs.iter().zip(entries).enumerate() {
        if entries.len() > 1
            && !owners.contains_key(&i)
            && !sensor_names.contains(output.name.text.as_str())
        {
            sensors.push(Sensor {
                docs: output.docs.clone(),
                name: output.name.text.clone(),
                outputs: entries.clone().collect(),
            });
        }
    }
    sensors
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

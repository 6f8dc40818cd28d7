//! The `generate` items: each names a generator of the registry, whose requirements the
//! model must meet before its options are read. The checks know no generator by name.

use super::names::generated_item;
use crate::ast::{GenerateDecl, ModelDecl};
use crate::diagnostics::{phrase, Diagnostics};
use crate::generators::{Args, Budget, Context, Generator, Kind, Requirement, REGISTRY};
use crate::scope::Scope;

/// A generator the model asks for, with its cycle budget if it gives one.
type Requested = (Box<dyn Generator>, Option<Budget>);

/// The generators the model asks for, with their options checked, in the order of
/// [`REGISTRY`] (the order their code takes in the generated module) and, within one kind,
/// as written.
pub(super) fn check_generate(
    decl: &ModelDecl,
    scope: &Scope,
    diag: &mut Diagnostics,
) -> Vec<Requested> {
    let cx = Context::new(decl, scope);
    let mut seen = std::collections::HashSet::new();
    let mut generators: Vec<(usize, Requested)> = Vec::new();
    for item in &decl.generate {
        let Some((rank, kind)) = lookup(item, diag) else {
            continue;
        };
        if !seen.insert(instance_key(kind, item)) {
            diag.error(item.name.span, asked_twice(kind, item));
            continue;
        }
        if !requirements_met(kind, decl, item, diag) {
            continue;
        }
        if let Some(option) = declared_delay(decl).filter(|_| !kind.runs_delayed()) {
            diag.error(item.name.span, no_delayed_horizon(kind, option));
            continue;
        }
        if !kind.takes_interval() && decl.constants.iter().any(|c| c.interval.is_some()) {
            diag.error(item.name.span, no_interval(kind));
            continue;
        }
        let mut args = Args::new(item, diag);
        let budget = Budget::read(
            &mut |name| args.take(&[name]).map(|a| a.value.clone()),
            diag,
        );
        let cx = cx.with_budget(budget.clone());
        let generator = kind.options(item, &mut args, &cx, diag);
        args.report_unused(diag);
        if let Some(generator) = generator {
            check_type_names(kind, item, generator.as_ref(), diag);
            generators.push((rank, (generator, budget)));
        }
    }
    // A stable sort: within one kind, the order written.
    generators.sort_by_key(|(rank, _)| *rank);
    generators.into_iter().map(|(_, g)| g).collect()
}

/// The registry's generator named by `item`, with its rank, or an error listing them all.
fn lookup(item: &GenerateDecl, diag: &mut Diagnostics) -> Option<(usize, &'static dyn Kind)> {
    let found = REGISTRY
        .iter()
        .enumerate()
        .find(|(_, kind)| kind.name() == item.name.text);
    if found.is_none() {
        let usages: Vec<String> = REGISTRY
            .iter()
            .map(|k| k.description().usage.to_owned())
            .collect();
        diag.error(
            item.name.span,
            format!(
                "unknown generator `{}`: use {}",
                item.name.text,
                phrase(&usages, "or")
            ),
        );
    }
    found.map(|(rank, kind)| (rank, *kind))
}

/// What tells two items of one kind apart: its name, and the type name where a model may
/// ask for several under different names.
fn instance_key(kind: &dyn Kind, item: &GenerateDecl) -> String {
    match kind.description().type_name_option {
        Some(default) => format!("{} {}", kind.name(), written_type_name(item, default)),
        None => kind.name().to_owned(),
    }
}

/// The type name an item asks for with `name = ..`, or `default`.
fn written_type_name<'a>(item: &'a GenerateDecl, default: &'a str) -> &'a str {
    item.args
        .iter()
        .find(|a| a.name.text == "name")
        .and_then(|a| match &a.value {
            crate::ast::ArgValue::Name(n) => Some(n.text.as_str()),
            _ => None,
        })
        .unwrap_or(default)
}

fn asked_twice(kind: &dyn Kind, item: &GenerateDecl) -> String {
    match kind.description().type_name_option {
        Some(default) => format!(
            "{} `{}` of type `{}` is asked for twice: give the second another type name, \
             `{}(name = Gated{default})`",
            if kind.name().starts_with(['a', 'e', 'i', 'o', 'u']) {
                "an"
            } else {
                "a"
            },
            kind.name(),
            written_type_name(item, default),
            kind.name()
        ),
        None => format!("`{}` is asked for twice", kind.name()),
    }
}

/// Reports every requirement of `kind` the model does not meet; whether all are met.
fn requirements_met(
    kind: &dyn Kind,
    decl: &ModelDecl,
    item: &GenerateDecl,
    diag: &mut Diagnostics,
) -> bool {
    let mut met = true;
    for &requirement in kind.requirements() {
        let alternatives = match requirement {
            // The filters that integrate the continuous dynamics need no unrolled step.
            Requirement::UnrolledStep => with(Requirement::ContinuousDynamics),
            other => without(other),
        };
        if let Some(message) = requirement.unmet(kind.name(), decl, &alternatives) {
            diag.error(item.name.span, message);
            met = false;
        }
    }
    met
}

/// The delay option a sensor of the model declares first, if any: `delay` (fixed) or
/// `max_delay` (given at run time).
fn declared_delay(decl: &ModelDecl) -> Option<&str> {
    decl.sensors
        .iter()
        .flat_map(|s| &s.options)
        .map(|o| o.name.text.as_str())
        .find(|&name| name == "delay" || name == "max_delay")
}

/// What a generator with no delayed horizon says of a model with a delayed sensor, whose
/// `option` (`delay` or `max_delay`) asks for one.
fn no_delayed_horizon(kind: &dyn Kind, option: &str) -> String {
    let names: Vec<String> = REGISTRY
        .iter()
        .filter(|k| k.runs_delayed())
        .map(|k| format!("`{}`", k.name()))
        .collect();
    format!(
        "`{}` does not run on a delayed horizon, which a sensor's `{option}` asks for{}: \
         {} does, or drop the `{option}`",
        kind.name(),
        if option == "max_delay" {
            " (each measurement's delay given to its update at run time)"
        } else {
            ""
        },
        phrase(&names, "or")
    )
}

/// What a generator whose predictions take no interval says of a model that declares one.
fn no_interval(kind: &dyn Kind) -> String {
    let names: Vec<String> = REGISTRY
        .iter()
        .filter(|k| k.takes_interval())
        .map(|k| format!("`{}`", k.name()))
        .collect();
    format!(
        "`{}` is designed for a fixed sample time, and the model's is an `interval`, given \
         at run time: {} takes it, or declare the sample time `const`",
        kind.name(),
        phrase(&names, "or")
    )
}

/// The generators that do not have `requirement`, as a phrase: "`ekf` and `lqr`".
fn without(requirement: Requirement) -> String {
    let names: Vec<String> = REGISTRY
        .iter()
        .filter(|kind| !kind.requirements().contains(&requirement))
        .map(|kind| format!("`{}`", kind.name()))
        .collect();
    phrase(&names, "and")
}

/// The generators that have `requirement`, as a phrase: "`hybrid_ekf` and `continuous_ekf`".
fn with(requirement: Requirement) -> String {
    let names: Vec<String> = REGISTRY
        .iter()
        .filter(|kind| kind.requirements().contains(&requirement))
        .map(|kind| format!("`{}`", kind.name()))
        .collect();
    phrase(&names, "and")
}

/// A type name chosen with `name = ..` must not be another item of the generated module.
fn check_type_names(
    kind: &dyn Kind,
    item: &GenerateDecl,
    generator: &dyn Generator,
    diag: &mut Diagnostics,
) {
    let Some(default) = kind.description().type_name_option else {
        return;
    };
    for name in generator.type_names() {
        if name != default && (generated_item(&name) || name == "Self") {
            let span = item
                .args
                .iter()
                .find(|a| a.name.text == "name")
                .map_or(item.name.span, |a| a.value.span());
            diag.error(
                span,
                format!(
                    "`{name}` is already an item of the generated module: choose another \
                     type name"
                ),
            );
        }
    }
}

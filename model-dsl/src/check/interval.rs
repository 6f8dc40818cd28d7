//! The sample interval (`interval DT = 0.004;`): a discrete model's step and process noise
//! are functions of it, continuous dynamics are integrated over it, and each prediction
//! takes it at run time. What a model may do with it, checked once the model is whole.

use crate::ast::{DynamicsKind, ModelDecl, Statement};
use crate::diagnostics::Diagnostics;
use crate::model::{Discretisation, Expr, Model};

/// The model's use of its sample interval, if it declares one: continuous dynamics are
/// integrated over it (see [`check_continuous_use`]), the model does not read the time `t`
/// (a prediction would need both), no output reads it (a measurement is of one instant),
/// and its parameter's name (`dt`) is no other name of the model.
pub(super) fn check_interval_use(decl: &ModelDecl, model: &Model, diag: &mut Diagnostics) {
    let Some(i) = model.interval() else {
        return;
    };
    let Some(declared) = decl.constants.iter().find(|c| c.interval.is_some()) else {
        return;
    };
    let at = declared.interval.unwrap_or(declared.name.span);
    let name = &model.constants[i].name;
    if let Discretisation::Continuous { dt, .. } = &model.dynamics.discretisation {
        check_continuous_use(decl, model, (i, dt), diag);
    }
    if model.uses_time() {
        diag.error(
            at,
            format!(
                "a model that reads the time `t` has no sample interval of its own yet \
                 (its predictions would take both): write `const {name} = ..;`, or drop `t`"
            ),
        );
    }
    let reads = |e: &Expr| matches!(e, Expr::Const(j) if *j == i);
    for (output, declared) in model.outputs.iter().zip(&decl.outputs) {
        if model.reads(&output.expr, &reads) {
            diag.error(
                declared.name.span,
                format!(
                    "the output `{}` reads the sample interval `{name}`, which a measurement \
                     of one instant has none of: only the dynamics read it",
                    output.name
                ),
            );
        }
    }
    let parameter = model.interval_parameter().unwrap_or_default();
    let taken = model
        .state_names()
        .chain(model.inputs.iter().map(|s| s.name.as_str()));
    let clash = taken
        .chain(model.known.iter().map(|s| s.name.as_str()))
        .chain(
            model
                .constants
                .iter()
                .filter(|c| !c.interval)
                .map(|c| c.name.as_str()),
        )
        .chain(model.outputs.iter().map(|o| o.name.as_str()))
        .chain(model.locals.iter().map(|l| l.name.as_str()))
        .any(|other| other == parameter);
    if clash {
        diag.error(
            declared.name.span,
            format!(
                "the sample interval `{name}` is the parameter `{parameter}` of the model's \
                 functions and predictions, a name the model uses already: rename one"
            ),
        );
    }
}

/// Continuous dynamics with a sample interval `i`: their step `dt` is the interval itself
/// (what each prediction integrates over is the time since the previous sample, not a
/// multiple of it: `h = dt / substeps` divides it), and their rates do not read it (a
/// rate is of one instant, whatever the samples around it).
fn check_continuous_use(
    decl: &ModelDecl,
    model: &Model,
    (i, dt): (usize, &Expr),
    diag: &mut Diagnostics,
) {
    let name = &model.constants[i].name;
    let written = decl.dynamics.first().and_then(|d| match &d.kind {
        DynamicsKind::Continuous { dt: Some(dt), .. } => Some(dt.span),
        _ => None,
    });
    if !matches!(dt, Expr::Const(j) if *j == i) {
        diag.error(
            written.unwrap_or(decl.span),
            format!(
                "continuous dynamics are integrated over the sample interval `{name}`, given \
                 to each prediction: write `dt = {name}` (the sub-steps divide it)"
            ),
        );
    }
    let reads = |e: &Expr| matches!(e, Expr::Const(j) if *j == i);
    let equations = decl.dynamics.iter().flat_map(|d| &d.statements);
    for statement in equations {
        let Statement::Equation { target, value, .. } = statement else {
            continue;
        };
        let Some(s) = model.states.iter().position(|s| s.name == target.text) else {
            continue;
        };
        if model.reads(&model.dynamics.rhs[s], &reads) {
            diag.error(
                value.span,
                format!(
                    "the rate of `{}` reads the sample interval `{name}`, which a rate of one \
                     instant has none of: only the step, `dt = {name}`, reads it",
                    target.text
                ),
            );
        }
    }
}

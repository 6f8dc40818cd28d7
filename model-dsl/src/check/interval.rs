//! The sample interval (`interval DT = 0.004;`): a discrete model's step and process noise
//! are functions of it, and each prediction takes it at run time. What a model may do with
//! it, checked once the model is whole.

use crate::ast::ModelDecl;
use crate::diagnostics::Diagnostics;
use crate::model::{Discretisation, Expr, Model};

/// The model's use of its sample interval, if it declares one: its dynamics are discrete
/// (a continuous model's `dt` is fixed), it does not read the time `t` (a prediction
/// would need both), no output reads it (a measurement is of one instant), and its name
/// as the functions' parameter (lower case, `dt`) is no other name of the model.
pub(super) fn check_interval_use(decl: &ModelDecl, model: &Model, diag: &mut Diagnostics) {
    let Some(i) = model.interval() else {
        return;
    };
    let Some(declared) = decl.constants.iter().find(|c| c.interval.is_some()) else {
        return;
    };
    let at = declared.interval.unwrap_or(declared.name.span);
    let name = &model.constants[i].name;
    if matches!(
        model.dynamics.discretisation,
        Discretisation::Continuous { .. }
    ) {
        diag.error(
            at,
            format!(
                "`interval {name}` is a discrete model's sample interval, given to each \
                 prediction; continuous dynamics are integrated over a fixed `dt`: write \
                 `const {name} = ..;`, or the dynamics as `dynamics discrete {{ .. }}`"
            ),
        );
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

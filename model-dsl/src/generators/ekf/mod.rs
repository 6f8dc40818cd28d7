//! The extended Kalman filter (Alg. 1 of the double Kalman filter paper), with an
//! optional innovation gate: `ekf(gate = 10.83, name = GatedEkf, process_noise = diagonal)`,
//! and noise on inputs mapped through the input Jacobian: `ekf(input_noise = [gyro])`.

pub mod delay;
pub mod horizon_calls;
pub mod lower;
pub mod spec;

use super::options::{Args, Context};
use super::unit::{Code, Cost, Description, Generator, Kind, Lowering, Requirement};
use crate::ast::{ArgValue, GenerateDecl};
use crate::diagnostics::Diagnostics;
use crate::emit::names::screaming_snake;
use crate::model::{Expr, Model, Scalar};
use crate::symbolic::ModelGraph;
pub use spec::EkfSpec;
use std::any::Any;
use std::borrow::Cow;

/// The `ekf` generator.
pub struct Ekf;

/// What `ekf` is and what it requires of the model.
const DESCRIPTION: Description = Description {
    name: "ekf",
    usage: "`ekf`",
    requirements: &[Requirement::Outputs, Requirement::UnrolledStep],
    items: &["Ekf"],
    type_name_option: Some("Ekf"),
};

impl Kind for Ekf {
    fn description(&self) -> &'static Description {
        &DESCRIPTION
    }

    fn options(
        &self,
        item: &GenerateDecl,
        args: &mut Args,
        cx: &Context,
        diag: &mut Diagnostics,
    ) -> Option<Box<dyn Generator>> {
        let type_name = args.type_name("Ekf", diag);
        let gate = args.gate(diag);
        Some(Box::new(EkfSpec {
            type_name,
            gate,
            recover_after: args.recover_after(diag),
            process_noise: args.process_noise_shape(cx, diag),
            input_noise: args.input_noise(cx, diag),
            fuses_late_as_current: horizon(args, cx, diag),
            item: Some(item.name.span),
        }))
    }

    fn runs_delayed(&self) -> bool {
        true
    }

    fn takes_interval(&self) -> bool {
        true
    }
}

/// `horizon = delayed` (the default) or `current`: whether the filter fuses a late
/// sensor's measurements on the delayed horizon or as if they were current. `current`
/// needs a sensor that declares a delay.
fn horizon(args: &mut Args, cx: &Context, diag: &mut Diagnostics) -> bool {
    let Some(arg) = args.take(&["horizon"]) else {
        return false;
    };
    match &arg.value {
        ArgValue::Name(n) if n.text == "delayed" => false,
        ArgValue::Name(n) if n.text == "current" => {
            let delayed = cx
                .decl
                .sensors
                .iter()
                .any(|s| s.options.iter().any(|o| o.name.text == "delay"));
            if !delayed {
                diag.error(
                    n.span,
                    "`horizon = current` fuses late measurements as if they were current, \
                     but no sensor of the model declares a delay: drop the option, or \
                     declare the sensor's, `sensor gnss(delay = 38) = [..];`",
                );
            }
            true
        }
        other => {
            diag.error(
                other.span(),
                "`horizon` is `delayed` (the default: a late sensor's measurements are fused \
                 at the sample they describe) or `current` (fused as if they were current, \
                 for comparison)",
            );
            false
        }
    }
}

impl EkfSpec {
    /// The model as the filter runs it: with `horizon = current`, its sensors' delays
    /// dropped.
    fn horizon_model<'a>(&self, model: &'a Model) -> Cow<'a, Model> {
        if !self.fuses_late_as_current {
            return Cow::Borrowed(model);
        }
        let mut current = model.clone();
        for sensor in &mut current.sensors {
            sensor.delay = 0;
        }
        Cow::Owned(current)
    }
}

impl Generator for EkfSpec {
    fn design(&self, model: &Model, _mg: &ModelGraph) -> syn::Result<Box<dyn Lowering>> {
        let model = self.horizon_model(model);
        let at = self.item.unwrap_or_else(proc_macro2::Span::call_site);
        if model.delay() > 0 && model.uses_time() {
            return Err(syn::Error::new(
                at,
                "`ekf`: a model that reads the time `t` has no delayed horizon yet (its \
                 buffer would hold the times as well as the inputs): drop the sensors' \
                 `delay`, or `t` from the model",
            ));
        }
        if model.delay() > 0
            && model
                .outputs
                .iter()
                .any(|o| model.reads(&o.expr, &|e| matches!(e, Expr::Input(_))))
        {
            return Err(syn::Error::new(
                at,
                "`ekf`: an output that reads an input has no delayed horizon yet (a late \
                 measurement would need the input of the sample it describes): drop the \
                 sensors' `delay`, or the input from the outputs",
            ));
        }
        // The covariance of a state with rotations is over its tangent space.
        let process_noise = self.process_noise.in_tangent(&model);
        Ok(Box::new(EkfSpec {
            process_noise,
            ..self.clone()
        }))
    }

    fn type_names(&self) -> Vec<String> {
        vec![self.type_name.clone()]
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

impl Lowering for EkfSpec {
    fn lower(&self, model: &Model, mg: &ModelGraph, scalar: Scalar) -> Code {
        let model = &*self.horizon_model(model);
        let ekf = lower::emit_ekf(model, self, mg, scalar);
        // `Ekf` gives `EKF_STEP_OPS`, `GatedEkf` `GATED_EKF_STEP_OPS`.
        let prefix = screaming_snake(&self.type_name);
        let methods = [
            ("predict".to_owned(), ekf.predict_ops),
            ("update".to_owned(), ekf.update_ops),
            ("step".to_owned(), ekf.step_ops),
        ];
        // A sensor's update as well: `EKF_UPDATE_GNSS_OPS`.
        let costs = methods
            .into_iter()
            .chain(ekf.sensor_update_ops)
            .map(|(method, ops)| {
                let constant = format!("{prefix}_{}_OPS", method.to_uppercase());
                let cost = Cost::new(&constant, &format!("{}::{method}", self.type_name), ops);
                if method == "step" {
                    cost.budgeted()
                } else {
                    cost
                }
            })
            .collect();
        let buffer_bytes = delay::buffer_bytes(model, &prefix, scalar);
        let tokens = ekf.tokens;
        Code {
            tokens: quote::quote! { #buffer_bytes #tokens },
            costs,
        }
    }
}

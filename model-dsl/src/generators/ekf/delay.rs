//! The delayed fusion horizon of a filter whose sensors arrive late (`sensor gnss(delay =
//! 38) = [..]`), as PX4's EKF2 runs it: the filter's estimate and covariance describe the
//! state `delay` samples ago, where a late measurement is fused at the time it describes;
//! a fixed-size buffer holds the inputs since, and an output predictor gives the current
//! state by propagating the delayed estimate through them. EKF2's output predictor is a
//! complementary observer (a few operations a sample, tracking the delayed estimate with a
//! lag); this one re-propagates the estimate, not the covariance, through the buffered
//! inputs after each call, `delay` evaluations of `f`: exact, and cheap beside the
//! covariance's `O(n^3)` for the delays of a few tens of samples a GNSS fix has.

use crate::emit::arguments::Arguments;
use crate::emit::lower::{literal, OpCount};
use crate::emit::model_fns::{emit_function, model_functions};
use crate::emit::names::ident;
use crate::model::{Model, Scalar};
use crate::symbolic::ModelGraph;
use proc_macro2::{Ident, Literal, TokenStream};
use quote::quote;

/// The buffer's fields: the inputs of the last `delay` samples (oldest first) with a flag
/// each, set once the sample is buffered, and the output predictor's current state.
pub fn fields(model: &Model, ty: &Ident) -> TokenStream {
    let delay = model.delay();
    if delay == 0 {
        return TokenStream::new();
    }
    let d = Literal::usize_unsuffixed(delay);
    let n = Literal::usize_unsuffixed(model.state_len());
    let inputs = (!model.inputs.is_empty()).then(|| {
        let nu = Literal::usize_unsuffixed(model.inputs.len());
        quote! { inputs: [[#ty; #nu]; #d], }
    });
    quote! {
        #inputs
        inputs_buffered: [bool; #d],
        current_x: [#ty; #n],
    }
}

/// The constructor's values of [`fields`]: an empty buffer, and the initial estimate `x0`
/// as the current state.
pub fn initial_values(model: &Model, scalar: Scalar) -> TokenStream {
    let delay = model.delay();
    if delay == 0 {
        return TokenStream::new();
    }
    let d = Literal::usize_unsuffixed(delay);
    let zero = literal(0.0, scalar);
    let inputs = (!model.inputs.is_empty()).then(|| {
        let nu = Literal::usize_unsuffixed(model.inputs.len());
        quote! { inputs: [[#zero; #nu]; #d], }
    });
    quote! {
        #inputs
        inputs_buffered: [false; #d],
        current_x: *x0,
    }
}

/// What `reset` does to the buffer, after setting the estimate: empties it (the horizon
/// starts again at the new estimate), the current state the new estimate.
pub fn clear(model: &Model) -> TokenStream {
    let delay = model.delay();
    if delay == 0 {
        return TokenStream::new();
    }
    let d = Literal::usize_unsuffixed(delay);
    quote! {
        self.inputs_buffered = [false; #d];
        self.current_x = self.x;
    }
}

/// The name of a method's step on the delayed horizon: `update_gnss_at_horizon`.
fn at_horizon(name: &Ident) -> Ident {
    ident(&format!("{name}_at_horizon"))
}

/// A method of the filter on the delayed horizon: the generated step, private and named
/// `<name>_at_horizon`, and the public method, which buffers the input (`predicts`: a
/// prediction or a step), runs the step on the horizon, and then the output predictor.
/// A step whose horizon has not moved yet (the buffer still filling, its measurement of
/// the start) is the correction alone.
pub fn wrap(
    (name, doc): (&Ident, &TokenStream),
    arguments: Arguments,
    body: TokenStream,
    (predicts, update_alone): (bool, Option<&Ident>),
    (model, ty): (&Model, &Ident),
) -> TokenStream {
    let inner = at_horizon(name);
    let params = arguments.params().to_vec();
    let passed: Vec<TokenStream> = params
        .iter()
        .filter_map(|p| p.clone().into_iter().next())
        .map(|first| {
            if first.to_string() == "u_prev" {
                quote! { &oldest }
            } else {
                quote! { #first }
            }
        })
        .collect();
    let horizon_doc = format!(" [`Self::{name}`] on the delayed horizon.");
    let step = arguments.private_method(&inner, &quote! { #[doc = #horizon_doc] }, body);
    let run = if predicts {
        let buffer = buffer_input(model, ty);
        // A step's measurement is checked before the input is buffered: a step refused
        // for it leaves the buffer and the horizon as they were.
        let measurement = update_alone.map(|_| {
            let entries: Vec<Ident> = (0..model.outputs.len())
                .map(|i| ident(&format!("y_{i}")))
                .collect();
            quote! {
                let [#(#entries),*] = *y;
                if !stateforge_math::#ty::all_finite([#(#entries),*]) {
                    return Status::RejectedInput;
                }
            }
        });
        let otherwise = match update_alone {
            Some(update) => {
                let update = at_horizon(update);
                quote! { self.#update(y) }
            }
            None => quote! { Status::Ok },
        };
        quote! {
            #measurement
            #buffer
            let status = if oldest_buffered { self.#inner(#(#passed),*) } else { #otherwise };
        }
    } else {
        quote! { let status = self.#inner(#(#passed),*); }
    };
    let horizon_doc = if predicts {
        " On the delayed horizon: the input is buffered, and the estimate and covariance, \
         `DELAY` samples behind, are predicted with the input of `DELAY` samples ago once \
         the buffer is full (a prediction there refused as non-finite leaves that sample \
         out of the horizon: reset the filter); the output predictor then brings \
         [`Self::current_state`] to the present."
    } else {
        " On the delayed horizon: the measurement, `DELAY` samples late, is fused at the \
         sample it describes (before the buffer is full, at the start, where the horizon \
         still is); the output predictor then brings [`Self::current_state`] to the \
         present."
    };
    quote! {
        #step

        #doc
        ///
        #[doc = #horizon_doc]
        pub fn #name(&mut self, #(#params),*) -> Status {
            #run
            self.predict_output();
            status
        }
    }
}

/// Checks the new input `u_prev` finite, then shifts it into the buffer: binds the
/// oldest sample, `oldest` (its input) and `oldest_buffered` (whether it was).
fn buffer_input(model: &Model, ty: &Ident) -> TokenStream {
    let delay = model.delay();
    let later = |prefix: &str| -> Vec<Ident> {
        (1..delay)
            .map(|i| ident(&format!("{prefix}_{i}")))
            .collect()
    };
    let buffered = later("buffered");
    let flags = quote! {
        let [oldest_buffered, #(#buffered),*] = self.inputs_buffered;
        self.inputs_buffered = [#(#buffered,)* true];
    };
    if model.inputs.is_empty() {
        return flags;
    }
    let entries: Vec<Ident> = (0..model.inputs.len())
        .map(|i| ident(&format!("u_prev_{i}")))
        .collect();
    let inputs = later("input");
    quote! {
        let [#(#entries),*] = *u_prev;
        if !stateforge_math::#ty::all_finite([#(#entries),*]) {
            return Status::RejectedInput;
        }
        #flags
        let [oldest, #(#inputs),*] = self.inputs;
        self.inputs = [#(#inputs,)* *u_prev];
    }
}

/// The output predictor, `predict_output`, the current state's accessor and the delay.
pub fn items(model: &Model, ty: &Ident) -> TokenStream {
    let delay = model.delay();
    if delay == 0 {
        return TokenStream::new();
    }
    let flags: Vec<Ident> = (0..delay)
        .map(|i| ident(&format!("buffered_{i}")))
        .collect();
    let known = (!model.known.is_empty()).then(|| quote! { , &self.known });
    let (unpack_inputs, steps): (TokenStream, Vec<TokenStream>) = if model.inputs.is_empty() {
        let steps = flags
            .iter()
            .map(|b| quote! { let x = if #b { f(&x #known) } else { x }; })
            .collect();
        (TokenStream::new(), steps)
    } else {
        let inputs: Vec<Ident> = (0..delay).map(|i| ident(&format!("input_{i}"))).collect();
        let steps = flags
            .iter()
            .zip(&inputs)
            .map(|(b, u)| quote! { let x = if #b { f(&x, &#u #known) } else { x }; })
            .collect();
        (quote! { let [#(#inputs),*] = self.inputs; }, steps)
    };
    let n = Literal::usize_unsuffixed(model.state_len());
    let d = Literal::usize_unsuffixed(delay);
    let delay_doc = format!(
        " How many samples late the sensors' measurements arrive (`delay = {delay}`): the \
         estimate and covariance describe the state this many samples ago."
    );
    quote! {
        #[doc = #delay_doc]
        pub const DELAY: usize = #d;

        /// The output predictor: the delayed estimate propagated through the buffered
        /// inputs to the current sample, `x = f(x, u)` once for each (the estimate only;
        /// the covariance stays on the horizon).
        fn predict_output(&mut self) {
            let [#(#flags),*] = self.inputs_buffered;
            #unpack_inputs
            let x = self.x;
            #(#steps)*
            self.current_x = x;
        }

        /// The current state, which the output predictor propagates from the delayed
        /// estimate ([`Self::state`], `DELAY` samples ago, where the late measurements
        /// are fused) through the inputs since.
        #[must_use]
        pub fn current_state(&self) -> [#ty; #n] {
            self.current_x
        }
    }
}

/// The RAM the buffer takes, in bytes (the inputs, their flags and the current state), as
/// a constant beside the cost constants: `EKF_BUFFER_BYTES`.
pub fn buffer_bytes(model: &Model, prefix: &str, scalar: Scalar) -> TokenStream {
    let delay = model.delay();
    if delay == 0 {
        return TokenStream::new();
    }
    let width = match scalar {
        Scalar::F32 => 4,
        Scalar::F64 => 8,
    };
    let bytes = delay * model.inputs.len() * width + delay + model.state_len() * width;
    let name = ident(&format!("{prefix}_BUFFER_BYTES"));
    let doc = format!(
        " The RAM the delayed horizon's buffer takes, in bytes: {delay} samples of the \
         inputs and their flags, and the output predictor's current state."
    );
    let bytes = Literal::usize_unsuffixed(bytes);
    quote! {
        #[doc = #doc]
        pub const #name: usize = #bytes;
    }
}

/// What the output predictor adds to each public call, at most: `f` once for each
/// buffered sample, a branch each, and the current state stored. Zero without a delay.
pub fn output_predictor_ops(model: &Model, mg: &ModelGraph, scalar: Scalar) -> OpCount {
    let delay = model.delay();
    if delay == 0 {
        return OpCount::default();
    }
    let mut mg = mg.clone();
    let f_ops = model_functions(model, &mut mg)
        .iter()
        .find(|function| function.name == "f")
        .map(|f| emit_function(model, &mg, f, scalar).1)
        .unwrap_or_default();
    let samples = u32::try_from(delay).unwrap_or(u32::MAX);
    f_ops
        .plus(OpCount::branches(1))
        .times(samples)
        .plus(OpCount::stores(model.state_len()))
}

//! The delayed fusion horizon of a filter whose sensors arrive late (`sensor gnss(delay =
//! 38) = [..]`), as PX4's EKF2 runs it: the filter's estimate and covariance describe the
//! state `DELAY` samples ago (the longest delay of its sensors), where a late measurement
//! is fused at the time it describes; a fixed-size buffer holds the inputs since, and an
//! output predictor gives the current state by propagating the delayed estimate through
//! them. A sensor that arrives sooner (`delay` below `DELAY`, or none) waits in a buffer of
//! its own until the horizon reaches the sample it describes, so the horizon fuses every
//! measurement in the order of the samples they describe.
//!
//! A sensor whose delay is given with each measurement (`sensor flow(max_delay = 25) =
//! [..]`, `update_flow(delay, y)`) has a buffer of one slot per sample the horizon lags
//! (`DELAY`), its measurement put in the slot of the sample it describes: a match over the
//! delay picks the slot, so storing costs the same whatever the delay, measurements that
//! arrive out of order are fused in the order of the samples they describe, and the
//! buffer is never full. EKF2 keeps a ring buffer of time-stamped samples instead, sized
//! from the delay and the sensor's rate, and refuses a sample not newer than the newest it
//! holds by its minimum observation interval; here the one refusal of that kind is a
//! second measurement of the sensor for a sample whose slot is taken (the first is kept,
//! and the filter is left as it was). A slot a sample costs a sensor of `m` outputs
//! `DELAY (m + 1)` scalars of RAM and their shift at each prediction; a queue of
//! time-stamped entries would take less RAM at a low rate, but needs a declared capacity,
//! counters decremented at each prediction, and a search (unrolled) for the due entry.
//!
//! EKF2's output predictor is a complementary observer (a few operations a sample,
//! tracking the delayed estimate with a lag); this one is exact: a prediction that fuses
//! nothing moves the current state by one evaluation of `f` with the new input (the
//! horizon and the present move along the same path), and a call that fuses a measurement
//! re-propagates the estimate, not the covariance, through the buffered inputs, `DELAY`
//! evaluations of `f`.

use crate::emit::lower::{literal, OpCount};
use crate::emit::model_fns::{emit_function, model_functions};
use crate::emit::names::ident;
use crate::model::{Model, Scalar, Sensor};
use crate::symbolic::ModelGraph;
use proc_macro2::{Ident, Literal, TokenStream};
use quote::quote;

/// A sensor whose measurements wait for the horizon: its delay is below the horizon's.
pub struct Pending<'a> {
    /// The sensor.
    pub sensor: &'a Sensor,
    /// The predictions its measurement waits for: the horizon's delay less its own.
    pub slots: usize,
}

impl Pending<'_> {
    /// The field of its waiting measurements, oldest first: `pending_magnetometer`.
    pub fn field(&self) -> Ident {
        ident(&format!("pending_{}", self.sensor.name))
    }

    /// The field's type, `[Option<[f32; 3]>; 38]`.
    fn field_type(&self, ty: &Ident) -> TokenStream {
        let m = Literal::usize_unsuffixed(self.sensor.outputs.len());
        let slots = Literal::usize_unsuffixed(self.slots);
        quote! { [Option<[#ty; #m]>; #slots] }
    }

    /// The field's value with no measurement waiting.
    fn empty(&self) -> TokenStream {
        let slots = Literal::usize_unsuffixed(self.slots);
        quote! { [None; #slots] }
    }
}

/// The sample interval's parameter (`dt`), if the model declares one: every prediction
/// reads it (its process noise is `Q dt`), so the buffer holds each sample's interval
/// beside its input.
pub fn buffered_interval(model: &Model) -> Option<Ident> {
    model.interval_parameter().map(|name| ident(&name))
}

/// The sensors of `model` whose measurements wait for the horizon, in declaration order:
/// those of a shorter delay, and those whose delay is given at run time (one slot a sample
/// the horizon lags, a measurement of no delay waiting longest); none without a delay.
pub fn pending(model: &Model) -> Vec<Pending<'_>> {
    let delay = model.delay();
    model
        .sensors
        .iter()
        .filter(|s| s.delay_at_run_time || s.delay < delay)
        .map(|sensor| Pending {
            sensor,
            slots: if sensor.delay_at_run_time {
                delay
            } else {
                delay - sensor.delay
            },
        })
        .collect()
}

/// Why `horizon = current` refuses a model whose sensor `sensor` takes its delay at run
/// time: a filter on the current horizon fuses each measurement as it arrives, so its
/// update would take a delay it does not use, and its calls would not be the delayed
/// filter's, which the comparison needs.
pub fn current_with_run_time_delay(sensor: &str) -> String {
    format!(
        "`horizon = current` fuses late measurements as if they were current, for \
         comparison with the delayed horizon; the sensor `{sensor}` takes each \
         measurement's delay at run time (`max_delay`), which such a filter would ignore: \
         compare with a fixed delay, `sensor {sensor}(delay = N) = [..];`, or drop the \
         option"
    )
}

/// The buffer's fields: the inputs of the last `DELAY` samples (oldest first) with a flag
/// each, set once the sample is buffered, the output predictor's current state, and the
/// waiting measurements of each sensor that arrives sooner than the horizon.
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
    let waiting = pending(model).into_iter().map(|p| {
        let (field, field_type) = (p.field(), p.field_type(ty));
        quote! { #field: #field_type, }
    });
    let intervals = buffered_interval(model).map(|_| quote! { intervals: [#ty; #d], });
    quote! {
        #inputs
        #intervals
        inputs_buffered: [bool; #d],
        current_x: [#ty; #n],
        #(#waiting)*
    }
}

/// The constructor's values of [`fields`]: empty buffers, and the initial estimate `x0`
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
    let waiting = pending(model).into_iter().map(|p| {
        let (field, empty) = (p.field(), p.empty());
        quote! { #field: #empty, }
    });
    let intervals = buffered_interval(model).map(|_| quote! { intervals: [#zero; #d], });
    quote! {
        #inputs
        #intervals
        inputs_buffered: [false; #d],
        current_x: *x0,
        #(#waiting)*
    }
}

/// What `reset` does to the buffers, after setting the estimate: empties them (the
/// horizon starts again at the new estimate, and a measurement of the time before is
/// dropped), the current state the new estimate.
pub fn clear(model: &Model) -> TokenStream {
    let delay = model.delay();
    if delay == 0 {
        return TokenStream::new();
    }
    let d = Literal::usize_unsuffixed(delay);
    let waiting = pending(model).into_iter().map(|p| {
        let (field, empty) = (p.field(), p.empty());
        quote! { self.#field = #empty; }
    });
    quote! {
        self.inputs_buffered = [false; #d];
        self.current_x = self.x;
        #(#waiting)*
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
    let inputs: Vec<Ident> = (0..delay).map(|i| ident(&format!("input_{i}"))).collect();
    let intervals: Vec<Ident> = (0..delay)
        .map(|i| ident(&format!("interval_{i}")))
        .collect();
    let interval = model.dynamics_read_interval();
    let steps: Vec<TokenStream> = (0..delay)
        .map(|i| {
            let b = &flags[i];
            let dt = interval.then(|| {
                let dt = &intervals[i];
                quote! { #dt, }
            });
            let u = (!model.inputs.is_empty()).then(|| {
                let u = &inputs[i];
                quote! { , #u }
            });
            quote! { let x = if #b { f(#dt &x #u #known) } else { x }; }
        })
        .collect();
    let unpack_inputs =
        (!model.inputs.is_empty()).then(|| quote! { let [#(#inputs),*] = &self.inputs; });
    let unpack_intervals = interval.then(|| quote! { let [#(#intervals),*] = self.intervals; });
    let unpack_inputs = quote! { #unpack_inputs #unpack_intervals };
    let n = Literal::usize_unsuffixed(model.state_len());
    let d = Literal::usize_unsuffixed(delay);
    let delay_doc = format!(
        " How many samples the delayed horizon lags the present (`delay = {delay}`, the \
         longest of the sensors' delays): the estimate and covariance describe the state \
         this many samples ago."
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

/// The RAM the buffers take, in bytes (the inputs, their flags, the current state and
/// the waiting measurements), as a constant beside the cost constants:
/// `EKF_BUFFER_BYTES`, the sizes of the fields' types as the target lays them out.
pub fn buffer_bytes(model: &Model, prefix: &str, scalar: Scalar) -> TokenStream {
    let delay = model.delay();
    if delay == 0 {
        return TokenStream::new();
    }
    let ty = ident(scalar.type_name());
    let d = Literal::usize_unsuffixed(delay);
    let n = Literal::usize_unsuffixed(model.state_len());
    let nu = Literal::usize_unsuffixed(model.inputs.len());
    let waiting: Vec<TokenStream> = pending(model)
        .iter()
        .map(|p| {
            let field_type = p.field_type(&ty);
            quote! { + core::mem::size_of::<#field_type>() }
        })
        .collect();
    let intervals =
        buffered_interval(model).map(|_| quote! { + core::mem::size_of::<[#ty; #d]>() });
    let name = ident(&format!("{prefix}_BUFFER_BYTES"));
    let doc = format!(
        " The RAM the delayed horizon's buffers take, in bytes: {delay} samples of the \
         inputs{} and their flags, the output predictor's current state{}.",
        if intervals.is_some() {
            ", their intervals"
        } else {
            ""
        },
        if waiting.is_empty() {
            ""
        } else if model.sensors.iter().any(|s| s.delay_at_run_time) {
            ", and the measurements of the sensors that arrive sooner, waiting for the horizon \
             (a slot a sample for a sensor whose delay is given at run time)"
        } else {
            ", and the measurements of the sensors that arrive sooner, waiting for the horizon"
        }
    );
    quote! {
        #[doc = #doc]
        pub const #name: usize = core::mem::size_of::<[[#ty; #nu]; #d]>()
            + core::mem::size_of::<[bool; #d]>()
            + core::mem::size_of::<[#ty; #n]>()
            #intervals
            #(#waiting)*;
    }
}

/// The arithmetic of a filter's calls: `predict`, `update`, `step` and each sensor's
/// update, in the order of the model's sensors.
pub struct CallOps {
    /// `predict`.
    pub predict: OpCount,
    /// The joint `update`.
    pub update: OpCount,
    /// `step`.
    pub step: OpCount,
    /// `update_<sensor>`, with the method's name.
    pub sensors: Vec<(String, OpCount)>,
}

impl CallOps {
    /// The public calls' arithmetic, at most, from their steps' on the horizon (`self`):
    /// each call that fuses runs the whole output predictor after its step; a prediction
    /// shifts the waiting measurements' slots and fuses, at most, one of each sensor that
    /// arrives sooner; such a
    /// sensor's update only buffers its measurement (one whose delay is given at run time
    /// matches it to its slot first, and at the horizon's delay fuses it at once, the
    /// dearer of the two counted); and with sensors of different delays,
    /// `update` is the sensors' updates in turn, `step` a prediction and then them.
    pub fn on_horizon(self, model: &Model, mg: &ModelGraph, scalar: Scalar) -> CallOps {
        let delay = model.delay();
        if delay == 0 {
            return self;
        }
        let predictor = output_predictor_ops(model, mg, scalar);
        let waiting = pending(model);
        let is_waiting = |name: &str| {
            waiting
                .iter()
                .any(|p| format!("update_{}", p.sensor.name) == name)
        };
        let fused_in_predict = self
            .sensors
            .iter()
            .filter(|(name, _)| is_waiting(name))
            .fold(OpCount::default(), |sum, (_, ops)| sum.plus(*ops));
        // Each waiting sensor's slots shifted by one (its measurement and tag each).
        let shifted = waiting.iter().fold(OpCount::default(), |sum, p| {
            let scalars = p.slots * (p.sensor.outputs.len() + 1);
            sum.plus(OpCount::loads(scalars))
                .plus(OpCount::stores(scalars))
        });
        let predict = (self.predict)
            .plus(fused_in_predict)
            .plus(shifted)
            .plus(predictor);
        let sensors: Vec<(String, OpCount)> = self
            .sensors
            .into_iter()
            .zip(&model.sensors)
            .map(|((name, ops), sensor)| {
                // Read, checked finite, stored with its tag.
                let compare = OpCount {
                    compare: 1,
                    ..OpCount::default()
                };
                let m = sensor.outputs.len();
                let stored = OpCount::loads(m)
                    .plus(OpCount::stores(m + 1))
                    .plus(compare)
                    .plus(OpCount::branches(1));
                let public = if sensor.delay_at_run_time {
                    // The delay matched to its slot (a compare and a jump), the slot's tag
                    // read and tested; or, at the horizon's delay, fused there.
                    let matched = compare
                        .plus(OpCount::branches(2))
                        .plus(OpCount::loads(1))
                        .plus(compare);
                    let at_horizon = (sensor.delay == delay).then(|| ops.plus(predictor));
                    matched.plus(at_horizon.unwrap_or(stored))
                } else if is_waiting(&name) {
                    stored
                } else {
                    ops.plus(predictor)
                };
                (name, public)
            })
            .collect();
        let (update, step) = if waiting.is_empty() {
            (self.update.plus(predictor), self.step.plus(predictor))
        } else {
            let in_turn = sensors
                .iter()
                .fold(OpCount::branches(1), |sum, (_, ops)| sum.plus(*ops));
            (in_turn, predict.plus(in_turn))
        };
        CallOps {
            predict,
            update,
            step,
            sensors,
        }
    }
}

/// What the whole output predictor costs, at most: `f` called once for each buffered
/// sample (its entry and return, its result stored and copied into the running state), a
/// branch each, and the current state stored. Zero without a delay.
fn output_predictor_ops(model: &Model, mg: &ModelGraph, scalar: Scalar) -> OpCount {
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
    let n = model.state_len();
    f_ops
        .plus(OpCount::entries(1))
        .plus(OpCount::loads(n))
        .plus(OpCount::stores(2 * n))
        .plus(OpCount::branches(1))
        .times(samples)
        .plus(OpCount::stores(model.state_len()))
}

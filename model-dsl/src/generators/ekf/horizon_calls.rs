//! The public calls of a filter on the delayed horizon (see [`super::delay`]): each runs
//! its step on the horizon, privately, as `<name>_at_horizon`, and then the output
//! predictor; a prediction first buffers its input, and then fuses the measurements that
//! the horizon has reached; a sensor that arrives sooner than the horizon buffers its
//! measurement; one whose delay is given at run time puts it in the slot of the sample it
//! describes (or fuses it at once at the horizon's delay); with sensors of different
//! delays, the joint update is theirs in turn.

use super::delay::{buffered_interval, pending, Pending};
use crate::emit::arguments::Arguments;
use crate::emit::code::reject_non_finite;
use crate::emit::interval;
use crate::emit::names::ident;
use crate::model::{Model, Scalar, Sensor};
use proc_macro2::{Ident, TokenStream};
use quote::quote;

/// Which public call of the filter a generated step is.
#[derive(Clone, Copy)]
pub enum Call<'a> {
    /// `predict`.
    Predict,
    /// `step`, a prediction and the joint update.
    Step,
    /// The joint `update` (or an output's own).
    Update,
    /// A sensor's update.
    Sensor(&'a Sensor),
}

/// The name of a method's step on the delayed horizon: `update_gnss_at_horizon`.
fn at_horizon(name: &Ident) -> Ident {
    ident(&format!("{name}_at_horizon"))
}

/// The call `name` on the delayed horizon, from its generated step `body`: the step
/// (private, `<name>_at_horizon`; none for a joint update of sensors of different delays,
/// which calls theirs) and the public method.
pub fn wrap(
    call: Call,
    (name, doc): (&Ident, &TokenStream),
    arguments: Arguments,
    body: TokenStream,
    (model, scalar): (&Model, Scalar),
) -> TokenStream {
    let ty = &ident(scalar.type_name());
    let mut params = arguments.params().to_vec();
    let names: Vec<TokenStream> = params
        .iter()
        .filter_map(|p| p.clone().into_iter().next())
        .map(|first| quote! { #first })
        .collect();
    let waiting = pending(model);
    let public = match call {
        Call::Sensor(sensor) if sensor.delay_at_run_time => {
            params.insert(0, quote! { delay: usize });
            slotted_update(sensor, model.delay(), (name, &names), ty)
        }
        Call::Sensor(sensor) if sensor.delay < model.delay() => {
            buffered_update(sensor, model.delay(), ty)
        }
        Call::Predict => prediction(model, &names, &waiting, scalar),
        Call::Update | Call::Step if !waiting.is_empty() => {
            let turn_doc = in_turn_doc(model, matches!(call, Call::Step));
            let body = in_turn(model, &names, matches!(call, Call::Step), ty);
            let delays = run_time_delays(model)
                .into_iter()
                .map(|(_, delay)| quote! { #delay: usize });
            return quote! {
                #[doc = #turn_doc]
                pub fn #name(&mut self, #(#delays,)* #(#params),*) -> Status {
                    #body
                }
            };
        }
        Call::Step => step(model, name, &names, scalar),
        Call::Update | Call::Sensor(_) => {
            let inner = at_horizon(name);
            quote! { let status = self.#inner(#(#names),*); self.predict_output(); status }
        }
    };
    let horizon_doc = horizon_doc(call, model);
    let private_doc = format!(" [`Self::{name}`] on the delayed horizon.");
    let step = arguments.private_method(&at_horizon(name), &quote! { #[doc = #private_doc] }, body);
    quote! {
        #step

        #doc
        ///
        #[doc = #horizon_doc]
        pub fn #name(&mut self, #(#params),*) -> Status {
            #public
        }
    }
}

/// What a public call on the horizon does, for its documentation.
fn horizon_doc(call: Call, model: &Model) -> String {
    match call {
        Call::Sensor(sensor) if sensor.delay_at_run_time => slotted_doc(sensor, model.delay()),
        Call::Sensor(sensor) if sensor.delay < model.delay() => format!(
            " On the delayed horizon: the measurement ({}) waits in a buffer until the \
             horizon reaches the sample it describes, {} predictions from now, and the \
             [`Self::predict`] that fuses it there returns its status; this call only checks \
             it finite and returns [`Status::Ok`]. One measurement of the sensor a sample: a \
             second before the next prediction replaces the first.",
            match sensor.delay {
                0 => "current".to_owned(),
                d => format!("{d} samples late"),
            },
            model.delay() - sensor.delay
        ),
        Call::Predict if !pending(model).is_empty() => " On the delayed horizon: the input is \
             buffered; the estimate and covariance, `DELAY` samples behind, are predicted with \
             the input of `DELAY` samples ago once the buffer is full (a prediction there \
             refused as non-finite leaves that sample out of the horizon: reset the filter); \
             the waiting measurements of the sensors that arrive sooner, which the horizon \
             has now reached, are fused there, in the order the sensors are declared (dropped \
             if the horizon's prediction was refused); the \
             output predictor then brings [`Self::current_state`] to the present. Returns the \
             first status that is not `Ok`: the prediction's, or a fused measurement's."
            .to_owned(),
        Call::Predict | Call::Step => " On the delayed horizon: the input is buffered, and the \
             estimate and covariance, `DELAY` samples behind, are predicted with the input of \
             `DELAY` samples ago once the buffer is full (a prediction there refused as \
             non-finite leaves that sample out of the horizon: reset the filter); the output \
             predictor then brings [`Self::current_state`] to the present."
            .to_owned(),
        Call::Update | Call::Sensor(_) => " On the delayed horizon: the measurement, `DELAY` \
             samples late, is fused at the sample it describes (before the buffer is full, at \
             the start, where the horizon still is); the output predictor then brings \
             [`Self::current_state`] to the present."
            .to_owned(),
    }
}

/// A sensor's update that arrives sooner than the horizon: checks the measurement finite
/// and puts it in the sensor's buffer, where the prediction `slots` samples on fuses it.
fn buffered_update(sensor: &Sensor, delay: usize, ty: &Ident) -> TokenStream {
    let field = Pending {
        sensor,
        slots: delay - sensor.delay,
    }
    .field();
    let entries: Vec<Ident> = (0..sensor.outputs.len())
        .map(|i| ident(&format!("y_{i}")))
        .collect();
    quote! {
        let [#(#entries),*] = *y;
        if !stateforge_math::#ty::all_finite([#(#entries),*]) {
            return Status::RejectedInput;
        }
        let [.., newest] = &mut self.#field;
        *newest = Some(*y);
        Status::Ok
    }
}

/// The sensors whose delay is given at run time, each with the joint update's parameter
/// of it, `gnss_delay`.
fn run_time_delays(model: &Model) -> Vec<(&Sensor, Ident)> {
    model
        .sensors
        .iter()
        .filter(|s| s.delay_at_run_time)
        .map(|s| (s, ident(&format!("{}_delay", s.name))))
        .collect()
}

/// What the update of a sensor whose delay is given at run time does, for its
/// documentation (the horizon `delay` samples behind).
fn slotted_doc(sensor: &Sensor, delay: usize) -> String {
    let at_horizon = if sensor.delay == delay {
        format!(
            " A measurement {delay} samples late describes the horizon's sample: it is fused \
             there at once, the output predictor then bringing [`Self::current_state`] to the \
             present, and this returns its status."
        )
    } else {
        String::new()
    };
    format!(
        " On the delayed horizon, `DELAY` samples behind: `delay` is how many samples \
         (calls of [`Self::predict`]) late this measurement is, from 0 to {max} (`max_delay`); \
         the measurement waits in a buffer of one slot a sample until the horizon reaches \
         the sample it describes, and the [`Self::predict`] that fuses it there returns its \
         status; this call returns [`Status::Ok`] once it is stored. Measurements arriving \
         out of order are fused in the order of the samples they describe.{at_horizon} \
         Refused as [`Status::RejectedInput`], the filter left as it was: a non-finite \
         measurement, a `delay` beyond {max}, and a second measurement of the sensor for a \
         sample one already waits for (the first is kept, as a flight stack refuses a \
         sensor's samples that come faster than its buffer takes them).",
        max = sensor.delay
    )
}

/// The update of a sensor whose delay is given at run time (`delay: usize`, at most the
/// sensor's `max_delay`) on a horizon `delay` samples behind: checks the measurement
/// finite, then a match over the delay picks the slot of the sample it describes (the
/// slot `DELAY - d - 1` from the oldest, which `DELAY - d` predictions bring to the
/// horizon), refusing a delay beyond the maximum and a slot already taken; at the
/// horizon's own delay the measurement is fused at once (`name` on the horizon with
/// `names`, then the output predictor).
fn slotted_update(
    sensor: &Sensor,
    delay: usize,
    (name, names): (&Ident, &[TokenStream]),
    ty: &Ident,
) -> TokenStream {
    let field = Pending {
        sensor,
        slots: delay,
    }
    .field();
    let entries: Vec<Ident> = (0..sensor.outputs.len())
        .map(|i| ident(&format!("y_{i}")))
        .collect();
    let inner = at_horizon(name);
    let arms = (0..=sensor.delay).map(|late| {
        let pattern = proc_macro2::Literal::usize_unsuffixed(late);
        if late == delay {
            return quote! {
                #pattern => {
                    let status = self.#inner(#(#names),*);
                    self.predict_output();
                    return status;
                }
            };
        }
        // The slot `delay - late - 1` from the oldest, written from the nearer end.
        let from_oldest = delay - late - 1;
        let from_newest = late;
        let slot = if from_oldest <= from_newest {
            let before = (0..from_oldest).map(|_| quote! { _ });
            quote! { [#(#before,)* slot, ..] }
        } else {
            let after = (0..from_newest).map(|_| quote! { _ });
            quote! { [.., slot #(, #after)*] }
        };
        quote! {
            #pattern => {
                let #slot = &mut self.#field;
                slot
            }
        }
    });
    quote! {
        let [#(#entries),*] = *y;
        if !stateforge_math::#ty::all_finite([#(#entries),*]) {
            return Status::RejectedInput;
        }
        let slot = match delay {
            #(#arms)*
            _ => return Status::RejectedInput,
        };
        let None = slot else {
            return Status::RejectedInput;
        };
        *slot = Some(*y);
        Status::Ok
    }
}

/// Checks the new input `u_prev` and the sample interval finite and the interval positive
/// ([`interval::guard`]), as a prediction without a horizon checks them, then shifts them
/// into their buffers: binds the oldest sample, `oldest` (its input), `oldest_interval`
/// and `oldest_buffered` (whether it was).
fn buffer_input(model: &Model, scalar: Scalar) -> TokenStream {
    let delay = model.delay();
    let later = |prefix: &str| -> Vec<Ident> {
        (1..delay)
            .map(|i| ident(&format!("{prefix}_{i}")))
            .collect()
    };
    let entries: Vec<Ident> = (0..model.inputs.len())
        .map(|i| ident(&format!("u_prev_{i}")))
        .collect();
    let unpack = (!entries.is_empty()).then(|| quote! { let [#(#entries),*] = *u_prev; });
    let dt = buffered_interval(model);
    let checked: Vec<Ident> = dt.iter().chain(&entries).cloned().collect();
    let finite = reject_non_finite(&checked, &[], &ident(scalar.type_name()));
    let guard = model
        .interval_parameter()
        .map(|parameter| interval::guard(&parameter, scalar));
    let intervals = dt.map(|dt| {
        let later = later("interval");
        quote! {
            let [oldest_interval, #(#later),*] = self.intervals;
            self.intervals = [#(#later,)* #dt];
        }
    });
    let buffered = later("buffered");
    let inputs = (!entries.is_empty()).then(|| {
        let inputs = later("input");
        quote! {
            let [oldest, #(#inputs),*] = self.inputs;
            self.inputs = [#(#inputs,)* *u_prev];
        }
    });
    quote! {
        #unpack
        #finite
        #guard
        #intervals
        let [oldest_buffered, #(#buffered),*] = self.inputs_buffered;
        self.inputs_buffered = [#(#buffered,)* true];
        #inputs
    }
}

/// The arguments of the step on the horizon: the buffer's oldest input for `u_prev`, and
/// its oldest interval for the sample interval's parameter.
fn on_horizon(names: &[TokenStream], model: &Model) -> Vec<TokenStream> {
    let dt = buffered_interval(model).map(|dt| dt.to_string());
    names
        .iter()
        .map(|n| {
            if n.to_string() == "u_prev" {
                quote! { &oldest }
            } else if Some(n.to_string()) == dt {
                quote! { oldest_interval }
            } else {
                n.clone()
            }
        })
        .collect()
}

/// `predict` on the horizon: buffers the input, predicts the horizon once the buffer is
/// full, fuses the waiting measurements the horizon has reached, and moves the current
/// state (one step of `f` when nothing was fused, else the whole output predictor).
fn prediction(
    model: &Model,
    names: &[TokenStream],
    waiting: &[Pending],
    scalar: Scalar,
) -> TokenStream {
    let buffer = buffer_input(model, scalar);
    let inner = at_horizon(&ident("predict"));
    let passed = on_horizon(names, model);
    let mut fused = Vec::new();
    let mut fusions = TokenStream::new();
    for p in waiting {
        let field = p.field();
        let update = at_horizon(&ident(&format!("update_{}", p.sensor.name)));
        let status = ident(&format!("{}_status", p.sensor.name));
        let flag = ident(&format!("fused_{}", p.sensor.name));
        let later: Vec<Ident> = (1..p.slots)
            .map(|i| ident(&format!("waiting_{i}")))
            .collect();
        fusions.extend(quote! {
            let [due, #(#later),*] = self.#field;
            self.#field = [#(#later,)* None];
            let (#flag, #status) = match due {
                Some(y) if status == Status::Ok => (true, self.#update(&y)),
                _ => (false, Status::Ok),
            };
        });
        fused.push((flag, status));
    }
    let known = (!model.known.is_empty()).then(|| quote! { , &self.known });
    let input = (!model.inputs.is_empty()).then(|| quote! { , u_prev });
    let dt = buffered_interval(model)
        .filter(|_| model.dynamics_read_interval())
        .map(|dt| quote! { #dt, });
    let one_step = quote! { self.current_x = f(#dt &self.current_x #input #known); };
    let statuses = first_refusal(&fused.iter().map(|(_, s)| quote! { #s }).collect::<Vec<_>>());
    let flags = fused.iter().map(|(flag, _)| flag);
    quote! {
        #buffer
        let status = if oldest_buffered { self.#inner(#(#passed),*) } else { Status::Ok };
        #fusions
        // The horizon moved as the present did, by `f`, unless a measurement corrected it
        // or its prediction was refused.
        if status == Status::Ok #(&& !#flags)* {
            #one_step
        } else {
            self.predict_output();
        }
        #statuses
    }
}

/// The first status that is not `Ok`: `status`'s, bound before, or one of `later`'s, each
/// evaluated in turn whatever the earlier ones were.
fn first_refusal(later: &[TokenStream]) -> TokenStream {
    let Some((last, earlier)) = later.split_last() else {
        return quote! { status };
    };
    let earlier = earlier.iter().map(|call| {
        quote! {
            let next = #call;
            let status = if status == Status::Ok { next } else { status };
        }
    });
    quote! {
        #(#earlier)*
        let next = #last;
        if status == Status::Ok { next } else { status }
    }
}

/// `step` of sensors of one delay on the horizon: the measurement checked before the
/// input is buffered (a step refused for it leaves the buffer and the horizon as they
/// were), then the step on the horizon, or the correction alone while the horizon has not
/// moved (the buffer still filling, its measurement of the start), then the output
/// predictor.
fn step(model: &Model, name: &Ident, names: &[TokenStream], scalar: Scalar) -> TokenStream {
    let ty = &ident(scalar.type_name());
    let inner = at_horizon(name);
    let update = at_horizon(&ident("update"));
    let passed = on_horizon(names, model);
    let entries: Vec<Ident> = (0..model.outputs.len())
        .map(|i| ident(&format!("y_{i}")))
        .collect();
    let buffer = buffer_input(model, scalar);
    quote! {
        let [#(#entries),*] = *y;
        if !stateforge_math::#ty::all_finite([#(#entries),*]) {
            return Status::RejectedInput;
        }
        #buffer
        let status = if oldest_buffered { self.#inner(#(#passed),*) } else { self.#update(y) };
        self.predict_output();
        status
    }
}

/// The joint update (and, for `step`, the prediction before it) of sensors of different
/// delays: each sensor's update in turn, each at the sample its measurement describes.
fn in_turn(model: &Model, names: &[TokenStream], predicts: bool, ty: &Ident) -> TokenStream {
    let entries: Vec<Ident> = (0..model.outputs.len())
        .map(|i| ident(&format!("y_{i}")))
        .collect();
    let predict_args: Vec<&TokenStream> = names.iter().filter(|n| n.to_string() != "y").collect();
    let updates: Vec<TokenStream> = model
        .sensors
        .iter()
        .map(|sensor| {
            let update = ident(&format!("update_{}", sensor.name));
            let own: Vec<&Ident> = sensor
                .outputs
                .iter()
                .filter_map(|&j| entries.get(j))
                .collect();
            let delay = sensor.delay_at_run_time.then(|| {
                let delay = ident(&format!("{}_delay", sensor.name));
                quote! { #delay, }
            });
            quote! { self.#update(#delay &[#(#own),*]) }
        })
        .collect();
    let (first, later) = if predicts {
        (quote! { self.predict(#(#predict_args),*) }, &updates[..])
    } else {
        match updates.split_first() {
            Some((first, later)) => (first.clone(), later),
            None => (quote! { Status::Ok }, &updates[..]),
        }
    };
    let later = first_refusal(later);
    quote! {
        let [#(#entries),*] = *y;
        if !stateforge_math::#ty::all_finite([#(#entries),*]) {
            return Status::RejectedInput;
        }
        let status = #first;
        #later
    }
}

/// What the joint update (or step) of sensors of different delays does.
fn in_turn_doc(model: &Model, predicts: bool) -> String {
    let updates: Vec<String> = model
        .sensors
        .iter()
        .map(|s| format!("[`Self::update_{}`]", s.name))
        .collect();
    let (sensors, delays): (Vec<String>, Vec<String>) = run_time_delays(model)
        .iter()
        .map(|(sensor, delay)| (format!("`{}`", sensor.name), format!("`{delay}`")))
        .unzip();
    let delays = match delays.len() {
        0 => String::new(),
        1 => format!(
            " {} is the delay of {}'s measurement, in samples, as its update takes it.",
            delays.join(""),
            sensors.join("")
        ),
        _ => format!(
            " {} are the delays of the measurements of {}, in samples, as their updates \
             take them.",
            crate::diagnostics::phrase(&delays, "and"),
            crate::diagnostics::phrase(&sensors, "and")
        ),
    };
    format!(
        " On the delayed horizon, whose sensors arrive with different delays: {}{}, each \
         measurement at the sample it describes.{delays} A non-finite measurement is refused \
         before anything is done; otherwise each call is applied or refused on its own, and \
         this returns the first status that is not `Ok`. Each sensor stores its own \
         innovation and is judged by its own gate (or the filter's); the joint innovation \
         ([`Self::innovation`]) is not stored.",
        if predicts {
            "[`Self::predict`], then "
        } else {
            ""
        },
        crate::diagnostics::phrase(&updates, "then")
    )
}

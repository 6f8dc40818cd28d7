//! The double Kalman filter (Alg. 2): the window transform derived from the model
//! ([`crate::generators::dkf::window`]), a linear Kalman filter on the transformed model (AKF),
//! and a Kalman filter linearised about the AKF's estimate (LKF).
//!
//! This file assembles the generated `Dkf` type; the transform's method is lowered in
//! [`super::transform`], the two filters' in [`super::filters`].

use super::filters::{step_fn, Filter};
use super::spec::DkfSpec;
use super::transform::transform_fn;
use super::window::WindowTransform;
use crate::emit::arguments::{Arguments, REJECTS_NON_FINITE};
use crate::emit::code::{destructure, unpack_symmetric, var_idents};
use crate::emit::filter::{model_names, noise_argument};
use crate::emit::lower::{literal, Lowered, Lowerer, OpCount};
use crate::emit::measurement;
use crate::emit::names::{ident, TempNamer};
use crate::model::{Model, Scalar};
use crate::symbolic::linalg::packed_len;
use crate::symbolic::{Graph, ModelGraph, NodeId, VarId};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::{quote, ToTokens};

/// Generated DKF code and its cost.
pub struct DkfCode {
    /// `WindowStatus`, `DkfStatus`, the window constants and the `Dkf` type.
    pub tokens: TokenStream,
    /// Arithmetic of the window transform (the full solve, the costliest branch).
    pub transform_ops: OpCount,
    /// Arithmetic of the two filters' step, after the transform.
    pub filters_ops: OpCount,
}

/// The DKF of `model` in `scalar` from its window transform `wt`, derived (once, by the
/// generator's design) in the graph `g`, of which this takes a copy to lower into.
pub fn emit_dkf(
    model: &Model,
    spec: &DkfSpec,
    (g, wt): (&ModelGraph, &WindowTransform),
    scalar: Scalar,
) -> DkfCode {
    let mut g = g.clone();
    let (transform, transform_ops) = transform_fn(model, &g, wt, scalar);
    let filters = step_fn(model, &mut g, wt, scalar, spec);
    let push = push_fn(model, &g, wt, scalar);
    let ltv = ltv_fn(model, &g, wt, scalar);
    // The design aid of every window, the minimum's included.
    let noise_gain = super::window_noise::noise_gain_at_zero(&mut g.graph, wt);
    let dkf = DkfType::new(model, spec, wt, scalar, noise_gain);
    let declaration = dkf.declaration(model, wt);
    let constructor = dkf.constructor_tokens(model);
    let estimates = dkf.estimate_accessors();
    let measurement = dkf.measurement_methods(model);
    let window_accessors = dkf.window_accessors(model);
    let setters = dkf.setter_tokens();
    let step = dkf.step_method(model, &filters.step);
    let predict = dkf.predict_method(model, &filters.predict);
    let (stages, filters_ops) = (filters.methods, filters.ops);
    let status_types = status_types();
    let window_constants = dkf.window_constants();
    let tokens = quote! {
        #declaration

        impl Dkf {
            #constructor
            #estimates
            #measurement
            #window_accessors
            #setters
            #step
            #predict
            #stages
            #transform
            #push
        }

        #status_types

        #ltv

        #window_constants
    };
    DkfCode {
        tokens,
        transform_ops,
        filters_ops,
    }
}

/// The generated `Dkf` type's element type and sizes, which its items share.
struct DkfType {
    scalar: Scalar,
    ty: Ident,
    /// States and parameters.
    n: usize,
    /// Outputs.
    m: usize,
    /// Parameters.
    np: usize,
    /// Inputs.
    nu: usize,
    diagonal_noise: bool,
    /// The innovation gate, if any.
    gate: Option<f64>,
    /// Refusals in a row after which a filter recovers (`recover_after`), if it does.
    recover_after: Option<u32>,
    /// Outputs the window holds, the latest included.
    window_outputs: usize,
    /// Outputs the paper's minimum window holds (the fewest that determine the
    /// parameters).
    minimum_window: usize,
    /// Past inputs the window holds.
    window_inputs: usize,
    /// Whether the window is solved by least squares, with a parameter covariance.
    least_squares: bool,
    /// A least-squares window's noise gain of its equations at zero parameters, if a
    /// number.
    noise_gain: Option<f64>,
}

impl DkfType {
    fn new(
        model: &Model,
        spec: &DkfSpec,
        wt: &WindowTransform,
        scalar: Scalar,
        noise_gain: Option<f64>,
    ) -> DkfType {
        DkfType {
            scalar,
            ty: ident(scalar.type_name()),
            n: model.state_len(),
            m: model.outputs.len(),
            np: model.params.len(),
            nu: model.inputs.len(),
            diagonal_noise: spec.diagonal_noise,
            gate: spec.gate,
            recover_after: spec.recover_after,
            window_outputs: wt.output_delays + 1,
            minimum_window: wt.minimum_window,
            window_inputs: wt.input_delays,
            least_squares: wt.least_squares(),
            noise_gain,
        }
    }

    /// The packed parameter covariance's field type and initial value (zero: the
    /// parameters of `x0` are taken as exact until a window is solved), for a
    /// least-squares window; nothing otherwise.
    fn covariance_field(&self) -> Option<(TokenStream, TokenStream)> {
        let ty = &self.ty;
        let zero = literal(0.0, self.scalar);
        let len = Literal::usize_unsuffixed(self.np * (self.np + 1) / 2);
        self.least_squares
            .then(|| (quote! { [#ty; #len] }, quote! { [#zero; #len] }))
    }

    /// What both filters' recovery adds ([`crate::emit::recovery`]): the LKF inflates `P`,
    /// the AKF `Pbar`.
    fn recovery(&self) -> crate::emit::recovery::RecoveryItems {
        use crate::emit::recovery::{items, Recovery};
        let stage = |prefix, covariance, what| Recovery {
            prefix,
            covariance,
            what,
        };
        let stages = [
            stage(Filter::Lkf.prefix(), "p", "the LKF"),
            stage(Filter::Akf.prefix(), "pbar", "the AKF"),
        ];
        items(self.recover_after, &stages, self.scalar)
    }

    /// The constructor argument, field type and stored value of the process noise `name`.
    fn noise(&self, name: &str) -> (TokenStream, TokenStream, TokenStream) {
        noise_argument(name, self.n, self.diagonal_noise, &self.ty)
    }

    /// The documented `struct Dkf`: the window's history and last solved parameters, and
    /// each filter's estimate, covariance and noise.
    fn declaration(&self, model: &Model, wt: &WindowTransform) -> TokenStream {
        let ty = &self.ty;
        let lit = Literal::usize_unsuffixed;
        let (n_len, p_len) = (lit(self.n), lit(self.np));
        let (nn, mm) = (lit(packed_len(self.n)), lit(packed_len(self.m)));
        let outputs_len = lit(self.m * self.window_outputs);
        let inputs_len = lit(self.nu * self.window_inputs);
        let window_outputs_lit = lit(self.window_outputs);
        let (_, q_field, _) = self.noise("q");
        let (_, qbar_field, _) = self.noise("qbar");
        let derivation: Vec<String> = wt.description.iter().map(|l| format!(" - {l}")).collect();
        let innovations = [
            measurement::innovation_fields(model, Filter::Lkf.prefix(), ty),
            measurement::innovation_fields(model, Filter::Akf.prefix(), ty),
        ];
        let gate_field = measurement::gate_field(self.gate, ty);
        let recovery_fields = self.recovery().fields;
        let gate_doc = measurement::gate_doc_attribute(self.gate);
        let covariance_field = self
            .covariance_field()
            .map(|(ty, _)| quote! { phi_covariance: #ty, });
        quote! {
            /// Double Kalman filter (Alg. 2) of this model.
            ///
            /// Stage one, the window transform derived from the model:
            #(#[doc = #derivation])*
            ///
            /// Stage two: a linear Kalman filter (AKF) on `x[k+1] = F x[k] + G u[k] + d`, with
            /// its own covariance and process noise, then a Kalman filter (LKF) on `f`
            /// linearised about the AKF's estimate. Until the window is full the transform is
            /// taken about the AKF's own estimate. A window whose excitation is below the
            /// threshold keeps the last solved parameters (Case 1); an input that is zero over
            /// the window freezes the parameters it multiplies (Case 2).
            /// Each filter keeps the innovation of the last measurement.
            #gate_doc
            #[derive(Clone, Copy, Debug, PartialEq)]
            pub struct Dkf {
                outputs: [#ty; #outputs_len],
                inputs: [#ty; #inputs_len],
                filled: [bool; #window_outputs_lit],
                phi_params: [#ty; #p_len],
                #covariance_field
                window_det_sq: #ty,
                window_column_norms: #ty,
                min_excitation_sq: #ty,
                xbar: [#ty; #n_len],
                pbar: [#ty; #nn],
                qbar: #qbar_field,
                x: [#ty; #n_len],
                p: [#ty; #nn],
                q: #q_field,
                r: [#ty; #mm],
                #(#innovations)*
                #gate_field
                #recovery_fields
            }
        }
    }

    /// `DEFAULT_MIN_EXCITATION`, `new` (both filters start from `x0`, the window empty,
    /// the parameters those of `x0`; every entry read checked finite) and
    /// `set_min_excitation` (Case 1's threshold).
    fn constructor_tokens(&self, model: &Model) -> TokenStream {
        let ty = &self.ty;
        let lit = Literal::usize_unsuffixed;
        let outputs_len = lit(self.m * self.window_outputs);
        let inputs_len = lit(self.nu * self.window_inputs);
        let window_outputs_lit = lit(self.window_outputs);
        let zero = literal(0.0, self.scalar);
        let default_excitation = literal(
            match self.scalar {
                Scalar::F32 => 1e-6,
                Scalar::F64 => 1e-9,
            },
            self.scalar,
        );
        let mut arguments = Arguments::default();
        let x0 = arguments.vector("x0", self.n, ty);
        let p0 = arguments.covariance("p0", self.n, ty);
        let q = arguments.process_noise("q", self.n, self.diagonal_noise, ty);
        let pbar0 = arguments.covariance("pbar0", self.n, ty);
        let qbar = arguments.process_noise("qbar", self.n, self.diagonal_noise, ty);
        let r = arguments.covariance("r", self.m, ty);
        // The parameters come last in the state vector.
        let params = &x0[model.states.len()..];
        let new_doc = self.new_doc();
        let innovations = [
            measurement::cleared_values(model, Filter::Lkf.prefix(), self.scalar),
            measurement::cleared_values(model, Filter::Akf.prefix(), self.scalar),
        ];
        let gate = measurement::gate_initial_value(self.gate, self.scalar);
        let recovery = self.recovery().initial;
        let covariance_value = self
            .covariance_field()
            .map(|(_, zero)| quote! { phi_covariance: #zero, });
        let new = arguments.constructor(
            &quote! { #[doc = #new_doc] },
            REJECTS_NON_FINITE,
            quote! {
                Ok(Dkf {
                    outputs: [#zero; #outputs_len],
                    inputs: [#zero; #inputs_len],
                    filled: [false; #window_outputs_lit],
                    phi_params: [#(#params),*],
                    #covariance_value
                    window_det_sq: #zero,
                    window_column_norms: #zero,
                    min_excitation_sq: Self::DEFAULT_MIN_EXCITATION
                        * Self::DEFAULT_MIN_EXCITATION,
                    xbar: *x0,
                    pbar: #pbar0,
                    qbar: #qbar,
                    x: *x0,
                    p: #p0,
                    q: #q,
                    r: #r,
                    #(#innovations)*
                    #gate
                    #recovery
                })
            },
        );
        quote! {
            /// Default threshold of the window's excitation measure (Case 1).
            pub const DEFAULT_MIN_EXCITATION: #ty = #default_excitation;

            #new

            /// Sets the excitation threshold (Case 1, [`Dkf::DEFAULT_MIN_EXCITATION`] until
            /// set): windows whose excitation measure is not above it keep the last solved
            /// parameters. Rejects a negative or non-finite threshold with
            /// [`Status::RejectedInput`], leaving the filter unchanged.
            pub fn set_min_excitation(&mut self, min_excitation: #ty) -> Status {
                if !(min_excitation >= #zero && min_excitation.is_finite()) {
                    return Status::RejectedInput;
                }
                self.min_excitation_sq = min_excitation * min_excitation;
                Status::Ok
            }
        }
    }

    /// `new`'s documentation, which says how the process noise is given.
    fn new_doc(&self) -> &'static str {
        if self.diagonal_noise {
            " A filter starting from `x0` for both stages, with the LKF's covariance `p0` and \
             process noise variances `q` (diagonal), the AKF's `pbar0` and `qbar`, and the \
             measurement noise `r`. Each must be a covariance (checked symmetric, positive \
             semi-definite)."
        } else {
            " A filter starting from `x0` for both stages, with the LKF's covariance `p0` and \
             process noise `q`, the AKF's `pbar0` and `qbar`, and the measurement noise `r`. \
             Each must be a covariance (checked symmetric, positive semi-definite)."
        }
    }

    /// Each filter's estimate and covariance.
    fn estimate_accessors(&self) -> TokenStream {
        let ty = &self.ty;
        let n_len = Literal::usize_unsuffixed(self.n);
        let (unpack_p, unpack_pbar) = (unpack_symmetric("p", ty), unpack_symmetric("pbar", ty));
        quote! {
            /// The DKF's estimate (the LKF's): physical states, then parameters.
            #[must_use]
            pub fn state(&self) -> [#ty; #n_len] {
                self.x
            }

            /// The AKF's estimate.
            #[must_use]
            pub fn akf_state(&self) -> [#ty; #n_len] {
                self.xbar
            }

            /// The LKF's covariance.
            #[must_use]
            pub fn covariance(&self) -> [[#ty; #n_len]; #n_len] {
                #unpack_p
            }

            /// The AKF's covariance.
            #[must_use]
            pub fn akf_covariance(&self) -> [[#ty; #n_len]; #n_len] {
                #unpack_pbar
            }
        }
    }

    /// `reset`, each filter's innovation and NIS, and the gate's getter and setter when
    /// there is one.
    fn measurement_methods(&self, model: &Model) -> TokenStream {
        let ty = &self.ty;
        let zero = literal(0.0, self.scalar);
        let outputs_len = Literal::usize_unsuffixed(self.m * self.window_outputs);
        let inputs_len = Literal::usize_unsuffixed(self.nu * self.window_inputs);
        let mut arguments = Arguments::default();
        let x0 = arguments.vector("x0", self.n, ty);
        let p0 = arguments.covariance("p0", self.n, ty);
        let pbar0 = arguments.covariance("pbar0", self.n, ty);
        let params = &x0[model.states.len()..];
        let clear = [
            measurement::clear_innovation(model, Filter::Lkf.prefix(), self.scalar),
            measurement::clear_innovation(model, Filter::Akf.prefix(), self.scalar),
        ];
        let recovery = self.recovery();
        let (recovery_clear, recovery_methods) = (&recovery.clear, &recovery.methods);
        let covariance_reset = self
            .covariance_field()
            .map(|(_, zero)| quote! { self.phi_covariance = #zero; });
        let reset = arguments.method(
            &ident("reset"),
            &quote! {
                /// Starts both filters again from the estimate `x0`, the LKF with the
                /// covariance `p0` and the AKF with `pbar0`, keeping the noise covariances,
                /// the gate and the excitation threshold: the way back after a fault (a run of
                /// [`Status::Diverged`], [`Status::NonFinite`] or rejected outliers) or a
                /// restart of the plant. The window is emptied (it refills), the
                /// parameters are those of `x0`, and the innovations are cleared. Rejects
                /// a non-finite entry with [`Status::RejectedInput`] and a covariance that
                /// is not symmetric and positive semi-definite with
                /// [`Status::InvalidCovariance`], leaving the filter unchanged.
            },
            quote! {
                self.x = *x0;
                self.p = #p0;
                self.xbar = *x0;
                self.pbar = #pbar0;
                self.outputs = [#zero; #outputs_len];
                self.inputs = [#zero; #inputs_len];
                self.filled = [false; WINDOW_OUTPUTS];
                self.phi_params = [#(#params),*];
                #covariance_reset
                self.window_det_sq = #zero;
                self.window_column_norms = #zero;
                #(#clear)*
                #recovery_clear
                Status::Ok
            },
        );
        let accessors = [
            measurement::accessors(model, Filter::Lkf.prefix(), self.scalar),
            measurement::accessors(model, Filter::Akf.prefix(), self.scalar),
        ];
        let gate = self
            .gate
            .map(|gate| measurement::gate_items(gate, self.scalar));
        quote! {
            #reset
            #(#accessors)*
            #gate
            #recovery_methods
        }
    }

    /// `window_equation_noise()`, the design aid `WINDOW_NOISE_GAIN` at the declared
    /// measurement noise (the largest output variance of `r`); nothing when the gain is
    /// not a number.
    fn equation_noise_method(&self) -> Option<TokenStream> {
        self.noise_gain.filter(|gain| gain.is_finite())?;
        let ty = &self.ty;
        let sqrt = crate::emit::names::math_fn(self.scalar, "sqrt");
        let variances: Vec<Ident> = (0..self.m).map(|i| ident(&format!("r{i}"))).collect();
        // `self.r` destructured: its variances named, the covariances `_`.
        let pattern = (0..packed_len(self.m)).map(|k| {
            match (0..self.m).find(|&i| crate::symbolic::linalg::packed_index(self.m, i, i) == k) {
                Some(i) => variances[i].to_token_stream(),
                None => quote! { _ },
            }
        });
        let largest = variances[1..].iter().map(|r| {
            quote! { let variance = if #r > variance { #r } else { variance }; }
        });
        let first = &variances[0];
        let params = Literal::usize_unsuffixed(self.np);
        let minimum_window = Literal::usize_unsuffixed(self.minimum_window);
        Some(quote! {
            /// A design aid at the declared measurement noise: the standard deviation of
            /// one window equation's error, `WINDOW_NOISE_GAIN * sqrt(R)` with `R` the
            /// largest output variance of `r`, in the scale the model's step writes the
            /// equation. Compare it with the equation's terms at the excitation (see
            /// `WINDOW_NOISE_GAIN`).
            #[must_use]
            pub fn window_equation_noise(&self) -> #ty {
                let [#(#pattern),*] = self.r;
                let variance = #first;
                #(#largest)*
                WINDOW_NOISE_GAIN * #sqrt(variance)
            }
            /// A design aid naming the window to use at the declared measurement noise:
            /// the least-squares window length (`dkf(window = N)`) at which
            /// [`Dkf::window_equation_noise`], averaged over the window's equations as if
            /// they were independent, is a tenth of `equation_terms`, the size of the
            /// equation's terms at the excitation (a rule of thumb: check it with a
            /// simulation). `None` when `equation_terms` is not positive and finite, or
            /// the window would need more than 100 000 equations.
            #[must_use]
            pub fn window_len_for(&self, equation_terms: #ty) -> Option<usize> {
                /// The parameters the window solves.
                const PARAMS: usize = #params;
                /// Outputs of the minimum window, which solves them from `PARAMS`
                /// equations.
                const MINIMUM_WINDOW: usize = #minimum_window;
                stateforge_math::#ty::window_len_for(
                    self.window_equation_noise(),
                    equation_terms,
                    MINIMUM_WINDOW,
                    PARAMS,
                )
            }
        })
    }

    /// What the window says: the last solved parameters, the excitation measure, and the
    /// reconstruction from the window as it stands.
    fn window_accessors(&self, model: &Model) -> TokenStream {
        let ty = &self.ty;
        let lit = Literal::usize_unsuffixed;
        let (n_len, p_len, u_len) = (lit(self.n), lit(self.np), lit(self.nu));
        let zero = literal(0.0, self.scalar);
        let sqrt = crate::emit::names::math_fn(self.scalar, "sqrt");
        let has_u = !model.inputs.is_empty();
        let u_param_plain = has_u.then(|| quote! { u: &[#ty; #u_len] });
        let u_arg_plain = has_u.then(|| quote! { u });
        let covariance_accessor = self.least_squares.then(|| {
            let unpack = crate::emit::code::unpack_symmetric("phi_covariance", &self.ty);
            quote! {
                /// The covariance `C` of the parameters the last solved window gave (zero
                /// until one is): the measurement noise `r` carried to first order through
                /// the window's finite differences and its least-squares solve,
                /// `C = M^-1 (sum_s r w_s w_s') M^-1` with `M = A' A` and `w_s` the normal
                /// equations' sensitivity to output sample `s` (neighbouring equations
                /// share samples, and this keeps their correlation). The AKF adds `J C J'`
                /// to its process noise, `J` the derivative of its model's prediction with
                /// respect to the parameters. Its diagonal's square roots are the
                /// parameters' standard deviations, for small noise (at larger noise a
                /// noisy regressor's parameter scatters more than first order says): a
                /// simulated run of the nominal excitation with them chooses the window's
                /// length and the sample time.
                #[must_use]
                pub fn window_parameter_covariance(&self) -> [[#ty; #p_len]; #p_len] {
                    #unpack
                }
            }
        });
        let equation_noise = self.equation_noise_method();
        quote! {
            #equation_noise

            /// The parameters the last well-excited window gave (or those of `x0`).
            #[must_use]
            pub fn window_parameters(&self) -> [#ty; #p_len] {
                self.phi_params
            }

            /// The last window's excitation measure, `|det| / prod |column|` of its
            /// parameter system, in `0..=1` (0 while the window fills). An application can
            /// pause adaptation while it is low.
            #[must_use]
            pub fn excitation(&self) -> #ty {
                // Stored as its two squared terms: the step itself never divides them.
                if self.window_column_norms > #zero {
                    #sqrt(self.window_det_sq / self.window_column_norms)
                } else {
                    #zero
                }
            }

            #covariance_accessor

            /// What the window holds now says of the state: `phi` (states, then
            /// parameters) reconstructed from the window that ends at the latest
            /// measurement, with `u` the input applied from then on, and the window's status.
            #[must_use]
            pub fn window_estimate(&self, #u_param_plain) -> ([#ty; #n_len], WindowStatus) {
                let (phi, window, ..) = self.transform(#u_arg_plain);
                (phi, window)
            }
        }
    }

    /// Run-time tuning: the LKF's `q`, the AKF's `qbar`, the shared `r`.
    fn setter_tokens(&self) -> TokenStream {
        let tuning = |method, field| {
            crate::emit::tuning::process_noise_setter(
                method,
                field,
                (self.n, ""),
                self.diagonal_noise,
                &self.ty,
            )
        };
        let (set_q, set_qbar) = (
            tuning("set_process_noise", "q"),
            tuning("set_akf_process_noise", "qbar"),
        );
        let set_r = crate::emit::tuning::measurement_noise_setter(self.m, &self.ty);
        quote! { #set_q #set_qbar #set_r }
    }

    /// The documented `step`, around `body` (from [`step_fn`]).
    fn step_method(&self, model: &Model, body: &TokenStream) -> TokenStream {
        let ty = &self.ty;
        let (u_len, m_len) = (
            Literal::usize_unsuffixed(self.nu),
            Literal::usize_unsuffixed(self.m),
        );
        let u_param = (!model.inputs.is_empty()).then(|| quote! { u_prev: &[#ty; #u_len], });
        let step_doc = format!(
            " One sample (Algorithm 2 of the double Kalman filter paper): runs the LKF linearised about the AKF's previous estimate \
             with the input `u[k-1]`, builds `F`, `G`, `d` from the window ending at the \
             previous sample and the same input, runs the AKF on them, each filter corrected \
             with `y[k]`; then pushes `y[k]` and `u[k-1]` into the window. A measurement \
             either filter refuses (beyond its innovation gate, or its divergence bound) \
             does not enter the window, which is emptied and refills. Cost: \
             [`DKF_TRANSFORM_OPS`] plus [`DKF_FILTERS_OPS`]{}.",
            if model.scalars.first() == Some(&self.scalar) {
                ""
            } else {
                " (parent module)"
            }
        );
        quote! {
            #[doc = #step_doc]
            pub fn step(&mut self, #u_param y: &[#ty; #m_len]) -> DkfStatus {
                #body
            }
        }
    }

    /// The documented `predict`, around `body` (from [`step_fn`]).
    fn predict_method(&self, model: &Model, body: &TokenStream) -> TokenStream {
        let ty = &self.ty;
        let u_len = Literal::usize_unsuffixed(self.nu);
        let u_param = (!model.inputs.is_empty()).then(|| quote! { u_prev: &[#ty; #u_len] });
        quote! {
            /// A sample without its measurement (a slower sensor's, or one known bad):
            /// both filters predict as [`Dkf::step`] does, the AKF on the window ending at
            /// the previous sample, and neither is corrected. The window is emptied (it
            /// refills): the sample is missing from its sequence. Rejects a non-finite
            /// input with [`Status::RejectedInput`], leaving both filters as they were.
            pub fn predict(&mut self, #u_param) -> DkfStatus {
                #body
            }
        }
    }

    /// `WINDOW_OUTPUTS` and `WINDOW_INPUTS`.
    fn window_constants(&self) -> TokenStream {
        let window_outputs_lit = Literal::usize_unsuffixed(self.window_outputs);
        let window_inputs_lit = Literal::usize_unsuffixed(self.window_inputs);
        let ty = &self.ty;
        let noise_gain = self.noise_gain.filter(|gain| gain.is_finite()).map(|gain| {
            let value = literal(gain, self.scalar);
            quote! {
                /// A design aid of the window: the standard deviation of one equation's
                /// error (eq. 8, in the scale the model's step writes it) per unit standard
                /// deviation of the measurement noise, from the window's finite
                /// differences alone (at zero parameters): how much the differences
                /// amplify noise, which a shorter sample time raises.
                /// [`Dkf::window_equation_noise`] gives it at the declared noise `R`. The
                /// minimum window solves the parameters from as many equations as there
                /// are parameters: where that noise is not small against the equation's
                /// terms at the excitation, its parameters are noise (and the AKF, which
                /// takes them as exact, refuses the measurements that disagree), and a
                /// least-squares window (`dkf(window = N)`) averages it over its
                /// equations: [`Dkf::window_len_for`] names the length to choose (the language
                /// reference's "How much noise a window takes").
                pub const WINDOW_NOISE_GAIN: #ty = #value;
            }
        });
        quote! {
            /// Outputs the DKF's window holds, the latest included.
            pub const WINDOW_OUTPUTS: usize = #window_outputs_lit;
            /// Past inputs the DKF's window holds.
            pub const WINDOW_INPUTS: usize = #window_inputs_lit;
            #noise_gain
        }
    }
}

/// `WindowStatus` and `DkfStatus`: what a step's window transform and filters did.
fn status_types() -> TokenStream {
    quote! {
        /// How the window transform went in a DKF step.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum WindowStatus {
            /// The step was rejected before the window was read.
            Skipped,
            /// Too few samples yet: the transform was taken about the AKF's own estimate.
            Filling,
            /// The window determined every parameter.
            Solved,
            /// An input was zero over the window: the parameters it multiplies kept their
            /// last values and the others were solved from the reduced system (Case 2).
            InputFree,
            /// The window's excitation was below the threshold: the last solved parameters
            /// were kept (Case 1).
            Degenerate,
        }

        /// Outcome of [`Dkf::step`]: the window's, and each filter stage's.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        #[must_use = "a filter stage that did not return `Status::Ok` did not take the measurement"]
        pub struct DkfStatus {
            /// What the window transform did.
            pub window: WindowStatus,
            /// What the AKF did: on [`Status::OutlierRejected`] it kept its prediction, on
            /// anything else but [`Status::Ok`] its estimate and covariance are unchanged.
            /// Each filter judges the measurement by its own innovation covariance, so one
            /// may take a measurement the other rejects.
            pub akf: Status,
            /// What the LKF (the DKF's estimate) did; likewise.
            pub lkf: Status,
        }

        impl DkfStatus {
            /// Whether both filter stages were applied.
            #[must_use]
            pub fn is_ok(&self) -> bool {
                self.akf == Status::Ok && self.lkf == Status::Ok
            }
        }
    }
}

/// `fn push(&mut self, u, y)`: shifts the latest output and input into the window.
fn push_fn(model: &Model, g: &ModelGraph, wt: &WindowTransform, scalar: Scalar) -> TokenStream {
    let shift = |vars: &[Vec<NodeId>], new: &[Ident]| {
        let mut keep_pattern = Vec::new();
        let mut rebuilt = Vec::new();
        for (row, new) in vars.iter().zip(new) {
            let names = var_idents(&g.graph, row);
            rebuilt.push(quote! { #new });
            for (d, name) in names.iter().enumerate() {
                if d + 1 < names.len() {
                    keep_pattern.push(quote! { #name });
                    rebuilt.push(quote! { #name });
                } else {
                    keep_pattern.push(quote! { _ });
                }
            }
        }
        (keep_pattern, rebuilt)
    };
    let y_new: Vec<Ident> = model
        .outputs
        .iter()
        .map(|o| ident(&format!("{}_new", o.name)))
        .collect();
    let u_new: Vec<Ident> = model
        .inputs
        .iter()
        .map(|i| ident(&format!("{}_new", i.name)))
        .collect();
    let (y_keep, y_rebuilt) = shift(&wt.outputs, &y_new);
    let (u_keep, u_rebuilt) = shift(&wt.inputs, &u_new);
    let filled: Vec<Ident> = (0..=wt.output_delays)
        .map(|d| ident(&format!("f{d}")))
        .collect();
    let filled_keep: Vec<TokenStream> = filled
        .iter()
        .enumerate()
        .map(|(d, f)| {
            if d < wt.output_delays {
                quote! { #f }
            } else {
                quote! { _ }
            }
        })
        .collect();
    let filled_new = &filled[..wt.output_delays];
    let ty = ident(scalar.type_name());
    let (u_len, y_len) = (
        Literal::usize_unsuffixed(model.inputs.len()),
        Literal::usize_unsuffixed(model.outputs.len()),
    );
    let has_inputs = !model.inputs.is_empty() && wt.input_delays > 0;
    let u_param = (!model.inputs.is_empty()).then(|| {
        let name = if has_inputs { ident("u") } else { ident("_u") };
        quote! { #name: &[#ty; #u_len], }
    });
    let inputs = has_inputs.then(|| {
        quote! {
            let [#(#u_new),*] = *u;
            let [#(#u_keep),*] = self.inputs;
            self.inputs = [#(#u_rebuilt),*];
        }
    });
    quote! {
        /// Shifts `y[k]` and `u[k-1]` into the window, dropping the oldest.
        fn push(&mut self, #u_param y: &[#ty; #y_len]) {
            let [#(#y_new),*] = *y;
            let [#(#y_keep),*] = self.outputs;
            self.outputs = [#(#y_rebuilt),*];
            #inputs
            let [#(#filled_keep),*] = self.filled;
            self.filled = [true, #(#filled_new),*];
        }
    }
}

/// `pub fn ltv_model(phi, u) -> (F, G, d)`: eq. (12) at a reconstructed point.
fn ltv_fn(model: &Model, mg: &ModelGraph, wt: &WindowTransform, scalar: Scalar) -> TokenStream {
    let n = model.state_len();
    let nu = model.inputs.len();
    let roots: Vec<NodeId> =
        wt.f.iter()
            .flatten()
            .chain(wt.g.iter().flatten())
            .chain(&wt.d)
            .copied()
            .collect();
    let avoid = model_names(model);
    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(&mg.graph, scalar, namer, &roots);
    let values = lowerer.segment(&roots);
    let Lowered {
        statements,
        used_vars,
        ..
    } = lowerer.finish();
    let (f_values, rest) = values.split_at(n * n);
    let (g_values, d_values) = rest.split_at(n * nu);
    let f_rows = f_values.chunks(n).map(|row| quote! { [#(#row),*] });
    let g_rows: Vec<TokenStream> = if nu == 0 {
        (0..n).map(|_| quote! { [] }).collect()
    } else {
        g_values
            .chunks(nu)
            .map(|row| quote! { [#(#row),*] })
            .collect()
    };
    let ty = ident(scalar.type_name());
    let (n_len, u_len) = (Literal::usize_unsuffixed(n), Literal::usize_unsuffixed(nu));
    let phi_name = if wt.phi.iter().any(|&v| reads(&mg.graph, v, &used_vars)) {
        ident("phi")
    } else {
        ident("_phi")
    };
    let u_name = if mg.u.iter().any(|&v| reads(&mg.graph, v, &used_vars)) {
        ident("u")
    } else {
        ident("_u")
    };
    let unpack_phi = destructure(&mg.graph, quote! { *#phi_name }, &wt.phi, &used_vars);
    let unpack_u = destructure(&mg.graph, quote! { *#u_name }, &mg.u, &used_vars);
    quote! {
        /// The window transform's model at the reconstructed point `phi` with input `u`
        /// (eq. 12): `(F, G, d)` with `x[k+1] = F x[k] + G u[k] + d`, exact at `x = phi`.
        #[must_use]
        pub fn ltv_model(#phi_name: &[#ty; #n_len], #u_name: &[#ty; #u_len]) -> ([[#ty; #n_len]; #n_len], [[#ty; #u_len]; #n_len], [#ty; #n_len]) {
            #unpack_phi
            #unpack_u
            #(#statements)*
            ([#(#f_rows),*], [#(#g_rows),*], [#(#d_values),*])
        }
    }
}

fn reads(graph: &Graph, node: NodeId, used: &std::collections::BTreeSet<VarId>) -> bool {
    matches!(graph.node(node), crate::symbolic::Node::Var(v) if used.contains(&v))
}

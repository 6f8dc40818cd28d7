//! The polynomial Kalman filter (Shults, Brubaker and Lee): the recursive step of
//! [`crate::generators::polynomial_kf::design::step`] lowered to straight-line code, and the periodic
//! re-initialisation from the window fit whose constant matrix is computed at generation
//! time. The window is a shift register (destructured, never indexed); the counters are
//! floats (exact below 2^24), so the code has no integer arithmetic.

use super::design::{self, WindowFit};
use super::spec::PolynomialKfSpec;
use crate::emit::arguments::{Arguments, REJECTS_NON_FINITE};
use crate::emit::code::{
    guard_pivots, innovation_pivot_failure, packed_diagonal, pivot_names, reject_diverged,
    unpack_symmetric, INNOVATION,
};
use crate::emit::filter::{finiteness_probe, model_names, packed_vars};
use crate::emit::lower::{literal, matrix_literal, Lowered, Lowerer, OpCount};
use crate::emit::measurement;
use crate::emit::names::{ident, TempNamer};
use crate::model::{Model, Scalar};
use crate::symbolic::linalg::{packed_len, packed_upper, symmetric_from_packed};
use crate::symbolic::{Graph, NodeId};
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// Generated polynomial KF and its costs.
pub struct PolynomialKfCode {
    /// The `PolynomialKf` type.
    pub tokens: TokenStream,
    /// Arithmetic of a recursive step.
    pub step_ops: OpCount,
    /// Arithmetic of a re-initialising step (the window fit).
    pub fit_ops: OpCount,
}

/// The `PolynomialKf` of `model` in `scalar`.
pub fn emit_polynomial_kf(
    model: &Model,
    spec: &PolynomialKfSpec,
    scalar: Scalar,
) -> PolynomialKfCode {
    let avoid = model_names(model);
    let taken = |name: &str| avoid.iter().any(|a| a == name);
    let window = WindowNames::new(spec.window, &taken);
    let fit = design::window_fit(spec);
    let fit_code = fit_branch(&avoid, &fit, &window.new, scalar);
    let kf = recursive_step(model, spec, &window.measured, scalar);
    // The window shifts by one sample (its entries after the oldest are read, all are
    // written) and its two counters are read and written.
    let shift = OpCount {
        load: u32::try_from(spec.window + 1).unwrap_or(u32::MAX),
        store: u32::try_from(spec.window + 2).unwrap_or(u32::MAX),
        ..OpCount::default()
    };
    let step_ops = kf.ops.plus(shift);
    // The fit stores its state and the constant covariance, whose entries are literals.
    let covariance_len = packed_len(spec.order + 1);
    let stored = OpCount {
        literal: u32::try_from(covariance_len).unwrap_or(u32::MAX),
        ..OpCount::stores(spec.order + 1 + covariance_len)
    };
    let fit_ops = fit_code.ops.plus(stored).plus(shift);
    let ty = ident(scalar.type_name());
    let [n_len, np_len, w_len] =
        [spec.order + 1, covariance_len, spec.window].map(Literal::usize_unsuffixed);
    let constants = associated_constants(spec, &fit, scalar);
    let accessors = accessors(model, spec, scalar);
    let step = step_method(spec, &fit, &window, fit_code, kf, scalar);
    let predict = predict_method(model, spec, scalar);
    let measurement_fields = measurement::fields(model, spec.gate, &ty);
    let gate_doc = measurement::gate_doc_attribute(spec.gate);
    let tokens = quote! {
        /// Polynomial Kalman filter (Shults, Brubaker and Lee, "A fast algorithm for control
        /// and estimation using a polynomial state-space structure"): the state
        /// `x = [z, T z', .., T^m/m! z^(m)]` of eq. (2) follows `x[n+1] = Phi(1) x[n]`
        /// (eq. 3-4) with process noise `f I` (the fading factor `f`) and measurement
        /// variance `sigma^2` (eq. 5-9, Joseph form). Every `REINIT_EVERY` samples, once
        /// its window is full, it is re-initialised by the non-recursive filter: the
        /// least-squares polynomial through the last `WINDOW` samples, `x = FIT_GAIN y`
        /// (a constant matrix computed when the code was generated), with the fit's
        /// covariance `FIT_COVARIANCE = sigma^2 FIT_GAIN FIT_GAIN'`.
        #gate_doc
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct PolynomialKf {
            x: [#ty; #n_len],
            p: [#ty; #np_len],
            window: [#ty; #w_len],
            filled: #ty,
            since: #ty,
            #measurement_fields
        }

        impl PolynomialKf {
            #constants
            #accessors
            #step
            #predict
        }
    };
    PolynomialKfCode {
        tokens,
        step_ops,
        fit_ops,
    }
}

/// The names of the window's entries in the step: as stored (`w1` oldest) and after this
/// sample (the oldest drops out, the measurement comes in).
struct WindowNames {
    old: Vec<String>,
    new: Vec<String>,
    measured: String,
}

impl WindowNames {
    fn new(window: usize, taken: &dyn Fn(&str) -> bool) -> WindowNames {
        let old: Vec<String> = (1..=window)
            .map(|i| fresh(&format!("w{i}"), taken))
            .collect();
        let measured = fresh("y_measured", taken);
        let new = old[1..].iter().cloned().chain([measured.clone()]).collect();
        WindowNames { old, new, measured }
    }
}

/// `ORDER`, `WINDOW`, `REINIT_EVERY`, `SAMPLE_PERIOD`, `FIT_GAIN`, `FIT_COVARIANCE`.
fn associated_constants(spec: &PolynomialKfSpec, fit: &WindowFit, scalar: Scalar) -> TokenStream {
    let ty = ident(scalar.type_name());
    let [n_len, w_len] = [spec.order + 1, spec.window].map(Literal::usize_unsuffixed);
    let order = Literal::usize_unsuffixed(spec.order);
    let reinit = Literal::usize_unsuffixed(spec.reinit_every as usize);
    let dt = literal(spec.dt, scalar);
    let (fit_gain, fit_cov) = (
        matrix_literal(&fit.gain, scalar),
        matrix_literal(&fit.covariance, scalar),
    );
    quote! {
        /// Order `m` of the polynomial.
        pub const ORDER: usize = #order;
        /// Samples in the re-initialisation window.
        pub const WINDOW: usize = #w_len;
        /// Samples between re-initialisations.
        pub const REINIT_EVERY: usize = #reinit;
        /// Sample period `T` [s].
        pub const SAMPLE_PERIOD: #ty = #dt;
        /// The window fit, `x = FIT_GAIN [y[k-N+1], .., y[k]]` (oldest sample first):
        /// the pseudo-inverse of the polynomial's design matrix at the newest sample.
        pub const FIT_GAIN: [[#ty; #w_len]; #n_len] = #fit_gain;
        /// The covariance of the window fit, `sigma^2 FIT_GAIN FIT_GAIN'`.
        pub const FIT_COVARIANCE: [[#ty; #n_len]; #n_len] = #fit_cov;
    }
}

/// `new`, `state`, `derivatives` and `covariance`.
fn accessors(model: &Model, spec: &PolynomialKfSpec, scalar: Scalar) -> TokenStream {
    let n = spec.order + 1;
    let ty = ident(scalar.type_name());
    let [n_len, w_len] = [n, spec.window].map(Literal::usize_unsuffixed);
    let zero = literal(0.0, scalar);
    let measurement_init = measurement::initial_values(model, spec.gate, scalar);
    let x_idents: Vec<proc_macro2::Ident> = (0..n).map(|j| ident(&format!("x{j}"))).collect();
    let derivatives = x_idents.iter().zip(derivative_scales(spec)).map(|(x, s)| {
        if s == 1.0 {
            quote! { #x }
        } else {
            let s = literal(s, scalar);
            quote! { #s * #x }
        }
    });
    let unpack_p = unpack_symmetric("p", &ty);
    let mut arguments = Arguments::default();
    arguments.vector("x0", n, &ty);
    let p0 = arguments.covariance("p0", n, &ty);
    let new = arguments.constructor(
        &quote! {
            /// A filter from the estimate `x0` (scaled as the state) and covariance `p0`
            /// (checked symmetric, positive semi-definite), with an empty window: it runs the
            /// recursive filter from this prior until its first re-initialisation.
        },
        REJECTS_NON_FINITE,
        quote! {
            Ok(PolynomialKf {
                x: *x0,
                p: #p0,
                window: [#zero; #w_len],
                filled: #zero,
                since: #zero,
                #measurement_init
            })
        },
    );
    let reset = reset_method(model, spec, scalar);
    quote! {
        #new

        #reset

        /// The state estimate, scaled as eq. (2): `[z, T z', .., T^m/m! z^(m)]`.
        #[must_use]
        pub fn state(&self) -> [#ty; #n_len] {
            self.x
        }

        /// The position and its derivatives in physical units:
        /// `[z, dz/dt, .., d^m z/dt^m]`, from `d^j z/dt^j = j!/T^j x_j`.
        #[must_use]
        pub fn derivatives(&self) -> [#ty; #n_len] {
            let [#(#x_idents),*] = self.x;
            [#(#derivatives),*]
        }

        /// The estimate's covariance (of the scaled state).
        #[must_use]
        pub fn covariance(&self) -> [[#ty; #n_len]; #n_len] {
            #unpack_p
        }
    }
}

/// `reset`, what the last recursive step measured (the shared measurement stage's
/// `innovation` and `normalised_innovation_squared`), and with a gate its getter, setter
/// and the cold keeper of a rejected sample's prediction.
fn reset_method(model: &Model, spec: &PolynomialKfSpec, scalar: Scalar) -> TokenStream {
    let n = spec.order + 1;
    let ty = ident(scalar.type_name());
    let zero = literal(0.0, scalar);
    let mut arguments = Arguments::default();
    arguments.vector("x0", n, &ty);
    let p0 = arguments.covariance("p0", n, &ty);
    let clear = measurement::clear_innovation(model, "", scalar);
    let reset = arguments.method(
        &ident("reset"),
        &quote! {
            /// Starts the filter again from the estimate `x0` and covariance `p0` with an
            /// empty window, as `new` does (a gate, where there is one, is kept): the way
            /// back after a fault (a run of [`Status::Diverged`]) or a restart of the
            /// motion. Rejects a non-finite entry with [`Status::RejectedInput`] and a `p0`
            /// that is not symmetric and positive semi-definite with
            /// [`Status::InvalidCovariance`], leaving the filter unchanged.
        },
        quote! {
            self.x = *x0;
            self.p = #p0;
            self.window = [#zero; Self::WINDOW];
            self.filled = #zero;
            self.since = #zero;
            #clear
            Status::Ok
        },
    );
    let innovation = measurement::accessors(model, "", scalar);
    let gate = measurement::gate_methods(model, spec.gate, scalar)
        .map(|(accessors, keep)| quote::quote! { #accessors #keep });
    quote! {
        #reset

        #innovation

        #gate
    }
}

/// `predict`: a sample without its measurement, `x = Phi x`, `S1 = Phi S Phi' + f I`
/// (eq. 5-6), and the window emptied (the sample is missing from its sequence). What a
/// gated step keeps of an outlier.
fn predict_method(model: &Model, spec: &PolynomialKfSpec, scalar: Scalar) -> TokenStream {
    let n = spec.order + 1;
    let avoid = model_names(model);
    let mut g = Graph::new();
    let x_vars: Vec<NodeId> = model.states.iter().map(|s| g.var(&s.name)).collect();
    let p_vars = packed_vars(&mut g, "p", n, &avoid);
    let p = symmetric_from_packed(&p_vars, n);
    let (x_pred, p_pred) = design::predict(&mut g, spec, &x_vars, &p);
    let probe = finiteness_probe(&mut g, &x_pred, &p_pred);
    let results: Vec<NodeId> = x_pred
        .iter()
        .chain(&packed_upper(&p_pred))
        .copied()
        .collect();
    let mut roots = results.clone();
    roots.push(probe);
    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(&g, scalar, namer, &roots);
    lowerer.read_lazily(&quote! { self.x }, &x_vars);
    lowerer.read_lazily(&quote! { self.p }, &p_vars);
    for (&node, state) in x_pred.iter().zip(&model.states) {
        lowerer.prefer_name(node, &format!("{}_pred", state.name));
    }
    let probe = lowerer.bind(probe, "divergence_probe");
    let values = lowerer.segment(&results);
    let statements = lowerer.finish().statements;
    let (x_values, p_values) = values.split_at(n);
    let check = reject_diverged(&probe, &packed_diagonal(p_values, n), scalar);
    let (zero, one) = (literal(0.0, scalar), literal(1.0, scalar));
    quote! {
        /// A sample without its measurement (eq. 5-6): the estimate and covariance
        /// predicted, the window emptied (a missing sample breaks its sequence; it
        /// refills before the next re-initialisation). What a gated step keeps when it
        /// rejects an outlier. Leaves the filter unchanged unless it returns
        /// [`Status::Ok`].
        pub fn predict(&mut self) -> Status {
            #(#statements)*
            #check
            self.x = [#(#x_values),*];
            self.p = [#(#p_values),*];
            self.filled = #zero;
            self.since += #one;
            Status::Ok
        }
    }
}

/// `step`: the window shift, the re-initialising branch, the recursive filter.
fn step_method(
    spec: &PolynomialKfSpec,
    fit: &WindowFit,
    window: &WindowNames,
    fit_code: FitCode,
    kf: RecursiveCode,
    scalar: Scalar,
) -> TokenStream {
    let n = spec.order + 1;
    let ty = ident(scalar.type_name());
    let lit = |v: f64| literal(v, scalar);
    let (window_f, reinit_f) = (lit(spec.window as f64), lit(f64::from(spec.reinit_every)));
    let (zero, one) = (lit(0.0), lit(1.0));
    let fit_p_packed = (0..n)
        .flat_map(|i| (i..n).map(move |j| (i, j)))
        .map(|(i, j)| lit(fit.covariance[(i, j)]));
    let mut old_pattern = vec![quote! { _ }];
    old_pattern.extend(window.old[1..].iter().map(|w| {
        let w = ident(w);
        quote! { #w }
    }));
    let new_idents: Vec<proc_macro2::Ident> = window.new.iter().map(|w| ident(w)).collect();
    let measured = ident(&window.measured);
    let FitCode {
        statements: fit_statements,
        x_values: fit_x,
        ..
    } = fit_code;
    let RecursiveCode {
        statements,
        x_values,
        p_values,
        probe,
        store_innovation,
        ..
    } = kf;
    let check = reject_diverged(&probe, &packed_diagonal(&p_values, x_values.len()), scalar);
    let step_doc = step_doc(spec);
    quote! {
        #[doc = #step_doc]
        pub fn step(&mut self, y: #ty) -> Status {
            if !y.is_finite() {
                return Status::RejectedInput;
            }
            let #measured = y;
            let [#(#old_pattern),*] = self.window;
            let filled = if self.filled < #window_f { self.filled + #one } else { self.filled };
            let since = self.since + #one;
            // The recursive step first, on a re-initialising sample too: its divergence
            // bound decides whether `y` may enter the window at all.
            #(#statements)*
            #check
            if since >= #reinit_f && filled >= #window_f {
                #(#fit_statements)*
                self.x = [#(#fit_x),*];
                self.p = [#(#fit_p_packed),*];
                self.window = [#(#new_idents),*];
                self.filled = filled;
                self.since = #zero;
                #store_innovation
                return Status::Ok;
            }
            self.x = [#(#x_values),*];
            self.p = [#(#p_values),*];
            self.window = [#(#new_idents),*];
            self.filled = filled;
            self.since = since;
            #store_innovation
            Status::Ok
        }
    }
}

/// `step`'s documentation: the re-initialisation, and what it does with an outlier.
fn step_doc(spec: &PolynomialKfSpec) -> String {
    format!(
        " One sample: the recursive filter runs (eq. 5-9) and the window takes `y`; every {} \
         samples, once the window holds its {} samples, the estimate and covariance are \
         re-initialised from the window fit instead. Rejects a non-finite `y`; {} \
         Otherwise leaves the filter unchanged unless it returns [`Status::Ok`].",
        spec.reinit_every,
        spec.window,
        if spec.gate.is_some() {
            "a `y` whose normalised innovation squared exceeds the gate is rejected \
             ([`Status::OutlierRejected`]): the prediction is kept, as [`Self::predict`] \
             gives it, and the window emptied, so the outlier never enters it."
        } else {
            "a `y` whose normalised innovation squared exceeds 1e8 returns \
             [`Status::Diverged`], so it never enters the window."
        }
    )
}

/// `j! / T^j`, the factor from the scaled state to the `j`-th derivative.
fn derivative_scales(spec: &PolynomialKfSpec) -> Vec<f64> {
    let mut factorial = 1.0;
    (0..=spec.order)
        .map(|j| {
            if j > 0 {
                factorial *= j as f64;
            }
            factorial / spec.dt.powi(j as i32)
        })
        .collect()
}

/// The lowered window fit.
struct FitCode {
    statements: Vec<TokenStream>,
    x_values: Vec<TokenStream>,
    ops: OpCount,
}

/// `x = FIT_GAIN window`, unrolled with literal coefficients.
fn fit_branch(avoid: &[String], fit: &WindowFit, window: &[String], scalar: Scalar) -> FitCode {
    let mut g = Graph::new();
    let vars: Vec<NodeId> = window.iter().map(|w| g.var(w)).collect();
    let x: Vec<NodeId> = fit
        .gain
        .to_rows()
        .iter()
        .map(|row| {
            let coefficients: Vec<NodeId> = row.iter().map(|&v| g.num(v)).collect();
            crate::symbolic::linalg::dot(&mut g, &coefficients, &vars)
        })
        .collect();
    let namer = TempNamer::new(
        avoid
            .iter()
            .map(String::as_str)
            .chain(window.iter().map(String::as_str)),
    );
    let mut lowerer = Lowerer::new(&g, scalar, namer, &x);
    let x_values = lowerer.segment(&x);
    let Lowered {
        statements, ops, ..
    } = lowerer.finish();
    FitCode {
        statements,
        x_values,
        ops,
    }
}

/// The lowered recursive step.
struct RecursiveCode {
    /// Ending in the divergence bound's test of the normalised innovation squared.
    statements: Vec<TokenStream>,
    x_values: Vec<TokenStream>,
    p_values: Vec<TokenStream>,
    probe: TokenStream,
    /// The innovation and its variance stored with the estimate.
    store_innovation: TokenStream,
    ops: OpCount,
}

/// Prediction and Joseph-form update, reading `self.x` and `self.p` at first use.
fn recursive_step(
    model: &Model,
    spec: &PolynomialKfSpec,
    measured: &str,
    scalar: Scalar,
) -> RecursiveCode {
    let n = spec.order + 1;
    let avoid = model_names(model);
    let mut g = Graph::new();
    let x_vars: Vec<NodeId> = model.states.iter().map(|s| g.var(&s.name)).collect();
    let p_vars = packed_vars(&mut g, "p", n, &avoid);
    let measured = g.var(measured);
    let p = symmetric_from_packed(&p_vars, n);
    let (update, residual) = design::step(&mut g, spec, &x_vars, &p, measured, |g, j| {
        g.var(&pivot_names(1, j, INNOVATION, "").1)
    });
    let kept = [residual, update.s[0][0], update.nis];
    let probe = finiteness_probe(&mut g, &update.x, &update.p);
    let p_packed = packed_upper(&update.p);
    let results: Vec<NodeId> = update.x.iter().chain(&p_packed).copied().collect();
    let mut roots = results.clone();
    roots.push(probe);
    roots.extend(&update.pivots);
    roots.extend(kept);
    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(&g, scalar, namer, &roots);
    // The window's entries after the oldest are read before the update and stored after
    // it (the shift): they hold registers throughout.
    lowerer.reserve_registers(spec.window - 1);
    lowerer.read_lazily(&quote! { self.x }, &x_vars);
    lowerer.read_lazily(&quote! { self.p }, &p_vars);
    for (&node, state) in update.x.iter().zip(&model.states) {
        lowerer.prefer_name(node, &format!("{}_new", state.name));
    }
    guard_pivots(
        &mut lowerer,
        &update.pivots,
        &update.reciprocals,
        (INNOVATION, ""),
        &innovation_pivot_failure,
        scalar,
    );
    let probe = lowerer.bind(probe, "divergence_probe");
    let values = lowerer.segment(&results);
    lowerer.count_extra(crate::emit::code::divergence_test_ops(n));
    let kept = measurement::Kept {
        prefix: "",
        innovation: &kept[..1],
        covariance: &kept[1..2],
        nis: Some(kept[2]),
        gated: spec.gate.is_some(),
        gate_prefix: "",
        keep_prediction: Some(measurement::keep_prediction_call(model)),
        // It recovers by its window's re-initialisation, every `REINIT_EVERY` samples.
        recovers: false,
    };
    let store_innovation = measurement::store_and_gate(&mut lowerer, &kept);
    let Lowered {
        statements, ops, ..
    } = lowerer.finish();
    let (x_values, p_values) = values.split_at(n);
    RecursiveCode {
        statements,
        x_values: x_values.to_vec(),
        p_values: p_values.to_vec(),
        probe,
        store_innovation,
        ops,
    }
}

fn fresh(name: &str, taken: &dyn Fn(&str) -> bool) -> String {
    let mut name = name.to_owned();
    while taken(&name) {
        name.push('_');
    }
    name
}

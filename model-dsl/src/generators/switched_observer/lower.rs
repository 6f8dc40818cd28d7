//! The switched observers of a piecewise-linear model: one type per design of
//! [`crate::generators::switched_observer::design::design`], each a one-step predictor
//! `x[k+1] = F_i x[k] + B_i u[k] + c_i + K_i y[k]` with `F_i = A_i - K_i C` computed at
//! generation time and the regime `i` read from the measurement.

use super::design::{innovation, observer_step, Designs, Gains, Regimes, Switch};
use crate::emit::arguments::{Arguments, REJECTS_NON_FINITE};
use crate::emit::code::{reject_diverged, reject_non_finite, var_idents};
use crate::emit::filter::model_names;
use crate::emit::lower::{literal, matrix_literal, Lowered, Lowerer, OpCount};
use crate::emit::names::{ident, TempNamer};
use crate::model::{Model, Scalar};
use crate::numerics::Mat;
use crate::symbolic::{Graph, NodeId};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::quote;

/// Generated observers and the cost of one step.
pub struct SwitchedCode {
    /// The three observer types and the regime constants.
    pub tokens: TokenStream,
    /// Arithmetic of one step (the same for every design, zeros aside: the largest).
    pub step_ops: OpCount,
}

/// The observers of `designs` in `scalar`.
pub fn emit_switched_observers(
    model: &Model,
    regimes: &Regimes,
    designs: &Designs,
    scalar: Scalar,
) -> SwitchedCode {
    let regime_doc = regime_doc(model, &regimes.switch);
    let constants = regime_constants(model, regimes, &regime_doc, scalar);
    let selector = regime_selector(model, &regimes.switch, &regime_doc, scalar);
    let mut step_ops = OpCount::default();
    let mut types = Vec::new();
    for (name, gains, doc) in observer_designs(designs) {
        let (tokens, ops) = observer_type(model, regimes, gains, name, doc, scalar);
        step_ops = costlier(step_ops, ops);
        types.push(tokens);
    }
    let tokens = quote! {
        #constants
        #selector
        #(#types)*
    };
    SwitchedCode { tokens, step_ops }
}

/// The three designs of the seed, each with its type's name and documentation.
fn observer_designs(designs: &Designs) -> [(&'static str, &Gains, &'static str); 3] {
    [
        (
            "LinearErrorObserver",
            &designs.linear_error,
            "Observer with linear error dynamics (\"Observer design for a piecewise linear beam \
             system\", sect. 5): `K2 = K1 + A_s C^+` with `A_s = A2 - A1`, so that \
             `A1 - K1 C = A2 - K2 C` and the error `e[k+1] = (A1 - K1 C) e[k]` is one stable \
             linear system whatever the switching (when the regime is read correctly).",
        ),
        (
            "SwitchedKalmanObserver",
            &designs.switched_kalman,
            "Switched Kalman filter (\"Observer design for a piecewise linear beam system\", \
             sect. 6): in each regime the steady-state gain of the one-step Kalman predictor \
             for the model's process and measurement noise (the discrete Riccati equation, \
             solved when the code was generated). Each regime's error dynamics is stable; \
             their switching is not guaranteed to be.",
        ),
        (
            "CommonGainObserver",
            &designs.common_gain,
            "One gain for both regimes (`K1` of the linear-error-dynamics observer), for \
             comparison: each regime's error dynamics is stable, but switching between them \
             can diverge (\"Observer design for a piecewise linear beam system\", sect. 3).",
        ),
    ]
}

/// The larger of two step costs: a step runs one regime's branch, and the reported cost
/// is the dearer one.
fn costlier(a: OpCount, b: OpCount) -> OpCount {
    if b.mul + b.add > a.mul + a.add {
        b
    } else {
        a
    }
}

/// What the regimes are and how the observers tell them apart, for the docs of the
/// regime constants and of [`regime_selector`]'s function.
fn regime_doc(model: &Model, switch: &Switch) -> String {
    let condition = format!(
        "`{} {} {}`",
        model.outputs[switch.output].name,
        switch.cmp.symbol(),
        switch.threshold
    );
    format!(
        " Regime 1 is where {condition} does not hold (the `else` branches of the model's \
         piecewise terms), regime 2 where it holds. The observers read it from the \
         measurement `{}` of `{}`.",
        model.outputs[switch.output].name,
        model.state_names().nth(switch.state).unwrap_or("?")
    )
}

/// `REGIME_A`, `REGIME_B`, `REGIME_OFFSET` and `OUTPUT_C`: the two regimes'
/// `x[k+1] = A_i x + B_i u + c_i`, `y = C x`, as read from the model.
fn regime_constants(
    model: &Model,
    regimes: &Regimes,
    regime_doc: &str,
    scalar: Scalar,
) -> TokenStream {
    let ty = ident(scalar.type_name());
    let (n, m, p) = (model.state_len(), model.outputs.len(), model.inputs.len());
    let matrices = |mats: &[Mat]| {
        let items = mats.iter().map(|mat| matrix_literal(mat, scalar));
        quote! { [#(#items),*] }
    };
    let [n_len, m_len, p_len] = [n, m, p].map(Literal::usize_unsuffixed);
    let regime_a = matrices(&regimes.a);
    let regime_b = matrices(&regimes.b);
    let regime_c = matrix_literal(&regimes.c, scalar);
    let offsets = regimes.offset.iter().map(|c| {
        let c = c.iter().map(|&v| literal(v, scalar));
        quote! { [#(#c),*] }
    });
    quote! {
        /// `A_i = df/dx` of the two regimes.
        #[doc = #regime_doc]
        pub const REGIME_A: [[[#ty; #n_len]; #n_len]; 2] = #regime_a;
        /// `B_i = df/du` of the two regimes.
        pub const REGIME_B: [[[#ty; #p_len]; #n_len]; 2] = #regime_b;
        /// `c_i = f(0, 0)` of the two regimes.
        pub const REGIME_OFFSET: [[#ty; #n_len]; 2] = [#(#offsets),*];
        /// `C = dh/dx`.
        pub const OUTPUT_C: [[#ty; #n_len]; #m_len] = #regime_c;
    }
}

/// `in_regime_2(y)`: the switching condition read from the measurement.
fn regime_selector(
    model: &Model,
    switch: &Switch,
    regime_doc: &str,
    scalar: Scalar,
) -> TokenStream {
    let ty = ident(scalar.type_name());
    let m_len = Literal::usize_unsuffixed(model.outputs.len());
    let y_idents: Vec<_> = model.outputs.iter().map(|o| ident(&o.name)).collect();
    let test = switch_test(switch, &y_idents, scalar);
    let pattern = y_idents.iter().enumerate().map(|(i, y)| {
        if i == switch.output {
            quote! { #y }
        } else {
            quote! { _ }
        }
    });
    quote! {
        /// Whether the measurement `y` selects regime 2.
        #[doc = #regime_doc]
        #[must_use]
        pub fn in_regime_2(y: &[#ty; #m_len]) -> bool {
            let [#(#pattern),*] = *y;
            #test
        }
    }
}

/// `y_s cmp threshold`, true in regime 2, over the outputs named `y_idents`.
fn switch_test(switch: &Switch, y_idents: &[Ident], scalar: Scalar) -> TokenStream {
    let switch_y = &y_idents[switch.output];
    let (cmp, threshold) = (cmp_tokens(switch.cmp), literal(switch.threshold, scalar));
    quote! { #switch_y #cmp #threshold }
}

fn cmp_tokens(cmp: crate::ast::Comparison) -> TokenStream {
    use crate::ast::Comparison;
    match cmp {
        Comparison::Gt => quote! { > },
        Comparison::Ge => quote! { >= },
        Comparison::Lt => quote! { < },
        Comparison::Le => quote! { <= },
    }
}

/// Values of `x` lowered: their statements and the values, reading `self.x` where first
/// used; `name` prefers names before the lowering (the innovation's).
fn lower_values(
    g: &Graph,
    avoid: &[String],
    x: &[NodeId],
    values: &[NodeId],
    scalar: Scalar,
    name: impl FnOnce(&mut Lowerer),
) -> (TokenStream, OpCount) {
    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(g, scalar, namer, values);
    lowerer.read_lazily(&quote! { self.x }, x);
    name(&mut lowerer);
    let exprs = lowerer.segment(values);
    let Lowered {
        statements, ops, ..
    } = lowerer.finish();
    let tokens = quote! {
        #(#statements)*
        [#(#exprs),*]
    };
    (tokens, ops)
}

/// One observer's step, lowered: the names of its arguments and each regime's prediction
/// `x[k+1] = F_i x + B_i u + K_i y + c_i`.
struct LoweredStep {
    /// The inputs, as the step unpacks them.
    u_idents: Vec<Ident>,
    /// The measurements, as the step unpacks them (`<output>_measured`).
    y_idents: Vec<Ident>,
    /// Regime 1's and regime 2's prediction: statements, then the new estimate.
    branches: Vec<TokenStream>,
    /// The innovation `y - C x`: statements, then its entries.
    innovation: TokenStream,
    /// The dearer branch's arithmetic.
    ops: OpCount,
}

/// Builds the observer's prediction in each regime ([`super::design::observer_step`])
/// and lowers both branches.
fn lowered_step(model: &Model, regimes: &Regimes, gains: &Gains, scalar: Scalar) -> LoweredStep {
    let avoid = model_names(model);
    let mut g = Graph::new();
    let x: Vec<NodeId> = model.state_names().map(|s| g.var(s)).collect();
    let u: Vec<NodeId> = model.inputs.iter().map(|s| g.var(&s.name)).collect();
    let y: Vec<NodeId> = model
        .outputs
        .iter()
        .map(|o| g.var(&format!("{}_measured", o.name)))
        .collect();
    let next = observer_step(&mut g, regimes, gains, &x, &u, &y);
    let residual = innovation(&mut g, regimes, &x, &y);
    let (innovation, innovation_ops) = lower_values(&g, &avoid, &x, &residual, scalar, |l| {
        crate::emit::measurement::name_innovation(l, model, &residual, "");
    });
    let mut ops = OpCount::default();
    let branches = next
        .iter()
        .map(|values| {
            let (tokens, branch_ops) = lower_values(&g, &avoid, &x, values, scalar, |_| {});
            ops = costlier(ops, branch_ops);
            tokens
        })
        .collect();
    LoweredStep {
        u_idents: var_idents(&g, &u),
        y_idents: var_idents(&g, &y),
        branches,
        innovation,
        // The new estimate and the innovation are stored.
        ops: ops
            .plus(innovation_ops)
            .plus(OpCount::stores(x.len() + y.len())),
    }
}

/// `step(u, y)`: checks the arguments, picks the regime from `y` and commits the
/// prediction if it is finite.
fn step_method(model: &Model, switch: &Switch, step: &LoweredStep, scalar: Scalar) -> TokenStream {
    let ty = ident(scalar.type_name());
    let [m_len, p_len] = [model.outputs.len(), model.inputs.len()].map(Literal::usize_unsuffixed);
    let LoweredStep {
        u_idents, y_idents, ..
    } = step;
    let (regime1, regime2) = (&step.branches[0], &step.branches[1]);
    let innovation = &step.innovation;
    let checked: Vec<_> = u_idents.iter().chain(y_idents).cloned().collect();
    let check = reject_non_finite(&checked, &[], &ty);
    let unpack_u = (!u_idents.is_empty()).then(|| quote! { let [#(#u_idents),*] = *u; });
    let u_param = (!u_idents.is_empty()).then(|| quote! { u: &[#ty; #p_len], });
    let test = switch_test(switch, y_idents, scalar);
    let next_idents: Vec<_> = model
        .state_names()
        .map(|s| ident(&format!("{s}_next")))
        .collect();
    let commit_check = reject_diverged(&quote! { #(#next_idents)+* }, &[], scalar);
    quote! {
        /// One sample: `x = A_i x + B_i u + c_i + K_i (y - C x)` with the regime `i`
        /// chosen by [`in_regime_2`] from `y`, keeping the innovation `y - C x`. Rejects a
        /// non-finite `u` or `y`; leaves the observer unchanged unless it returns
        /// [`Status::Ok`].
        pub fn step(&mut self, #u_param y: &[#ty; #m_len]) -> Status {
            #unpack_u
            let [#(#y_idents),*] = *y;
            #check
            // `next`, not `x_next`: the entries are `<state>_next`, and a state named
            // `x` would shadow the array.
            let innovation = { #innovation };
            let next = if #test { #regime2 } else { #regime1 };
            let [#(#next_idents),*] = next;
            #commit_check
            self.x = next;
            self.innovation = innovation;
            Status::Ok
        }
    }
}

/// `new(x0)` and `reset(x0)`: an observer starting from `x0`, the innovation zero.
fn new_and_reset(model: &Model, type_name: &Ident, scalar: Scalar) -> (TokenStream, TokenStream) {
    let ty = ident(scalar.type_name());
    let m_len = Literal::usize_unsuffixed(model.outputs.len());
    let zero = literal(0.0, scalar);
    let mut arguments = Arguments::default();
    arguments.vector("x0", model.state_len(), &ty);
    let zeros = quote! { [#zero; #m_len] };
    let new = arguments.constructor(
        &quote! {
            /// An observer starting from the estimate `x0`.
        },
        REJECTS_NON_FINITE,
        quote! { Ok(#type_name { x: *x0, innovation: #zeros }) },
    );
    let mut arguments = Arguments::default();
    arguments.vector("x0", model.state_len(), &ty);
    let reset = arguments.method(
        &ident("reset"),
        &quote! {
            /// Starts the observer again from the estimate `x0`, the innovation cleared:
            /// the way back after a fault or a restart of the plant. Rejects a non-finite
            /// entry with [`Status::RejectedInput`], leaving the observer unchanged.
        },
        quote! {
            self.x = *x0;
            self.innovation = #zeros;
            Status::Ok
        },
    );
    (new, reset)
}

/// One observer type with its gains: the struct, `GAINS`, `new`, `state` and `step`.
fn observer_type(
    model: &Model,
    regimes: &Regimes,
    gains: &Gains,
    name: &str,
    doc: &str,
    scalar: Scalar,
) -> (TokenStream, OpCount) {
    let ty = ident(scalar.type_name());
    let [n_len, m_len] = [model.state_len(), model.outputs.len()].map(Literal::usize_unsuffixed);
    let lowered = lowered_step(model, regimes, gains, scalar);
    let step = step_method(model, &regimes.switch, &lowered, scalar);
    let gains_literal = {
        let items = gains.k.iter().map(|k| matrix_literal(k, scalar));
        quote! { [#(#items),*] }
    };
    let type_name = ident(name);
    let (new, reset) = new_and_reset(model, &type_name, scalar);
    let radius_doc = format!(
        " Largest pole modulus of `A_i - K_i C`: regime 1 {:.6}, regime 2 {:.6} (certified \
         below 1 when the code was generated).",
        gains.radius[0], gains.radius[1]
    );
    let tokens = quote! {
        #[doc = #doc]
        #[doc = ""]
        #[doc = #radius_doc]
        ///
        /// [`Self::step`] at sample `k` takes `u[k]` and `y[k]` and predicts `x[k+1]`
        /// (the discrete form of the seed's observer, eq. 5.1).
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct #type_name {
            x: [#ty; #n_len],
            innovation: [#ty; #m_len],
        }

        impl #type_name {
            /// The gains `K_1`, `K_2` (`states x outputs`).
            pub const GAINS: [[[#ty; #m_len]; #n_len]; 2] = #gains_literal;

            #new

            #reset

            /// The estimate of the state at the next sample.
            #[must_use]
            pub fn state(&self) -> [#ty; #n_len] {
                self.x
            }

            /// The innovation `y - C x` of the last measurement used, at the estimate it
            /// corrected: what the measurement said that the prediction did not (an
            /// observer has no covariance to normalise it by). Zero before the first step.
            #[must_use]
            pub fn innovation(&self) -> [#ty; #m_len] {
                self.innovation
            }

            #step
        }
    };
    (tokens, lowered.ops)
}

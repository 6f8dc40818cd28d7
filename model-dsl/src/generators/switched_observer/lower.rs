//! The switched observers of a piecewise-linear model (seed 003): one type per design of
//! [`crate::generators::switched_observer::design::design`], each a one-step predictor
//! `x[k+1] = F_i x[k] + B_i u[k] + c_i + K_i y[k]` with `F_i = A_i - K_i C` computed at
//! generation time and the regime `i` read from the measurement.

use super::design::{Designs, Gains, Regimes};
use crate::emit::code::var_idents;
use crate::emit::filter::model_names;
use crate::emit::lower::{literal, Lowered, Lowerer, OpCount};
use crate::emit::names::{ident, TempNamer};
use crate::model::{Model, Scalar};
use crate::numerics::Mat;
use crate::symbolic::{Graph, NodeId};
use proc_macro2::{Literal, TokenStream};
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
    let switch = &regimes.switch;
    let condition = format!(
        "`{} {} {}`",
        model.outputs[switch.output].name,
        switch.cmp.symbol(),
        switch.threshold
    );
    let regime_doc = format!(
        " Regime 1 is where {condition} does not hold (the `else` branches of the model's \
         piecewise terms), regime 2 where it holds. The observers read it from the \
         measurement `{}` of `{}`.",
        model.outputs[switch.output].name,
        model.state_names().nth(switch.state).unwrap_or("?")
    );
    let mut step_ops = OpCount::default();
    let mut types = Vec::new();
    for (name, gains, doc) in [
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
    ] {
        let (tokens, ops) = observer_type(model, regimes, gains, name, doc, scalar);
        if ops.mul + ops.add > step_ops.mul + step_ops.add {
            step_ops = ops;
        }
        types.push(tokens);
    }
    let y_idents: Vec<_> = model.outputs.iter().map(|o| ident(&o.name)).collect();
    let switch_y = &y_idents[switch.output];
    let threshold = literal(switch.threshold, scalar);
    let cmp = cmp_tokens(switch.cmp);
    let pattern = y_idents.iter().enumerate().map(|(i, y)| {
        if i == switch.output {
            quote! { #y }
        } else {
            quote! { _ }
        }
    });
    let tokens = quote! {
        /// `A_i = df/dx` of the two regimes.
        #[doc = #regime_doc]
        pub const REGIME_A: [[[#ty; #n_len]; #n_len]; 2] = #regime_a;
        /// `B_i = df/du` of the two regimes.
        pub const REGIME_B: [[[#ty; #p_len]; #n_len]; 2] = #regime_b;
        /// `c_i = f(0, 0)` of the two regimes.
        pub const REGIME_OFFSET: [[#ty; #n_len]; 2] = [#(#offsets),*];
        /// `C = dh/dx`.
        pub const OUTPUT_C: [[#ty; #n_len]; #m_len] = #regime_c;

        /// Whether the measurement `y` selects regime 2.
        #[doc = #regime_doc]
        #[must_use]
        pub fn in_regime_2(y: &[#ty; #m_len]) -> bool {
            let [#(#pattern),*] = *y;
            #switch_y #cmp #threshold
        }

        #(#types)*
    };
    SwitchedCode { tokens, step_ops }
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

fn matrix_literal(mat: &Mat, scalar: Scalar) -> TokenStream {
    let rows = mat.to_rows();
    let rows = rows.iter().map(|row| {
        let row = row.iter().map(|&v| literal(v, scalar));
        quote! { [#(#row),*] }
    });
    quote! { [#(#rows),*] }
}

/// One regime's prediction: its statements and the new estimate, reading `self.x` where
/// first used.
fn lower_branch(
    g: &Graph,
    avoid: &[String],
    x: &[NodeId],
    values: &[NodeId],
    scalar: Scalar,
) -> (TokenStream, OpCount) {
    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(g, scalar, namer, values);
    lowerer.read_lazily(&quote! { self.x }, x);
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

/// One observer type with its gains.
fn observer_type(
    model: &Model,
    regimes: &Regimes,
    gains: &Gains,
    name: &str,
    doc: &str,
    scalar: Scalar,
) -> (TokenStream, OpCount) {
    let ty = ident(scalar.type_name());
    let (n, m, p) = (model.state_len(), model.outputs.len(), model.inputs.len());
    let [n_len, m_len, p_len] = [n, m, p].map(Literal::usize_unsuffixed);
    let avoid = model_names(model);
    let mut g = Graph::new();
    let x: Vec<NodeId> = model.state_names().map(|s| g.var(s)).collect();
    let u: Vec<NodeId> = model.inputs.iter().map(|s| g.var(&s.name)).collect();
    let y: Vec<NodeId> = model
        .outputs
        .iter()
        .map(|o| g.var(&format!("{}_measured", o.name)))
        .collect();
    let next = crate::generators::switched_observer::design::observer_step(
        &mut g, regimes, gains, &x, &u, &y,
    );
    let mut ops = OpCount::default();
    let branches: Vec<TokenStream> = next
        .iter()
        .map(|values| {
            let (tokens, branch_ops) = lower_branch(&g, &avoid, &x, values, scalar);
            if branch_ops.mul + branch_ops.add > ops.mul + ops.add {
                ops = branch_ops;
            }
            tokens
        })
        .collect();
    let (regime1, regime2) = (&branches[0], &branches[1]);
    let u_idents = var_idents(&g, &u);
    let y_idents = var_idents(&g, &y);
    let checked: Vec<_> = u_idents.iter().chain(&y_idents).cloned().collect();
    let check = crate::emit::code::reject_non_finite(&checked);
    let unpack_u = (!u.is_empty()).then(|| quote! { let [#(#u_idents),*] = *u; });
    let u_param = (!u.is_empty()).then(|| quote! { u: &[#ty; #p_len], });
    let gains_literal = {
        let items = gains.k.iter().map(|k| matrix_literal(k, scalar));
        quote! { [#(#items),*] }
    };
    let type_name = ident(name);
    let radius_doc = format!(
        " Largest pole modulus of `A_i - K_i C`: regime 1 {:.6}, regime 2 {:.6} (certified \
         below 1 when the code was generated).",
        gains.radius[0], gains.radius[1]
    );
    let switch = &regimes.switch;
    let switch_y = &y_idents[switch.output];
    let (cmp, threshold) = (cmp_tokens(switch.cmp), literal(switch.threshold, scalar));
    let next_idents: Vec<_> = model
        .state_names()
        .map(|s| ident(&format!("{s}_next")))
        .collect();
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
        }

        impl #type_name {
            /// The gains `K_1`, `K_2` (`states x outputs`).
            pub const GAINS: [[[#ty; #m_len]; #n_len]; 2] = #gains_literal;

            /// An observer starting from the estimate `x0`.
            #[must_use]
            pub fn new(x0: [#ty; #n_len]) -> #type_name {
                #type_name { x: x0 }
            }

            /// The estimate of the state at the next sample.
            #[must_use]
            pub fn state(&self) -> [#ty; #n_len] {
                self.x
            }

            /// One sample: `x = A_i x + B_i u + c_i + K_i (y - C x)` with the regime `i`
            /// chosen by [`in_regime_2`] from `y`. Rejects a non-finite `u` or `y`; leaves
            /// the observer unchanged unless it returns [`Status::Ok`].
            pub fn step(&mut self, #u_param y: &[#ty; #m_len]) -> Status {
                #unpack_u
                let [#(#y_idents),*] = *y;
                #check
                // `next`, not `x_next`: the entries are `<state>_next`, and a state named
                // `x` would shadow the array.
                let next = if #switch_y #cmp #threshold { #regime2 } else { #regime1 };
                let [#(#next_idents),*] = next;
                if !(#(#next_idents)+*).is_finite() {
                    return Status::NonFinite;
                }
                self.x = next;
                Status::Ok
            }
        }
    };
    (tokens, ops)
}

//! The hybrid (continuous-discrete) EKF of seed 001 ("Adaptive predictive control of
//! transient vibrations of cantilevers with changing weight", sect. 3.2): between samples
//! the estimate follows `x' = f(x, u)` and its covariance `P' = F P + P F' + Q` (eq. 21),
//! integrated together with the model's rule and sub-steps (a loop when there are several);
//! at each sample the discrete Joseph-form update (eqs. 24-26), shared with the EKF.

use crate::emit::code::{
    commit_or_non_finite, guard_pivots, pivot_names, reject_non_finite, var_idents, INNOVATION,
};
use crate::emit::filter::{finiteness_probe, model_names, noise_vars, packed_vars, time_param};
use crate::emit::lower::{Lowered, Lowerer, OpCount};
use crate::emit::names::{ident, TempNamer};
use crate::emit::substeps::{lower_loop, Carried, P_SUB, T_SUB, X_SUB};
use crate::model::{Method, Model, Scalar};
use crate::symbolic::continuous::{
    covariance_rate, euler_covariance_step, integrate_substep, join, riccati_measurement_terms,
    split, AtPoint,
};
use crate::symbolic::linalg::{packed_len, packed_upper, symmetric_from_packed, Matrix};
use crate::symbolic::{kalman, ModelGraph, NodeId};
use proc_macro2::{Literal, TokenStream};
use quote::quote;

/// Which method to generate.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// The hybrid EKF's propagation over one sample.
    Predict,
    /// The hybrid EKF's update at a sample.
    Update,
    /// Both.
    Step,
    /// The continuous-time EKF's step: state and Riccati equations with the measurement
    /// terms, integrated over one sample; with `alpha`, a prescribed degree of stability.
    Continuous {
        /// Whether the filter has the field `alpha`.
        alpha: bool,
    },
}

/// One method: the propagation between samples and/or the update at the sample, built
/// symbolically, then lowered (the sub-steps as a loop when there are several).
pub fn method(
    model: &Model,
    mg: &ModelGraph,
    scalar: Scalar,
    kind: Kind,
    diagonal_noise: bool,
) -> (TokenStream, OpCount, OpCount) {
    let mut g = mg.clone();
    let (n, m) = (model.state_len(), model.outputs.len());
    let continuous = matches!(kind, Kind::Continuous { .. });
    let (predicts, updates) = (
        kind != Kind::Update,
        matches!(kind, Kind::Update | Kind::Step),
    );
    let mut avoid = model_names(model);
    avoid.extend([X_SUB, P_SUB, T_SUB, "t_prev"].map(String::from));
    let p_vars = packed_vars(&mut g.graph, "p", n, &avoid);
    let (q_vars, q) = noise_vars(&mut g.graph, "q", n, diagonal_noise, &avoid);
    let r_vars = packed_vars(&mut g.graph, "r", m, &avoid);
    let y_vars = measured_vars(&mut g, model, &avoid);
    let (rule, h, substeps) = g
        .substep(model)
        .expect("the checker admits the hybrid EKF on continuous dynamics only");
    let looped = predicts && substeps > 1;
    let uses_time = model.uses_time();
    // The integration starts at the previous sample's time in a step, at `t` in `predict`.
    let t_start = if (kind == Kind::Step || continuous) && uses_time {
        g.graph.var("t_prev")
    } else {
        g.t
    };
    let t_sub = g.graph.var(T_SUB);
    let x_vars = g.x.clone();

    // dx/dt and F = df/dx over the variables, evaluated at each stage by substitution.
    let rate_x = g.derivative(model, t_sub, &x_vars);
    let jacobian = g.jacobian(&rate_x, &x_vars);
    let at = AtPoint::new(
        std::iter::once(t_sub)
            .chain(x_vars.iter().copied())
            .map(|v| g.var_id(v))
            .collect(),
    );
    let mut x = x_vars.clone();
    let mut p = symmetric_from_packed(&p_vars, n);
    let mut loop_next = Vec::new();
    // The continuous-time EKF's measurement terms: R^-1 (guarded pivots, computed once
    // per sample), and h, H over the measurement's time and the state.
    let measurement = continuous.then(|| ContinuousTerms::new(&mut g, &r_vars, m));
    let alpha_var = matches!(kind, Kind::Continuous { alpha: true }).then(|| {
        // A model symbol may be called `alpha`: the local must not shadow it.
        let mut name = String::from("alpha");
        while avoid.contains(&name) {
            name.push('_');
        }
        g.graph.var(&name)
    });
    let two_alpha = alpha_var.map(|alpha| {
        let two = g.graph.num(2.0);
        g.graph.mul(two, alpha)
    });
    if predicts {
        let graph = &mut g.graph;
        let mut rate = |gr: &mut crate::symbolic::Graph, t: NodeId, z: &[NodeId]| {
            let (xs, ps) = split(z, n);
            let point: Vec<NodeId> = std::iter::once(t).chain(xs.iter().copied()).collect();
            let mut dx = at.eval(gr, &point, &rate_x);
            let f = at.eval_matrix(gr, &point, &jacobian);
            let mut dp = covariance_rate(gr, &f, &ps, &q, two_alpha);
            if let Some(terms) = &measurement {
                (dx, dp) = terms.apply(gr, &point, &y_vars, &dx, &dp, &ps);
            }
            join(&dx, &dp)
        };
        let t0 = if looped { t_sub } else { t_start };
        let z = match rule {
            // The covariance of the Euler step itself (see `euler_covariance_step`).
            Method::Euler => {
                let point: Vec<NodeId> = std::iter::once(t0).chain(x.iter().copied()).collect();
                let mut dx = at.eval(graph, &point, &rate_x);
                let f = at.eval_matrix(graph, &point, &jacobian);
                let mut s = q.clone();
                if let Some(terms) = &measurement {
                    (dx, s) = terms.apply(graph, &point, &y_vars, &dx, &q, &p);
                }
                let p_next = euler_covariance_step(graph, h, &f, alpha_var, &p, &s);
                let x_next: Vec<NodeId> = x
                    .iter()
                    .zip(&dx)
                    .map(|(&xi, &di)| {
                        let step = graph.mul(h, di);
                        graph.add(xi, step)
                    })
                    .collect();
                join(&x_next, &p_next)
            }
            Method::Rk4 => integrate_substep(graph, rule, h, t0, &join(&x, &p), &mut rate),
        };
        if looped {
            loop_next = z;
            if uses_time {
                loop_next.push(graph.add(t_sub, h));
            }
        } else {
            (x, p) = split(&z, n);
        }
    }
    let mut pivots = Vec::new();
    let mut reciprocals = Vec::new();
    if updates {
        let outcome = correct(&mut g, &x, &p, &y_vars, &r_vars, m);
        (x, p, pivots, reciprocals) = outcome;
    }
    let probe = finiteness_probe(&mut g.graph, &x, &p);
    let p_packed = packed_upper(&p);
    let results: Vec<NodeId> = x.iter().chain(&p_packed).copied().collect();
    let mut all_roots = results.clone();
    all_roots.push(probe);
    all_roots.extend(&pivots);
    all_roots.extend(&loop_next);
    if let Some(terms) = &measurement {
        all_roots.extend(&terms.r_pivots);
    }

    let namer = TempNamer::new(avoid.iter().map(String::as_str));
    let mut lowerer = Lowerer::new(&g.graph, scalar, namer, &all_roots);
    lowerer.read_lazily(&quote! { self.q }, &q_vars);
    lowerer.read_lazily(&quote! { self.r }, &r_vars);
    if let Some(alpha) = alpha_var {
        let name = var_idents(&g.graph, &[alpha]).remove(0);
        lowerer.statement(quote! { let #name = self.alpha; });
    }
    if let Some(terms) = &measurement {
        guard_pivots(
            &mut lowerer,
            &terms.r_pivots,
            &terms.r_reciprocals,
            (MEASUREMENT, ""),
            &quote! { return Status::NonPositiveInnovation; },
            scalar,
        );
    }
    let t_start_ident = var_idents(&g.graph, &[t_start]).remove(0);
    let mut per_substep = OpCount::default();
    let mut loop_code = TokenStream::new();
    let mut loop_used = std::collections::BTreeSet::new();
    if looped {
        let (x_next, rest) = loop_next.split_at(n);
        let (p_next, t_next) = rest.split_at(packed_len(n));
        let mut carried = vec![
            Carried {
                name: X_SUB,
                initial: quote! { self.x },
                vars: &x_vars,
                next: x_next,
                scalar: false,
            },
            Carried {
                name: P_SUB,
                initial: quote! { self.p },
                vars: &p_vars,
                next: p_next,
                scalar: false,
            },
        ];
        let t_sub_vars = [t_sub];
        if uses_time {
            carried.push(Carried {
                name: T_SUB,
                initial: quote! { #t_start_ident },
                vars: &t_sub_vars,
                next: t_next,
                scalar: true,
            });
        }
        let lowered = lower_loop(&mut lowerer, &carried, &quote! { Self::SUBSTEPS });
        per_substep = lowered.per_substep;
        loop_code = lowered.code;
        loop_used = lowered.used_vars;
        let (x_sub, p_sub) = (ident(X_SUB), ident(P_SUB));
        lowerer.read_lazily(&quote! { #x_sub }, &x_vars);
        lowerer.read_lazily(&quote! { #p_sub }, &p_vars);
    } else {
        lowerer.read_lazily(&quote! { self.x }, &x_vars);
        lowerer.read_lazily(&quote! { self.p }, &p_vars);
    }
    let suffix = if updates { "new" } else { "pred" };
    for (&node, name) in x.iter().zip(model.state_names()) {
        lowerer.prefer_name(node, &format!("{name}_{suffix}"));
    }
    guard_pivots(
        &mut lowerer,
        &pivots,
        &reciprocals,
        (INNOVATION, ""),
        &quote! { return Status::NonPositiveInnovation; },
        scalar,
    );
    let probe = lowerer.segment(&[probe]).remove(0);
    let values = lowerer.segment(&results);
    let Lowered {
        statements,
        used_vars,
        ops,
    } = lowerer.finish();
    let total = ops.plus(per_substep.times(if looped { substeps } else { 0 }));
    // With one sub-step, unrolled, the step is that sub-step (and the update).
    let per_substep = if looped { per_substep } else { total };
    let (x_values, p_values) = values.split_at(n);
    let commit = commit_or_non_finite(&probe, x_values, p_values);

    let graph = &g.graph;
    let ty = ident(scalar.type_name());
    let mut used_vars: std::collections::BTreeSet<_> =
        used_vars.union(&loop_used).copied().collect();
    if predicts && uses_time {
        // The running time starts from it.
        used_vars.insert(g.var_id(t_start));
    }
    let mut params = Vec::new();
    let mut unpack = Vec::new();
    let mut checked = Vec::new();
    if uses_time {
        if kind == Kind::Step || continuous {
            params.push(time_param(graph, t_start, &used_vars, &ty, "t_prev"));
        }
        if !continuous {
            params.push(time_param(graph, g.t, &used_vars, &ty, "t"));
        }
    }
    if predicts && !g.u.is_empty() {
        let u_idents = var_idents(graph, &g.u);
        let len = Literal::usize_unsuffixed(g.u.len());
        let arg = ident(if kind == Kind::Predict { "u" } else { "u_prev" });
        params.push(quote! { #arg: &[#ty; #len] });
        unpack.push(quote! { let [#(#u_idents),*] = *#arg; });
        checked.extend(u_idents);
    }
    if updates || continuous {
        let y_idents = var_idents(graph, &y_vars);
        let len = Literal::usize_unsuffixed(m);
        params.push(quote! { y: &[#ty; #len] });
        unpack.push(quote! { let [#(#y_idents),*] = *y; });
        checked.extend(y_idents);
    }
    let check = reject_non_finite(&checked);
    let (name, doc) = match kind {
        Kind::Predict => (
            "predict",
            " Integrates the estimate and its covariance over one sample (eqs. 21-23) with \
             the input `u` held, from time `t`. Rejects a non-finite input; leaves the \
             filter unchanged unless it returns [`Status::Ok`].",
        ),
        Kind::Update => (
            "update",
            " Corrects the estimate with the measurement `y` (eqs. 24-26, Joseph form). \
             Rejects a non-finite measurement and a non-positive innovation variance (never \
             divided by); leaves the filter unchanged unless it returns [`Status::Ok`].",
        ),
        Kind::Step => (
            "step",
            " One sample: integrates `x[k-1]` and its covariance to the sample `k` with the \
             input `u[k-1]` held (eqs. 21-23), then corrects them with the measurement \
             `y[k]` (eqs. 24-26). Leaves the filter unchanged unless it returns \
             [`Status::Ok`].",
        ),
        Kind::Continuous { .. } => (
            "step",
            " One sample: integrates the estimate and the Riccati equation (eq. 5) from \
             `x[k-1]` to the sample `k` with the input `u[k-1]` and the measurement `y` \
             (normally `y[k]`) held over the sample. Rejects a non-finite input or \
             measurement and an `R` that is not positive definite (never divided by); \
             leaves the filter unchanged unless it returns [`Status::Ok`].",
        ),
    };
    let name = ident(name);
    let tokens = quote! {
        #[doc = #doc]
        pub fn #name(&mut self, #(#params),*) -> Status {
            #(#unpack)*
            #check
            #loop_code
            #(#statements)*
            #commit
        }
    };
    (tokens, total, per_substep)
}

/// The Joseph-form update (seed 001 eqs. 24-26) of `x`, `p` with the measurement
/// variables `y_vars` at time `t`: the shared Kalman stage, with `h` and its Jacobian at
/// `x`. Returns the corrected estimate and covariance, the pivots and their reciprocals.
pub fn correct(
    g: &mut ModelGraph,
    x: &[NodeId],
    p: &Matrix,
    y_vars: &[NodeId],
    r_vars: &[NodeId],
    m: usize,
) -> (Vec<NodeId>, Matrix, Vec<NodeId>, Vec<NodeId>) {
    let r = symmetric_from_packed(r_vars, m);
    let at_x = AtPoint::new(g.x.iter().map(|&v| g.var_id(v)).collect());
    let c = g.jacobian_h_wrt_x();
    let c = at_x.eval_matrix(&mut g.graph, x, &c);
    let h_exprs = g.h.clone();
    let h = at_x.eval(&mut g.graph, x, &h_exprs);
    let graph = &mut g.graph;
    let residual: Vec<NodeId> = y_vars
        .iter()
        .zip(&h)
        .map(|(&y, &h)| graph.sub(y, h))
        .collect();
    let update = kalman::update(graph, x, p, &residual, &c, &r, |g, j| {
        g.var(&pivot_names(m, j, INNOVATION, "").1)
    });
    (update.x, update.p, update.pivots, update.reciprocals)
}

/// The pivot names of the measurement noise covariance's `L D L'` inverse.
const MEASUREMENT: (&str, &str) = ("measurement_variance", "inv_r");

/// The measurement terms of the continuous-time EKF (seed 004 eq. 5): `R^-1` through
/// guarded pivots, and `h`, `H` as expressions over the measurement time and state.
struct ContinuousTerms {
    r_inv: Matrix,
    r_pivots: Vec<NodeId>,
    r_reciprocals: Vec<NodeId>,
    h: Vec<NodeId>,
    jacobian_h: Matrix,
    at: AtPoint,
}

impl ContinuousTerms {
    fn new(g: &mut ModelGraph, r_vars: &[NodeId], m: usize) -> ContinuousTerms {
        let r = symmetric_from_packed(r_vars, m);
        let ldl = crate::symbolic::linalg::ldl_inverse(&mut g.graph, &r, |gr, j| {
            gr.var(&pivot_names(m, j, MEASUREMENT, "").1)
        });
        let jacobian_h = g.jacobian_h_wrt_x();
        let at = AtPoint::new(
            std::iter::once(g.t)
                .chain(g.x.iter().copied())
                .map(|v| g.var_id(v))
                .collect(),
        );
        ContinuousTerms {
            r_inv: ldl.inverse,
            r_pivots: ldl.pivots,
            r_reciprocals: ldl.reciprocals,
            h: g.h.clone(),
            jacobian_h,
            at,
        }
    }

    /// `dx + K (y - h(x))` and `dp - P H' R^-1 H P` at `point = [t, x..]`.
    fn apply(
        &self,
        g: &mut crate::symbolic::Graph,
        point: &[NodeId],
        y: &[NodeId],
        dx: &[NodeId],
        dp: &Matrix,
        p: &Matrix,
    ) -> (Vec<NodeId>, Matrix) {
        let h = self.at.eval(g, point, &self.h);
        let jacobian_h = self.at.eval_matrix(g, point, &self.jacobian_h);
        let (gain, dp) = riccati_measurement_terms(g, dp, p, &jacobian_h, &self.r_inv);
        let dx = dx
            .iter()
            .zip(&gain)
            .map(|(&rate, gain_row)| {
                let mut v = rate;
                for ((&k, &yj), &hj) in gain_row.iter().zip(y).zip(&h) {
                    let innovation = g.sub(yj, hj);
                    let term = g.mul(k, innovation);
                    v = g.add(v, term);
                }
                v
            })
            .collect();
        (dx, dp)
    }
}

/// The variables of the measurement, `<output>_measured`, avoiding the model's names.
pub fn measured_vars(g: &mut ModelGraph, model: &Model, avoid: &[String]) -> Vec<NodeId> {
    model
        .outputs
        .iter()
        .map(|o| {
            let mut name = format!("{}_measured", o.name);
            while avoid.contains(&name) {
                name.push('_');
            }
            g.graph.var(&name)
        })
        .collect()
}

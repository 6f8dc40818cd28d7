//! The linear time-varying model of the window transform (eq. 12): the model rewritten
//! exactly as `x[k+1] = F x[k] + G u[k] + d` around the reconstructed point `phi`, each
//! product of a parameter and a state (or input) split with the weight `eta` between the
//! parameter's column of `F` and the states' columns.

use crate::model::Model;
use crate::symbolic::diff::Differentiator;
use crate::symbolic::graph::{Graph, Node, NodeId, VarId};
use crate::symbolic::linalg::Matrix;
use crate::symbolic::model_graph::ModelGraph;
use crate::symbolic::substitute;

/// `F`, `G`, `d` of eq. (12) over `phi` and the model's input variables.
pub fn split(
    model: &Model,
    mg: &mut ModelGraph,
    phi: &[NodeId],
    param_vars: &[VarId],
    state_vars: &[VarId],
    eta: f64,
) -> (Matrix, Matrix, Vec<NodeId>) {
    let n = model.states.len();
    let total = model.state_len();
    let input_vars: Vec<VarId> = mg.u.iter().map(|&u| mg.var_id(u)).collect();
    let at_phi: Vec<(VarId, NodeId)> = state_vars
        .iter()
        .chain(param_vars)
        .copied()
        .zip(phi.iter().copied())
        .collect();
    let graph = &mut mg.graph;
    let zero = graph.zero();
    let one = graph.one();
    let ltv = Ltv {
        state_vars,
        param_vars,
        input_vars: &input_vars,
        phi,
        inputs: &mg.u,
        at_phi: &at_phi,
        eta: graph.num(eta),
        rest_weight: graph.num(1.0 - eta),
    };
    let mut f = vec![vec![zero; total]; total];
    let mut g = vec![vec![zero; model.inputs.len()]; total];
    let mut d = vec![zero; total];
    for c in 0..n {
        let (state_columns, param_columns) = f[c].split_at_mut(n);
        let r = ltv.split_parameter_products(graph, mg.f[c], param_columns);
        d[c] = ltv.linearise_rest(graph, r, state_columns, &mut g[c]);
    }
    for p in 0..model.params.len() {
        f[n + p][n + p] = one;
    }
    (f, g, d)
}

/// What every row of eq. (12) shares: the variables, the point `phi` (and input `u`) the
/// model is rewritten about, and the weight `eta`.
struct Ltv<'a> {
    state_vars: &'a [VarId],
    param_vars: &'a [VarId],
    input_vars: &'a [VarId],
    /// `phi`, states then parameters.
    phi: &'a [NodeId],
    /// The step's input variables `u`.
    inputs: &'a [NodeId],
    /// The substitution putting every state and parameter at `phi`.
    at_phi: &'a [(VarId, NodeId)],
    /// `eta`, as a node.
    eta: NodeId,
    /// `1 - eta`, as a node.
    rest_weight: NodeId,
}

impl Ltv<'_> {
    /// The split of a row's state-parameter products (eq. 12): fills its parameter columns,
    /// `F[c][p] = eta a_p(phi, u)` with `a_p = df/dtheta_p`, and returns what stays on the
    /// states, `r = f|theta=0 + (1 - eta) sum_p phi_p a_p`.
    fn split_parameter_products(
        &self,
        graph: &mut Graph,
        row: NodeId,
        param_columns: &mut [NodeId],
    ) -> NodeId {
        let n = self.state_vars.len();
        let zero = graph.zero();
        let zeros: Vec<(VarId, NodeId)> = self.param_vars.iter().map(|&p| (p, zero)).collect();
        let mut r = substitute(graph, row, &zeros);
        for (p, &pv) in self.param_vars.iter().enumerate() {
            let mut dp = Differentiator::new(pv);
            let coef = dp.diff(graph, row);
            if graph.is_zero(coef) {
                continue;
            }
            let at = substitute(graph, coef, self.at_phi);
            param_columns[p] = graph.mul(self.eta, at);
            let weighted = graph.mul(self.rest_weight, self.phi[n + p]);
            let term = graph.mul(weighted, coef);
            r = graph.add(r, term);
        }
        r
    }

    /// The states' and inputs' columns of a row, `F[c][s] = dr/ds (phi, u)` and
    /// `G[c][j] = dr/du_j (phi, u)`, and its known term `d`: `r`'s constant part, exactly,
    /// when `r` is affine in the states and inputs, else the sum of its terms'
    /// [`Ltv::affine_correction`]s.
    fn linearise_rest(
        &self,
        graph: &mut Graph,
        r: NodeId,
        state_columns: &mut [NodeId],
        input_columns: &mut [NodeId],
    ) -> NodeId {
        let (derivatives, affine_row) = self.first_derivatives(graph, r);
        // The offset `r(phi) - F phi - G u` is replaced by the exact forms below; it is still
        // built, in this order, so that the graph's nodes (whose numbering orders the
        // operands of sums and products) stay as they were.
        let (slopes, _offset) = self.tangent_at_phi(graph, r, &derivatives);
        let (state_slopes, input_slopes) = slopes.split_at(self.state_vars.len());
        state_columns.copy_from_slice(state_slopes);
        input_columns.copy_from_slice(input_slopes);
        if affine_row {
            return self.constant_part(graph, r);
        }
        let mut known = graph.zero();
        for (negative, term) in additive_terms(graph, r) {
            let part = self.affine_correction(graph, term);
            known = if negative {
                graph.sub(known, part)
            } else {
                graph.add(known, part)
            };
        }
        known
    }

    /// What `term` adds to `d`: its constant part if it is affine in the states and inputs,
    /// else `term(phi) - sum_s dterm/ds(phi) phi_s - sum_j dterm/du_j(phi) u_j`.
    fn affine_correction(&self, graph: &mut Graph, term: NodeId) -> NodeId {
        let (derivatives, affine) = self.first_derivatives(graph, term);
        if affine {
            return self.constant_part(graph, term);
        }
        self.tangent_at_phi(graph, term, &derivatives).1
    }

    /// The derivatives of `expr` in each state, then each input, and whether `expr` is
    /// affine in them (every second derivative zero).
    fn first_derivatives(&self, graph: &mut Graph, expr: NodeId) -> (Vec<NodeId>, bool) {
        let mut derivatives = Vec::new();
        let vars: Vec<VarId> = self
            .state_vars
            .iter()
            .chain(self.input_vars)
            .copied()
            .collect();
        let mut affine = !graph.switches_on(expr, &vars);
        for &v in self.state_vars.iter().chain(self.input_vars) {
            let mut dv = Differentiator::new(v);
            let deriv = dv.diff(graph, expr);
            for &w in self.state_vars.iter().chain(self.input_vars) {
                let mut dw = Differentiator::new(w);
                let second = dw.diff(graph, deriv);
                affine &= graph.is_zero(second);
            }
            derivatives.push(deriv);
        }
        (derivatives, affine)
    }

    /// The slopes of `expr` at `phi` (its `derivatives` there) and its value at `phi` less
    /// its tangent there, `expr(phi) - sum_s slope_s phi_s - sum_j slope_j u_j`.
    fn tangent_at_phi(
        &self,
        graph: &mut Graph,
        expr: NodeId,
        derivatives: &[NodeId],
    ) -> (Vec<NodeId>, NodeId) {
        let mut value = substitute(graph, expr, self.at_phi);
        let points = self
            .phi
            .iter()
            .take(self.state_vars.len())
            .chain(self.inputs);
        let mut slopes = Vec::with_capacity(derivatives.len());
        for (&deriv, &point) in derivatives.iter().zip(points) {
            let slope = substitute(graph, deriv, self.at_phi);
            let tangent = graph.mul(slope, point);
            value = graph.sub(value, tangent);
            slopes.push(slope);
        }
        (slopes, value)
    }

    /// `expr` with the states and inputs at zero, then at `phi`: the constant part of an
    /// expression affine in the states and inputs.
    fn constant_part(&self, graph: &mut Graph, expr: NodeId) -> NodeId {
        let zero = graph.zero();
        let origin: Vec<(VarId, NodeId)> = self
            .state_vars
            .iter()
            .chain(self.input_vars)
            .map(|&v| (v, zero))
            .collect();
        let constant = substitute(graph, expr, &origin);
        substitute(graph, constant, self.at_phi)
    }
}

/// The additive terms of `node`, each with whether it is subtracted.
fn additive_terms(graph: &Graph, node: NodeId) -> Vec<(bool, NodeId)> {
    match graph.node(node) {
        Node::Add(a, b) => {
            let mut terms = additive_terms(graph, a);
            terms.extend(additive_terms(graph, b));
            terms
        }
        Node::Sub(a, b) => {
            let mut terms = additive_terms(graph, a);
            terms.extend(
                additive_terms(graph, b)
                    .into_iter()
                    .map(|(neg, t)| (!neg, t)),
            );
            terms
        }
        Node::Neg(a) => additive_terms(graph, a)
            .into_iter()
            .map(|(neg, t)| (!neg, t))
            .collect(),
        _ => vec![(false, node)],
    }
}

//! Lowers a model into the graph: the discrete step `f`, the measurement `h`, and their
//! Jacobians, all as nodes over the variables `t`, `x` and `u`.

use super::diff::Differentiator;
use super::error_state::{self, TangentLayout};
use super::graph::{Graph, Node, NodeId, VarId};
use crate::model::{Discretisation, Expr, Method, Model};

/// A model as graph nodes.
#[derive(Clone)]
pub struct ModelGraph {
    /// The graph holding every node below.
    pub graph: Graph,
    /// The time variable.
    pub t: NodeId,
    /// The state vector's variables: physical states, then parameters.
    pub x: Vec<NodeId>,
    /// The inputs' variables.
    pub u: Vec<NodeId>,
    /// The variables of the constants known at run time.
    pub known: Vec<NodeId>,
    /// Named constants, by index into the model's constants: the sample interval's
    /// (`interval DT = ..`) a variable, [`ModelGraph::interval`].
    pub constants: Vec<NodeId>,
    /// The sample interval's variable (`dt`), if the model declares one.
    pub interval: Option<NodeId>,
    /// `x[k+1] = f(t, x[k], u[k])`, one node per entry of the state vector.
    pub f: Vec<NodeId>,
    /// `f` before its rotations are renormalised ([`crate::model::Dynamics::renormalised`]):
    /// what the error-state Jacobian differentiates. `f` itself for a model without one.
    pub f_unnormalised: Vec<NodeId>,
    /// `y = h(t, x, u)`, one node per output.
    pub h: Vec<NodeId>,
    /// Where the state's rotations are: a filter's covariance is over the tangent space.
    pub tangent: TangentLayout,
}

/// The point at which the dynamics are evaluated: a time and physical states. Parameters,
/// inputs and constants are always the model's own variables.
struct Env {
    t: NodeId,
    states: Vec<NodeId>,
    /// Lowered `let` intermediates of this evaluation of the dynamics.
    locals: Vec<Option<NodeId>>,
}

impl ModelGraph {
    /// Builds `f` (discretising continuous dynamics) and `h` for `model`.
    pub fn build(model: &Model) -> ModelGraph {
        let mut graph = Graph::new();
        let t = graph.var("t");
        let x: Vec<NodeId> = model.state_names().map(|n| graph.var(n)).collect();
        let u: Vec<NodeId> = model.inputs.iter().map(|s| graph.var(&s.name)).collect();
        let known: Vec<NodeId> = model.known.iter().map(|s| graph.var(&s.name)).collect();
        let constants: Vec<NodeId> = model
            .constants
            .iter()
            .map(|c| {
                if c.interval {
                    graph.var(crate::model::INTERVAL_PARAMETER)
                } else {
                    graph.named_const(&c.name, c.value)
                }
            })
            .collect();
        let interval = model.interval().map(|i| constants[i]);
        let mut mg = ModelGraph {
            graph,
            t,
            x,
            u,
            known,
            constants,
            interval,
            f: Vec::new(),
            f_unnormalised: Vec::new(),
            tangent: TangentLayout::of(model),
            h: Vec::new(),
        };
        let states = mg.x[..model.states.len()].to_vec();

        let next_states = match &model.dynamics.discretisation {
            Discretisation::Discrete => mg.rhs(model, t, &states),
            // Too many sub-steps to unroll: `f` is generated as a loop of sub-steps
            // (`emit::substeps`), and no unrolled step exists.
            Discretisation::Continuous { .. } if model.dynamics.discretisation.is_looped() => {
                Vec::new()
            }
            Discretisation::Continuous {
                method,
                dt,
                substeps,
            } => {
                let dt = mg.lower(model, dt, &mut Env::at(model, t, Vec::new()));
                let n = mg.graph.num(f64::from(*substeps));
                let h = mg.graph.div(dt, n);
                let mut current = states;
                let mut time = t;
                for step in 1..=*substeps {
                    current = match method {
                        Method::Euler => mg.euler_step(model, &current, time, h),
                        Method::Rk4 => mg.rk4_step(model, &current, time, h),
                    };
                    if step < *substeps {
                        mg.name_stage(model, &current, "", &format!("_substep{step}"));
                    }
                    time = mg.graph.add(time, h);
                }
                current
            }
        };
        // Parameters are random walks: their prediction is themselves.
        let params = mg.x[model.states.len()..].to_vec();
        if !model.dynamics.discretisation.is_looped() {
            mg.f_unnormalised = next_states.into_iter().chain(params).collect();
            mg.f = mg.renormalised(model, &mg.f_unnormalised.clone());
        }
        let states = mg.x[..model.states.len()].to_vec();
        let mut env = Env::at(model, t, states);
        mg.h = model
            .outputs
            .iter()
            .map(|output| mg.lower(model, &output.expr, &mut env))
            .collect();
        mg
    }

    /// `next` with each rotation state's quaternion renormalised by one Newton step,
    /// `q (3 - q·q) / 2`: it squares the norm's error, so a rotation advanced every sample
    /// stays a unit quaternion to rounding.
    fn renormalised(&mut self, model: &Model, next: &[NodeId]) -> Vec<NodeId> {
        let mut next = next.to_vec();
        for &first in &model.dynamics.renormalised {
            let q = [
                next[first],
                next[first + 1],
                next[first + 2],
                next[first + 3],
            ];
            let unit = crate::geometry::renormalize(&mut self.graph, q);
            next[first..first + 4].copy_from_slice(&unit);
        }
        next
    }

    /// The right-hand sides of the dynamics at time `t` and physical states `states`.
    fn rhs(&mut self, model: &Model, t: NodeId, states: &[NodeId]) -> Vec<NodeId> {
        let mut env = Env::at(model, t, states.to_vec());
        // Intermediates in the order they are written (each reads only earlier ones), so
        // lowering one never recurses through a chain of them.
        for (i, local) in model.locals.iter().enumerate() {
            let node = self.lower(model, &local.expr, &mut env);
            self.graph.set_name_hint(node, &local.name);
            env.locals[i] = Some(node);
        }
        model
            .dynamics
            .rhs
            .iter()
            .map(|e| self.lower(model, e, &mut env))
            .collect()
    }

    /// `dx/dt` of the whole state vector at time `t` and physical states `states`: the
    /// model's right-hand sides, then zeros for the parameters (random walks).
    pub fn derivative(&mut self, model: &Model, t: NodeId, states: &[NodeId]) -> Vec<NodeId> {
        let mut rates = self.rhs(model, t, &states[..model.states.len()]);
        rates.extend(model.params.iter().map(|_| self.graph.zero()));
        rates
    }

    /// The sample time `dt` of continuous dynamics (the time between a sample and the
    /// next); `None` if discrete, whose model does not state it.
    pub fn sample_time(&mut self, model: &Model) -> Option<NodeId> {
        let Discretisation::Continuous { dt, .. } = &model.dynamics.discretisation else {
            return None;
        };
        let t = self.t;
        Some(self.lower(model, dt, &mut Env::at(model, t, Vec::new())))
    }

    /// The integration rule of continuous dynamics, the length of one sub-step
    /// (`dt / substeps`) and the number of sub-steps per sample; `None` if discrete.
    pub fn substep(&mut self, model: &Model) -> Option<(Method, NodeId, u32)> {
        let Discretisation::Continuous {
            method,
            dt,
            substeps,
        } = &model.dynamics.discretisation
        else {
            return None;
        };
        let t = self.t;
        let dt = self.lower(model, dt, &mut Env::at(model, t, Vec::new()));
        let n = self.graph.num(f64::from(*substeps));
        let h = self.graph.div(dt, n);
        Some((*method, h, *substeps))
    }

    /// One forward Euler step: `x + h f(t, x)`.
    fn euler_step(&mut self, model: &Model, x: &[NodeId], t: NodeId, h: NodeId) -> Vec<NodeId> {
        let k1 = self.rhs(model, t, x);
        self.name_stage(model, &k1, "der_", "");
        self.axpy(x, h, &k1)
    }

    /// Names the nodes of one integration stage after the states, for readable code.
    fn name_stage(&mut self, model: &Model, nodes: &[NodeId], prefix: &str, suffix: &str) {
        for (node, state) in nodes.iter().zip(&model.states) {
            let name = format!("{prefix}{}{suffix}", state.name);
            self.graph.set_name_hint(*node, &name);
        }
    }

    /// One classical Runge-Kutta step.
    fn rk4_step(&mut self, model: &Model, x: &[NodeId], t: NodeId, h: NodeId) -> Vec<NodeId> {
        let half = self.graph.num(0.5);
        let half_h = self.graph.mul(half, h);
        let t_mid = self.graph.add(t, half_h);
        let t_end = self.graph.add(t, h);
        let k1 = self.rhs(model, t, x);
        let x2 = self.axpy(x, half_h, &k1);
        let k2 = self.rhs(model, t_mid, &x2);
        let x3 = self.axpy(x, half_h, &k2);
        let k3 = self.rhs(model, t_mid, &x3);
        let x4 = self.axpy(x, h, &k3);
        let k4 = self.rhs(model, t_end, &x4);
        for (stage, (k, x)) in [(&k1, x), (&k2, &x2[..]), (&k3, &x3[..]), (&k4, &x4[..])]
            .into_iter()
            .enumerate()
        {
            let n = stage + 1;
            self.name_stage(model, k, &format!("k{n}_"), "");
            if n > 1 {
                self.name_stage(model, x, "", &format!("_stage{n}"));
            }
        }
        let sixth = self.graph.num(1.0 / 6.0);
        let h_sixth = self.graph.mul(h, sixth);
        let two = self.graph.num(2.0);
        (0..x.len())
            .map(|i| {
                let g = &mut self.graph;
                let middle = g.add(k2[i], k3[i]);
                let twice_middle = g.mul(two, middle);
                let ends = g.add(k1[i], k4[i]);
                let sum = g.add(ends, twice_middle);
                let step = g.mul(h_sixth, sum);
                g.add(x[i], step)
            })
            .collect()
    }

    /// `x + a * y`, entry by entry.
    fn axpy(&mut self, x: &[NodeId], a: NodeId, y: &[NodeId]) -> Vec<NodeId> {
        x.iter()
            .zip(y)
            .map(|(&xi, &yi)| {
                let step = self.graph.mul(a, yi);
                self.graph.add(xi, step)
            })
            .collect()
    }

    /// Lowers a model expression at the point `env` describes.
    fn lower(&mut self, model: &Model, expr: &Expr, env: &mut Env) -> NodeId {
        match expr {
            Expr::Number(v) => self.graph.num(*v),
            Expr::Const(i) => self.constants[*i],
            Expr::State(i) => env.states[*i],
            Expr::Param(i) => self.x[model.states.len() + *i],
            Expr::Input(i) => self.u[*i],
            Expr::Known(i) => self.known[*i],
            Expr::Time => env.t,
            Expr::Local(i) => {
                if let Some(done) = env.locals[*i] {
                    return done;
                }
                let local = &model.locals[*i];
                let node = self.lower(model, &local.expr, env);
                self.graph.set_name_hint(node, &local.name);
                env.locals[*i] = Some(node);
                node
            }
            Expr::Neg(a) => {
                let a = self.lower(model, a, env);
                self.graph.neg(a)
            }
            Expr::Add(a, b) => {
                let (a, b) = (self.lower(model, a, env), self.lower(model, b, env));
                self.graph.add(a, b)
            }
            Expr::Sub(a, b) => {
                let (a, b) = (self.lower(model, a, env), self.lower(model, b, env));
                self.graph.sub(a, b)
            }
            Expr::Mul(a, b) => {
                let (a, b) = (self.lower(model, a, env), self.lower(model, b, env));
                self.graph.mul(a, b)
            }
            Expr::Div(a, b) => {
                let (a, b) = (self.lower(model, a, env), self.lower(model, b, env));
                self.graph.div(a, b)
            }
            Expr::Powi(a, n) => {
                let a = self.lower(model, a, env);
                self.graph.powi(a, *n)
            }
            Expr::Call(f, a) => {
                let a = self.lower(model, a, env);
                self.graph.call(*f, a)
            }
            Expr::Atan2(y, x) => {
                let (y, x) = (self.lower(model, y, env), self.lower(model, x, env));
                self.graph.atan2(y, x)
            }
            Expr::Select {
                cmp,
                lhs,
                rhs,
                then,
                otherwise,
            } => {
                let lhs = self.lower(model, lhs, env);
                let rhs = self.lower(model, rhs, env);
                let then = self.lower(model, then, env);
                let otherwise = self.lower(model, otherwise, env);
                self.graph.select(*cmp, lhs, rhs, then, otherwise)
            }
        }
    }

    /// Names the time variable `name` in generated code: a method that evaluates the
    /// model at one time names it for what that time is (`t_prev`). Returns its node.
    pub fn name_time(&mut self, name: &str) -> NodeId {
        let t = self.var_id(self.t);
        self.graph.rename_var(t, name);
        self.t
    }

    /// The variable behind a variable node.
    pub fn var_id(&self, node: NodeId) -> VarId {
        match self.graph.node(node) {
            Node::Var(v) => v,
            other => unreachable!("not a variable node: {other:?}"),
        }
    }

    /// `d rows[i] / d wrt[j]`, row by row.
    pub fn jacobian(&mut self, rows: &[NodeId], wrt: &[NodeId]) -> Vec<Vec<NodeId>> {
        let mut table = vec![Vec::with_capacity(wrt.len()); rows.len()];
        for &var in wrt {
            let mut d = Differentiator::new(self.var_id(var));
            for (row, &r) in table.iter_mut().zip(rows) {
                row.push(d.diff(&mut self.graph, r));
            }
        }
        table
    }

    /// The Jacobian of `f` with respect to the state vector.
    pub fn jacobian_f_wrt_x(&mut self) -> Vec<Vec<NodeId>> {
        let (f, x) = (self.f.clone(), self.x.clone());
        self.jacobian(&f, &x)
    }

    /// The Jacobian of `f` with respect to the inputs.
    pub fn jacobian_f_wrt_u(&mut self) -> Vec<Vec<NodeId>> {
        let (f, u) = (self.f.clone(), self.u.clone());
        self.jacobian(&f, &u)
    }

    /// The Jacobian of `f` over the tangent space, `F = d(f(x ⊞ δx) ⊟ f(x))/dδx` at
    /// `δx = 0`: [`ModelGraph::jacobian_f_wrt_x`] between the maps' Jacobians at `f(x)`
    /// and at `x` (see [`error_state`]); itself for a state without a rotation.
    pub fn tangent_jacobian_f_wrt_x(&mut self) -> Vec<Vec<NodeId>> {
        if self.tangent.is_euclidean() {
            return self.jacobian_f_wrt_x();
        }
        // The renormalisation is left out: its derivative at a unit quaternion `r` is
        // `I - r rᵀ` (to rounding), and the error's map at `r` annihilates `r`.
        let (layout, f, x) = (self.tangent.clone(), self.f.clone(), self.x.clone());
        let next = self.f_unnormalised.clone();
        let a = self.jacobian(&next, &x);
        let local = error_state::local_jacobian(&mut self.graph, &layout, &f);
        let retraction = error_state::retraction_jacobian(&mut self.graph, &layout, &x);
        let mut tangent =
            error_state::to_tangent(&mut self.graph, Some(&local), &a, Some(&retraction));
        for &r in &layout.rotations {
            if error_state::turns_by_right_factor(&mut self.graph, (&x, &next), r, &a) {
                let t = r.tangent;
                for (i, row) in tangent[t..t + 3].iter_mut().enumerate() {
                    for (j, entry) in row[t..t + 3].iter_mut().enumerate() {
                        *entry = if i == j {
                            self.graph.one()
                        } else {
                            self.graph.zero()
                        };
                    }
                }
            }
        }
        tangent
    }

    /// The Jacobian of `f` with respect to the inputs, taken to the tangent space of the
    /// state, `G = d(f(x, u + δu) ⊟ f(x, u))/dδu` at `δu = 0`:
    /// [`ModelGraph::jacobian_f_wrt_u`] after the local map's Jacobian at `f(x)` (see
    /// [`error_state`]); itself for a state without a rotation.
    pub fn tangent_jacobian_f_wrt_u(&mut self) -> Vec<Vec<NodeId>> {
        if self.tangent.is_euclidean() {
            return self.jacobian_f_wrt_u();
        }
        // Without the renormalisation, as `tangent_jacobian_f_wrt_x`.
        let (layout, f, u) = (self.tangent.clone(), self.f.clone(), self.u.clone());
        let b = self.jacobian(&self.f_unnormalised.clone(), &u);
        let local = error_state::local_jacobian(&mut self.graph, &layout, &f);
        error_state::to_tangent(&mut self.graph, Some(&local), &b, None)
    }

    /// The Jacobian of `h` over the tangent space, `d h(x ⊞ δx)/dδx` at `δx = 0`; itself
    /// for a state without a rotation.
    pub fn tangent_jacobian_h_wrt_x(&mut self) -> Vec<Vec<NodeId>> {
        let c = self.jacobian_h_wrt_x();
        if self.tangent.is_euclidean() {
            return c;
        }
        let (layout, x) = (self.tangent.clone(), self.x.clone());
        let retraction = error_state::retraction_jacobian(&mut self.graph, &layout, &x);
        error_state::to_tangent(&mut self.graph, None, &c, Some(&retraction))
    }

    /// The Jacobian of `h` with respect to the state vector.
    pub fn jacobian_h_wrt_x(&mut self) -> Vec<Vec<NodeId>> {
        let (h, x) = (self.h.clone(), self.x.clone());
        self.jacobian(&h, &x)
    }
}

impl Env {
    fn at(model: &Model, t: NodeId, states: Vec<NodeId>) -> Env {
        Env {
            t,
            states,
            locals: vec![None; model.locals.len()],
        }
    }
}

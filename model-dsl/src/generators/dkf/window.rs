//! The LTV window transform (eqs. 4-12), the first stage of the double Kalman filter,
//! derived from the model.
//!
//! From a window of past outputs and inputs it reconstructs every state and parameter
//! (`phi`), then rewrites the model exactly as `x[k+1] = F x[k] + G u[k] + d` around
//! `phi`, splitting each product of a parameter and a state (or input) with the weight
//! `eta` (eq. 12). The derivation:
//! 1. Measured states are known at lag 0 (`y = x_j`).
//! 2. A known state `a` whose step is `a[k+1] = a[k] + c b[k] + (known terms)`, with `c`
//!    a constant and no parameter, determines `b` one sample later by a finite
//!    difference: `b[k] = (a[k+1] - rest) / c` (the paper's `x2 = dy`).
//! 3. Every state whose step depends on parameters gives, at each past sample, one
//!    equation linear in the parameters (eq. 8). Equations are taken from the most
//!    recent samples until they determine every parameter structurally; the system is
//!    solved by Cramer's rule with its determinant (eq. 9).
//! 4. States known only with a lag are propagated to the window's end with the model
//!    and the solved parameters (the paper's `phi2`).
//!
//! A window longer than the minimum (`dkf(window = N)`) takes every parameter row at
//! every sample the window reaches, an over-determined system solved by least squares
//! (its normal equations, see [`super::transform`]): the window's noise is averaged over
//! the equations instead of amplified by the fewest samples that determine the parameters.
//!
//! A model outside this class gets a compile error naming the term that breaks it.

use super::ltv;
use crate::model::Model;
use crate::symbolic::diff::Differentiator;
use crate::symbolic::graph::{Graph, Node, NodeId, VarId};
use crate::symbolic::linalg::Matrix;
use crate::symbolic::model_graph::ModelGraph;
use crate::symbolic::substitute;
use std::collections::{BTreeSet, HashMap};

/// Most parameters the unrolled window solve supports (Cramer's rule grows as `P!`).
pub const MAX_PARAMS: usize = 5;

/// Most output samples a window holds (`window = ..`): the least-squares sums are
/// unrolled, so the transform's code grows with the window.
pub const MAX_WINDOW: usize = 200;

/// How a physical state is known from the window.
#[derive(Clone, Debug)]
enum Known {
    /// Measured directly by output `output`.
    Measured { output: usize },
    /// From the step of state `from`: `state[j] = (from[j+1] - rest(j)) / coef`.
    Difference {
        from: usize,
        coef: NodeId,
        rest: NodeId,
    },
}

/// One row of the parameter system: `sum_p coefficients[p] theta_p = rhs`.
#[derive(Clone, Debug)]
struct Equation {
    /// The [`ParamRow`] it takes, by index.
    row: usize,
    /// The sample it is taken at: the step from `k - delay` to `k - delay + 1`.
    delay: usize,
}

/// The derived transform, as nodes of the model's graph.
pub struct WindowTransform {
    /// Window variables `y_i[k - d]`: `[output][d]`, `d = 0..=output_delays`.
    pub outputs: Vec<Vec<NodeId>>,
    /// Window variables `u_j[k - d]`: `[input][d - 1]`, `d = 1..=input_delays` (the input
    /// at the window's end, `d = 0`, is the step's own input, the model's `u`).
    pub inputs: Vec<Vec<NodeId>>,
    /// The parameter system's matrix, `[equation][parameter]`, over the window variables.
    pub matrix: Matrix,
    /// Its right-hand side.
    pub rhs: Vec<NodeId>,
    /// Per parameter, the inputs (window variables) its column consists of, if the column
    /// depends on inputs only: when they are all zero the parameter is not determined and
    /// is frozen (Case 2).
    pub input_only: Vec<Option<Vec<NodeId>>>,
    /// Variables standing for the solved parameters, `phi_x3` ...
    pub phi_params: Vec<NodeId>,
    /// The reconstructed physical states at the window's end, over the window variables,
    /// the step's input and `phi_params`.
    pub phi_states: Vec<NodeId>,
    /// Variables standing for the whole reconstructed vector `phi` (states, parameters).
    pub phi: Vec<NodeId>,
    /// `F` over `phi` and the step's input `u`.
    pub f: Matrix,
    /// `G` over `phi` and `u`.
    pub g: Matrix,
    /// The known affine term `d` over `phi` and `u` (zero where the model is bilinear).
    pub d: Vec<NodeId>,
    /// Number of past outputs before the window's end the transform reads.
    pub output_delays: usize,
    /// Number of past inputs before the window's end the transform reads.
    pub input_delays: usize,
    /// The fewest output samples that determine the parameters (the paper's window).
    pub minimum_window: usize,
    /// Per parameter row, its most recent equation (an index into `matrix`): whose noise
    /// gain stands for every equation of that row in the parameters' covariance.
    pub newest_equations: Vec<usize>,
    /// A plain-words account of the derivation, for the generated documentation.
    pub description: Vec<String>,
}

/// Derives the window transform of `model` over `window` output samples (the minimum if
/// `None` or shorter), or says why the model is outside the class.
pub fn derive(
    model: &Model,
    mg: &mut ModelGraph,
    eta: f64,
    window: Option<usize>,
) -> Result<WindowTransform, String> {
    check_class(model)?;
    let n = model.states.len();
    let np = model.params.len();
    let mut steps = Derivation {
        model,
        state_vars: (0..n).map(|i| mg.var_id(mg.x[i])).collect(),
        param_vars: (n..n + np).map(|i| mg.var_id(mg.x[i])).collect(),
        description: Vec::new(),
    };
    // 1. Measured states; 2. states determined by finite differences of known ones.
    let mut known = steps.measured_states(mg)?;
    steps.difference_states(mg, &mut known);
    let lag = steps.lags(&known)?;
    // 3. Parameter equations: rows linear in the parameters, from the most recent samples.
    let rows = steps.parameter_rows(mg, &lag)?;
    let equations = steps.choose_equations(mg, &rows)?;

    // Window variables, then the values of states at past samples.
    // Values at delay `d` read outputs at delays up to `d`; propagation reads up to the lag.
    let minimal_delays = equations
        .iter()
        .map(|e| e.delay)
        .max()
        .unwrap_or(0)
        .max(lag.iter().copied().max().unwrap_or(0));
    let (equations, output_delays) = match window {
        Some(samples) if samples > minimal_delays + 1 => {
            let equations = every_equation(&rows, samples - 1);
            steps.description.push(format!(
                "The window is longer than the {} samples that determine the parameters: its \
                 {} equations are solved by least squares.",
                minimal_delays + 1,
                equations.len()
            ));
            (equations, samples - 1)
        }
        _ => (equations, minimal_delays),
    };
    let mut window = Window::new(model, mg, output_delays, &known, &lag);
    let (matrix, rhs) = steps.parameter_system(mg, &mut window, &rows, &equations);
    let input_delays = window.input_delays_used(mg, &matrix, &rhs);
    let input_only = input_only_columns(mg, &window, &matrix, np);
    // 4. Reconstructed states at the window's end.
    let (phi_params, phi_states, phi) = reconstruction(model, mg, &mut window);

    // 5. F, G, d around phi, eq. (12).
    let (f, g, d) = ltv::split(model, mg, &phi, &steps.param_vars, &steps.state_vars, eta);
    steps.description.push(format!(
        "The window holds y[k-{output_delays}..k] and u[k-{input_delays}..k-1]; products of a \
         parameter and a state or input are split with eta = {eta} (eq. 12)."
    ));
    Ok(WindowTransform {
        outputs: window.outputs,
        inputs: window.inputs[..]
            .iter()
            .map(|v| v[..input_delays].to_vec())
            .collect(),
        matrix,
        rhs,
        input_only,
        phi_params,
        phi_states,
        phi,
        f,
        g,
        d,
        output_delays,
        input_delays,
        minimum_window: minimal_delays + 1,
        newest_equations: newest_equations(&equations),
        description: steps.description,
    })
}

impl WindowTransform {
    /// Whether the window is longer than the minimum: its system has more equations than
    /// parameters and is solved by least squares.
    pub fn least_squares(&self) -> bool {
        self.matrix.len() > self.phi_params.len()
    }
}

/// The index of each row's first (most recent) equation.
fn newest_equations(equations: &[Equation]) -> Vec<usize> {
    let mut seen = BTreeSet::new();
    (0..equations.len())
        .filter(|&e| seen.insert(equations[e].row))
        .collect()
}

/// Every row at every sample a window reaching `deepest` samples back gives it, the most
/// recent first: the over-determined system of a window longer than the minimum.
fn every_equation(rows: &[ParamRow], deepest: usize) -> Vec<Equation> {
    (1..=deepest)
        .flat_map(|delay| {
            rows.iter()
                .enumerate()
                .filter(move |(_, row)| row.min_delay <= delay)
                .map(move |(row, _)| Equation { row, delay })
        })
        .collect()
}

/// Whether `model` is in the transform's class as a whole: time-invariant, with between one
/// and [`MAX_PARAMS`] parameters.
fn check_class(model: &Model) -> Result<(), String> {
    if model.uses_time() {
        return Err(
            "the window transform needs a time-invariant model: the dynamics use `t`".into(),
        );
    }
    let np = model.params.len();
    if np == 0 {
        return Err(
            "the double Kalman filter estimates parameters: declare at least one `param`".into(),
        );
    }
    if np > MAX_PARAMS {
        return Err(format!(
            "the unrolled window solve supports at most {MAX_PARAMS} parameters, the model has {np}"
        ));
    }
    Ok(())
}

/// How each physical state is known, and after how many samples (its lag).
type KnownStates = Vec<Option<(Known, usize)>>;

/// A row of the model linear in the parameters (eq. 8): `f_state = sum_p coefficients[p]
/// theta_p + rest`, usable at delays from `min_delay` on.
struct ParamRow {
    state: usize,
    coefficients: Vec<NodeId>,
    rest: NodeId,
    min_delay: usize,
}

/// The derivation's steps 1-3 on one model: its state and parameter variables, and the
/// plain-words account of what each step found.
struct Derivation<'m> {
    model: &'m Model,
    state_vars: Vec<VarId>,
    param_vars: Vec<VarId>,
    description: Vec<String>,
}

impl Derivation<'_> {
    /// Step 1: the states the outputs measure directly (`y = x_j`), known at lag 0.
    fn measured_states(&mut self, mg: &ModelGraph) -> Result<KnownStates, String> {
        let model = self.model;
        let mut known: KnownStates = vec![None; model.states.len()];
        for (i, (&h, output)) in mg.h.iter().zip(&model.outputs).enumerate() {
            match mg.graph.node(h) {
                Node::Var(v) if self.state_vars.contains(&v) => {
                    let s = self.state_vars.iter().position(|&x| x == v).unwrap_or(0);
                    if known[s].is_none() {
                        known[s] = Some((Known::Measured { output: i }, 0));
                        self.description.push(format!(
                            "`{}` is measured by `{}`.",
                            model.states[s].name, output.name
                        ));
                    }
                }
                _ => {
                    return Err(format!(
                        "the output `{}` is not a state: the window transform reads states \
                         from outputs that measure them directly (`output y = x1`)",
                        output.name
                    ))
                }
            }
        }
        Ok(known)
    }

    /// Step 2: states determined by finite differences of known ones, repeated until no
    /// known state's step determines another (the paper's `x2 = dy`).
    fn difference_states(&mut self, mg: &mut ModelGraph, known: &mut KnownStates) {
        let mut progress = true;
        while progress {
            progress = false;
            for a in 0..known.len() {
                let Some((_, lag_a)) = known[a].clone() else {
                    continue;
                };
                let Some((b, difference)) = self.finite_difference(mg, a, known) else {
                    continue;
                };
                known[b] = Some((difference, lag_a + 1));
                self.description.push(format!(
                    "`{}` follows from a finite difference of `{}` (one sample later).",
                    self.model.states[b].name, self.model.states[a].name
                ));
                progress = true;
            }
        }
    }

    /// The one unknown state `b` the step of known state `a` determines, when that step
    /// has no parameter and is `a[k+1] = rest + c b[k]` with `c` a nonzero constant:
    /// `b[k] = (a[k+1] - rest) / c`.
    fn finite_difference(
        &self,
        mg: &mut ModelGraph,
        a: usize,
        known: &KnownStates,
    ) -> Option<(usize, Known)> {
        let row = mg.f[a];
        if !self.param_free(mg, row) {
            return None;
        }
        let unknown: Vec<usize> = (0..known.len())
            .filter(|&b| known[b].is_none())
            .filter(|&b| {
                let mut d = Differentiator::new(self.state_vars[b]);
                let db = d.diff(&mut mg.graph, row);
                !mg.graph.is_zero(db)
            })
            .collect();
        let [b] = unknown[..] else {
            return None;
        };
        let mut d = Differentiator::new(self.state_vars[b]);
        let coef = d.diff(&mut mg.graph, row);
        if mg.graph.constant_value(coef).is_none_or(|c| c == 0.0) {
            return None;
        }
        let zero = mg.graph.zero();
        let rest = substitute(&mut mg.graph, row, &[(self.state_vars[b], zero)]);
        Some((
            b,
            Known::Difference {
                from: a,
                coef,
                rest,
            },
        ))
    }

    /// Whether `row` reads no parameter.
    fn param_free(&self, mg: &mut ModelGraph, row: NodeId) -> bool {
        self.param_vars.iter().all(|&p| {
            let mut d = Differentiator::new(p);
            let dp = d.diff(&mut mg.graph, row);
            mg.graph.is_zero(dp)
        })
    }

    /// Each state's lag after steps 1 and 2, or which state the outputs do not determine.
    fn lags(&self, known: &KnownStates) -> Result<Vec<usize>, String> {
        if let Some(s) = known.iter().position(Option::is_none) {
            return Err(format!(
                "the state `{}` is not determined by the outputs: measure it, or let it appear \
                 with a constant coefficient in the step of a measured (or determined) state \
                 that has no parameter, as `x1 = x1 + TS * x2` determines `x2`",
                self.model.states[s].name
            ));
        }
        Ok(known
            .iter()
            .map(|k| k.as_ref().map_or(0, |(_, l)| *l))
            .collect())
    }

    /// Step 3: the rows of the model that involve parameters, each linear in them (eq. 8),
    /// with the earliest delay at which the window gives every state it reads.
    fn parameter_rows(&self, mg: &mut ModelGraph, lag: &[usize]) -> Result<Vec<ParamRow>, String> {
        let n = self.state_vars.len();
        let mut rows = Vec::new();
        for c in 0..n {
            let row = mg.f[c];
            let coefficients = self.parameter_coefficients(mg, c)?;
            if coefficients.iter().all(|&c| mg.graph.is_zero(c)) {
                continue;
            }
            let zeros: Vec<(VarId, NodeId)> = self
                .param_vars
                .iter()
                .map(|&p| (p, mg.graph.zero()))
                .collect();
            let rest = substitute(&mut mg.graph, row, &zeros);
            let mut reads = BTreeSet::new();
            for &node in coefficients.iter().chain([&rest]) {
                free_vars(&mg.graph, node, &mut reads);
            }
            let max_lag = (0..n)
                .filter(|&s| reads.contains(&self.state_vars[s]))
                .map(|s| lag[s])
                .max()
                .unwrap_or(0);
            rows.push(ParamRow {
                state: c,
                coefficients,
                rest,
                min_delay: max_lag.max(lag[c] + 1).max(1),
            });
        }
        Ok(rows)
    }

    /// The coefficient of each parameter in the step of state `c`, or the product of
    /// parameters that makes the step nonlinear in them.
    fn parameter_coefficients(&self, mg: &mut ModelGraph, c: usize) -> Result<Vec<NodeId>, String> {
        let row = mg.f[c];
        if mg.graph.switches_on(row, &self.param_vars) {
            return Err(format!(
                "the step of `{}` switches on a parameter (an `if` whose condition reads \
                 one): the window transform needs each step linear in the parameters. Make \
                 the switch read states or inputs only",
                self.model.states[c].name
            ));
        }
        let mut coefficients = Vec::with_capacity(self.param_vars.len());
        for (p, &pv) in self.param_vars.iter().enumerate() {
            let mut d = Differentiator::new(pv);
            let coef = d.diff(&mut mg.graph, row);
            for (q, &qv) in self.param_vars.iter().enumerate() {
                let mut dq = Differentiator::new(qv);
                let second = dq.diff(&mut mg.graph, coef);
                if !mg.graph.is_zero(second) {
                    let model = self.model;
                    return Err(format!(
                        "the step of `{}` is not linear in the parameters: it has a term in \
                         `{}` times `{}`. Reparameterise: make the product (or the nonlinear \
                         function of a parameter) one parameter",
                        model.states[c].name, model.params[p].name, model.params[q].name
                    ));
                }
            }
            coefficients.push(coef);
        }
        Ok(coefficients)
    }

    /// Equations from the most recent samples on, each kept while it raises the system's
    /// structural rank, until they determine every parameter (eq. 9 then has a nonzero
    /// determinant for a generic window); or the parameter no row involves.
    fn choose_equations(
        &self,
        mg: &ModelGraph,
        rows: &[ParamRow],
    ) -> Result<Vec<Equation>, String> {
        let np = self.param_vars.len();
        let mut equations: Vec<Equation> = Vec::new();
        let supports: Vec<Vec<usize>> = rows
            .iter()
            .map(|r| {
                (0..np)
                    .filter(|&p| !mg.graph.is_zero(r.coefficients[p]))
                    .collect()
            })
            .collect();
        let mut chosen_supports: Vec<Vec<usize>> = Vec::new();
        let deepest = rows.iter().map(|r| r.min_delay).max().unwrap_or(1) + np;
        'delays: for delay in 1..=deepest {
            for (r, row) in rows.iter().enumerate() {
                if delay < row.min_delay {
                    continue;
                }
                let mut trial = chosen_supports.clone();
                trial.push(supports[r].clone());
                if matching_size(&trial, np) > chosen_supports.len() {
                    chosen_supports = trial;
                    equations.push(Equation { row: r, delay });
                    if equations.len() == np {
                        break 'delays;
                    }
                }
            }
        }
        if equations.len() < np {
            let covered: BTreeSet<usize> = supports.iter().flatten().copied().collect();
            let missing = (0..np).find(|p| !covered.contains(p)).unwrap_or(0);
            return Err(format!(
                "the parameter `{}` does not enter the step of any state the outputs determine, \
                 so no window determines it",
                self.model.params[missing].name
            ));
        }
        Ok(equations)
    }

    /// The parameter system over the window variables (eq. 8): per chosen equation, its
    /// coefficients at its sample, and the state's next value less the row's rest. Each
    /// equation of a square system is described; a least-squares one is described whole.
    fn parameter_system(
        &mut self,
        mg: &mut ModelGraph,
        window: &mut Window,
        rows: &[ParamRow],
        equations: &[Equation],
    ) -> (Matrix, Vec<NodeId>) {
        let mut matrix = Vec::with_capacity(equations.len());
        let mut rhs = Vec::with_capacity(equations.len());
        for e in equations {
            let row = &rows[e.row];
            let coefficients: Vec<NodeId> = row
                .coefficients
                .iter()
                .map(|&c| window.at(mg, c, e.delay))
                .collect();
            let rest = window.at(mg, row.rest, e.delay);
            let next = window.state(mg, row.state, e.delay - 1);
            rhs.push(mg.graph.sub(next, rest));
            matrix.push(coefficients);
            if equations.len() > self.param_vars.len() {
                continue;
            }
            self.description.push(format!(
                "Equation {}: the step of `{}` from sample k-{} to k-{} (eq. 8).",
                matrix.len(),
                self.model.states[row.state].name,
                e.delay,
                e.delay - 1
            ));
        }
        (matrix, rhs)
    }
}

/// Case 2: per parameter, the inputs its column of the system consists of, when it holds
/// inputs only (all of them zero leave the parameter undetermined).
fn input_only_columns(
    mg: &ModelGraph,
    window: &Window,
    matrix: &Matrix,
    np: usize,
) -> Vec<Option<Vec<NodeId>>> {
    let input_vars: BTreeSet<VarId> = window
        .inputs
        .iter()
        .flatten()
        .map(|&node| mg.var_id(node))
        .collect();
    (0..np)
        .map(|p| {
            let mut reads = BTreeSet::new();
            for row in matrix {
                free_vars(&mg.graph, row[p], &mut reads);
            }
            let only_inputs = !reads.is_empty() && reads.iter().all(|v| input_vars.contains(v));
            only_inputs.then(|| {
                window
                    .inputs
                    .iter()
                    .flatten()
                    .copied()
                    .filter(|&node| reads.contains(&mg.var_id(node)))
                    .collect()
            })
        })
        .collect()
}

/// Step 4: the reconstruction at the window's end: the variables standing for the solved
/// parameters, the states over the window and them (those known with a lag propagated
/// with the model, the paper's `phi2`), and the variables standing for the whole `phi`.
fn reconstruction(
    model: &Model,
    mg: &mut ModelGraph,
    window: &mut Window,
) -> (Vec<NodeId>, Vec<NodeId>, Vec<NodeId>) {
    let phi_params: Vec<NodeId> = model
        .params
        .iter()
        .map(|p| mg.graph.var(&format!("phi_{}", p.name)))
        .collect();
    window.phi_params = phi_params.clone();
    let phi_states: Vec<NodeId> = (0..model.states.len())
        .map(|s| window.estimate(mg, s, 0))
        .collect();
    let phi: Vec<NodeId> = model
        .state_names()
        .map(|name| mg.graph.var(&format!("phi_{name}")))
        .collect();
    (phi_params, phi_states, phi)
}

/// Window variables and the values of states at past samples, built on demand.
struct Window {
    outputs: Vec<Vec<NodeId>>,
    inputs: Vec<Vec<NodeId>>,
    known: Vec<Option<(Known, usize)>>,
    lag: Vec<usize>,
    values: HashMap<(usize, usize), NodeId>,
    estimates: HashMap<(usize, usize), NodeId>,
    phi_params: Vec<NodeId>,
    n: usize,
    /// The physical states' names, for the temporaries holding their window values.
    names: Vec<String>,
}

impl Window {
    fn new(
        model: &Model,
        mg: &mut ModelGraph,
        output_delays: usize,
        known: &[Option<(Known, usize)>],
        lag: &[usize],
    ) -> Window {
        let outputs = model
            .outputs
            .iter()
            .map(|o| {
                (0..=output_delays)
                    .map(|d| mg.graph.var(&window_name(&o.name, d)))
                    .collect()
            })
            .collect();
        // Inputs at delays 1..=output_delays + 1 (trimmed to those used later).
        let inputs = model
            .inputs
            .iter()
            .map(|i| {
                (1..=output_delays + 1)
                    .map(|d| mg.graph.var(&window_name(&i.name, d)))
                    .collect()
            })
            .collect();
        Window {
            outputs,
            inputs,
            known: known.to_vec(),
            lag: lag.to_vec(),
            values: HashMap::new(),
            estimates: HashMap::new(),
            phi_params: Vec::new(),
            n: model.states.len(),
            names: model.states.iter().map(|s| s.name.clone()).collect(),
        }
    }

    /// The input variable of input `j` at `delay` (0: the step's own input).
    fn input(&self, mg: &ModelGraph, j: usize, delay: usize) -> NodeId {
        if delay == 0 {
            mg.u[j]
        } else {
            self.inputs[j][delay - 1]
        }
    }

    /// `node` with the states it reads (from the window) and the inputs put at sample
    /// `k - delay`. Only states `node` reads are looked up, so a derived state's own
    /// definition never asks for itself.
    fn at(&mut self, mg: &mut ModelGraph, node: NodeId, delay: usize) -> NodeId {
        let mut reads = BTreeSet::new();
        free_vars(&mg.graph, node, &mut reads);
        let mut map = Vec::new();
        for s in 0..self.n {
            let var = mg.var_id(mg.x[s]);
            if reads.contains(&var) {
                let v = self.state(mg, s, delay);
                map.push((var, v));
            }
        }
        for j in 0..mg.u.len() {
            map.push((mg.var_id(mg.u[j]), self.input(mg, j, delay)));
        }
        substitute(&mut mg.graph, node, &map)
    }

    /// State `s` at sample `k - delay` from the window alone (`delay >= lag[s]`).
    fn state(&mut self, mg: &mut ModelGraph, s: usize, delay: usize) -> NodeId {
        if let Some(&v) = self.values.get(&(s, delay)) {
            return v;
        }
        let value = match self.known[s].clone() {
            Some((Known::Measured { output }, _)) => self.outputs[output][delay],
            Some((Known::Difference { from, coef, rest }, _)) => {
                let next = self.state(mg, from, delay - 1);
                let rest = self.at(mg, rest, delay);
                let difference = mg.graph.sub(next, rest);
                let value = mg.graph.div(difference, coef);
                mg.graph
                    .set_name_hint(value, &window_name(&self.names[s], delay));
                value
            }
            None => unreachable!("every state is known before values are asked for"),
        };
        self.values.insert((s, delay), value);
        value
    }

    /// State `s` at `k - delay` from the window where it reaches, else propagated with the
    /// model and the solved parameters (the paper's `phi2`).
    fn estimate(&mut self, mg: &mut ModelGraph, s: usize, delay: usize) -> NodeId {
        if self.lag[s] <= delay {
            return self.state(mg, s, delay);
        }
        if let Some(&v) = self.estimates.get(&(s, delay)) {
            return v;
        }
        let mut at: Vec<(VarId, NodeId)> = Vec::new();
        for t in 0..self.n {
            let v = self.estimate(mg, t, delay + 1);
            at.push((mg.var_id(mg.x[t]), v));
        }
        for (p, &phi) in self.phi_params.clone().iter().enumerate() {
            at.push((mg.var_id(mg.x[self.n + p]), phi));
        }
        for j in 0..mg.u.len() {
            at.push((mg.var_id(mg.u[j]), self.input(mg, j, delay + 1)));
        }
        let value = substitute(&mut mg.graph, mg.f[s], &at);
        self.estimates.insert((s, delay), value);
        value
    }

    /// The deepest input delay the system reads (at least 1 when propagation needs one).
    fn input_delays_used(&self, mg: &ModelGraph, matrix: &Matrix, rhs: &[NodeId]) -> usize {
        let mut reads = BTreeSet::new();
        for &node in matrix.iter().flatten().chain(rhs) {
            free_vars(&mg.graph, node, &mut reads);
        }
        let deepest_used = self
            .inputs
            .iter()
            .flat_map(|v| v.iter().enumerate())
            .filter(|(_, &node)| reads.contains(&mg.var_id(node)))
            .map(|(d, _)| d + 1)
            .max()
            .unwrap_or(0);
        let propagation = self.lag.iter().copied().max().unwrap_or(0);
        if mg.u.is_empty() {
            0
        } else {
            deepest_used.max(propagation)
        }
    }
}

/// `y_km2` for `y[k-2]`, `y_k` for `y[k]`.
fn window_name(name: &str, delay: usize) -> String {
    if delay == 0 {
        format!("{name}_k")
    } else {
        format!("{name}_km{delay}")
    }
}

/// Adds the variables `root` reads to `out`.
pub fn free_vars(graph: &Graph, root: NodeId, out: &mut BTreeSet<VarId>) {
    let mut stack = vec![root];
    let mut seen = BTreeSet::new();
    while let Some(id) = stack.pop() {
        if !seen.insert(id) {
            continue;
        }
        match graph.node(id) {
            Node::Var(v) => {
                out.insert(v);
            }
            node => stack.extend(node.children()),
        }
    }
}

/// Size of a maximum matching between equations (each with the parameters it involves)
/// and parameters: the structural rank of the system.
fn matching_size(supports: &[Vec<usize>], params: usize) -> usize {
    fn augment(
        e: usize,
        supports: &[Vec<usize>],
        owner: &mut [Option<usize>],
        seen: &mut [bool],
    ) -> bool {
        for &p in &supports[e] {
            if std::mem::replace(&mut seen[p], true) {
                continue;
            }
            if owner[p].is_none_or(|other| augment(other, supports, owner, seen)) {
                owner[p] = Some(e);
                return true;
            }
        }
        false
    }
    let mut owner = vec![None; params];
    (0..supports.len())
        .filter(|&e| augment(e, supports, &mut owner, &mut vec![false; params]))
        .count()
}

/// Cramer's rule: the determinant of `matrix` and the numerators of each unknown, so the
/// solution is `numerators[p] / det`. Minors are shared through the graph.
pub fn cramer(graph: &mut Graph, matrix: &Matrix, rhs: &[NodeId]) -> (NodeId, Vec<NodeId>) {
    let n = matrix.len();
    let rows: Vec<usize> = (0..n).collect();
    let cols: Vec<usize> = (0..n).collect();
    let det = determinant(graph, matrix, &rows, &cols);
    let numerators = (0..n)
        .map(|p| {
            let replaced: Matrix = matrix
                .iter()
                .zip(rhs)
                .map(|(row, &b)| {
                    let mut row = row.clone();
                    row[p] = b;
                    row
                })
                .collect();
            determinant(graph, &replaced, &rows, &cols)
        })
        .collect();
    (det, numerators)
}

/// Laplace expansion along the first of `rows`.
pub fn determinant(graph: &mut Graph, m: &Matrix, rows: &[usize], cols: &[usize]) -> NodeId {
    match rows.len() {
        0 => graph.one(),
        1 => m[rows[0]][cols[0]],
        _ => {
            let mut sum = graph.zero();
            for (k, &c) in cols.iter().enumerate() {
                let entry = m[rows[0]][c];
                if graph.is_zero(entry) {
                    continue;
                }
                let minor_cols: Vec<usize> = cols.iter().copied().filter(|&x| x != c).collect();
                let minor = determinant(graph, m, &rows[1..], &minor_cols);
                let term = graph.mul(entry, minor);
                sum = if k % 2 == 0 {
                    graph.add(sum, term)
                } else {
                    graph.sub(sum, term)
                };
            }
            sum
        }
    }
}

/// The squared column norms' product `prod_p sum_e m[e][p]^2`: `det^2` over it is the
/// squared excitation measure, in `0..=1` (Hadamard's inequality).
pub fn column_norms_product(graph: &mut Graph, m: &Matrix) -> NodeId {
    let mut product = graph.one();
    for p in 0..m.first().map_or(0, Vec::len) {
        let mut norm = graph.zero();
        for row in m {
            let sq = graph.mul(row[p], row[p]);
            norm = graph.add(norm, sq);
        }
        product = graph.mul(product, norm);
    }
    product
}

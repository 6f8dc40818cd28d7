//! Piecewise-linear models and their switched observers ("Observer design for a
//! piecewise linear beam system"). [`regimes`] reads the model's one switching condition
//! and, for each side of it, the constant matrices of `x[k+1] = A_i x + B_i u + c_i`,
//! `y = C x`; [`design`] computes, at generation time, the per-regime gains of the
//! observer `x[k+1] = A_i x + B_i u + c_i + K_i (y - C x)` three ways, each certified by
//! its poles.

use super::spec::SwitchedObserverSpec;
use crate::ast::Comparison;
use crate::model::Model;
use crate::numerics::{self, largest_pole, Mat};
use crate::symbolic::graph::{Graph, Node, NodeId};
use crate::symbolic::ModelGraph;
use std::collections::HashMap;

/// The switching condition `y[output] cmp threshold`, on a measured state.
#[derive(Clone, Debug)]
pub struct Switch {
    /// The output that measures the switching state.
    pub output: usize,
    /// The state it measures.
    pub state: usize,
    /// The comparison, with the state on the left.
    pub cmp: Comparison,
    /// The constant on the right.
    pub threshold: f64,
}

/// A piecewise-linear model's two regimes: index 0 where the condition does not hold
/// (the `else` branches), index 1 where it holds (the `if` branches).
#[derive(Clone, Debug)]
pub struct Regimes {
    /// The switching condition.
    pub switch: Switch,
    /// `A_i = df/dx` in each regime.
    pub a: [Mat; 2],
    /// `B_i = df/du` in each regime.
    pub b: [Mat; 2],
    /// `c_i = f(0, 0)` in each regime.
    pub offset: [Vec<f64>; 2],
    /// `C = dh/dx`.
    pub c: Mat,
}

/// Reads the regimes of `model`, or says why it is not piecewise linear with one
/// condition on a measured state.
pub fn regimes(model: &Model, mg: &ModelGraph) -> Result<Regimes, String> {
    if model.uses_time() {
        return Err("a switched observer needs time-invariant regimes; this model uses `t`".into());
    }
    let switch = read_switch(model, mg, switching_condition(mg)?)?;
    let mut graph = mg.graph.clone();
    let (a1, b1, c1) = linear_regime(model, mg, &mut graph, 1, false)?;
    let (a2, b2, c2) = linear_regime(model, mg, &mut graph, 2, true)?;
    let c = output_matrix(model, mg)?;
    Ok(Regimes {
        switch,
        a: [a1, a2],
        b: [b1, b2],
        offset: [c1, c2],
        c,
    })
}

/// The one condition `(cmp, lhs, rhs)` the piecewise terms of `f` and `h` switch on.
fn switching_condition(mg: &ModelGraph) -> Result<(Comparison, NodeId, NodeId), String> {
    let mut conditions = Vec::new();
    for &root in mg.f.iter().chain(&mg.h) {
        collect_conditions(&mg.graph, root, &mut conditions);
    }
    match conditions.as_slice() {
        [] => Err("the model has no piecewise term: there is nothing to switch on".into()),
        [one] => Ok(*one),
        _ => Err(format!(
            "switched observers take one switching condition; this model's piecewise \
             terms compare {} different things",
            conditions.len()
        )),
    }
}

/// Regime `regime` of the step, `x[k+1] = A_i x + B_i u + c_i`: `A_i`, `B_i` and `c_i`,
/// read from `f` with every select resolved to its `then` branch (`holds`) or its
/// `otherwise`, built on `graph`; or the entry that is not constant.
fn linear_regime(
    model: &Model,
    mg: &ModelGraph,
    graph: &mut Graph,
    regime: usize,
    holds: bool,
) -> Result<(Mat, Mat, Vec<f64>), String> {
    let mut memo = HashMap::new();
    let f: Vec<NodeId> =
        mg.f.iter()
            .map(|&e| resolve(graph, e, holds, &mut memo))
            .collect();
    let mut branch = mg.clone();
    branch.graph = graph.clone();
    let jx = branch.jacobian(&f, &mg.x);
    let ju = branch.jacobian(&f, &mg.u);
    let name = |i: usize| model.state_names().nth(i).unwrap_or("?").to_owned();
    let input = |j: usize| model.inputs[j].name.clone();
    let a = constant_jacobian(&branch.graph, &jx, regime, &name, &name)?;
    let b = constant_jacobian(&branch.graph, &ju, regime, &name, &input)?;
    let offset = f.iter().map(|&e| branch.graph.eval(e, &|_| 0.0)).collect();
    *graph = branch.graph;
    Ok((a, b, offset))
}

/// The Jacobian `table` of regime `regime`'s step as numbers, or which entry is not
/// constant (the step is not linear in `wrt(j)`).
fn constant_jacobian(
    g: &Graph,
    table: &[Vec<NodeId>],
    regime: usize,
    name: &dyn Fn(usize) -> String,
    wrt: &dyn Fn(usize) -> String,
) -> Result<Mat, String> {
    let mut m = Mat::zeros(table.len(), table.first().map_or(0, Vec::len));
    for (i, row) in table.iter().enumerate() {
        for (j, &e) in row.iter().enumerate() {
            m[(i, j)] = g.constant_value(e).ok_or_else(|| {
                format!(
                    "in regime {regime} the step of `{}` is not linear: its derivative \
                     with respect to `{}` is not constant",
                    name(i),
                    wrt(j)
                )
            })?;
        }
    }
    Ok(m)
}

/// `C = dh/dx`, the same in both regimes, or which output is not linear in the state
/// (or has a constant term).
fn output_matrix(model: &Model, mg: &ModelGraph) -> Result<Mat, String> {
    let mut hg = mg.clone();
    let jh = hg.jacobian_h_wrt_x();
    let mut c = Mat::zeros(model.outputs.len(), model.state_len());
    for (i, row) in jh.iter().enumerate() {
        for (j, &e) in row.iter().enumerate() {
            c[(i, j)] = hg.graph.constant_value(e).ok_or_else(|| {
                format!(
                    "the output `{}` is not linear in the state",
                    model.outputs[i].name
                )
            })?;
        }
        if hg.graph.eval(mg.h[i], &|_| 0.0) != 0.0 {
            return Err(format!(
                "the output `{}` has a constant term",
                model.outputs[i].name
            ));
        }
    }
    Ok(c)
}

/// The distinct conditions `(cmp, lhs, rhs)` of the selects under `root`.
fn collect_conditions(g: &Graph, root: NodeId, out: &mut Vec<(Comparison, NodeId, NodeId)>) {
    let mut stack = vec![root];
    let mut seen = std::collections::HashSet::new();
    while let Some(id) = stack.pop() {
        if !seen.insert(id) {
            continue;
        }
        let node = g.node(id);
        if let Node::Select { cmp, lhs, rhs, .. } = node {
            if !out.contains(&(cmp, lhs, rhs)) {
                out.push((cmp, lhs, rhs));
            }
        }
        stack.extend(node.children());
    }
}

/// `state cmp constant` (either way round), with the state measured by an output.
fn read_switch(
    model: &Model,
    mg: &ModelGraph,
    (cmp, lhs, rhs): (Comparison, NodeId, NodeId),
) -> Result<Switch, String> {
    let g = &mg.graph;
    let state_of = |id: NodeId| mg.x.iter().position(|&x| x == id);
    let flipped = |c: Comparison| match c {
        Comparison::Gt => Comparison::Lt,
        Comparison::Ge => Comparison::Le,
        Comparison::Lt => Comparison::Gt,
        Comparison::Le => Comparison::Ge,
    };
    let (state, cmp, threshold) = match (state_of(lhs), state_of(rhs)) {
        (Some(s), None) => (s, cmp, g.constant_value(rhs)),
        (None, Some(s)) => (s, flipped(cmp), g.constant_value(lhs)),
        _ => (usize::MAX, cmp, None),
    };
    let Some(threshold) = threshold.filter(|_| state != usize::MAX) else {
        return Err(
            "the switching condition must compare one state with a constant \
                    (`if q_mid > 0.0 { .. }`), so the regime can be read from a measurement"
                .into(),
        );
    };
    let output = mg.h.iter().position(|&h| h == mg.x[state]).ok_or_else(|| {
        format!(
            "the regime switches on `{}`, which no output measures: add `output y = {0};` \
             (the observer chooses the regime from the measurement)",
            model.state_names().nth(state).unwrap_or("?")
        )
    })?;
    Ok(Switch {
        output,
        state,
        cmp,
        threshold,
    })
}

/// `root` with every select replaced by its `then` branch (`holds`) or `otherwise`.
fn resolve(g: &mut Graph, root: NodeId, holds: bool, memo: &mut HashMap<NodeId, NodeId>) -> NodeId {
    if let Some(&done) = memo.get(&root) {
        return done;
    }
    let node = g.node(root);
    let mut go = |g: &mut Graph, id| resolve(g, id, holds, memo);
    let result = match node {
        Node::Num(_) | Node::Named(_) | Node::Var(_) => root,
        Node::Neg(a) => {
            let a = go(g, a);
            g.neg(a)
        }
        Node::Add(a, b) => {
            let (a, b) = (go(g, a), go(g, b));
            g.add(a, b)
        }
        Node::Sub(a, b) => {
            let (a, b) = (go(g, a), go(g, b));
            g.sub(a, b)
        }
        Node::Mul(a, b) => {
            let (a, b) = (go(g, a), go(g, b));
            g.mul(a, b)
        }
        Node::Div(a, b) => {
            let (a, b) = (go(g, a), go(g, b));
            g.div(a, b)
        }
        Node::Call(f, a) => {
            let a = go(g, a);
            g.call(f, a)
        }
        Node::Atan2(y, x) => {
            let (y, x) = (go(g, y), go(g, x));
            g.atan2(y, x)
        }
        Node::Select {
            then, otherwise, ..
        } => go(g, if holds { then } else { otherwise }),
    };
    memo.insert(root, result);
    result
}

/// The gains of one observer, per regime (`n x m`), and the observer matrices
/// `F_i = A_i - K_i C` they give.
#[derive(Clone, Debug)]
pub struct Gains {
    /// `K_1`, `K_2`.
    pub k: [Mat; 2],
    /// `A_i - K_i C`.
    pub f: [Mat; 2],
    /// Largest pole modulus of each `F_i`.
    pub radius: [f64; 2],
}

/// The three designs of the seed, computed once.
#[derive(Clone, Debug)]
pub struct Designs {
    /// (a) Linear error dynamics: `K_2 = K_1 + A_s C^+`, `A_s = A_2 - A_1`, so
    /// `A_1 - K_1 C = A_2 - K_2 C` (eq. 5.7).
    pub linear_error: Gains,
    /// (b) The steady-state Kalman gain of each regime (Riccati eq. 6.3, discrete).
    pub switched_kalman: Gains,
    /// One gain, `K_1` of (a), for both regimes: the observer the seed warns about.
    pub common_gain: Gains,
}

/// Where a design failed: the noise option, the `k1` option, or the generator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Culprit {
    /// `process_noise` / `measurement_noise`.
    Noise,
    /// `k1`.
    K1,
    /// The generator (the model's form).
    Generator,
}

/// Designs the observers of `regimes` with the options of `spec`.
pub fn design(
    regimes: &Regimes,
    spec: &SwitchedObserverSpec,
) -> Result<Designs, (Culprit, String)> {
    let (n, m) = (regimes.c.cols(), regimes.c.rows());
    let noise = |msg: String| (Culprit::Noise, msg);
    if spec.process_noise.len() != n || spec.measurement_noise.len() != m {
        return Err(noise(format!(
            "`process_noise` lists one variance per state ({n}) and `measurement_noise` one \
             per output ({m}); got {} and {}",
            spec.process_noise.len(),
            spec.measurement_noise.len()
        )));
    }
    observable(regimes).map_err(|msg| (Culprit::Generator, msg))?;
    let kalman = kalman_gains(regimes, spec).map_err(noise)?;
    let switched_kalman = certified(
        regimes,
        [kalman[0].clone(), kalman[1].clone()],
        "switched Kalman filter",
    )
    .map_err(noise)?;

    let k1_culprit = if spec.k1.is_some() {
        Culprit::K1
    } else {
        Culprit::Noise
    };
    let k1 = match &spec.k1 {
        Some(values) if values.len() == n * m => {
            Mat::from_rows(&values.chunks(m).map(<[f64]>::to_vec).collect::<Vec<_>>())
        }
        Some(values) => {
            return Err((
                Culprit::K1,
                format!(
                    "`k1` is {n} x {m}, row by row: {} entries, not {}",
                    n * m,
                    values.len()
                ),
            ))
        }
        None => kalman[0].clone(),
    };
    let k_s = switching_gain(regimes).map_err(|msg| (Culprit::Generator, msg))?;
    let k2 = &k1 + &k_s;
    let linear_error = certified(regimes, [k1.clone(), k2], "linear error dynamics")
        .map_err(|msg| (k1_culprit, msg))?;
    let common_gain =
        certified(regimes, [k1.clone(), k1], "common gain").map_err(|msg| (k1_culprit, msg))?;
    Ok(Designs {
        linear_error,
        switched_kalman,
        common_gain,
    })
}

/// Checks that the state is observable from the outputs in each regime.
fn observable(regimes: &Regimes) -> Result<(), String> {
    let n = regimes.c.cols();
    for (i, a) in regimes.a.iter().enumerate() {
        let rank = numerics::observability_rank(a, &regimes.c);
        if rank < n {
            return Err(format!(
                "regime {}: the state is not observable from the outputs (observability \
                 rank {rank} of {n})",
                i + 1
            ));
        }
    }
    Ok(())
}

/// The steady-state Kalman gain of each regime's one-step predictor.
fn kalman_gains(regimes: &Regimes, spec: &SwitchedObserverSpec) -> Result<[Mat; 2], String> {
    let q = Mat::diagonal(&spec.process_noise);
    let r = Mat::diagonal(&spec.measurement_noise);
    let gain = |i: usize| {
        numerics::kalman_predictor_gain(&regimes.a[i], &regimes.c, &q, &r)
            .map(|(k, _)| k)
            .map_err(|e| format!("regime {}: the Kalman gain's Riccati equation: {e}", i + 1))
    };
    Ok([gain(0)?, gain(1)?])
}

/// `K_s = A_s C^+` with `A_s = A_2 - A_1`, the extra gain of regime 2 that cancels the
/// switched dynamics (eq. 5.7), if `A_s C^+ C = A_s`: what makes `A_s - K_s C = 0`
/// solvable (eq. 5.6).
fn switching_gain(regimes: &Regimes) -> Result<Mat, String> {
    let a_s = &regimes.a[1] - &regimes.a[0];
    let k_s = &a_s * &numerics::pinv(&regimes.c);
    let leftover = (&a_s - &(&k_s * &regimes.c)).max_abs();
    if leftover > 1e-12 * regimes.a[0].max_abs() {
        return Err(format!(
            "linear error dynamics need the regimes to differ only through measured \
             states (A_2 - A_1 = K_s C); here A_2 - A_1 reaches states the outputs do not \
             measure (residual {leftover:.3e})"
        ));
    }
    Ok(k_s)
}

/// The gains with their observer matrices, if every regime's `A_i - K_i C` is Schur
/// stable; else says which pole is not.
fn certified(regimes: &Regimes, k: [Mat; 2], what: &str) -> Result<Gains, String> {
    let f = [0, 1].map(|i| &regimes.a[i] - &(&k[i] * &regimes.c));
    let mut radius = [0.0; 2];
    for i in 0..2 {
        let pole = largest_pole(&f[i])
            .ok_or_else(|| format!("{what}: the poles of regime {} did not converge", i + 1))?;
        if pole.abs().is_nan() || pole.abs() >= 1.0 {
            return Err(format!(
                "{what}: regime {}: A - K C has a pole at {pole} (|z| = {:.6}), outside the \
                 unit circle",
                i + 1,
                pole.abs()
            ));
        }
        radius[i] = pole.abs();
    }
    Ok(Gains { k, f, radius })
}

/// The innovation the observer corrects with, `y - C x`, as nodes (zeros of `C` skipped).
pub fn innovation(g: &mut Graph, regimes: &Regimes, x: &[NodeId], y: &[NodeId]) -> Vec<NodeId> {
    y.iter()
        .enumerate()
        .map(|(row, &measured)| {
            let coefficients: Vec<NodeId> =
                (0..x.len()).map(|j| g.num(regimes.c[(row, j)])).collect();
            let output = crate::symbolic::linalg::dot(g, &coefficients, x);
            g.sub(measured, output)
        })
        .collect()
}

/// The observer's prediction in each regime as nodes:
/// `x[k+1] = F_i x + B_i u + K_i y + c_i` with the literals of the design (zeros skipped).
pub fn observer_step(
    g: &mut Graph,
    regimes: &Regimes,
    gains: &Gains,
    x: &[NodeId],
    u: &[NodeId],
    y: &[NodeId],
) -> [Vec<NodeId>; 2] {
    [0, 1].map(|i| {
        (0..x.len())
            .map(|row| {
                let terms = [(&gains.f[i], x), (&regimes.b[i], u), (&gains.k[i], y)];
                let mut coefficients = Vec::new();
                let mut operands = Vec::new();
                for (matrix, vars) in terms {
                    for (j, &var) in vars.iter().enumerate() {
                        coefficients.push(g.num(matrix[(row, j)]));
                        operands.push(var);
                    }
                }
                let sum = crate::symbolic::linalg::dot(g, &coefficients, &operands);
                let offset = g.num(regimes.offset[i][row]);
                g.add(sum, offset)
            })
            .collect()
    })
}

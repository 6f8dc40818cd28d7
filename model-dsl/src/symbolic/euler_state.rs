//! The estimate's forward Euler sub-step `x + h f(x)` in a hybrid EKF's loop, written where
//! it can from the entries of `Phi = I + h F` that the covariance sub-step computes anyway.

use super::continuous::{euler_transition, scale};
use super::graph::{Graph, Node, NodeId};
use super::linalg::Matrix;
use super::scaled_covariance::Scaling;
use std::collections::{HashMap, HashSet};

/// One forward Euler sub-step `x + h f(x)` of the estimate, with `F = df/dx` at `x`, beside
/// the covariance sub-step, which computes the entries of `Phi = I + h F` (or, carried
/// with `scaling`, of `Phi~ = D Phi D^-1`) anyway.
///
/// A row `f_i` affine in a set `V` of the estimate's variables (its derivatives by them
/// read none of them, and no `if` of it tests one: `if v > 0 { 2 } else { -2 }`, a Coulomb
/// friction, has a zero derivative but is not its value at `v = 0`) is exactly
/// `f_i(x_V=0) + sum_{k in V} F_ik x_k`, so `x_i + h f_i = h f_i(x_V=0) + sum_{k in V, k != i}
/// Phi_ik x_k + Phi_ii x_i` (the last term `x_i` when `i` is not in `V`). The `Phi_ik` are
/// the covariance sub-step's own entries (`Phi_ik x_k = Phi~_ik (h^(e_k - e_i) x_k)` when
/// scaled, the factor computed before the loop for a parameter): only the products and the
/// remainder at zero are new work, and a remainder that reads no changing state is
/// computed once, before the loop. The sets tried are the states that change (the
/// parameters, random walks, are held) and each variable alone; the row takes the form
/// with the fewest operations in the loop, the plain `x_i + h f_i` only where it is cheaper
/// than every affine form. The blade's `q'' = (1/m)(c u - k q - b q') + eta2` is affine in
/// `1/m`: `q' + h eta2 + (1/m) Phi_(q', 1/m)`, two multiply-adds where the form in the
/// changing states takes four.
pub fn euler_state_step(
    g: &mut Graph,
    h: NodeId,
    x: &[NodeId],
    dx: &[NodeId],
    f: &Matrix,
    scaling: Option<&Scaling>,
) -> Vec<NodeId> {
    let n = x.len();
    let changing: Vec<usize> = (0..n).filter(|&i| !g.is_zero(dx[i])).collect();
    let phi = euler_transition(g, h, f, None);
    let step = Step {
        h,
        x,
        dx,
        f,
        computed: match scaling {
            Some(scaling) => scaling.transition(g, f, None),
            None => phi.clone(),
        },
        phi,
        scaling,
    };
    let mut work = LoopWork::new(g, &step.computed, changing.iter().map(|&k| x[k]).collect());
    let mut sets = vec![changing];
    sets.extend((0..n).map(|k| vec![k]));
    (0..n)
        .map(|i| {
            if g.is_zero(dx[i]) {
                return x[i];
            }
            let mut best: Option<(usize, NodeId)> = None;
            for set in &sets {
                if let Some(row) = step.affine_row(g, i, set) {
                    let cost = work.operations(g, row);
                    if best.is_none_or(|(least, _)| cost < least) {
                        best = Some((cost, row));
                    }
                }
            }
            let increment = g.mul(h, dx[i]);
            let plain = g.add(x[i], increment);
            let row = match best {
                Some((least, row)) if least <= work.operations(g, plain) => row,
                _ => plain,
            };
            work.computed_by(g, row);
            row
        })
        .collect()
}

/// What one Euler sub-step reads: its length, the estimate, `f` and `F` there,
/// `Phi = I + h F`, and the transition the covariance sub-step computes with its scaling.
struct Step<'a> {
    h: NodeId,
    x: &'a [NodeId],
    dx: &'a [NodeId],
    f: &'a Matrix,
    phi: Matrix,
    computed: Matrix,
    scaling: Option<&'a Scaling>,
}

impl Step<'_> {
    /// Row `i` of `x + h f(x)` in the form affine in the variables `set` (see
    /// [`euler_state_step`]), or `None` where `f_i` is not affine in them jointly or
    /// `set` is a single variable `f_i` does not read.
    fn affine_row(&self, g: &mut Graph, i: usize, set: &[usize]) -> Option<NodeId> {
        let (h, x, f) = (self.h, self.x, self.f);
        if set.len() == 1 && g.is_zero(f[i][set[0]]) {
            return None;
        }
        let mut to_zero = HashMap::new();
        for v in set.iter().map(|&k| x[k]) {
            let Node::Var(id) = g.node(v) else {
                return None;
            };
            to_zero.insert(id, g.zero());
        }
        let var_ids: Vec<_> = to_zero.keys().copied().collect();
        if set.iter().any(|&k| g.reads_any(f[i][k], &var_ids))
            || g.switches_on(self.dx[i], &var_ids)
        {
            return None;
        }
        let at_zero = g.substitute(self.dx[i], &to_zero, &mut HashMap::new());
        let remainder = scale(g, h, at_zero);
        // `x_i` first where it is not in `set`: each product then adds to the sum, one
        // multiply-add.
        let mut sum = if set.contains(&i) {
            remainder
        } else {
            g.add(x[i], remainder)
        };
        for &k in set.iter().filter(|&&k| k != i) {
            let term = self.product(g, i, k);
            sum = g.add(sum, term);
        }
        if !set.contains(&i) {
            return Some(sum);
        }
        if g.constant_value(f[i][i]).is_some() {
            let diagonal = g.mul_whole(self.phi[i][i], x[i]);
            return Some(g.add(sum, diagonal));
        }
        // `Phi_ii x_i` as `x_i + (h F_ii) x_i`: `h F_ii` is computed before the loop.
        let diagonal = scale(g, h, f[i][i]);
        let term = g.mul_whole(diagonal, x[i]);
        sum = g.add(sum, term);
        Some(g.add(sum, x[i]))
    }

    /// `Phi_ik x_k`; with the covariance scaled and `x_k` a parameter, as
    /// `Phi~_ik (h^(e_k - e_i) x_k)`: the scaled entry is the one the loop computes, the
    /// parameter's factor is computed before it.
    fn product(&self, g: &mut Graph, i: usize, k: usize) -> NodeId {
        match self.scaling {
            Some(scaling) if g.is_zero(self.dx[k]) => {
                let x_k = match scaling.power(g, scaling.exponent(k) - scaling.exponent(i)) {
                    Some(factor) => g.mul(factor, self.x[k]),
                    None => self.x[k],
                };
                g.mul_whole(self.computed[i][k], x_k)
            }
            _ => g.mul_whole(self.phi[i][k], self.x[k]),
        }
    }
}

/// The operations a loop body already computes, and a count of those a new expression
/// adds: the ones that read a changing state (the others are computed before the loop)
/// and are neither `Phi`'s entries nor an earlier row's.
struct LoopWork {
    computed: HashSet<NodeId>,
    changing: Vec<NodeId>,
}

impl LoopWork {
    fn new(g: &Graph, transition: &Matrix, changing: Vec<NodeId>) -> LoopWork {
        let mut work = LoopWork {
            computed: HashSet::new(),
            changing,
        };
        for &entry in transition.iter().flatten() {
            work.computed_by(g, entry);
        }
        work
    }

    /// Records `root` and what it reads as computed.
    fn computed_by(&mut self, g: &Graph, root: NodeId) {
        let mut stack = vec![root];
        while let Some(id) = stack.pop() {
            if self.computed.insert(id) {
                stack.extend(g.node(id).children());
            }
        }
    }

    /// The operations `root` adds to the loop body.
    fn operations(&self, g: &Graph, root: NodeId) -> usize {
        let mut varies: HashMap<NodeId, bool> = HashMap::new();
        let mut count = 0;
        for id in g.pending_from(root, Node::children, |_| false) {
            let reads_state =
                self.changing.contains(&id) || g.node(id).children().iter().any(|c| varies[c]);
            varies.insert(id, reads_state);
            if reads_state && !g.is_leaf(id) && !self.computed.contains(&id) {
                count += 1;
            }
        }
        count
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symbolic::Differentiator;

    /// The blade in control mode, `[q, q', eta, 1/m]` with `q'' = (1/m)(c u - k q - b q')
    /// + eta` written out as the simplifier keeps it, `eta' = -a eta`, `1/m` held; `u = 2`.
    fn blade(g: &mut Graph) -> (Vec<NodeId>, Vec<NodeId>, Matrix) {
        let x: Vec<NodeId> = ["q", "qd", "eta", "inv_m"]
            .iter()
            .map(|v| g.var(v))
            .collect();
        let [q, qd, eta, inv_m] = [x[0], x[1], x[2], x[3]];
        let (k, b, cu, a) = (g.num(533.0), g.num(0.11), g.num(1.6e-3), g.num(25.0));
        let spring = g.mul(k, q);
        let damping = g.mul(b, qd);
        let force = g.sub(cu, spring);
        let force = g.sub(force, damping);
        let acceleration = g.mul(inv_m, force);
        let acceleration = g.add(acceleration, eta);
        let decay = g.mul(a, eta);
        let decay = g.neg(decay);
        let dx = vec![qd, acceleration, decay, g.zero()];
        let f = dx
            .iter()
            .map(|&row| {
                x.iter()
                    .map(|&v| {
                        let Node::Var(id) = g.node(v) else {
                            unreachable!("the states are variables")
                        };
                        Differentiator::new(id).diff(g, row)
                    })
                    .collect()
            })
            .collect();
        (x, dx, f)
    }

    #[test]
    fn each_row_is_the_euler_step() {
        let mut g = Graph::new();
        let (x, dx, f) = blade(&mut g);
        let h = g.num(2e-5);
        let scaling = Scaling::for_unit_couplings(&g, &f, 2e-5).expect("q' = qd scales");
        let unscaled = euler_state_step(&mut g, h, &x, &dx, &f, None);
        let scaled = euler_state_step(&mut g, h, &x, &dx, &f, Some(&scaling));
        let point = [1e-3, -0.2, 3.0, 4.5];
        let at = |v: crate::symbolic::VarId| point[v.0 as usize];
        for (i, next) in (0..4).flat_map(|i| [(i, unscaled[i]), (i, scaled[i])]) {
            let want = point[i] + 2e-5 * g.eval(dx[i], &at);
            let got = g.eval(next, &at);
            assert!(
                (got - want).abs() <= 1e-15 * want.abs().max(1.0),
                "row {i}: {got} vs {want}"
            );
        }
    }

    #[test]
    fn a_switch_on_a_variable_keeps_the_row_whole() {
        // [x, v] with `v' = -4 x - 0.1 v - (if v > 0 { 2 } else { -2 }) + 1`, a Coulomb
        // friction: its derivative by `v` is -0.1, but it is not affine in `v`.
        let mut g = Graph::new();
        let (x, v) = (g.var("x"), g.var("v"));
        let (zero, two, minus_two) = (g.zero(), g.num(2.0), g.num(-2.0));
        let friction = g.select(crate::ast::Comparison::Gt, v, zero, two, minus_two);
        let (four, tenth, one) = (g.num(4.0), g.num(0.1), g.one());
        let spring = g.mul(four, x);
        let damping = g.mul(tenth, v);
        let rate = g.sub(one, spring);
        let rate = g.sub(rate, damping);
        let rate = g.sub(rate, friction);
        let dx = vec![v, rate];
        let f: Matrix = dx
            .iter()
            .map(|&row| {
                [0, 1]
                    .map(|k| Differentiator::new(crate::symbolic::VarId(k)).diff(&mut g, row))
                    .to_vec()
            })
            .collect();
        let h = g.num(0.01);
        let next = euler_state_step(&mut g, h, &[x, v], &dx, &f, None);
        for point in [[0.3, 1.0], [0.3, -1.0]] {
            let at = |var: crate::symbolic::VarId| point[var.0 as usize];
            let want = point[1] + 0.01 * g.eval(dx[1], &at);
            let got = g.eval(next[1], &at);
            assert!((got - want).abs() <= 1e-15, "at {point:?}: {got} vs {want}");
        }
    }

    #[test]
    fn a_row_affine_in_a_parameter_reads_phi_s_column_of_it() {
        let mut g = Graph::new();
        let (x, dx, f) = blade(&mut g);
        let h = g.num(2e-5);
        let phi = euler_transition(&mut g, h, &f, None);
        let next = euler_state_step(&mut g, h, &x, &dx, &f, None);
        // q' + h eta + (1/m) Phi_(q', 1/m): two products and two additions, where
        // `Phi_(q', q) q + (h F_(q', q')) q' + q' + h eta + h (1/m) c u` takes three
        // products in the loop and four additions.
        let changing = x[..3].to_vec();
        let work = LoopWork::new(&g, &phi, changing);
        let product = g.mul_whole(phi[1][3], x[3]);
        let reached = g.pending_from(next[1], Node::children, |_| false);
        assert!(reached.contains(&product));
        assert!(work.operations(&g, next[1]) <= 4);
    }
}

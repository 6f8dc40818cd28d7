//! The covariance of a loop of Euler sub-steps carried in scaled coordinates, in which the
//! unit couplings of the model (`der(q) = qd`: `Phi_(q, qd) = h`) are ones.
//!
//! With `x~ = D x`, `D = diag(h^e_i)`, the covariance is `P~ = D P D` and the transition
//! `Phi~ = D Phi D^-1`, `Phi~_ij = Phi_ij h^(e_i - e_j)`. Where `F_ij = +-1` and
//! `e_j = e_i + 1`, `Phi~_ij = +-1`: its products in `Phi~ P~ Phi~'` are additions, and no
//! product by `h` is shared by two sums (the compiler computes a shared product once, as a
//! multiplication and an addition, where each sum alone would take one multiply-add). The
//! propagation is the same, `P = D^-1 P~ D^-1` after the loop, up to rounding.

// Index loops mirror the subscripts of `F_ij` and `e_j` more plainly than iterators.
#![allow(clippy::needless_range_loop)]

use super::continuous::{covariance_of_transition, euler_transition_with, scale};
use super::graph::{Graph, NodeId};
use super::linalg::Matrix;

/// The largest power of ten by which the scaling may move a covariance entry: `f32`'s
/// normal numbers span 76 decades, so a model's covariance keeps more than 50 of them.
const MAX_DECADES: f64 = 20.0;

/// The exponents `e_i` of `D = diag(h^e_i)` and the sub-step `h`.
#[derive(Clone, Debug, PartialEq)]
pub struct Scaling {
    exponents: Vec<i32>,
    h: f64,
}

impl Scaling {
    /// The scaling that turns the unit couplings of `f` (`F_ij = +-1`, `i != j`) into
    /// ones: `e_j = e_i + 1` along each, following the couplings from each state not yet
    /// reached (a coupling that contradicts the exponents already given stays `+-h`),
    /// each connected group's smallest exponent zero. `None` where no coupling becomes
    /// a one, `h` is not a positive number, or `h^(2 e_i)` would move a covariance entry
    /// by more than `MAX_DECADES` (20).
    pub fn for_unit_couplings(g: &Graph, f: &Matrix, h: f64) -> Option<Scaling> {
        let n = f.len();
        let unit =
            |i: usize, j: usize| i != j && g.literal(f[i][j]).is_some_and(|v| v.abs() == 1.0);
        let mut exponents: Vec<Option<i32>> = vec![None; n];
        for root in 0..n {
            if exponents[root].is_some() {
                continue;
            }
            exponents[root] = Some(0);
            let mut group = vec![root];
            let mut stack = vec![root];
            while let Some(i) = stack.pop() {
                let Some(e) = exponents[i] else { continue };
                for j in 0..n {
                    for (coupled, e_j) in [(unit(i, j), e + 1), (unit(j, i), e - 1)] {
                        if coupled && exponents[j].is_none() {
                            exponents[j] = Some(e_j);
                            group.push(j);
                            stack.push(j);
                        }
                    }
                }
            }
            let least = group
                .iter()
                .filter_map(|&k| exponents[k])
                .min()
                .unwrap_or(0);
            for k in group {
                exponents[k] = exponents[k].map(|e| e - least);
            }
        }
        let exponents: Vec<i32> = exponents.into_iter().map(|e| e.unwrap_or(0)).collect();
        let largest = exponents.iter().copied().max().unwrap_or(0);
        let decades = 2.0 * f64::from(largest) * h.log10().abs();
        (largest > 0 && h.is_finite() && h > 0.0 && decades <= MAX_DECADES)
            .then_some(Scaling { exponents, h })
    }

    /// `h^k` as a literal, `None` for `k = 0`.
    pub fn power(&self, g: &mut Graph, k: i32) -> Option<NodeId> {
        (k != 0).then(|| g.num(self.h.powi(k)))
    }

    /// The exponent `e_i` of state `i`.
    pub fn exponent(&self, i: usize) -> i32 {
        self.exponents[i]
    }

    /// `Phi~ = I + (h D A D^-1)`, `A = F` or `F + alpha I` (see `euler_transition`).
    pub fn transition(&self, g: &mut Graph, f: &Matrix, alpha: Option<NodeId>) -> Matrix {
        let e = &self.exponents;
        let steps: Vec<Vec<Option<NodeId>>> = (0..f.len())
            .map(|i| {
                (0..f.len())
                    .map(|j| self.power(g, 1 + e[i] - e[j]))
                    .collect()
            })
            .collect();
        euler_transition_with(g, f, alpha, |i, j| steps[i][j])
    }

    /// `D P D` (`by = 1`) or `D^-1 P D^-1` (`by = -1`).
    pub fn apply(&self, g: &mut Graph, p: &Matrix, by: i32) -> Matrix {
        let e = &self.exponents;
        self.times_powers(g, p, |i, j| by * (e[i] + e[j]))
    }

    /// Each entry `(i, j)` of `m` times `h^k(i, j)` (itself where the power is zero).
    fn times_powers(&self, g: &mut Graph, m: &Matrix, k: impl Fn(usize, usize) -> i32) -> Matrix {
        (0..m.len())
            .map(|i| {
                (0..m.len())
                    .map(|j| match self.power(g, k(i, j)) {
                        Some(factor) => scale(g, factor, m[i][j]),
                        None => m[i][j],
                    })
                    .collect()
            })
            .collect()
    }

    /// One Euler sub-step of the scaled covariance: `Phi~ P~ Phi~' + h D S D`, the
    /// scaled `euler_covariance_step`.
    pub fn covariance_step(
        &self,
        g: &mut Graph,
        f: &Matrix,
        alpha: Option<NodeId>,
        p_scaled: &Matrix,
        s: &Matrix,
    ) -> Matrix {
        let phi = self.transition(g, f, alpha);
        let e = &self.exponents;
        let noise = self.times_powers(g, s, |i, j| 1 + e[i] + e[j]);
        covariance_of_transition(g, &phi, p_scaled, &noise)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symbolic::continuous::euler_covariance_step;

    /// The blade in control mode's couplings: `q' = qd`, `qd' = -a q - b qd + eta2 + c m`,
    /// `eta1' = eta2`, `eta2' = -w eta1 - z eta2`, `m' = 0`.
    fn blade_jacobian(g: &mut Graph) -> Matrix {
        let rows = [
            [0.0, 1.0, 0.0, 0.0, 0.0],
            [-2665.0, -0.55, 0.0, 1.0, 3e-4],
            [0.0, 0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, -3947.8, -50.0, 0.0],
            [0.0; 5],
        ];
        rows.iter()
            .map(|row| row.iter().map(|&v| g.num(v)).collect())
            .collect()
    }

    #[test]
    fn the_couplings_chain_position_velocity_and_the_shaping_filter() {
        let mut g = Graph::new();
        let f = blade_jacobian(&mut g);
        let scaling = Scaling::for_unit_couplings(&g, &f, 2e-5).expect("the blade scales");
        assert_eq!(scaling.exponents, [0, 1, 1, 2, 0]);
        let phi = scaling.transition(&mut g, &f, None);
        for (i, j) in [(0, 1), (1, 3), (2, 3)] {
            assert!(g.is_one(phi[i][j]), "Phi~_({i}, {j}) is one");
        }
        // A step of 1e-6 would move the shaping filter's variance by 24 decades.
        assert_eq!(Scaling::for_unit_couplings(&g, &f, 1e-6), None);
        // A model without unit couplings is left as it is.
        let zero = g.zero();
        assert_eq!(
            Scaling::for_unit_couplings(&g, &vec![vec![zero; 2]; 2], 2e-5),
            None
        );
    }

    #[test]
    fn the_scaled_step_is_the_step_in_scaled_coordinates() {
        let mut g = Graph::new();
        let f = blade_jacobian(&mut g);
        let h = 2e-5;
        let scaling = Scaling::for_unit_couplings(&g, &f, h).expect("the blade scales");
        let values = [
            [1e-5, 2e-4, -1e-6, 3e-3, 1e-6],
            [2e-4, 1.0, 1e-3, -2e-2, 4e-4],
            [-1e-6, 1e-3, 1e-2, 5e-3, 0.0],
            [3e-3, -2e-2, 5e-3, 30.0, 1e-3],
            [1e-6, 4e-4, 0.0, 1e-3, 1e-4],
        ];
        let p: Matrix = values
            .iter()
            .map(|row| row.iter().map(|&v| g.num(v)).collect())
            .collect();
        let s: Matrix = (0..5)
            .map(|i| {
                (0..5)
                    .map(|j| g.num(if i == j { 10.0 + i as f64 } else { 0.0 }))
                    .collect()
            })
            .collect();
        let h_node = g.num(h);
        let want = euler_covariance_step(&mut g, h_node, &f, None, &p, &s);
        let p_scaled = scaling.apply(&mut g, &p, 1);
        let step = scaling.covariance_step(&mut g, &f, None, &p_scaled, &s);
        let got = scaling.apply(&mut g, &step, -1);
        let value = |g: &Graph, id| g.eval(id, &|_| f64::NAN);
        for i in 0..5 {
            for j in 0..5 {
                let (got, want) = (value(&g, got[i][j]), value(&g, want[i][j]));
                assert!(
                    (got - want).abs() <= 1e-12 * want.abs().max(1e-12),
                    "({i}, {j}): {got} vs {want}"
                );
            }
        }
    }
}

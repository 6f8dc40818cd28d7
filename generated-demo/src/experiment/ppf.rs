//! Positive position feedback for the blade (Takács et al., sect. 4.1, after Friswell and
//! Inman, "The relationship between positive position feedback and output feedback
//! controllers", 1999), tuned optimally on the host and run as a sampled compensator.
//!
//! The compensator (eqs. 45-46, whose OCR is damaged; this is the standard PPF form)
//! `eta'' + 2 xi_p w_p eta' + w_p^2 eta = w_p^2 q`, `u = g eta`, on the nominal blade
//! `m q'' + b q' + k q = c u` gives the closed loop `z' = A(g, w_p, xi_p) z` with
//! `z = [q, q', eta, eta']`. Friswell and Inman tune `(g, w_p, xi_p)` as an output
//! feedback minimising a continuous infinite-horizon quadratic cost (eq. 47). With the
//! paper's `beta = gamma = 0` the cost is `J = int alpha q^2 + delta u^2 dt` (`u` in V,
//! `q` in m), `alpha = 1.7e8`, `delta = R = 1e-10`. For an initial state `z0`,
//! `J = z0' P z0` with `A' P + P A + W = 0` (a Lyapunov equation; `W` the cost's weight
//! on `z`). We take `z0` an impact, a unit tip velocity (the stinger's hits are velocity
//! jumps), and minimise `J` over the logarithms of the three parameters by Nelder-Mead;
//! parameters that make the loop unstable cost infinity.

use super::blade_plant::{rk4, B, C, K, M};

/// The cost's weights of sect. 4.1: `alpha` on the position, `delta` on the input.
pub const ALPHA: f64 = 1.7e8;
pub const DELTA: f64 = 1e-10;

/// A tuned PPF: gain `g` \[V/m\], filter frequency `w_p` \[rad/s\] and damping `xi_p`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PpfTuning {
    /// The gain `g` \[V/m\] of `u = g eta`.
    pub gain: f64,
    /// The compensator's natural frequency `w_p` \[rad/s\].
    pub omega: f64,
    /// The compensator's damping ratio `xi_p`.
    pub xi: f64,
}

impl PpfTuning {
    /// The closed loop's matrix `A` for the nominal blade.
    fn closed_loop(&self) -> [[f64; 4]; 4] {
        let (w, xi) = (self.omega, self.xi);
        [
            [0.0, 1.0, 0.0, 0.0],
            [-K / M, -B / M, C * self.gain / M, 0.0],
            [0.0, 0.0, 0.0, 1.0],
            [w * w, 0.0, -w * w, -2.0 * xi * w],
        ]
    }

    /// `J = z0' P z0` for a unit tip velocity; infinity if the loop is not stable.
    pub fn cost(&self) -> f64 {
        let a = self.closed_loop();
        if !is_hurwitz(&a) {
            return f64::INFINITY;
        }
        let mut w = [[0.0; 4]; 4];
        w[0][0] = ALPHA;
        w[2][2] = DELTA * self.gain * self.gain;
        match lyapunov(&a, &w) {
            Some(p) if p[1][1].is_finite() && p[1][1] > 0.0 => p[1][1],
            _ => f64::INFINITY,
        }
    }

    /// The optimal tuning: Nelder-Mead on `ln g, ln w_p, ln xi_p` from a PPF tuned by
    /// hand to the blade's mode (`w_p = w_n`, `xi_p = 0.3`, a tenth of the static limit
    /// `g < k / c`).
    pub fn optimal() -> Self {
        let from = |p: [f64; 3]| PpfTuning {
            gain: p[0].exp(),
            omega: p[1].exp(),
            xi: p[2].exp(),
        };
        let start = [(0.1 * K / C).ln(), (K / M).sqrt().ln(), 0.3f64.ln()];
        from(nelder_mead(|p| from(p).cost(), start, 0.5, 4000))
    }
}

/// The compensator run at the sample rate: its state integrated with RK4 over each
/// sample with the measured position held.
#[derive(Clone, Debug)]
pub struct Ppf {
    tuning: PpfTuning,
    eta: [f64; 2],
}

impl Ppf {
    /// A compensator at rest.
    pub fn new(tuning: PpfTuning) -> Self {
        Self {
            tuning,
            eta: [0.0; 2],
        }
    }

    /// The input `g eta` for the present sample, then the compensator advanced over the
    /// sample `ts` driven by the measurement `y`.
    pub fn input(&mut self, y: f64, ts: f64) -> f64 {
        let u = self.tuning.gain * self.eta[0];
        let (w, xi) = (self.tuning.omega, self.tuning.xi);
        let rate = |_: f64, e: [f64; 2]| [e[1], w * w * (y - e[0]) - 2.0 * xi * w * e[1]];
        self.eta = rk4(rate, 0.0, self.eta, ts, 10);
        u
    }
}

/// Solves `A' P + P A + W = 0` for `P` through its Kronecker form (16 unknowns).
fn lyapunov(a: &[[f64; 4]; 4], w: &[[f64; 4]; 4]) -> Option<[[f64; 4]; 4]> {
    let idx = |i: usize, j: usize| 4 * i + j;
    let mut m = [[0.0; 17]; 16];
    for i in 0..4 {
        for j in 0..4 {
            let row = idx(i, j);
            // (A' P)_ij = sum_k A_ki P_kj;  (P A)_ij = sum_k P_ik A_kj.
            for k in 0..4 {
                m[row][idx(k, j)] += a[k][i];
                m[row][idx(i, k)] += a[k][j];
            }
            m[row][16] = -w[i][j];
        }
    }
    let x = solve_augmented(m)?;
    Some(std::array::from_fn(|i| {
        std::array::from_fn(|j| x[idx(i, j)])
    }))
}

/// Gaussian elimination with partial pivoting on an augmented 16 x 17 system.
fn solve_augmented(mut m: [[f64; 17]; 16]) -> Option<[f64; 16]> {
    for col in 0..16 {
        let pivot = (col..16).max_by(|&r, &s| m[r][col].abs().total_cmp(&m[s][col].abs()))?;
        if m[pivot][col].abs() < 1e-300 {
            return None;
        }
        m.swap(col, pivot);
        let pivot_row = m[col];
        for row in &mut m[col + 1..] {
            let factor = row[col] / pivot_row[col];
            for (entry, &p) in row[col..].iter_mut().zip(&pivot_row[col..]) {
                *entry -= factor * p;
            }
        }
    }
    let mut x = [0.0; 16];
    for row in (0..16).rev() {
        let tail: f64 = (row + 1..16).map(|k| m[row][k] * x[k]).sum();
        x[row] = (m[row][16] - tail) / m[row][row];
    }
    Some(x)
}

/// Whether every eigenvalue of `a` has a negative real part, by the Routh-Hurwitz test
/// on its characteristic polynomial `s^4 + c1 s^3 + c2 s^2 + c3 s + c4` (Faddeev-LeVerrier).
fn is_hurwitz(a: &[[f64; 4]; 4]) -> bool {
    let mul = |x: &[[f64; 4]; 4], y: &[[f64; 4]; 4]| -> [[f64; 4]; 4] {
        std::array::from_fn(|i| std::array::from_fn(|j| (0..4).map(|k| x[i][k] * y[k][j]).sum()))
    };
    let trace = |x: &[[f64; 4]; 4]| (0..4).map(|i| x[i][i]).sum::<f64>();
    let mut c = [1.0; 5];
    let mut m = [[0.0; 4]; 4];
    for k in 1..=4 {
        // M_k = A M_{k-1} + c_{k-1} I, c_k = -tr(A M_k) / k.
        let mut next = mul(a, &m);
        for (i, row) in next.iter_mut().enumerate() {
            row[i] += c[k - 1];
        }
        m = next;
        c[k] = -trace(&mul(a, &m)) / k as f64;
    }
    let [_, c1, c2, c3, c4] = c;
    c1 > 0.0
        && c2 > 0.0
        && c3 > 0.0
        && c4 > 0.0
        && c1 * c2 > c3
        && c3 * (c1 * c2 - c3) > c1 * c1 * c4
}

/// Minimises `f` from `start` by Nelder-Mead (reflection 1, expansion 2, contraction and
/// shrink 1/2) with an initial simplex of side `step`, for `iterations` iterations.
fn nelder_mead(
    f: impl Fn([f64; 3]) -> f64,
    start: [f64; 3],
    step: f64,
    iterations: usize,
) -> [f64; 3] {
    let mut simplex: Vec<([f64; 3], f64)> = (0..4)
        .map(|i| {
            let mut p = start;
            if i > 0 {
                p[i - 1] += step;
            }
            (p, f(p))
        })
        .collect();
    let along = |a: [f64; 3], b: [f64; 3], t: f64| -> [f64; 3] {
        std::array::from_fn(|i| a[i] + t * (b[i] - a[i]))
    };
    for _ in 0..iterations {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let centroid: [f64; 3] =
            std::array::from_fn(|i| simplex[..3].iter().map(|p| p.0[i]).sum::<f64>() / 3.0);
        let worst = simplex[3];
        let reflected = along(centroid, worst.0, -1.0);
        let fr = f(reflected);
        if fr < simplex[0].1 {
            let expanded = along(centroid, worst.0, -2.0);
            let fe = f(expanded);
            simplex[3] = if fe < fr {
                (expanded, fe)
            } else {
                (reflected, fr)
            };
        } else if fr < simplex[2].1 {
            simplex[3] = (reflected, fr);
        } else {
            let contracted = along(centroid, worst.0, 0.5);
            let fc = f(contracted);
            if fc < worst.1 {
                simplex[3] = (contracted, fc);
            } else {
                let best = simplex[0].0;
                for p in &mut simplex[1..] {
                    p.0 = along(best, p.0, 0.5);
                    p.1 = f(p.0);
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex[0].0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lyapunov_of_a_damped_mode_gives_its_energy_integral() {
        // Decoupled modes x_i' = -(1 + i) x_i: int x_i^2 dt = x_i(0)^2 / (2 (1 + i)).
        let mut a = [[0.0; 4]; 4];
        for (i, row) in a.iter_mut().enumerate() {
            row[i] = -1.0 - i as f64;
        }
        let w = std::array::from_fn(|i| std::array::from_fn(|j| f64::from(u8::from(i == j))));
        let p = lyapunov(&a, &w).unwrap();
        for (i, row) in p.iter().enumerate() {
            assert!((row[i] - 1.0 / (2.0 * (1.0 + i as f64))).abs() < 1e-12);
        }
        assert!(is_hurwitz(&a));
        a[3][3] = 0.5;
        assert!(!is_hurwitz(&a));
    }

    #[test]
    fn the_optimal_tuning_is_a_local_minimum() {
        let best = PpfTuning::optimal();
        let cost = best.cost();
        assert!(cost.is_finite());
        for (dg, dw, dx) in [
            (1.05, 1.0, 1.0),
            (0.95, 1.0, 1.0),
            (1.0, 1.05, 1.0),
            (1.0, 0.95, 1.0),
            (1.0, 1.0, 1.05),
            (1.0, 1.0, 0.95),
        ] {
            let near = PpfTuning {
                gain: best.gain * dg,
                omega: best.omega * dw,
                xi: best.xi * dx,
            };
            assert!(near.cost() >= cost, "{near:?} costs less than {best:?}");
        }
    }
}

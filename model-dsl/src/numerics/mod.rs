//! Build-time numerics: the designs a generator computes once, in `f64`, so the generated
//! code only holds their results as typed literals. Small dense matrices, our own code
//! (the macro's dependencies stay light), each result checked (Riccati solutions by their
//! residual) and tested against nalgebra in `tests/tests/numerics.rs`.

pub mod eig;
pub mod matrix;
pub mod riccati;
pub mod svd;

pub use eig::{eigenvalues, largest_pole, rightmost_pole, Complex};
pub use matrix::Mat;
pub use riccati::{care, dare, kalman_predictor_gain, RiccatiError};
pub use svd::{pinv, rank, svd};

/// The rank of the observability matrix of `(A, C)`.
///
/// Built from `M = (A - mu I) / |A - mu I|` with `mu` the mean of `A`'s diagonal, not from
/// `A`: both give the same rank (`[C; CM; ..]` spans what `[C; CA; ..]` spans), but a
/// discrete system sampled fast has `A` close to `I`, whose powers make the plain
/// observability matrix numerically rank-deficient. Each block row is normalised.
pub fn observability_rank(a: &Mat, c: &Mat) -> usize {
    let n = a.rows();
    let mu = (0..n).map(|i| a[(i, i)]).sum::<f64>() / n as f64;
    let shifted = a - &Mat::identity(n).scale(mu);
    let norm = shifted.norm();
    let m = if norm > 0.0 {
        shifted.scale(1.0 / norm)
    } else {
        shifted
    };
    let mut block = c.clone();
    let mut stacked = normalised(&block);
    for _ in 1..n {
        block = &block * &m;
        stacked = stacked.stack(&normalised(&block));
    }
    rank(&stacked)
}

fn normalised(m: &Mat) -> Mat {
    let norm = m.norm();
    if norm > 0.0 {
        m.scale(1.0 / norm)
    } else {
        m.clone()
    }
}

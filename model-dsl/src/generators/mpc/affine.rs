//! Whether an expression the MPC treats as affine is: its derivatives being constants is
//! not enough (a piecewise-constant term, `if v > 0.0 { F } else { -F }`, has constant
//! derivatives on each side and a value that jumps), so it is also evaluated at points
//! where every variable takes both signs, against the affine map its derivatives and its
//! value at zero define.

use crate::symbolic::{ModelGraph, NodeId};

/// The points each variable takes in turn, scaled per variable so that no two are alike.
const SCALES: [f64; 3] = [1.0, -1.3, 7.1];

/// Whether `root` equals `offset + sum_j coefficients[j] wrt[j]` at the check's points
/// (every other variable zero), to rounding.
pub fn affine_at_points(
    mg: &ModelGraph,
    root: NodeId,
    wrt: &[NodeId],
    coefficients: &[f64],
    offset: f64,
) -> bool {
    let vars: Vec<_> = wrt.iter().map(|&v| mg.var_id(v)).collect();
    SCALES.iter().all(|&scale| {
        let point = |j: usize| {
            let sign = if j.is_multiple_of(2) { 1.0 } else { -1.0 };
            sign * scale * (0.5 + 0.37 * j as f64)
        };
        let value = mg.graph.eval(root, &|v| {
            vars.iter().position(|&w| w == v).map_or(0.0, point)
        });
        let terms: Vec<f64> = coefficients
            .iter()
            .enumerate()
            .map(|(j, c)| c * point(j))
            .collect();
        let expected = offset + terms.iter().sum::<f64>();
        let size = 1.0 + offset.abs() + terms.iter().map(|t| t.abs()).sum::<f64>();
        (value - expected).abs() <= 1e-9 * size
    })
}

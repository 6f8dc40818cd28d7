//! Small matrices for the filters' constructors.

/// The square matrix with diagonal `d` and zeros elsewhere: a covariance given by its
/// variances.
pub fn diag<const N: usize>(d: [f32; N]) -> [[f32; N]; N] {
    let mut m = [[0.0; N]; N];
    for (i, row) in m.iter_mut().enumerate() {
        row[i] = d[i];
    }
    m
}

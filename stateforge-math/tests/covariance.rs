//! `is_covariance` against nalgebra's symmetric eigenvalues: random symmetric matrices of
//! every definiteness, semi-definite ones of every rank, and variances of very different
//! scales side by side.

use nalgebra::{DMatrix, SMatrix};

/// A small deterministic generator (xorshift), so the cases are the same on every run.
struct Cases(u64);

impl Cases {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }

    fn matrix<const N: usize>(&mut self, cols: usize) -> SMatrix<f64, N, N> {
        let a = DMatrix::from_fn(N, cols, |_, _| self.uniform());
        SMatrix::<f64, N, N>::from_iterator((&a * a.transpose()).iter().copied())
    }
}

impl Cases {
    /// A random full-rank matrix shifted down so that its smallest eigenvalue is between
    /// -1.05 and -0.05: indefinite by a margin no rounding covers.
    fn indefinite(&mut self) -> SMatrix<f64, 4, 4> {
        let mut m = self.matrix::<4>(4);
        let shift = 0.05 + self.uniform().abs();
        let smallest = smallest_eigenvalue(&m);
        m -= SMatrix::<f64, 4, 4>::identity() * (smallest + shift);
        assert!(smallest_eigenvalue(&m) < -0.04);
        m
    }
}

fn array<const N: usize>(m: &SMatrix<f64, N, N>) -> [[f64; N]; N] {
    core::array::from_fn(|i| core::array::from_fn(|j| m[(i, j)]))
}

fn smallest_eigenvalue(m: &SMatrix<f64, 4, 4>) -> f64 {
    m.symmetric_eigenvalues().min()
}

#[test]
fn positive_definite_and_semi_definite_matrices_are_covariances() {
    let mut cases = Cases(0x9E37_79B9_7F4A_7C15);
    for rank in 0..=5 {
        for _ in 0..200 {
            let m = cases.matrix::<5>(rank);
            assert!(
                stateforge_math::f64::is_covariance(&array(&m)),
                "rank {rank}: {m}"
            );
            let single: [[f32; 5]; 5] = array(&m).map(|row| row.map(|v| v as f32));
            assert!(
                stateforge_math::f32::is_covariance(&single),
                "rank {rank}: {m}"
            );
        }
    }
}

#[test]
fn indefinite_matrices_are_not_covariances() {
    let mut cases = Cases(0xD1B5_4A32_D192_ED03);
    let mut rejected = 0;
    for _ in 0..2000 {
        let m = cases.indefinite();
        assert!(!stateforge_math::f64::is_covariance(&array(&m)), "{m}");
        let single: [[f32; 4]; 4] = array(&m).map(|row| row.map(|v| v as f32));
        assert!(!stateforge_math::f32::is_covariance(&single), "{m}");
        rejected += 1;
    }
    assert_eq!(rejected, 2000);
}

#[test]
fn variances_of_very_different_scales_are_judged_each_on_its_own_above_the_largests_rounding() {
    // A parameter's variance of 1e8 beside a state's of 1e-6: positive definite.
    let spread = [[1e8, 0.0, 0.0], [0.0, 1e-6, 1e-7], [0.0, 1e-7, 1e-6]];
    assert!(stateforge_math::f32::is_covariance(&spread));
    assert!(stateforge_math::f64::is_covariance(
        &spread.map(|r| r.map(f64::from))
    ));
    // The same small block with a correlation of 10: an eigenvalue of -9e-6. In `f64` it
    // is far above the rounding of the 1e8 (5.3e-15 of it, 5.3e-7), so it is judged on its
    // own scale and refused, although tiny beside the 1e8.
    let indefinite = [[1e8, 0.0, 0.0], [0.0, 1e-6, 1e-5], [0.0, 1e-5, 1e-6]];
    assert!(!stateforge_math::f64::is_covariance(
        &indefinite.map(|r| r.map(f64::from))
    ));
    // In `f32` the rounding of a 1e8 is 286 (2.9e-6 of it): a matrix computed in `f32`
    // from such entries cannot tell the block's -9e-6 from rounding, so it passes there;
    // beside a variance of 1 (rounding 2.9e-6) the block is refused again.
    assert!(stateforge_math::f32::is_covariance(&indefinite));
    let beside_one = [[1.0, 0.0, 0.0], [0.0, 1e-6, 1e-5], [0.0, 1e-5, 1e-6]];
    assert!(!stateforge_math::f32::is_covariance(&beside_one));
}

#[test]
fn negative_variances_asymmetry_and_nan_are_rejected() {
    assert!(!stateforge_math::f64::is_covariance(&[
        [-1.0, 0.0],
        [0.0, 1.0]
    ]));
    assert!(!stateforge_math::f64::is_covariance(&[
        [1.0, 0.5],
        [0.4, 1.0]
    ]));
    assert!(stateforge_math::f64::is_covariance(&[
        [1.0, 0.5],
        [0.5 + 1e-12, 1.0]
    ]));
    assert!(!stateforge_math::f32::is_covariance(&[
        [1.0, f32::NAN],
        [f32::NAN, 1.0]
    ]));
    // A zero variance with a non-zero covariance: a correlation beyond 1.
    assert!(!stateforge_math::f64::is_covariance(&[
        [0.0, 1e-3],
        [1e-3, 1.0]
    ]));
    assert!(stateforge_math::f64::is_covariance(&[
        [0.0, 0.0],
        [0.0, 0.0]
    ]));
    // Perfectly correlated: semi-definite. A correlation of 1.001: indefinite.
    assert!(stateforge_math::f32::is_covariance(&[
        [4.0, 6.0],
        [6.0, 9.0]
    ]));
    assert!(!stateforge_math::f32::is_covariance(&[
        [4.0, 6.006],
        [6.006, 9.0]
    ]));
    assert!(stateforge_math::f32::all_non_negative(&[0.0, 1.0, 1e-30]));
    assert!(!stateforge_math::f32::all_non_negative(&[0.0, -1e-30]));
    assert!(!stateforge_math::f64::all_non_negative(&[f64::NAN]));
}

/// A 4 x 4 measurement noise with two sensors, outputs `[0, 2]` and `[3, 1]` (the second
/// listing its outputs out of the model's order).
const SENSOR_NOISE: [[f64; 4]; 4] = [
    [1.0, 0.0, 0.5, 0.0],
    [0.0, 4.0, 0.0, 0.25],
    [0.5, 0.0, 9.0, 0.0],
    [0.0, 0.25, 0.0, 16.0],
];

#[test]
fn a_sensor_block_is_packed_in_the_sensor_order() {
    let first: [f64; 3] = stateforge_math::f64::pack_upper_of(&SENSOR_NOISE, &[0, 2]);
    assert_eq!(first, [1.0, 0.5, 9.0]);
    let second: [f64; 3] = stateforge_math::f64::pack_upper_of(&SENSOR_NOISE, &[3, 1]);
    assert_eq!(second, [16.0, 0.25, 4.0]);
    // Read from the upper triangle: a lower entry that differs is not read.
    let mut lower_differs = SENSOR_NOISE.map(|row| row.map(|v| v as f32));
    lower_differs[3][1] = 7.0;
    let second: [f32; 3] = stateforge_math::f32::pack_upper_of(&lower_differs, &[3, 1]);
    assert_eq!(second, [16.0, 0.25, 4.0]);
    // The whole matrix, by its own rows, is `pack_upper`.
    let all: [f64; 10] = stateforge_math::f64::pack_upper_of(&SENSOR_NOISE, &[0, 1, 2, 3]);
    let packed: [f64; 10] = stateforge_math::f64::pack_upper(&SENSOR_NOISE);
    assert_eq!(all, packed);
}

#[test]
fn a_correlation_between_two_sensors_is_not_block_diagonal() {
    let blocks: [&[usize]; 2] = [&[0, 2], &[3, 1]];
    assert!(stateforge_math::f64::is_block_diagonal(
        &SENSOR_NOISE,
        &blocks
    ));
    // Any entry between the sensors, in either triangle.
    for (i, j) in [(0, 1), (1, 0), (2, 3), (3, 2), (0, 3), (1, 2)] {
        let mut correlated = SENSOR_NOISE.map(|row| row.map(|v| v as f32));
        correlated[i][j] = 1e-6;
        assert!(
            !stateforge_math::f32::is_block_diagonal(&correlated, &blocks),
            "({i}, {j})"
        );
    }
    // Within a sensor it is its own noise's correlation; NaN between them is not zero.
    assert!(stateforge_math::f64::is_block_diagonal(
        &SENSOR_NOISE,
        &[&[0, 1, 2, 3]]
    ));
    let mut nan = SENSOR_NOISE;
    nan[0][1] = f64::NAN;
    assert!(!stateforge_math::f64::is_block_diagonal(&nan, &blocks));
}

#[test]
fn weights_are_judged_from_their_upper_triangle_as_covariances_are() {
    let mut cases = Cases(0x2545_F491_4F6C_DD1D);
    for rank in 0..=4 {
        for _ in 0..200 {
            let m = cases.matrix::<4>(rank);
            let mut weight = array(&m);
            // The lower triangle is not read: garbage there changes nothing.
            for (i, row) in weight.iter_mut().enumerate() {
                for entry in &mut row[..i] {
                    *entry = -1e3 * cases.uniform();
                }
            }
            assert!(stateforge_math::f64::is_weight(&weight), "rank {rank}: {m}");
            let single: [[f32; 4]; 4] = weight.map(|row| row.map(|v| v as f32));
            assert!(stateforge_math::f32::is_weight(&single), "rank {rank}: {m}");
        }
    }
    for _ in 0..1000 {
        let m = cases.indefinite();
        assert!(!stateforge_math::f64::is_weight(&array(&m)), "{m}");
        let single: [[f32; 4]; 4] = array(&m).map(|row| row.map(|v| v as f32));
        assert!(!stateforge_math::f32::is_weight(&single), "{m}");
    }
    // A negative weight on the diagonal, a cross weight beyond the diagonal's, NaN.
    assert!(!stateforge_math::f64::is_weight(&[[-1.0, 0.0], [0.0, 1.0]]));
    assert!(!stateforge_math::f64::is_weight(&[[1.0, 2.0], [0.0, 1.0]]));
    assert!(!stateforge_math::f64::is_weight(&[
        [f64::NAN, 0.0],
        [0.0, 1.0]
    ]));
    assert!(stateforge_math::f64::is_weight(&[[1.0, 1.0], [7.0, 1.0]]));
    assert!(stateforge_math::f32::is_weight(&[[0.0]]));
}

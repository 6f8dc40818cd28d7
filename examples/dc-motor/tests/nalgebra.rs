//! The `interop` module reads the generated row-major arrays as rows: the Jacobian as an
//! `SMatrix` maps a small change of the state to the change of `f`, as a Jacobian must
//! (the transpose, which `SMatrix::from(jacobian)` would give, does not).

use dc_motor::motor::in_f64::{f, jacobian_f_wrt_x};
use dc_motor::motor::interop::{from_matrix, from_vector, to_matrix, to_vector};

#[test]
fn the_jacobian_as_a_matrix_maps_a_change_of_the_state_to_the_change_of_f() {
    let (x, u) = ([2.0, 150.0, 0.01, 3.0], [12.0]);
    let dx = [1e-6, -2e-5, 3e-8, 1e-6];
    let x_moved: [f64; 4] = core::array::from_fn(|i| x[i] + dx[i]);
    let (before, after) = (f(&x, &u), f(&x_moved, &u));
    let change = to_vector(&after) - to_vector(&before);
    let jacobian = to_matrix(&jacobian_f_wrt_x(&x, &u));
    let predicted = jacobian * to_vector(&dx);
    assert!(
        (predicted - change).amax() < 1e-9 * change.amax(),
        "{predicted} vs {change}"
    );
    let transposed = nalgebra::SMatrix::<f64, 4, 4>::from(jacobian_f_wrt_x(&x, &u));
    assert!((transposed * to_vector(&dx) - change).amax() > 1e-3 * change.amax());
    // And back: the conversions are inverses.
    assert_eq!(from_matrix(&jacobian), jacobian_f_wrt_x(&x, &u));
    assert_eq!(from_vector(&to_vector(&x)), x);
}

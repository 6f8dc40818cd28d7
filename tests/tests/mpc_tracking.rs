//! Tracking an output through its steady state (`tracked_outputs`,
//! `set_output_reference`) on continuous dynamics with a constant term: a mass on a
//! spring under gravity, whose holding force is not zero, regulated on two of its three
//! states; the steady state against nalgebra's least-squares solution of the equilibrium
//! equations, and the closed loop settling there.

use nalgebra::{DMatrix, DVector};

stateforge::model! {
    /// A mass on a damped spring under gravity, driven by a force; `drift` integrates
    /// the height and is not regulated (its rate does not enter the others').
    pub mod hanging_mass {
        scalar f64;
        const TS = 0.05;
        state z, vz, drift;
        input force;
        output height = z;
        dynamics continuous(euler, dt = TS, substeps = 10) {
            der(z) = vz;
            der(vz) = -4.0 * z - 0.5 * vz - 9.81 + force;
            der(drift) = 0.1 * z;
        }
        generate mpc(horizon = 5, states = [z, vz], input = force, discretisation = zoh,
            tracked_outputs = [height]);
    }
}

use hanging_mass::{Mpc, Status};

/// The equilibrium `dz/dt = dvz/dt = 0` with `z = height`, by nalgebra's SVD: `(z, vz,
/// force)`.
fn steady_state(height: f64) -> DVector<f64> {
    let equations = DMatrix::from_row_slice(3, 3, &[0.0, 1.0, 0.0, -4.0, -0.5, 1.0, 1.0, 0.0, 0.0]);
    let right = DVector::from_column_slice(&[0.0, 9.81, height]);
    equations.pseudo_inverse(1e-12).expect("an SVD") * right
}

#[test]
fn the_output_settles_at_its_reference_with_the_force_that_holds_it() {
    let q = [[10.0, 0.0], [0.0, 1.0]];
    let mut mpc = Mpc::new(&q, &[[0.01]], &[-50.0], &[50.0]).expect("valid");
    let mut x = [0.0, 0.0, 0.0];
    let mut u = [0.0];
    for height in [0.5, -1.25] {
        assert_eq!(mpc.set_output_reference(&[height]), Status::Ok);
        for _ in 0..400 {
            let status = mpc.solve(&x, &u);
            assert_eq!(status.status, Status::Ok);
            u = mpc.control();
            x = hanging_mass::f(&x, &u);
        }
        let expected = steady_state(height);
        assert!((x[0] - expected[0]).abs() < 1e-9, "{x:?} {expected}");
        assert!((x[1] - expected[1]).abs() < 1e-9, "{x:?} {expected}");
        assert!((u[0] - expected[2]).abs() < 1e-9, "{u:?} {expected}");
    }
    // A reference that is not finite leaves the controller as it was.
    let kept = mpc;
    assert_eq!(
        mpc.set_output_reference(&[f64::INFINITY]),
        Status::RejectedInput
    );
    assert_eq!(mpc, kept);
}

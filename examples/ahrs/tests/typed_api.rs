//! The generated API's named views (`State`, `Input`) and the `interop` conversions of a
//! rotation: what a user hands to and takes from nalgebra.

use ahrs::ahrs::interop::{from_rotation, to_rotation};
use ahrs::ahrs::{Input, State, U_LEN, X_LEN};
use nalgebra::{UnitQuaternion, Vector3};

#[test]
fn the_state_by_name_is_the_flat_array() {
    let flat: [f32; X_LEN] = core::array::from_fn(|i| i as f32 + 0.5);
    let state = State::from_array(&flat);
    assert_eq!(state.q, [0.5, 1.5, 2.5, 3.5]);
    assert_eq!(state.gyro_bias, [4.5, 5.5, 6.5]);
    assert_eq!(state.to_array(), flat);
    let input = Input::from_array(&[1.0; U_LEN]);
    assert_eq!(input.to_array(), [1.0; U_LEN]);
}

#[test]
fn a_rotation_goes_to_and_from_nalgebra_unchanged() {
    let turn = UnitQuaternion::from_scaled_axis(Vector3::new(0.3_f64, -1.1, 0.4));
    let stored = from_rotation(&turn);
    // The model's order is nalgebra's `coords`: `[x, y, z, w]`.
    assert_eq!(stored, [turn.i, turn.j, turn.k, turn.w]);
    assert_eq!(stored.as_slice(), turn.coords.as_slice());
    let back = to_rotation(&stored);
    assert_eq!(back, turn);
    // The model's `f` turns `q` as nalgebra does: `q * exp(w DT)`.
    let rate = [0.2_f64, 0.5, -0.3];
    let mut x = [0.0_f64; X_LEN];
    x[..4].copy_from_slice(&stored);
    let next = ahrs::ahrs::in_f64::f(&x, &rate);
    let dt = ahrs::ahrs::in_f64::DT;
    let expected = turn * UnitQuaternion::from_scaled_axis(Vector3::from(rate) * dt);
    let got = to_rotation(&[next[0], next[1], next[2], next[3]]);
    assert!(
        got.angle_to(&expected) < 1e-14,
        "{}",
        got.angle_to(&expected)
    );
}

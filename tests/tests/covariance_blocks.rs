//! A covariance in blocks that nothing couples (the `carried_state` test model's slope, a
//! parameter nothing moves or reads; the navigation model's wind): the filter leaves the
//! covariance between blocks zero without computing it, and equals a dense Kalman filter
//! (nalgebra, every entry computed) over a run; its constructor and `reset` refuse an
//! initial covariance that is not zero between blocks, leaving the filter as it was. And
//! the analysis itself, on models small enough to read: which coordinates it keeps apart.

include!("../models/carried_state.rs");

use carried_state::in_f64::{Ekf, Status};
use nalgebra::{Matrix1x3, Matrix3, Vector3};
use tests::rng::Lcg;

const DT: f64 = 0.01;
const Q: [f64; 3] = [1e-6, 1e-4, 1e-8];
const R: f64 = 0.04;

fn p0() -> [[f64; 3]; 3] {
    [[0.5, 0.1, 0.0], [0.1, 0.2, 0.0], [0.0, 0.0, 0.01]]
}

#[test]
fn the_blocks_are_the_measured_cart_and_the_carried_slope() {
    assert_eq!(Ekf::COVARIANCE_BLOCKS, [0, 0, 1]);
    // The navigation model's wind, which no sensor of the model reads: each coordinate a
    // block of its own; everything else one block.
    let names = generated_demo::navigation::TANGENT_NAMES;
    let blocks = generated_demo::navigation::Ekf::COVARIANCE_BLOCKS;
    for (name, block) in names.iter().zip(blocks) {
        let expected = match *name {
            "wind_n" => 1,
            "wind_e" => 2,
            _ => 0,
        };
        assert_eq!(block, expected, "{name}");
    }
}

#[test]
fn the_filter_equals_a_dense_kalman_filter_over_a_run() {
    let x0 = [0.3, -0.1, 0.02];
    let mut ekf = Ekf::new(&x0, &p0(), &Q, &[[R]]).expect("a valid filter");
    let a = Matrix3::new(1.0, DT, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
    let b = Vector3::new(0.0, DT, 0.0);
    let h = Matrix1x3::new(1.0, 0.0, 0.0);
    let mut x = Vector3::from(x0);
    let mut p = Matrix3::from_fn(|i, j| p0()[i][j]);
    let mut rng = Lcg(7);
    for k in 0..500 {
        let push = rng.uniform();
        let fix = 0.3 + 0.2 * (0.01 * f64::from(k)).sin() + 0.2 * rng.uniform();
        assert_eq!(ekf.predict(&[push]), Status::Ok);
        x = a * x + b * push;
        p = a * p * a.transpose() + Matrix3::from_diagonal(&Vector3::from(Q));
        if k % 3 == 0 {
            assert_eq!(ekf.update(&[fix]), Status::Ok);
            let s = (h * p * h.transpose())[0] + R;
            let gain = p * h.transpose() / s;
            x += gain * (fix - (h * x)[0]);
            let joseph = Matrix3::identity() - gain * h;
            p = joseph * p * joseph.transpose() + gain * R * gain.transpose();
        }
        let (state, covariance) = (ekf.state(), ekf.covariance());
        for i in 0..3 {
            assert!(
                (state[i] - x[i]).abs() <= 1e-12 * (1.0 + x[i].abs()),
                "x{i} at {k}"
            );
            for j in 0..3 {
                let scale = (p[(i, i)] * p[(j, j)]).sqrt();
                let difference = (covariance[i][j] - p[(i, j)]).abs();
                assert!(
                    difference <= 1e-12 * scale,
                    "p{i}{j} at {k}: {difference:e}"
                );
            }
        }
        // Between the blocks, exactly zero in both.
        for i in 0..2 {
            assert_eq!(covariance[i][2], 0.0);
            assert_eq!(p[(i, 2)], 0.0);
        }
    }
}

#[test]
fn an_initial_covariance_not_zero_between_blocks_is_refused() {
    let x0 = [0.0; 3];
    let mut coupled = p0();
    (coupled[0][2], coupled[2][0]) = (0.01, 0.01);
    assert_eq!(
        Ekf::new(&x0, &coupled, &Q, &[[R]]).err(),
        Some(Status::InvalidCovariance)
    );
    let mut ekf = Ekf::new(&x0, &p0(), &Q, &[[R]]).expect("a valid filter");
    assert_eq!(ekf.predict(&[0.5]), Status::Ok);
    let before = ekf;
    assert_eq!(ekf.reset(&[1.0; 3], &coupled), Status::InvalidCovariance);
    assert_eq!(ekf, before);
    // A negative zero is zero.
    let mut signed = p0();
    (signed[1][2], signed[2][1]) = (-0.0, -0.0);
    assert_eq!(ekf.reset(&[1.0; 3], &signed), Status::Ok);
}

use quote::quote;
use stateforge_compiler::symbolic::covariance_blocks::{Couplings, CovarianceBlocks};
use stateforge_compiler::symbolic::ModelGraph;
use std::ops::Range;

/// The blocks of the model `body` with the couplings' options given.
fn blocks(
    body: proc_macro2::TokenStream,
    correlated_noise: &[usize],
    noisy: &[usize],
) -> Vec<usize> {
    let checked = stateforge_compiler::parse_model(body).expect("the test model is valid");
    let model = checked.model;
    let mg = ModelGraph::build(&model);
    let together: Vec<Range<usize>> = model
        .rotations()
        .iter()
        .map(|r| r.tangent..r.tangent + 3)
        .collect();
    let couplings = Couplings {
        correlated_noise,
        noisy_inputs: noisy,
        together: &together,
    };
    CovarianceBlocks::of_ekf(&mg, &couplings).ids().to_vec()
}

/// A cart whose position is measured, with a slope nothing reads and an offset
/// nothing measures but the velocity moves with.
fn cart() -> proc_macro2::TokenStream {
    quote! {
        mod cart {
            scalar f64;
            const DT = 0.1;
            state position, velocity;
            param slope, drag;
            input force;
            output fix = position;
            dynamics discrete {
                position = position + DT * velocity;
                velocity = velocity + DT * (force - drag * velocity);
            }
        }
    }
}

#[test]
fn a_state_nothing_moves_or_reads_is_a_block_of_its_own() {
    // `drag` moves the velocity, which moves the measured position: one block.
    assert_eq!(blocks(cart(), &[], &[]), [0, 0, 1, 0]);
}

#[test]
fn a_full_process_noise_couples_the_states_it_enters() {
    assert_eq!(blocks(cart(), &[0, 1, 2, 3], &[]), [0, 0, 0, 0]);
    assert_eq!(blocks(cart(), &[1, 3], &[]), [0, 0, 1, 0]);
}

#[test]
fn noise_on_an_input_couples_the_states_it_enters() {
    let body = quote! {
        mod sled {
            scalar f64;
            const DT = 0.1;
            state position, heading;
            input push, turn;
            output fix = position;
            dynamics discrete {
                position = position + DT * push;
                heading = heading + DT * turn + DT * push;
            }
        }
    };
    // Apart, the heading (moved by nothing measured) is a block of its own; the push's
    // noise enters both.
    assert_eq!(blocks(body.clone(), &[], &[]), [0, 1]);
    assert_eq!(blocks(body.clone(), &[], &[1]), [0, 1]);
    assert_eq!(blocks(body, &[], &[0]), [0, 0]);
}

#[test]
fn a_rotations_coordinates_are_one_block_and_a_carried_vector_is_apart() {
    let body = quote! {
        mod attitude {
            scalar f64;
            const DT = 0.01;
            state q: Rot3;
            param bias: Vec3, carried: Vec3;
            input gyro: Vec3;
            output down = q.inverse() * vec3(0.0, 0.0, 1.0);
            dynamics discrete {
                q = q * exp((gyro - bias) * DT);
            }
        }
    };
    assert_eq!(blocks(body, &[], &[]), [0, 0, 0, 0, 0, 0, 1, 2, 3]);
}

//! The window transform is exact on noise-free data, for every model that has a DKF:
//! the reconstructed `phi` equals the true state and parameters, and
//! `F x + G u + d = f(x, u)` at the true state, to 1e-9 relative (f64); a window longer
//! than the minimum (least squares) as well, and a model with a switched (Coulomb) friction.

use generated_demo::{beam_two_actuators, cantilever, cantilever_long_window, duffing_beam};

const RTOL: f64 = 1e-9;

stateforge::model! {
    /// The cantilever with a Coulomb friction on its velocity: a term whose derivatives
    /// vanish but which switches with the state, so the transform must not take its value
    /// at zero state.
    mod friction_beam {
        scalar f32, f64;
        const TS = 0.015;
        const FRICTION = 5.0;
        state x1, x2;
        param x3, x4, x5;
        input u;
        output y = x1;
        generate dkf(eta = 0.5, process_noise = diagonal, gate = off);
        dynamics discrete {
            let coulomb = if x2 > 0.0 { FRICTION } else { -FRICTION };
            x1 = x1 + TS * x2;
            x2 = TS * x1 * x3 + (1.0 + TS * x4) * x2 + TS * x5 * u - TS * coulomb;
        }
    }
}

/// Entry-wise agreement at the vector's scale.
fn assert_agree(what: &str, k: usize, got: &[f64], want: &[f64]) {
    let scale = want.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (i, (&g, &w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= RTOL * g.abs().max(w.abs()).max(scale),
            "{what} at sample {k}, entry {i}: {g:e} vs {w:e}"
        );
    }
}

/// A deterministic, richly varying input: a sum of incommensurate sines.
fn input(k: usize, phase: f64) -> f64 {
    let t = k as f64 * 0.015;
    60.0 * (7.0 * t + phase).sin() + 40.0 * (23.0 * t + 2.0 * phase).sin()
}

fn identity_matrix<const N: usize>() -> [[f64; N]; N] {
    std::array::from_fn(|i| std::array::from_fn(|j| if i == j { 1.0 } else { 0.0 }))
}

macro_rules! check_exactness {
    ($module:ident, $x0:expr, $noise:expr, $inputs:expr) => {{
        use $module::in_f64::{f, ltv_model, Dkf, WindowStatus};
        use $module::{STATE_LEN, WINDOW_OUTPUTS, X_LEN};
        let truth0: [f64; X_LEN] = $x0;
        let identity = {
            let mut m = [[0.0; X_LEN]; X_LEN];
            for (i, row) in m.iter_mut().enumerate() {
                row[i] = 1.0;
            }
            m
        };
        let noise = $noise;
        let mut dkf = Dkf::new(&truth0, &identity, &noise, &identity, &noise, &[[1e-3]]).unwrap();
        let mut x = truth0;
        let inputs = $inputs;
        let mut checked = 0;
        for k in 1..400 {
            let u_prev = inputs(k - 1);
            x = f(&x, &u_prev);
            let status = dkf.step(&u_prev, &[x[0]]);
            assert!(status.is_ok(), "{status:?}");
            if k < WINDOW_OUTPUTS {
                continue;
            }
            let u = inputs(k);
            let (phi, window) = dkf.window_estimate(&u);
            assert_eq!(
                window,
                WindowStatus::Solved,
                "sample {k}: x = {x:?}, excitation {}",
                dkf.excitation()
            );
            assert_agree("phi", k, &phi, &x);
            let (fm, gm, d) = ltv_model(&phi, &u);
            let mut transformed = [0.0; X_LEN];
            for i in 0..X_LEN {
                transformed[i] = d[i]
                    + (0..X_LEN).map(|j| fm[i][j] * x[j]).sum::<f64>()
                    + (0..u.len()).map(|j| gm[i][j] * u[j]).sum::<f64>();
            }
            assert_agree("F x + G u + d", k, &transformed, &f(&x, &u));
            checked += 1;
        }
        assert!(checked > 390 - WINDOW_OUTPUTS, "{checked} windows checked");
        assert!(STATE_LEN < X_LEN);
    }};
}

#[test]
fn cantilever_transform_is_exact() {
    check_exactness!(
        cantilever,
        [0.2, 0.0, -393.93, -6.941, 0.4924],
        [1.0; 5],
        |k: usize| [input(k, 0.0)]
    );
}

#[test]
fn two_actuator_transform_is_exact() {
    check_exactness!(
        beam_two_actuators,
        [0.2, 0.0, -393.93, -6.941, 0.4924, -0.3],
        identity_matrix::<6>(),
        |k: usize| [input(k, 0.0), input(k, 1.3)]
    );
}

#[test]
fn cubic_stiffness_transform_is_exact() {
    check_exactness!(
        duffing_beam,
        [0.2, 0.0, -393.93, -6.941, -50.0, 0.4924],
        identity_matrix::<6>(),
        |k: usize| [input(k, 0.0)]
    );
}

#[test]
fn a_switched_friction_transform_is_exact() {
    check_exactness!(
        friction_beam,
        [0.2, 0.0, -393.93, -6.941, 0.4924],
        [1.0; 5],
        |k: usize| [input(k, 0.0)]
    );
}

#[test]
fn least_squares_transform_is_exact() {
    check_exactness!(
        cantilever_long_window,
        [0.2, 0.0, -393.93, -6.941, 0.4924],
        [1.0; 5],
        |k: usize| [input(k, 0.0)]
    );
}

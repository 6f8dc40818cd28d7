//! `atan2`, `tanh`, `min`, `max` and `clamp` (the saturation) in a model: the rover test
//! model (`tests/models/rover.rs`) written with them, its generated `f64` functions against
//! the same model written by hand in Rust with the standard library's functions, its
//! Jacobians against central differences of that hand-written model (on each side of
//! every kink: piecewise terms are differentiated branch by branch), the model file
//! (`tests/models/rover.toml`) generating the macro's code, and the generated code's
//! safety rules.

use tests::rng::Lcg;
use tests::workspace_path;

include!("../models/rover.rs");

use rover::in_f64 as generated;

const TS: f64 = 0.01;
const STEER_MAX: f64 = 0.5;
const WHEELBASE: f64 = 0.3;
const V_MAX: f64 = 4.0;

/// The rover's step, written by hand with `f64`'s own functions.
fn f_by_hand(x: &[f64; 5], u: &[f64; 2]) -> [f64; 5] {
    let [px, py, heading, speed, drag] = *x;
    let [throttle, steer] = *u;
    let delta = steer.clamp(-STEER_MAX, STEER_MAX);
    let push = throttle.max(0.0);
    [
        px + TS * speed * heading.cos(),
        py + TS * speed * heading.sin(),
        heading + TS * speed * (delta / STEER_MAX).tanh() * STEER_MAX / WHEELBASE,
        (speed + TS * (push - drag * speed)).min(V_MAX),
        drag,
    ]
}

/// The rover's measurement, written by hand.
fn h_by_hand(x: &[f64; 5]) -> [f64; 2] {
    let [px, py, ..] = *x;
    [py.atan2(px), (px * px + py * py).sqrt()]
}

/// A random point of the state and input spaces; `steer` and `throttle` reach past
/// their kinks, the speed past its limit.
fn random_point(rng: &mut Lcg) -> ([f64; 5], [f64; 2]) {
    let x = [
        3.0 * rng.uniform(),
        3.0 * rng.uniform(),
        3.2 * rng.uniform(),
        4.0 + 1.5 * rng.uniform(),
        0.5 + 0.3 * rng.uniform(),
    ];
    (x, [2.0 * rng.uniform(), 0.9 * rng.uniform()])
}

/// Whether a central difference of step `eps` around `(x, u)` stays on one side of
/// every kink, so it measures the derivative of the branch taken.
fn away_from_kinks(x: &[f64; 5], u: &[f64; 2], eps: f64) -> bool {
    let [_, _, _, speed, drag] = *x;
    let [throttle, steer] = *u;
    let margin = 1e3 * eps;
    let unclamped_speed = speed + TS * (throttle.max(0.0) - drag * speed);
    throttle.abs() > margin
        && (steer.abs() - STEER_MAX).abs() > margin
        && (unclamped_speed - V_MAX).abs() > margin
}

fn assert_close(what: &str, got: f64, want: f64, rtol: f64, scale: f64) {
    let tolerance = rtol * want.abs().max(scale);
    assert!(
        (got - want).abs() <= tolerance,
        "{what}: generated {got:e}, reference {want:e} (tolerance {tolerance:e})"
    );
}

#[test]
fn generated_functions_equal_the_model_written_by_hand() {
    let mut rng = Lcg(11);
    for _ in 0..500 {
        let (x, u) = random_point(&mut rng);
        for (i, (got, want)) in generated::f(&x, &u)
            .iter()
            .zip(f_by_hand(&x, &u))
            .enumerate()
        {
            assert_close(&format!("f[{i}] at {x:?} {u:?}"), *got, want, 1e-14, 1.0);
        }
        for (i, (got, want)) in generated::h(&x).iter().zip(h_by_hand(&x)).enumerate() {
            assert_close(&format!("h[{i}] at {x:?}"), *got, want, 1e-14, 1.0);
        }
    }
}

#[test]
fn jacobians_equal_central_differences_on_each_branch() {
    let eps = 1e-6;
    let mut rng = Lcg(12);
    let (mut checked, mut clamped_steer, mut idle_throttle, mut top_speed) = (0, 0, 0, 0);
    while checked < 400 {
        let (x, u) = random_point(&mut rng);
        if !away_from_kinks(&x, &u, eps) {
            continue;
        }
        checked += 1;
        clamped_steer += usize::from(u[1].abs() > STEER_MAX);
        idle_throttle += usize::from(u[0] < 0.0);
        top_speed += usize::from(f_by_hand(&x, &u)[3] == V_MAX);
        let (a, b, c) = (
            generated::jacobian_f_wrt_x(&x, &u),
            generated::jacobian_f_wrt_u(&x, &u),
            generated::jacobian_h_wrt_x(&x),
        );
        for j in 0..5 {
            let (mut up, mut down) = (x, x);
            up[j] += eps;
            down[j] -= eps;
            let (fu, fd) = (f_by_hand(&up, &u), f_by_hand(&down, &u));
            let (hu, hd) = (h_by_hand(&up), h_by_hand(&down));
            for i in 0..5 {
                let fd_ij = (fu[i] - fd[i]) / (2.0 * eps);
                assert_close(
                    &format!("df{i}/dx{j} at {x:?} {u:?}"),
                    a[i][j],
                    fd_ij,
                    1e-6,
                    1e-3,
                );
            }
            for i in 0..2 {
                let fd_ij = (hu[i] - hd[i]) / (2.0 * eps);
                assert_close(&format!("dh{i}/dx{j} at {x:?}"), c[i][j], fd_ij, 1e-6, 1e-3);
            }
        }
        for j in 0..2 {
            let (mut up, mut down) = (u, u);
            up[j] += eps;
            down[j] -= eps;
            let (fu, fd) = (f_by_hand(&x, &up), f_by_hand(&x, &down));
            for i in 0..5 {
                let fd_ij = (fu[i] - fd[i]) / (2.0 * eps);
                assert_close(
                    &format!("df{i}/du{j} at {x:?} {u:?}"),
                    b[i][j],
                    fd_ij,
                    1e-6,
                    1e-3,
                );
            }
        }
    }
    // Every branch of every piecewise term was exercised.
    for (branch, count) in [
        ("steering at its stop", clamped_steer),
        ("throttle that does not push", idle_throttle),
        ("speed at its limit", top_speed),
    ] {
        assert!(count > 20, "{branch}: only {count} of {checked} points");
    }
}

#[test]
fn a_saturated_input_has_no_effect_and_a_zero_derivative() {
    let x = [1.0, 2.0, 0.3, 1.0, 0.5];
    let (at_stop, past_stop) = ([0.5, 0.5], [0.5, 0.9]);
    assert_eq!(generated::f(&x, &at_stop), generated::f(&x, &past_stop));
    assert_eq!(generated::jacobian_f_wrt_u(&x, &past_stop)[2][1], 0.0);
    assert!(generated::jacobian_f_wrt_u(&x, &[0.5, 0.4])[2][1] > 0.0);
    // `atan2` keeps the quadrant that `atan(y / x)` loses.
    let behind = [-1.0, -1.0, 0.0, 0.0, 0.0];
    assert_close(
        "bearing",
        generated::h(&behind)[0],
        -0.75 * std::f64::consts::PI,
        1e-15,
        1.0,
    );
}

#[test]
fn the_model_file_generates_the_macros_code() {
    let without_docs = |tokens| {
        let text = stateforge_cli::format(tokens).expect("formats");
        text.lines()
            .filter(|l| !l.trim_start().starts_with("///") && !l.trim_start().starts_with("//!"))
            .collect::<Vec<_>>()
            .join("\n")
    };
    let read = |name| std::fs::read_to_string(workspace_path(name)).expect("test model exists");
    let from_file = stateforge_cli::expand_model_file(&read("tests/models/rover.toml"))
        .expect("model file expands");
    let from_macro = stateforge_compiler::expand_macro_source(&read("tests/models/rover.rs"))
        .expect("macro expands");
    assert_eq!(without_docs(from_file), without_docs(from_macro));
}

#[test]
fn the_generated_code_calls_stateforge_math_and_compares_typed_values() {
    let source = std::fs::read_to_string(workspace_path("tests/models/rover.rs")).expect("exists");
    let code =
        stateforge_cli::format(stateforge_compiler::expand_macro_source(&source).expect("expands"))
            .expect("formats");
    for call in [
        "stateforge_math::f32::atan2(",
        "stateforge_math::f32::tanh(",
        "stateforge_math::f64::atan2(",
        "stateforge_math::f64::tanh(",
    ] {
        assert!(code.contains(call), "no `{call}` in the generated code");
    }
    assert!(!code.contains(".min(") && !code.contains(".max(") && !code.contains(".clamp("));
}

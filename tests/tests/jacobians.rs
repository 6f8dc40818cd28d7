//! Every demo model's generated `f64` functions against the model evaluated by `meval`:
//! `f` and `h` agree with the model text (discretised here, independently of the symbolic
//! engine), and every Jacobian agrees with central finite differences of it, at random
//! points.

use generated_demo::{helicopter, polynomial};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use stateforge_compiler::model::{Discretisation, Method, Model};
use tests::demo_model_source;

/// Relative agreement required of each Jacobian entry.
const JACOBIAN_RTOL: f64 = 1e-6;
/// Relative agreement required of `f` and `h` (different evaluation order only).
const VALUE_RTOL: f64 = 1e-10;

/// A generated vector function, as `(t, x, u) -> value`.
type VectorFn = fn(f64, &[f64], &[f64]) -> Vec<f64>;
/// A generated Jacobian, as `(t, x, u) -> rows`.
type MatrixFn = fn(f64, &[f64], &[f64]) -> Vec<Vec<f64>>;

/// The generated functions of one model, behind one signature.
struct Generated {
    f: VectorFn,
    h: VectorFn,
    /// `None` for a model whose sub-steps run in a loop: its `f` has no Jacobians.
    jacobians_f: Option<JacobiansF>,
    jacobian_h_wrt_x: MatrixFn,
}

/// The Jacobians of the unrolled step `f` and the structural zeros of `df/dx`.
struct JacobiansF {
    wrt_x: MatrixFn,
    wrt_u: MatrixFn,
    nonzero_wrt_x: Vec<Vec<bool>>,
}

fn arr<const N: usize>(v: &[f64]) -> [f64; N] {
    v.try_into().expect("length matches the model")
}

fn rows<const N: usize, const M: usize>(m: [[f64; N]; M]) -> Vec<Vec<f64>> {
    m.iter().map(|r| r.to_vec()).collect()
}

/// The model as text evaluated by `meval`, discretised the way the model says.
struct Reference {
    model: Model,
    rhs: Vec<meval::Expr>,
    outputs: Vec<meval::Expr>,
}

impl Reference {
    fn new(name: &str) -> Reference {
        let model = stateforge_compiler::parse_macro_source(&demo_model_source(name))
            .unwrap_or_else(|e| panic!("{name}: {e}"))
            .model;
        let parse = |e: &stateforge_compiler::model::Expr| -> meval::Expr {
            let text = stateforge_cli::meval_text::to_meval(&model, e);
            text.parse()
                .unwrap_or_else(|err| panic!("{name}: meval cannot parse {text}: {err}"))
        };
        let rhs = model.dynamics.rhs.iter().map(parse).collect();
        let outputs = model.outputs.iter().map(|o| parse(&o.expr)).collect();
        Reference {
            model,
            rhs,
            outputs,
        }
    }

    fn eval(&self, exprs: &[meval::Expr], t: f64, x: &[f64], u: &[f64]) -> Vec<f64> {
        let mut ctx = stateforge_cli::meval_text::context(&self.model);
        ctx.var("t", t);
        for (name, v) in self.model.state_names().zip(x) {
            ctx.var(name, *v);
        }
        for (s, v) in self.model.inputs.iter().zip(u) {
            ctx.var(s.name.clone(), *v);
        }
        exprs
            .iter()
            .map(|e| e.eval_with_context(&ctx).expect("model evaluates"))
            .collect()
    }

    /// One sample of the model: the right-hand sides, integrated if continuous.
    fn f(&self, t: f64, x: &[f64], u: &[f64]) -> Vec<f64> {
        let n = self.model.states.len();
        let (physical, params) = x.split_at(n);
        let with_params = |s: &[f64]| [s, params].concat();
        let deriv = |t: f64, s: &[f64]| self.eval(&self.rhs, t, &with_params(s), u);
        let next = match &self.model.dynamics.discretisation {
            Discretisation::Discrete => deriv(t, physical),
            Discretisation::Continuous {
                method,
                dt,
                substeps,
            } => {
                let dt = dt
                    .const_value(&self.model.constants)
                    .expect("dt is constant");
                let h = dt / f64::from(*substeps);
                let mut s = physical.to_vec();
                let mut time = t;
                let axpy = |a: &[f64], c: f64, b: &[f64]| -> Vec<f64> {
                    a.iter().zip(b).map(|(a, b)| a + c * b).collect()
                };
                for _ in 0..*substeps {
                    s = match method {
                        Method::Euler => axpy(&s, h, &deriv(time, &s)),
                        Method::Rk4 => {
                            let k1 = deriv(time, &s);
                            let k2 = deriv(time + h / 2.0, &axpy(&s, h / 2.0, &k1));
                            let k3 = deriv(time + h / 2.0, &axpy(&s, h / 2.0, &k2));
                            let k4 = deriv(time + h, &axpy(&s, h, &k3));
                            (0..n)
                                .map(|i| {
                                    s[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
                                })
                                .collect()
                        }
                    };
                    time += h;
                }
                s
            }
        };
        with_params(&next)
    }

    fn h(&self, t: f64, x: &[f64], u: &[f64]) -> Vec<f64> {
        self.eval(&self.outputs, t, x, u)
    }
}

/// Central differences of `g` with respect to `v`, column by column: `[i][j] = d g_i/d v_j`,
/// each with an estimate of its own rounding noise.
///
/// With steps of `1e-6 max(|v_j|, 1)` the truncation error (order `step^2`) is negligible, and what
/// is left is rounding: about `eps S_i / step`, where `S_i` is the size of the terms that
/// `g_i` sums, not of `g_i` itself, which can be small after cancellation. That noise is
/// measured rather than guessed: the difference is taken again at half and twice the step,
/// and the spread of the three is the noise.
fn central_differences(g: &dyn Fn(&[f64]) -> Vec<f64>, v: &[f64]) -> Vec<Vec<Estimate>> {
    let rows = g(v).len();
    let mut table = vec![vec![Estimate::default(); v.len()]; rows];
    for j in 0..v.len() {
        let step = 1e-6 * v[j].abs().max(1.0);
        let differences = [0.5, 1.0, 2.0].map(|scale| central_difference(g, v, j, scale * step));
        for (i, entry) in table.iter_mut().enumerate() {
            let [half, one, double] = differences.each_ref().map(|d| d[i]);
            let noise = (one - half).abs().max((one - double).abs());
            entry[j] = Estimate { value: one, noise };
        }
    }
    table
}

/// `(g(v + step e_j) - g(v - step e_j)) / 2 step`.
fn central_difference(g: &dyn Fn(&[f64]) -> Vec<f64>, v: &[f64], j: usize, step: f64) -> Vec<f64> {
    let (mut plus, mut minus) = (v.to_vec(), v.to_vec());
    plus[j] += step;
    minus[j] -= step;
    g(&plus)
        .iter()
        .zip(g(&minus))
        .map(|(p, m)| (p - m) / (2.0 * step))
        .collect()
}

/// A finite difference and the size of its rounding noise.
#[derive(Clone, Copy, Default)]
struct Estimate {
    value: f64,
    noise: f64,
}

/// Each entry within `JACOBIAN_RTOL` of the finite difference, allowing for the
/// difference's own rounding noise: three times the measured spread (see
/// `central_differences`), and at least `1e-8 |g_i|`.
fn assert_jacobian(what: &str, generated: &[Vec<f64>], fd: &[Vec<Estimate>], values: &[f64]) {
    assert_eq!(generated.len(), fd.len(), "{what}: row count");
    for (i, (g_row, fd_row)) in generated.iter().zip(fd).enumerate() {
        for (j, (&g, d)) in g_row.iter().zip(fd_row).enumerate() {
            let rounding = (3.0 * d.noise).max(1e-8 * values[i].abs().max(1.0));
            let tolerance = JACOBIAN_RTOL * g.abs().max(d.value.abs()) + rounding;
            assert!(
                (g - d.value).abs() <= tolerance,
                "{what}[{i}][{j}]: generated {g:e}, finite differences {:e} (noise {:e})",
                d.value,
                d.noise
            );
        }
    }
}

fn assert_values(what: &str, generated: &[f64], reference: &[f64]) {
    assert_eq!(generated.len(), reference.len(), "{what}: length");
    for (i, (&g, &r)) in generated.iter().zip(reference).enumerate() {
        let tolerance = VALUE_RTOL * g.abs().max(r.abs()).max(1.0);
        assert!(
            (g - r).abs() <= tolerance,
            "{what}[{i}]: generated {g:e}, meval {r:e}"
        );
    }
}

fn check_model(name: &str, generated: &Generated) {
    check_model_at(name, generated, &[]);
}

/// A point of the model's arguments: `(t, x, u)`.
type Point = (f64, Vec<f64>, Vec<f64>);

/// The checks at `fixed` points (inputs that once failed) and at 48 random ones.
fn check_model_at(name: &str, generated: &Generated, fixed: &[Point]) {
    let reference = Reference::new(name);
    for (t, x, u) in fixed {
        check_point(name, &reference, generated, *t, x, u);
    }
    let n = reference.model.state_len();
    let m = reference.model.inputs.len();
    let point = (
        0.0..2.0f64,
        prop::collection::vec(-1.0..1.0f64, n),
        prop::collection::vec(-1.0..1.0f64, m),
    );
    let mut runner = TestRunner::new(Config {
        cases: 48,
        failure_persistence: None,
        ..Config::default()
    });
    let result = runner.run(&point, |(t, x, u)| {
        check_point(name, &reference, generated, t, &x, &u);
        Ok(())
    });
    if let Err(e) = result {
        panic!("{name}: {e}");
    }
}

/// `f`, `h` and every Jacobian at one point, with `df/dx`'s structural zeros exactly zero.
fn check_point(
    name: &str,
    reference: &Reference,
    generated: &Generated,
    t: f64,
    x: &[f64],
    u: &[f64],
) {
    let f = reference.f(t, x, u);
    assert_values(&format!("{name}: f"), &(generated.f)(t, x, u), &f);
    let y = reference.h(t, x, u);
    assert_values(&format!("{name}: h"), &(generated.h)(t, x, u), &y);

    if let Some(jacobians) = &generated.jacobians_f {
        let fd_x = central_differences(&|x| reference.f(t, x, u), x);
        let jfx = (jacobians.wrt_x)(t, x, u);
        assert_jacobian(&format!("{name}: df/dx"), &jfx, &fd_x, &f);
        for (i, row) in jfx.iter().enumerate() {
            for (j, &value) in row.iter().enumerate() {
                if !jacobians.nonzero_wrt_x[i][j] {
                    assert_eq!(value, 0.0, "{name}: df/dx[{i}][{j}] is a structural zero");
                }
            }
        }
        let fd_u = central_differences(&|u| reference.f(t, x, u), u);
        let jfu = (jacobians.wrt_u)(t, x, u);
        assert_jacobian(&format!("{name}: df/du"), &jfu, &fd_u, &f);
    }
    let fd_hx = central_differences(&|x| reference.h(t, x, u), x);
    let jhx = (generated.jacobian_h_wrt_x)(t, x, u);
    assert_jacobian(&format!("{name}: dh/dx"), &jhx, &fd_hx, &y);
}

/// Structural non-zeros as rows.
fn nonzero<const N: usize>(pattern: &[[bool; N]; N]) -> Vec<Vec<bool>> {
    pattern.iter().map(|r| r.to_vec()).collect()
}

/// The adapters of a model without time and with inputs (`f(x, u)`, `h(x)`).
macro_rules! time_invariant_with_inputs {
    ($module:ident) => {{
        use generated_demo::$module::in_f64 as g;
        Generated {
            f: |_, x, u| g::f(&arr(x), &arr(u)).to_vec(),
            h: |_, x, _| g::h(&arr(x)).to_vec(),
            jacobians_f: Some(JacobiansF {
                wrt_x: |_, x, u| rows(g::jacobian_f_wrt_x(&arr(x), &arr(u))),
                wrt_u: |_, x, u| rows(g::jacobian_f_wrt_u(&arr(x), &arr(u))),
                nonzero_wrt_x: nonzero(&generated_demo::$module::JACOBIAN_F_WRT_X_NONZERO),
            }),
            jacobian_h_wrt_x: |_, x, _| rows(g::jacobian_h_wrt_x(&arr(x))),
        }
    }};
}

/// The adapters of a time-invariant model with inputs whose sub-steps run in a loop:
/// `f(x, u)` with no Jacobians, `h(x)`.
macro_rules! looped_with_inputs {
    ($module:ident) => {{
        use generated_demo::$module::in_f64 as g;
        Generated {
            f: |_, x, u| g::f(&arr(x), &arr(u)).to_vec(),
            h: |_, x, _| g::h(&arr(x)).to_vec(),
            jacobians_f: None,
            jacobian_h_wrt_x: |_, x, _| rows(g::jacobian_h_wrt_x(&arr(x))),
        }
    }};
}

#[test]
fn cantilever_jacobians_match_finite_differences() {
    check_model("cantilever", &time_invariant_with_inputs!(cantilever));
}

#[test]
fn mass_spring_damper_jacobians_match_finite_differences() {
    check_model(
        "mass_spring_damper",
        &looped_with_inputs!(mass_spring_damper),
    );
}

#[test]
fn blade_identification_jacobians_match_finite_differences() {
    check_model(
        "blade_identification",
        &looped_with_inputs!(blade_identification),
    );
}

#[test]
fn polynomial_jacobians_match_finite_differences() {
    use polynomial::in_f64 as g;
    check_model(
        "polynomial",
        &Generated {
            f: |_, x, _| g::f(&arr(x)).to_vec(),
            h: |_, x, _| g::h(&arr(x)).to_vec(),
            jacobians_f: Some(JacobiansF {
                wrt_x: |_, x, _| rows(g::jacobian_f_wrt_x(&arr(x))),
                // No inputs: df/du has no columns.
                wrt_u: |_, x, _| vec![Vec::new(); x.len()],
                nonzero_wrt_x: nonzero(&polynomial::JACOBIAN_F_WRT_X_NONZERO),
            }),
            jacobian_h_wrt_x: |_, x, _| rows(g::jacobian_h_wrt_x(&arr(x))),
        },
    );
}

#[test]
fn piecewise_beam_jacobians_match_finite_differences() {
    // At this point df/dx[5][4] is 8.6404361e-3 and its finite difference 8.6404616e-3:
    // the row of `v_xi` sums terms of order 1e5 (stiffness times the step), so the
    // difference's rounding noise (measured 5.8e-8) is far above `1e-8 |f_5|`. One point in
    // about 20000 is like it; this one is kept so the allowance is always exercised there.
    let cancelling = (
        0.0,
        vec![
            0.6592894308309662,
            -0.7747728280499633,
            -0.188865597369809,
            0.45010699749177707,
            0.09524465803267823,
            -0.9492109517342384,
        ],
        vec![-0.6462361046467797],
    );
    check_model_at(
        "piecewise_beam",
        &time_invariant_with_inputs!(piecewise_beam),
        &[cancelling],
    );
}

#[test]
fn helicopter_jacobians_match_finite_differences() {
    use helicopter::in_f64 as g;
    check_model(
        "helicopter",
        &Generated {
            f: |t, x, u| g::f(t, &arr(x), &arr(u)).to_vec(),
            h: |t, x, _| g::h(t, &arr(x)).to_vec(),
            jacobians_f: Some(JacobiansF {
                wrt_x: |t, x, u| rows(g::jacobian_f_wrt_x(t, &arr(x), &arr(u))),
                wrt_u: |t, x, u| rows(g::jacobian_f_wrt_u(t, &arr(x), &arr(u))),
                nonzero_wrt_x: nonzero(&helicopter::JACOBIAN_F_WRT_X_NONZERO),
            }),
            jacobian_h_wrt_x: |t, x, _| rows(g::jacobian_h_wrt_x(t, &arr(x))),
        },
    );
}

#[test]
fn beam_two_actuators_jacobians_match_finite_differences() {
    check_model(
        "beam_two_actuators",
        &time_invariant_with_inputs!(beam_two_actuators),
    );
}

#[test]
fn duffing_beam_jacobians_match_finite_differences() {
    check_model("duffing_beam", &time_invariant_with_inputs!(duffing_beam));
}

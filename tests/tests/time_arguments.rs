//! The times a filter evaluates a model that reads `t` at (the generated API's rule 5): a
//! step predicts from `t_prev` and corrects at the measurement's time, `t_prev + dt` for
//! continuous dynamics (the step takes no `t`) and the argument `t` for discrete ones. Each
//! step agrees with `predict(t_prev, u_prev)` then `update(t, y)` at that time, on models
//! whose `f` and `h` both read `t` (a sensor whose offset drifts with time), so a step
//! that evaluated `h` at another time would be off by the drift's share of the gain.

use tests::compare::assert_same_estimates;

stateforge::model! {
    /// An oscillator with a decaying drive; its position sensor drifts with time.
    mod drifting {
        scalar f64;
        const TS = 0.01;
        state x1, x2;
        input u;
        output y = x1 + 0.1 * t;
        generate ekf, hybrid_ekf;
        dynamics continuous(rk4, dt = TS) {
            der(x1) = x2;
            der(x2) = -4.0 * x1 - 0.2 * x2 + exp(-0.5 * t) * u;
        }
    }
}

stateforge::model! {
    /// The same, sampled: the model does not state its sample time.
    mod drifting_sampled {
        scalar f64;
        const TS = 0.01;
        state x1, x2;
        input u;
        output y = x1 + 0.1 * t;
        generate ekf;
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 + TS * (-4.0 * x1 - 0.2 * x2 + exp(-0.5 * t) * u);
        }
    }
}

const P0: [[f64; 2]; 2] = [[0.1, 0.0], [0.0, 0.1]];
const Q: [[f64; 2]; 2] = [[1e-6, 0.0], [0.0, 1e-4]];
const R: [[f64; 1]; 1] = [[1e-4]];

/// The sample `k`'s time, input and measurement (of a truth that is not the filter's).
fn sample(k: usize) -> (f64, [f64; 1], [f64; 1]) {
    let t = k as f64 * drifting::TS;
    (t, [(3.0 * t).sin()], [0.2 * (2.0 * t).cos() + 0.1 * t])
}

#[test]
fn a_step_of_continuous_dynamics_corrects_a_sample_time_after_t_prev() {
    use drifting::{Ekf, HybridEkf, Status, TS};
    let x0 = [0.3, 0.0];
    let (mut stepped, mut split) = (
        Ekf::new(&x0, &P0, &Q, &R).unwrap(),
        Ekf::new(&x0, &P0, &Q, &R).unwrap(),
    );
    let (mut hybrid, mut hybrid_split) = (
        HybridEkf::new(&x0, &P0, &Q, &R).unwrap(),
        HybridEkf::new(&x0, &P0, &Q, &R).unwrap(),
    );
    let mut worst = 0.0_f64;
    for k in 1..=300 {
        let (t, u_prev, y) = sample(k);
        let t_prev = t - TS;
        assert_eq!(stepped.step(t_prev, &u_prev, &y), Status::Ok);
        assert_eq!(split.predict(t_prev, &u_prev), Status::Ok);
        assert_eq!(split.update(t_prev + TS, &y), Status::Ok);
        assert_eq!(hybrid.step(t_prev, &u_prev, &y), Status::Ok);
        assert_eq!(hybrid_split.predict(t_prev, &u_prev), Status::Ok);
        assert_eq!(hybrid_split.update(t_prev + TS, &y), Status::Ok);
        let pairs = [
            (
                (stepped.state(), stepped.covariance()),
                (split.state(), split.covariance()),
            ),
            (
                (hybrid.state(), hybrid.covariance()),
                (hybrid_split.state(), hybrid_split.covariance()),
            ),
        ];
        worst = worst.max(assert_same_estimates(k, &pairs));
    }
    println!("continuous dynamics: step and predict/update at t_prev + dt within {worst:.1e}");
}

#[test]
fn a_step_of_discrete_dynamics_corrects_at_its_time_argument() {
    use drifting_sampled::{Ekf, Status, TS};
    let x0 = [0.3, 0.0];
    let (mut stepped, mut split) = (
        Ekf::new(&x0, &P0, &Q, &R).unwrap(),
        Ekf::new(&x0, &P0, &Q, &R).unwrap(),
    );
    let mut worst = 0.0_f64;
    for k in 1..=300 {
        let (t, u_prev, y) = sample(k);
        let t_prev = t - TS;
        assert_eq!(stepped.step(t_prev, t, &u_prev, &y), Status::Ok);
        assert_eq!(split.predict(t_prev, &u_prev), Status::Ok);
        assert_eq!(split.update(t, &y), Status::Ok);
        let pair = (
            (stepped.state(), stepped.covariance()),
            (split.state(), split.covariance()),
        );
        worst = worst.max(assert_same_estimates(k, &[pair]));
    }
    println!("discrete dynamics: step and predict/update at t within {worst:.1e}");
}

//! Names the generated code gives its own values stay clear of the model's: a model whose
//! states are named like the LQR's gain entries (`k11`, `k12`) gets the control law it
//! asks for, not one that reads a gain where it means a state.

stateforge::model! {
    /// A double integrator whose states are named like the entries of an LQR gain.
    pub mod gain_named_states {
        scalar f64;
        const TS = 0.1;
        state k11, k12;
        input u;
        output y = k11;
        generate lqr(horizon = 50, states = [k11, k12], input = u);
        dynamics discrete {
            k11 = k11 + TS * k12;
            k12 = k12 + TS * u;
        }
    }
}

use gain_named_states::{Lqr, Status};

#[test]
fn an_lqr_whose_states_are_named_like_its_gain_controls_with_the_states() {
    let mut lqr = Lqr::new(&[[1.0, 0.0], [0.0, 1.0]], &[[0.1]], None).expect("finite tuning");
    let x = [0.7, -0.3];
    assert_eq!(lqr.solve(&x, &[0.0]), Status::Ok);
    let [[g1, g2]] = lqr.gain();
    assert!(g1 > 0.0 && g2 > 0.0, "a stabilising gain: {g1} {g2}");
    let [u] = lqr.control(&x);
    let expected = -(g1 * x[0] + g2 * x[1]);
    assert!(
        (u - expected).abs() <= 1e-12 * expected.abs(),
        "{u} vs {expected}"
    );
}

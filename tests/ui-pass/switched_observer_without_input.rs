stateforge::model! {
    /// A piecewise-linear model with no input: the regime matrices `B_i` have no columns.
    pub mod m {
        scalar f32, f64;
        const Q = 1e-6;
        const R = 1e-4;
        state x1, x2;
        output y1 = x1, y2 = x1 + x2;
        generate switched_observer(process_noise = [Q, Q], measurement_noise = [R, R]);
        dynamics discrete {
            x1 = 0.9 * x1 + 0.1 * x2 - if x1 > 0.0 { 0.2 * x1 } else { 0.0 };
            x2 = -0.1 * x1 + 0.8 * x2;
        }
    }
}

fn main() {
    let mut observer = m::LinearErrorObserver::new(&[0.0; 2]).unwrap();
    assert_eq!(observer.step(&[0.5, 0.7]), m::Status::Ok);
    assert!(observer.state().iter().all(|v| v.is_finite()));
    assert_eq!(m::REGIME_B, [[[]; 2]; 2]);
}

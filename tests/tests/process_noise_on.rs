//! Process noise on some states only (`process_noise_on = [..]`, the paper's noise input
//! matrix as a selection): a filter given the noise on the states listed runs as the same
//! filter given the whole noise matrix with zeros elsewhere, for the EKF (a full matrix
//! over the states listed, in their order) and the hybrid EKF (variances).

use tests::compare::assert_same_estimates;

stateforge::model! {
    /// An oscillator whose stiffness is estimated; the noise drives the velocity and the
    /// stiffness, listed in the order [stiffness, velocity].
    mod selected {
        scalar f64;
        const TS = 0.01;
        state x1, x2;
        param k;
        input u;
        output y = x1;
        generate ekf(process_noise_on = [k, x2]),
            ekf(process_noise = diagonal, process_noise_on = [k], name = EkfOnK),
            hybrid_ekf(process_noise = diagonal, process_noise_on = [k, x2]);
        dynamics continuous(euler, dt = TS, substeps = 20) {
            der(x1) = x2;
            der(x2) = -k * x1 - 0.2 * x2 + u;
        }
    }
}

stateforge::model! {
    /// The same oscillator with the noise on every state.
    mod everywhere {
        scalar f64;
        const TS = 0.01;
        state x1, x2;
        param k;
        input u;
        output y = x1;
        generate ekf, hybrid_ekf(process_noise = diagonal);
        dynamics continuous(euler, dt = TS, substeps = 20) {
            der(x1) = x2;
            der(x2) = -k * x1 - 0.2 * x2 + u;
        }
    }
}

const X0: [f64; 3] = [0.2, 0.0, 3.0];
const P0: [[f64; 3]; 3] = [[0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 1.0]];
const R: [[f64; 1]; 1] = [[1e-4]];

/// The sample `k`'s input and measurement.
fn sample(k: usize) -> ([f64; 1], [f64; 1]) {
    let t = k as f64 * 0.01;
    ([(1.3 * t).sin()], [0.2 * (2.0 * t).cos()])
}

#[test]
fn noise_on_the_states_listed_is_the_whole_noise_with_zeros_elsewhere() {
    // [k, x2] in the order listed: var(k) = 1e-2, var(x2) = 4e-3, their covariance 1e-3.
    let q_listed = [[1e-2, 1e-3], [1e-3, 4e-3]];
    let q_whole = [[0.0, 0.0, 0.0], [0.0, 4e-3, 1e-3], [0.0, 1e-3, 1e-2]];
    let mut listed = selected::Ekf::new(&X0, &P0, &q_listed, &R).unwrap();
    let mut whole = everywhere::Ekf::new(&X0, &P0, &q_whole, &R).unwrap();
    let mut hybrid_listed = selected::HybridEkf::new(&X0, &P0, &[1e-2, 4e-3], &R).unwrap();
    let mut hybrid_whole = everywhere::HybridEkf::new(&X0, &P0, &[0.0, 4e-3, 1e-2], &R).unwrap();
    let mut worst = 0.0_f64;
    for k in 1..=200 {
        let (u, y) = sample(k);
        assert_eq!(listed.step(&u, &y), selected::Status::Ok);
        assert_eq!(whole.step(&u, &y), everywhere::Status::Ok);
        assert_eq!(hybrid_listed.step(&u, &y), selected::Status::Ok);
        assert_eq!(hybrid_whole.step(&u, &y), everywhere::Status::Ok);
        let pairs = [
            (
                (listed.state(), listed.covariance()),
                (whole.state(), whole.covariance()),
            ),
            (
                (hybrid_listed.state(), hybrid_listed.covariance()),
                (hybrid_whole.state(), hybrid_whole.covariance()),
            ),
        ];
        worst = worst.max(assert_same_estimates(k, &pairs));
    }
    // The noise entered the states listed: their variances grew between samples.
    let mut predicted = selected::Ekf::new(&X0, &P0, &q_listed, &R).unwrap();
    assert_eq!(predicted.predict(&[0.0]), selected::Status::Ok);
    assert!(predicted.covariance()[2][2] >= P0[2][2] + 1e-2 - 1e-12);
    println!("process noise on [k, x2]: as the whole noise with zeros within {worst:.1e}");
}

#[test]
fn noise_on_one_parameter_is_its_variance_alone() {
    let q_whole = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1e-2]];
    let mut listed = selected::EkfOnK::new(&X0, &P0, &[1e-2], &R).unwrap();
    let mut whole = everywhere::Ekf::new(&X0, &P0, &q_whole, &R).unwrap();
    let mut worst = 0.0_f64;
    for k in 1..=200 {
        let (u, y) = sample(k);
        assert_eq!(listed.step(&u, &y), selected::Status::Ok);
        assert_eq!(whole.step(&u, &y), everywhere::Status::Ok);
        let pair = (
            (listed.state(), listed.covariance()),
            (whole.state(), whole.covariance()),
        );
        worst = worst.max(assert_same_estimates(k, &[pair]));
    }
    assert_eq!(
        listed.set_process_noise(&[-1e-3]),
        selected::Status::InvalidCovariance
    );
    println!("process noise on k alone: as the whole noise with zeros within {worst:.1e}");
}

#[test]
fn the_setter_takes_the_noise_on_the_states_listed() {
    let mut filter = selected::HybridEkf::new(&X0, &P0, &[1e-2, 4e-3], &R).unwrap();
    assert_eq!(
        filter.set_process_noise(&[-1.0, 4e-3]),
        selected::Status::InvalidCovariance
    );
    assert_eq!(
        filter.set_process_noise(&[2e-2, 4e-3]),
        selected::Status::Ok
    );
    let mut fresh = selected::HybridEkf::new(&X0, &P0, &[2e-2, 4e-3], &R).unwrap();
    let (u, y) = sample(1);
    assert_eq!(filter.step(&u, &y), selected::Status::Ok);
    assert_eq!(fresh.step(&u, &y), selected::Status::Ok);
    assert_eq!(filter, fresh);
}

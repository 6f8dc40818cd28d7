//! Measurement noise and gates per sensor: each `sensor` keeps its own block of `R`
//! (`<sensor>_noise`, `set_<sensor>_noise`) and its own gate (`sensor fix(gate = ..)`),
//! and each acts on its sensor's update only. A sensor's update and the joint update
//! equal a dense nalgebra Kalman update (Joseph form) with that sensor's block, or with the
//! block-diagonal `R` of every sensor's, to 1e-12; the normalised innovation squared each
//! sensor records equals the dense `r' S^-1 r`; a whole `R` that correlates two sensors is
//! refused. The EKF, hybrid EKF and continuous-time EKF of a model with sensors follow
//! those of the same model without (one full `R`) to 1e-14, given a block-diagonal `R`
//! (3e-23 measured: the zeros they skip add nothing).

use nalgebra::{DMatrix, DVector};
use tests::compare::largest_relative_difference;

stateforge::model! {
    /// A point in a plane, measured by a position fix (listed out of the model's order), an
    /// odometer and a range that no sensor measures.
    pub mod tracker {
        scalar f64;
        const DT = 0.1;
        state px, py, vx, vy;
        output
            fix_x = px,
            fix_y = py,
            speed_x = vx,
            speed_y = vy,
            range = px + py;
        sensor fix(gate = 13.82) = [fix_y, fix_x];
        sensor odometer(gate = 13.82) = [speed_x, speed_y];
        generate ekf(process_noise = diagonal, gate = 20.52);
        dynamics discrete {
            px = px + DT * vx;
            py = py + DT * vy;
            vx = vx;
            vy = vy;
        }
    }
}

use tracker::{Ekf, Status};

/// The measurement matrix: `h` is linear.
const H: [[f64; 4]; 5] = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
    [1.0, 1.0, 0.0, 0.0],
];
/// The sensors' rows, in the order each lists its outputs.
const FIX: [usize; 2] = [1, 0];
const ODOMETER: [usize; 2] = [2, 3];
const ALL: [usize; 5] = [0, 1, 2, 3, 4];

/// `R`: the fix's axes correlated, the odometer's not, the range alone; zero between them.
fn noise() -> [[f64; 5]; 5] {
    [
        [0.04, 0.01, 0.0, 0.0, 0.0],
        [0.01, 0.09, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0025, 0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0036, 0.0],
        [0.0, 0.0, 0.0, 0.0, 0.25],
    ]
}

/// A filter after a few predictions, so that its covariance couples the states.
fn filter(r: &[[f64; 5]; 5]) -> Ekf {
    let p0 = [
        [1.0, 0.2, 0.1, 0.0],
        [0.2, 2.0, 0.0, 0.3],
        [0.1, 0.0, 0.5, 0.05],
        [0.0, 0.3, 0.05, 0.4],
    ];
    let mut ekf = Ekf::new(&[1.0, -2.0, 0.5, 0.25], &p0, &[1e-4, 1e-4, 1e-3, 1e-3], r).unwrap();
    for _ in 0..3 {
        assert_eq!(ekf.predict(), Status::Ok);
    }
    ekf
}

/// The Joseph-form update of `ekf`'s estimate with the measurement `y` of the outputs
/// `rows` whose noise is `r` (over those rows, in that order), dense; and its `r' S^-1 r`.
fn dense_update(ekf: &Ekf, rows: &[usize], r: &DMatrix<f64>, y: &[f64]) -> (Vec<f64>, f64) {
    let (x, p) = (ekf.state(), ekf.covariance());
    let k = rows.len();
    let xm = DVector::from_column_slice(&x);
    let pm = DMatrix::from_fn(4, 4, |i, j| p[i][j]);
    let c = DMatrix::from_fn(k, 4, |a, j| H[rows[a]][j]);
    let residual = DVector::from_column_slice(y) - &c * &xm;
    let s = &c * &pm * c.transpose() + r;
    let s_inv = s.try_inverse().unwrap();
    let gain = &pm * c.transpose() * &s_inv;
    let i_kc = DMatrix::identity(4, 4) - &gain * &c;
    let p_new = &i_kc * &pm * i_kc.transpose() + &gain * r * gain.transpose();
    let x_new = xm + &gain * &residual;
    let nis = (residual.transpose() * s_inv * &residual)[(0, 0)];
    let flat = x_new
        .iter()
        .copied()
        .chain(
            (0..4)
                .flat_map(|i| (0..4).map(move |j| (i, j)))
                .map(|(i, j)| p_new[(i, j)]),
        )
        .collect();
    (flat, nis)
}

/// The block of `r` on `rows`, in that order.
fn block(r: &[[f64; 5]; 5], rows: &[usize]) -> DMatrix<f64> {
    DMatrix::from_fn(rows.len(), rows.len(), |a, b| r[rows[a]][rows[b]])
}

fn flat(ekf: &Ekf) -> Vec<f64> {
    ekf.state()
        .into_iter()
        .chain(ekf.covariance().concat())
        .collect()
}

/// The measurement of `rows` a little off the prediction.
fn measurement<const K: usize>(ekf: &Ekf, rows: [usize; K], offset: f64) -> [f64; K] {
    let h = tracker::h(&ekf.state());
    std::array::from_fn(|a| h[rows[a]] + offset * (1.0 + a as f64))
}

#[test]
fn each_sensor_keeps_its_block_of_r_in_the_order_it_lists_its_outputs() {
    let r = noise();
    let ekf = filter(&r);
    // The fix lists `fix_y` first.
    assert_eq!(ekf.fix_noise(), [[0.09, 0.01], [0.01, 0.04]]);
    assert_eq!(ekf.odometer_noise(), [[0.0025, 0.0], [0.0, 0.0036]]);
    // Its update and the joint one are the dense updates with the blocks.
    let mut by_fix = ekf;
    let y = measurement(&ekf, FIX, 0.1);
    assert_eq!(by_fix.update_fix(&y), Status::Ok);
    let (want, nis) = dense_update(&ekf, &FIX, &block(&r, &FIX), &y);
    assert!(largest_relative_difference(&flat(&by_fix), &want) < 1e-12);
    let got = by_fix.fix_normalised_innovation_squared();
    assert!((got - nis).abs() <= 1e-12 * nis, "{got} against {nis}");
    let mut joint = ekf;
    let y = measurement(&ekf, ALL, 0.05);
    assert_eq!(joint.update(&y), Status::Ok);
    let (want, nis) = dense_update(&ekf, &ALL, &block(&r, &ALL), &y);
    assert!(largest_relative_difference(&flat(&joint), &want) < 1e-12);
    let got = joint.normalised_innovation_squared();
    assert!((got - nis).abs() <= 1e-12 * nis, "{got} against {nis}");
}

#[test]
fn a_sensors_noise_acts_on_its_update_and_its_block_of_the_joint_update_only() {
    let r = noise();
    let before = filter(&r);
    let mut retuned = before;
    let odometer = [[0.01, 0.002], [0.002, 0.02]];
    assert_eq!(retuned.set_odometer_noise(&odometer), Status::Ok);
    assert_eq!(retuned.odometer_noise(), odometer);
    assert_eq!(retuned.fix_noise(), before.fix_noise());
    // The fix's update is the same, to the bit.
    let (mut a, mut b) = (before, retuned);
    let y = measurement(&before, FIX, 0.1);
    assert_eq!(a.update_fix(&y), Status::Ok);
    assert_eq!(b.update_fix(&y), Status::Ok);
    assert_eq!((a.state(), a.covariance()), (b.state(), b.covariance()));
    // The odometer's is the dense update with its new block.
    let mut b = retuned;
    let y = measurement(&before, ODOMETER, 0.02);
    assert_eq!(b.update_odometer(&y), Status::Ok);
    let odometer_block = DMatrix::from_fn(2, 2, |i, j| odometer[i][j]);
    let (want, nis) = dense_update(&retuned, &ODOMETER, &odometer_block, &y);
    assert!(largest_relative_difference(&flat(&b), &want) < 1e-12);
    let got = b.odometer_normalised_innovation_squared();
    assert!((got - nis).abs() <= 1e-12 * nis, "{got} against {nis}");
    // The joint update's `R` is the blocks' block diagonal.
    let mut whole = r;
    for (a, &i) in ODOMETER.iter().enumerate() {
        for (b, &j) in ODOMETER.iter().enumerate() {
            whole[i][j] = odometer[a][b];
        }
    }
    let mut joint = retuned;
    let y = measurement(&before, ALL, 0.05);
    assert_eq!(joint.update(&y), Status::Ok);
    let (want, _) = dense_update(&retuned, &ALL, &block(&whole, &ALL), &y);
    assert!(largest_relative_difference(&flat(&joint), &want) < 1e-12);
    // `set_measurement_noise` sets every block.
    assert_eq!(joint.set_measurement_noise(&r), Status::Ok);
    assert_eq!(joint.odometer_noise(), before.odometer_noise());
}

#[test]
fn a_noise_that_is_no_covariance_or_correlates_two_sensors_is_refused() {
    let r = noise();
    let mut ekf = filter(&r);
    let before = ekf;
    assert_eq!(
        ekf.set_fix_noise(&[[0.01, f64::NAN], [f64::NAN, 0.01]]),
        Status::RejectedInput
    );
    assert_eq!(
        ekf.set_fix_noise(&[[0.01, 0.02], [0.02, 0.01]]),
        Status::InvalidCovariance
    );
    assert_eq!(
        ekf.set_odometer_noise(&[[-0.01, 0.0], [0.0, 0.01]]),
        Status::InvalidCovariance
    );
    assert_eq!(ekf, before);
    // A covariance between two sensors, or a sensor and the range: each sensor's noise
    // is its own.
    for (i, j) in [(0, 2), (1, 3), (3, 4), (0, 4)] {
        let mut correlated = r;
        correlated[i][j] = 1e-3;
        correlated[j][i] = 1e-3;
        assert_eq!(
            ekf.set_measurement_noise(&correlated),
            Status::InvalidCovariance,
            "({i}, {j})"
        );
        assert_eq!(ekf, before);
        assert_eq!(
            Ekf::new(&[0.0; 4], &[[0.0; 4]; 4], &[0.0; 4], &correlated),
            Err(Status::InvalidCovariance)
        );
    }
}

#[test]
fn a_sensors_gate_acts_on_its_update_only() {
    let r = noise();
    let mut ekf = filter(&r);
    // Declared with each sensor; the joint update's is the filter's.
    assert_eq!(ekf.fix_innovation_gate(), 13.82);
    assert_eq!(ekf.odometer_innovation_gate(), 13.82);
    assert_eq!(ekf.innovation_gate(), 20.52);
    assert_eq!(ekf.set_odometer_innovation_gate(1e-6), Status::Ok);
    assert_eq!(ekf.fix_innovation_gate(), 13.82);
    assert_eq!(ekf.innovation_gate(), 20.52);
    // An odometer measurement within a standard deviation is now refused (and recorded),
    // while the fix and the joint update take theirs.
    let before = ekf;
    let y = measurement(&before, ODOMETER, 0.05);
    assert_eq!(ekf.update_odometer(&y), Status::OutlierRejected);
    assert_eq!(flat(&ekf), flat(&before));
    let (_, nis) = dense_update(&before, &ODOMETER, &block(&r, &ODOMETER), &y);
    let got = ekf.odometer_normalised_innovation_squared();
    assert!(got > 1e-6 && (got - nis).abs() <= 1e-12 * nis, "{got}");
    let y = measurement(&before, FIX, 0.05);
    assert_eq!(ekf.update_fix(&y), Status::Ok);
    let mut joint = before;
    assert_eq!(joint.update(&measurement(&before, ALL, 0.05)), Status::Ok);
    // The range, which no sensor measures, is judged by the filter's gate.
    let mut ranged = before;
    let h = tracker::h(&before.state());
    assert_eq!(ranged.update_range(h[4] + 0.5), Status::Ok);
    assert_eq!(ranged.update_range(h[4] + 1e3), Status::OutlierRejected);
}

/// `R`'s entries between two sensors are structural zeros: the generated code stores and
/// reads none of them. The AHRS test model's two vector outputs are each a sensor of its
/// own, `accel` (outputs 1 to 3) and `mag` (4 to 6): no `r14`, .., `r36`.
#[test]
fn the_code_holds_no_entry_of_r_between_two_sensors() {
    let code = tests::test_model_code("ahrs");
    assert!(code.contains("accel_r: [f32; 6]") && code.contains("mag_r: [f32; 6]"));
    let word = |c: char| c.is_alphanumeric() || c == '_';
    for i in 1..=3 {
        for j in 4..=6 {
            let name = format!("r{i}{j}");
            let found = code.match_indices(&name).any(|(at, _)| {
                !code[at + name.len()..].starts_with(word) && !code[..at].ends_with(word)
            });
            assert!(!found, "`{name}` is in the AHRS filters' code");
        }
    }
}

stateforge::model! {
    /// A point slowing in a plane, its position and speed measured by two sensors: every
    /// filter of the EKF family keeps each sensor's block of `R`.
    pub mod grouped {
        scalar f64;
        state px, py, vx, vy;
        output fix_x = px, fix_y = py, speed_x = vx, speed_y = vy;
        sensor fix = [fix_x, fix_y];
        sensor odometer = [speed_x, speed_y];
        generate ekf(process_noise = diagonal), hybrid_ekf(process_noise = diagonal),
            continuous_ekf(process_noise = diagonal);
        dynamics continuous(rk4, dt = 0.1) {
            der(px) = vx;
            der(py) = vy;
            der(vx) = -0.2 * vx * (1.0 + 0.1 * vy * vy);
            der(vy) = -0.2 * vy;
        }
    }
}

stateforge::model! {
    /// The same model without sensors: one full `R`, as before sensors had blocks.
    pub mod whole {
        scalar f64;
        state px, py, vx, vy;
        output fix_x = px, fix_y = py, speed_x = vx, speed_y = vy;
        generate ekf(process_noise = diagonal), hybrid_ekf(process_noise = diagonal),
            continuous_ekf(process_noise = diagonal);
        dynamics continuous(rk4, dt = 0.1) {
            der(px) = vx;
            der(py) = vy;
            der(vx) = -0.2 * vx * (1.0 + 0.1 * vy * vy);
            der(vy) = -0.2 * vy;
        }
    }
}

/// Sensors change where `R` is kept, not the filters: given the same block-diagonal `R`,
/// the EKF, the hybrid EKF and the continuous-time EKF of the model with sensors follow
/// those of the model without, sample after sample (the zeros they skip add nothing), and
/// each refuses an `R` that correlates two sensors where the other takes it.
#[test]
fn every_filter_of_the_family_keeps_the_blocks_and_filters_as_with_one_r() {
    let r = [
        [0.04, 0.01, 0.0, 0.0],
        [0.01, 0.09, 0.0, 0.0],
        [0.0, 0.0, 0.0025, 0.0],
        [0.0, 0.0, 0.0, 0.0036],
    ];
    let p0 = [
        [1.0, 0.2, 0.1, 0.0],
        [0.2, 2.0, 0.0, 0.3],
        [0.1, 0.0, 0.5, 0.05],
        [0.0, 0.3, 0.05, 0.4],
    ];
    let (x0, q) = ([1.0, -2.0, 0.5, 0.25], [1e-4, 1e-4, 1e-3, 1e-3]);
    let mut grouped = (
        grouped::Ekf::new(&x0, &p0, &q, &r).unwrap(),
        grouped::HybridEkf::new(&x0, &p0, &q, &r).unwrap(),
        grouped::ContinuousEkf::new(&x0, &p0, &q, &r).unwrap(),
    );
    let mut whole = (
        whole::Ekf::new(&x0, &p0, &q, &r).unwrap(),
        whole::HybridEkf::new(&x0, &p0, &q, &r).unwrap(),
        whole::ContinuousEkf::new(&x0, &p0, &q, &r).unwrap(),
    );
    assert_eq!(grouped.1.fix_noise(), [[0.04, 0.01], [0.01, 0.09]]);
    assert_eq!(grouped.2.odometer_noise(), [[0.0025, 0.0], [0.0, 0.0036]]);
    let mut worst: f64 = 0.0;
    for k in 0..50 {
        let t = f64::from(k) * 0.1;
        let y = [
            1.0 + 0.4 * t,
            -2.0 + 0.2 * t,
            0.4 * (-0.2 * t).exp(),
            0.25 - 0.01 * t,
        ];
        let flat = |x: [f64; 4], p: [[f64; 4]; 4]| -> Vec<f64> {
            x.into_iter().chain(p.concat()).collect()
        };
        assert_eq!(grouped.0.step(&y), grouped::Status::Ok);
        assert_eq!(whole.0.step(&y), whole::Status::Ok);
        assert_eq!(grouped.1.step(&y), grouped::Status::Ok);
        assert_eq!(whole.1.step(&y), whole::Status::Ok);
        assert_eq!(grouped.2.step(&y), grouped::Status::Ok);
        assert_eq!(whole.2.step(&y), whole::Status::Ok);
        for (a, b) in [
            (
                flat(grouped.0.state(), grouped.0.covariance()),
                flat(whole.0.state(), whole.0.covariance()),
            ),
            (
                flat(grouped.1.state(), grouped.1.covariance()),
                flat(whole.1.state(), whole.1.covariance()),
            ),
            (
                flat(grouped.2.state(), grouped.2.covariance()),
                flat(whole.2.state(), whole.2.covariance()),
            ),
        ] {
            worst = worst.max(largest_relative_difference(&a, &b));
        }
    }
    eprintln!("filters with sensors against one R: {worst:e} relative");
    assert!(worst <= 1e-14, "{worst:e}");
    let mut correlated = r;
    (correlated[0][2], correlated[2][0]) = (0.001, 0.001);
    assert_eq!(
        grouped.1.set_measurement_noise(&correlated),
        grouped::Status::InvalidCovariance
    );
    assert_eq!(
        grouped::ContinuousEkf::new(&x0, &p0, &q, &correlated),
        Err(grouped::Status::InvalidCovariance)
    );
    assert_eq!(
        whole.1.set_measurement_noise(&correlated),
        whole::Status::Ok
    );
}

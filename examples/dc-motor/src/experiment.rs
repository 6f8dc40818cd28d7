//! The experiment: one second of voltage steps while the EKF identifies the friction and
//! the load torque, then one second in which the LQR, re-solved every 10 ms on the
//! estimated model, brakes the motor.

use crate::motor::{Ekf, Lqr, Status};
use crate::plant::{Motor, Noise};

/// Samples per second (the model's 1 ms sample time).
pub const RATE: usize = 1000;
/// Samples of the identification phase.
pub const IDENTIFICATION: usize = RATE;
/// Samples of the whole run.
pub const SAMPLES: usize = 2 * RATE;
/// Standard deviation of the current sensor [A].
pub const CURRENT_NOISE: f64 = 0.01;
/// Standard deviation of the speed measurement [rad/s].
pub const SPEED_NOISE: f64 = 0.5;
/// The LQR's input limit [V].
pub const VOLTAGE_LIMIT: f32 = 24.0;

/// The true motor: friction 0.2 mN m s/rad, load torque 20 mN m.
pub const TRUE_MOTOR: Motor = Motor {
    current: 0.0,
    speed: 0.0,
    friction: 0.2,
    load_torque: 20.0,
};

/// One sample of the run.
#[derive(Clone, Copy, Debug)]
pub struct Sample {
    /// Sample index `k` (1 ms apart).
    pub k: usize,
    /// The voltage applied over the sample before `k`.
    pub voltage: f32,
    /// The true motor at `k`: current, speed, friction, load torque.
    pub truth: [f64; 4],
    /// The EKF's estimate at `k`, in the same order.
    pub estimate: [f32; 4],
}

/// Runs the experiment with sensor noise from `seed`, handing every sample to `observe`.
/// Returns the first status of the EKF or LQR (their construction included) that was not
/// `Ok`, if any.
pub fn run(seed: u64, mut observe: impl FnMut(&Sample)) -> Result<(), Status> {
    let mut motor = TRUE_MOTOR;
    let mut noise = Noise::new(seed);
    // The EKF starts at rest with friction and load torque both wrong (0.5 and 0).
    let x0 = [0.0, 0.0, 0.5, 0.0];
    let p0 = [
        [1e-4, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1e3],
    ];
    // Small process noise on the parameters lets them drift; the states take up model error.
    let q = [1e-4, 1e-2, 1e-8, 1e-6];
    let r = [
        [(CURRENT_NOISE * CURRENT_NOISE) as f32, 0.0],
        [0.0, (SPEED_NOISE * SPEED_NOISE) as f32],
    ];
    let mut ekf = Ekf::new(&x0, &p0, &q, &r)?;
    // Speed matters most; current is cheap; volts are weighted to stay within the limit.
    let mut lqr = Lqr::new(
        &[[0.01, 0.0], [0.0, 1.0]],
        &[[0.05]],
        Some(&[VOLTAGE_LIMIT]),
    )?;
    let mut voltage = 0.0_f32;
    for k in 1..=SAMPLES {
        motor.advance(f64::from(voltage));
        let y = [
            (motor.current + noise.normal(CURRENT_NOISE)) as f32,
            (motor.speed + noise.normal(SPEED_NOISE)) as f32,
        ];
        check(ekf.step(&[voltage], &y))?;
        let estimate = ekf.state();
        observe(&Sample {
            k,
            voltage,
            truth: motor.state(),
            estimate,
        });
        voltage = if k < IDENTIFICATION {
            // Steps between 6 V and 12 V every 100 ms: two speeds separate friction from load.
            if (k / 100).is_multiple_of(2) {
                12.0
            } else {
                6.0
            }
        } else {
            if k.is_multiple_of(10) {
                check(lqr.solve(&estimate, &[voltage]))?;
            }
            let [v] = lqr.control(&estimate);
            v
        };
    }
    Ok(())
}

fn check(status: Status) -> Result<(), Status> {
    match status {
        Status::Ok => Ok(()),
        other => Err(other),
    }
}

//! The runs the C firmware (`targets/c/main.c`) makes through the C API of the same
//! generated code, made here by the Rust calls: `cargo xtask` checks that the two print the
//! same lines, bit for bit.
//!
//! Output: `bits <run> <k> <bits..>`, each `f32` as the eight hexadecimal digits of its
//! bits:
//! - `bits cantilever k <x1..x5> <K1 K2> <u>` every tenth sample: the EKF from the close
//!   guess on the measured sequence, and the LQR solved at its estimate each sample, with
//!   its gain and control;
//! - `bits navigation k <x1..x24>` after every hundredth IMU sample of the navigation
//!   flight (its prediction, then the updates that follow it), and `bits
//!   navigation_covariance 1000 <P row by row>` at its end.

use crate::navigation::{self, Event};
use cortex_m_semihosting::{hprint, hprintln};
use generated_demo::cantilever::{Ekf, Lqr};

/// `bits <run> <k> <bits..>`.
fn bits_line<'a>(run: &str, k: usize, values: impl IntoIterator<Item = &'a f32>) {
    hprint!("bits {} {}", run, k);
    for value in values {
        hprint!(" {:08x}", value.to_bits());
    }
    hprintln!();
}

/// Both runs: the cantilever's from `filter` and `controller` (the EKF from the close
/// guess, the LQR) on `sequence`, then the navigation flight's.
pub fn runs(filter: Ekf, controller: Lqr, sequence: &[(f32, f32)]) {
    cantilever(filter, controller, sequence);
    navigation_flight();
}

/// The EKF on the measured sequence, and the LQR at its estimate.
fn cantilever(mut filter: Ekf, mut controller: Lqr, sequence: &[(f32, f32)]) {
    for k in 1..sequence.len() {
        let (u_prev, y) = (sequence[k - 1].0, sequence[k].1);
        let _ = filter.step(&[u_prev], &[y]);
        let estimate = filter.state();
        let _ = controller.solve(&estimate, &[u_prev]);
        let u = controller.control(&estimate);
        if k % 10 == 0 {
            let gain = controller.gain()[0];
            bits_line("cantilever", k, estimate.iter().chain(&gain).chain(&u));
        }
    }
}

/// The navigation flight, every call's status but `Ok` and `OutlierRejected` a panic.
fn navigation_flight() {
    let mut filter = navigation::filter();
    let mut imu_samples = 0;
    let mut events = navigation::events().enumerate().peekable();
    while let Some((call, event)) = events.next() {
        let status = match event {
            Event::Predict(dt, u) => {
                imu_samples += 1;
                filter.predict(dt, u)
            }
            Event::Magnetometer(y) => filter.update_magnetometer(y),
            Event::Gnss(y) => filter.update_gnss(y),
        };
        let _ = navigation::used(status, event, call);
        let sample_done = !matches!(
            events.peek(),
            Some((_, Event::Magnetometer(_) | Event::Gnss(_)))
        );
        if sample_done && imu_samples % 100 == 0 {
            bits_line("navigation", imu_samples, &filter.state());
        }
    }
    bits_line(
        "navigation_covariance",
        imu_samples,
        filter.covariance().as_flattened(),
    );
}

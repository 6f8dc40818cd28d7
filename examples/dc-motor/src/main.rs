//! Runs the experiment and prints what the EKF estimated and what the LQR did.

use dc_motor::experiment::{self, Sample, IDENTIFICATION, RATE};

fn main() {
    println!("  time   voltage   speed (true, est.)   friction (true, est.)   load (true, est.)");
    let mut at_identification_end = None;
    let mut last = None;
    let outcome = experiment::run(1, |s: &Sample| {
        if s.k.is_multiple_of(RATE / 10) {
            println!(
                "{:5.2} s {:7.2} V {:8.2} {:8.2} rad/s {:7.3} {:7.3} mN m s {:6.2} {:6.2} mN m",
                s.k as f64 / RATE as f64,
                s.voltage,
                s.truth[1],
                s.estimate[1],
                s.truth[2],
                s.estimate[2],
                s.truth[3],
                s.estimate[3],
            );
        }
        if s.k == IDENTIFICATION {
            at_identification_end = Some(*s);
        }
        last = Some(*s);
    });
    if let Err(status) = outcome {
        eprintln!("the generated filter or controller stopped: {status:?}");
        std::process::exit(1);
    }
    let (Some(identified), Some(last)) = (at_identification_end, last) else {
        return;
    };
    let relative = |estimate: f32, truth: f64| (f64::from(estimate) - truth).abs() / truth;
    println!(
        "after {} s of voltage steps: friction within {:.1} %, load torque within {:.1} %",
        IDENTIFICATION / RATE,
        100.0 * relative(identified.estimate[2], identified.truth[2]),
        100.0 * relative(identified.estimate[3], identified.truth[3]),
    );
    println!(
        "the LQR brought the speed from {:.1} to {:.2} rad/s (it regulates to zero with no \
         feed-forward of the load torque, which holds the residual)",
        identified.truth[1], last.truth[1],
    );
}

//! Shults, Brubaker and Lee ("A fast algorithm for control and estimation using a
//! polynomial state-space structure"): the generated polynomial Kalman filter on a
//! simulated flexible-arm hub signal, for several fading factors and re-initialisation
//! periods, and the paper's design rule: the smallest fading factor whose deterministic
//! error just before re-initialisation is within a stated bound.
//!
//! The paper's hub data are not available: the hub angle here is a synthetic signal with
//! the character it describes (a slow slew and lightly damped flexible motion, all below
//! 5 Hz, sampled at 100 Hz), a sum of sinusoids so its derivatives are known exactly.
//! Noise variance 1e-4, order 3, window 25 samples. The paper's configuration (fading
//! 1e-9, every 100 samples) is the library's `polynomial` model; the other
//! configurations are generated here, each its own `model!`, since the design is fixed
//! when the code is generated.

use super::report::{self, Line, Trace};
use generated_demo::noise::GaussianNoise;
use std::error::Error;
use std::path::Path;

/// The other configurations of the experiment, one generated filter each: the hub model
/// of `models/polynomial.rs` with another fading factor and re-initialisation period.
mod variants {
    macro_rules! hub_filter_model {
        ($name:ident, fading = $fading:tt, reinit_every = $period:tt) => {
            stateforge::model! {
                /// A hub filter of the polynomial Kalman filter experiment.
                pub mod $name {
                    scalar f64;
                    state z0, z1, z2, z3;
                    output y = z0;
                    generate polynomial_kf(order = 3, dt = 0.01, fading = $fading,
                        noise_variance = 1e-4, reinit_every = $period, window = 25);
                    dynamics discrete {
                        z0 = z0 + z1 + z2 + z3;
                        z1 = z1 + 2.0 * z2 + 3.0 * z3;
                        z2 = z2 + 3.0 * z3;
                        z3 = z3;
                    }
                }
            }
        };
    }

    hub_filter_model!(fade_0, fading = 0.0, reinit_every = 100);
    hub_filter_model!(fade_1e12, fading = 1e-12, reinit_every = 100);
    hub_filter_model!(fade_1e10, fading = 1e-10, reinit_every = 100);
    hub_filter_model!(fade_1e8, fading = 1e-8, reinit_every = 100);
    hub_filter_model!(fade_1e6, fading = 1e-6, reinit_every = 100);
    hub_filter_model!(fade_1e9_every_50, fading = 1e-9, reinit_every = 50);
    hub_filter_model!(fade_1e9_every_400, fading = 1e-9, reinit_every = 400);
}

/// Sample period \[s\] and run length \[s\].
const TS: f64 = 0.01;
const RUN: f64 = 20.0;
/// Measurement noise variance (the paper's 1e-4).
const SIGMA2: f64 = 1e-4;
/// Samples in the fit window (every configuration uses 25).
const WINDOW: usize = 25;
/// The stated bound of the design rule: deterministic position error just before
/// re-initialisation at most a fifth of the sensor's standard deviation.
const DETERMINISTIC_BOUND: f64 = 0.2 * 0.01;

/// The hub angle \[rad\] and its first three derivatives at `t`: amplitude, frequency \[Hz\]
/// and phase of each component (a 0.25 Hz slew, flexible motion at 1.1 and 3.3 Hz).
fn hub(t: f64) -> [f64; 4] {
    const PARTS: [(f64, f64, f64); 3] = [(0.4, 0.25, 0.0), (0.05, 1.1, 0.4), (0.01, 3.3, 1.3)];
    let mut z = [0.0; 4];
    for (a, f, phase) in PARTS {
        let w = 2.0 * std::f64::consts::PI * f;
        for (k, zk) in z.iter_mut().enumerate() {
            // d^k/dt^k a sin(w t + phase) = a w^k sin(w t + phase + k pi / 2)
            let shift = k as f64 * std::f64::consts::FRAC_PI_2;
            *zk += a * w.powi(k as i32) * (w * t + phase + shift).sin();
        }
    }
    z
}

/// A generated filter behind one interface: step, and derivatives in physical units.
trait HubFilter {
    fn step(&mut self, y: f64);
    fn derivatives(&self) -> [f64; 4];
}

macro_rules! hub_filter {
    ($($filter:ty),*) => {$(
        impl HubFilter for $filter {
            fn step(&mut self, y: f64) {
                // A finite measurement is always accepted; the status only reports rejections.
                let _ = <$filter>::step(self, y);
            }
            fn derivatives(&self) -> [f64; 4] {
                <$filter>::derivatives(self)
            }
        }
    )*};
}

hub_filter!(
    generated_demo::polynomial::in_f64::PolynomialKf,
    variants::fade_0::PolynomialKf,
    variants::fade_1e12::PolynomialKf,
    variants::fade_1e10::PolynomialKf,
    variants::fade_1e8::PolynomialKf,
    variants::fade_1e6::PolynomialKf,
    variants::fade_1e9_every_50::PolynomialKf,
    variants::fade_1e9_every_400::PolynomialKf
);

/// A configuration: label, fading factor, period, and a fresh filter from a wide prior
/// (it runs from the prior until its first re-initialisation).
type Configuration = (&'static str, f64, usize, fn() -> Box<dyn HubFilter>);

const P0: [[f64; 4]; 4] = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// Why the filters' constructors cannot fail.
const PRIOR: &str = "the prior is finite";

const CONFIGURATIONS: [Configuration; 8] = [
    ("f = 0", 0.0, 100, || {
        Box::new(variants::fade_0::PolynomialKf::new(&[0.0; 4], &P0).expect(PRIOR))
    }),
    ("f = 1e-12", 1e-12, 100, || {
        Box::new(variants::fade_1e12::PolynomialKf::new(&[0.0; 4], &P0).expect(PRIOR))
    }),
    ("f = 1e-10", 1e-10, 100, || {
        Box::new(variants::fade_1e10::PolynomialKf::new(&[0.0; 4], &P0).expect(PRIOR))
    }),
    ("f = 1e-9 (paper)", 1e-9, 100, || {
        Box::new(
            generated_demo::polynomial::in_f64::PolynomialKf::new(&[0.0; 4], &P0).expect(PRIOR),
        )
    }),
    ("f = 1e-8", 1e-8, 100, || {
        Box::new(variants::fade_1e8::PolynomialKf::new(&[0.0; 4], &P0).expect(PRIOR))
    }),
    ("f = 1e-6", 1e-6, 100, || {
        Box::new(variants::fade_1e6::PolynomialKf::new(&[0.0; 4], &P0).expect(PRIOR))
    }),
    ("f = 1e-9, every 50", 1e-9, 50, || {
        Box::new(variants::fade_1e9_every_50::PolynomialKf::new(&[0.0; 4], &P0).expect(PRIOR))
    }),
    ("f = 1e-9, every 400", 1e-9, 400, || {
        Box::new(variants::fade_1e9_every_400::PolynomialKf::new(&[0.0; 4], &P0).expect(PRIOR))
    }),
];

/// Errors of one configuration.
struct Errors {
    /// Largest deterministic error (noise-free run) of z and dz/dt just before a
    /// re-initialisation.
    before_reinit: [f64; 2],
    /// RMS of the noise's effect (noisy run minus noise-free run) on z and dz/dt.
    random: [f64; 2],
    /// RMS error against the truth of z and its three derivatives (noisy run).
    total: [f64; 4],
}

fn evaluate(
    make: fn() -> Box<dyn HubFilter>,
    period: usize,
    mut trace: Option<&mut Trace>,
) -> Errors {
    let noise = GaussianNoise::new(SIGMA2.sqrt(), 2);
    let mut clean = make();
    let mut noisy = make();
    let steps = (RUN / TS).round() as usize;
    // Errors are taken once the first re-initialisation has happened.
    let from = period.max(WINDOW);
    let mut before = [0.0_f64; 2];
    let mut random = [0.0; 2];
    let mut total = [0.0; 4];
    let mut count = 0.0;
    for k in 0..steps {
        let t = k as f64 * TS;
        let truth = hub(t);
        clean.step(truth[0]);
        noisy.step(truth[0] + noise.sample(k as u64));
        let (c, n) = (clean.derivatives(), noisy.derivatives());
        if let Some(trace) = trace.as_deref_mut() {
            trace.begin(t);
            for (i, name) in ["z", "dz/dt", "d2z/dt2", "d3z/dt3"].iter().enumerate() {
                trace.set(&format!("true {name}"), truth[i]);
                trace.set(&format!("estimated {name}"), n[i]);
            }
        }
        if k < from {
            continue;
        }
        // Re-initialisations happen at the samples k with (k + 1) % period == 0.
        if (k + 2) % period == 0 {
            for i in 0..2 {
                before[i] = before[i].max((c[i] - truth[i]).abs());
            }
        }
        for i in 0..2 {
            random[i] += (n[i] - c[i]).powi(2);
        }
        for i in 0..4 {
            total[i] += (n[i] - truth[i]).powi(2);
        }
        count += 1.0;
    }
    Errors {
        before_reinit: before,
        random: random.map(|s| (s / count).sqrt()),
        total: total.map(|s| (s / count).sqrt()),
    }
}

/// Runs the polynomial Kalman filter experiment: prints the table and the design rule,
/// writes CSV and SVG.
pub fn experiment(out: &Path) -> Result<(), Box<dyn Error>> {
    println!(
        "\nPolynomial Kalman filter of Shults, Brubaker and Lee, \"A fast algorithm for control"
    );
    println!(
        "and estimation using a polynomial state-space structure\", flexible-arm hub: order 3,"
    );
    println!(
        "100 samples/s, noise variance 1e-4, window {WINDOW} samples; synthetic hub angle [rad]"
    );
    println!("over {RUN} s.");
    println!(
        "{:<22} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}",
        "filter", "det z", "det dz", "rand z", "rand dz", "rms z", "rms dz", "rms d2z", "rms d3z"
    );
    let mut chosen = None;
    let mut trace = Trace::new();
    for (label, fading, period, make) in CONFIGURATIONS {
        let paper = label.contains("paper");
        let e = evaluate(make, period, paper.then_some(&mut trace));
        println!(
            "{:<22} {:>9.2e} {:>9.2e} {:>9.2e} {:>9.2e} {:>9.2e} {:>9.2e} {:>9.2e} {:>9.2e}",
            label,
            e.before_reinit[0],
            e.before_reinit[1],
            e.random[0],
            e.random[1],
            e.total[0],
            e.total[1],
            e.total[2],
            e.total[3]
        );
        if period == 100 && chosen.is_none() && e.before_reinit[0] <= DETERMINISTIC_BOUND {
            chosen = Some((label, fading));
        }
    }
    println!("(det: largest deterministic error just before a re-initialisation, noise-free run;");
    println!(" rand: RMS effect of the noise; rms: RMS error against the truth; rad, rad/s, ..)");
    match chosen {
        Some((label, fading)) => println!(
            "Design rule (every 100 samples): the smallest fading factor whose deterministic \
             position error before re-initialisation is within {DETERMINISTIC_BOUND:.0e} rad: \
             {fading:e} ({label})."
        ),
        None => println!("Design rule: no fading factor meets {DETERMINISTIC_BOUND:.0e} rad."),
    }
    report::write_csv(
        &trace,
        std::fs::File::create(out.join("hub_estimates.csv"))?,
    )?;
    let names = ["true dz/dt", "estimated dz/dt"];
    let lines: Vec<Line> = names.iter().filter_map(|n| trace.line(n)).collect();
    report::plot_lines(
        &out.join("hub_velocity.svg"),
        "Shults, Brubaker and Lee: hub velocity, polynomial KF (f = 1e-9, re-initialised every 1 s)",
        "dz/dt [rad/s]",
        &lines,
        None,
    )?;
    Ok(())
}

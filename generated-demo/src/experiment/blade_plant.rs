//! The simulated blade of Takács et al. (sect. 4): eq. (1) integrated with RK4, the 54 g
//! weight added between 40 and 60 s, a stinger hit every 4 s from 22 s, laser noise, and
//! the paper's 50-sample running median of the weight estimate. Shared by the filter
//! experiment (`blade`) and the controller comparison (`blade_control`).

/// The simulated blade's parameters: the paper's identified values (sect. 4.1).
pub const K: f64 = 533.0;
pub const B: f64 = 0.11;
pub const C: f64 = 8.0e-4;
pub const M: f64 = 0.20;
/// The weight added at 40 s and removed at 60 s \[kg\] (sect. 4).
pub const ADDED_MASS: f64 = 0.054;
pub const LOADED: (f64, f64) = (40.0, 60.0);
/// Identification until 20 s, then control mode until 80 s (sect. 4).
pub const IDENTIFICATION_END: f64 = 20.0;
pub const END: f64 = 80.0;
/// Stinger hits every 4 s in control mode: a half-sine force of `HIT_FORCE` over
/// `HIT_DURATION` (the paper's `F_e = 4 N`, `T_e = 0.1 s`).
pub const HIT_EVERY: f64 = 4.0;
pub const HIT_FORCE: f64 = 4.0;
pub const HIT_DURATION: f64 = 0.1;
/// The first hit, 2 s into control mode.
pub const FIRST_HIT: f64 = 22.0;
/// Laser noise: "1 % of 10^-3 m" (sect. 4.1).
pub const NOISE_SIGMA: f64 = 1e-5;
/// The plant is integrated with classical RK4 at this many steps per sample.
pub const PLANT_STEPS: u32 = 20;

/// The blade's mass at time `t`.
pub fn mass(t: f64) -> f64 {
    if (LOADED.0..LOADED.1).contains(&t) {
        M + ADDED_MASS
    } else {
        M
    }
}

/// The stinger's force at time `t`: a half sine of `peak` \[N\] every `HIT_EVERY` seconds
/// from `FIRST_HIT`.
pub fn hit_force(t: f64, peak: f64) -> f64 {
    if t < FIRST_HIT {
        return 0.0;
    }
    let since = (t - FIRST_HIT) % HIT_EVERY;
    if since < HIT_DURATION {
        peak * (std::f64::consts::PI * since / HIT_DURATION).sin()
    } else {
        0.0
    }
}

/// eq. (1), `m q'' + b q' + k q = c u + F_e`, over one sample with `u` held; hits of
/// `hit_peak` \[N\]. The weight goes on and off at sample boundaries: the mass is the
/// sample's, read at its middle (read at each RK4 stage, the rounding of the stages'
/// times decides on which side of the boundary the last one falls).
pub fn plant_step(t: f64, x: [f64; 2], u: f64, dt: f64, hit_peak: f64) -> [f64; 2] {
    let m = mass(t + 0.5 * dt);
    let rate = |t: f64, x: [f64; 2]| {
        [
            x[1],
            (C * u + hit_force(t, hit_peak) - K * x[0] - B * x[1]) / m,
        ]
    };
    rk4(rate, t, x, dt, PLANT_STEPS)
}

/// Integrates `x' = rate(t, x)` from `t` over `dt` by `steps` classical Runge-Kutta steps.
pub fn rk4<const N: usize>(
    rate: impl Fn(f64, [f64; N]) -> [f64; N],
    t: f64,
    x: [f64; N],
    dt: f64,
    steps: u32,
) -> [f64; N] {
    let h = dt / f64::from(steps);
    let axpy =
        |x: [f64; N], a: f64, k: [f64; N]| -> [f64; N] { std::array::from_fn(|i| x[i] + a * k[i]) };
    let (mut t, mut x) = (t, x);
    for _ in 0..steps {
        let k1 = rate(t, x);
        let k2 = rate(t + h / 2.0, axpy(x, h / 2.0, k1));
        let k3 = rate(t + h / 2.0, axpy(x, h / 2.0, k2));
        let k4 = rate(t + h, axpy(x, h, k3));
        x = std::array::from_fn(|i| x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
        t += h;
    }
    x
}

/// The median of the last `width` values (the paper's 50-sample running median of the
/// weight estimate).
pub fn median_of_last(values: &[f64], width: usize) -> f64 {
    let mut window: Vec<f64> = values[values.len().saturating_sub(width)..].to_vec();
    window.sort_by(f64::total_cmp);
    window[window.len() / 2]
}

//! The simulated beam: the first bending mode of the cantilever, sampled at TS.
//!
//! Two plant kinds (the notes, "Simulating the cantilever"):
//! - [`PlantKind::Euler`] (default): the filters' own forward-Euler model (the generated
//!   `cantilever::in_f64::f`) run with the Euler-equivalent parameters of the physical
//!   mode. Structurally what every filter assumes, so the comparison measures the filters.
//! - [`PlantKind::ExactZoh`]: the continuous mode sampled exactly with a zero-order hold.
//!   Same poles and DC gain, different zero: the DKF's window relation then holds only
//!   while u is constant across the window (a bias at every input switch).
//!
//! Scenario (the double Kalman filter paper, sect. 5.1): "The experiment starts with an additional weight on the
//! tip mass and in the middle of the experiment it was detached". So the beam starts with
//! the 400 g tip mass (wn = 20 rad/s) and the mass change *removes* it (wn -> 50 rad/s,
//! the free beam). Removing mass m keeps the stiffness k and the actuator's force gain b:
//! wn^2 = k/m and alpha = b/m both scale by 1/m, so alpha scales by (50/20)^2 and the
//! static gain alpha/wn^2 is unchanged; zeta is kept (the note's assumption).
//! Table 1 averages over 2-15 s and reports wn = 20, so the removal must come after 15 s.
//!
//! Stinger (sect. 4.1, 5.2): "a linear actuator ... a repeatable initial disturbance". It
//! is modelled as an impulse of force, i.e. an instantaneous tip-velocity change (a kick
//! added to x2 at the first sample at or after its time); the kick bypasses u, so the
//! filters see it only through y, as an unknown disturbance.

use super::TS;
use generated_demo::cantilever::in_f64;
use generated_demo::noise::GaussianNoise;

/// Physical parameters of the beam's first mode (units mm, V, s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Physical {
    /// Natural frequency \[rad/s\].
    pub wn: f64,
    /// Damping ratio \[-\].
    pub zeta: f64,
    /// Input gain \[mm s^-2 V^-1\].
    pub alpha: f64,
}

impl Physical {
    /// The beam with the extra 400 g tip mass: "this value decreases to 20 with an extra
    /// tip-mass of 400 g" (sect. 5.1); zeta unchanged, alpha scaled by `(50/20)^2`.
    pub const WITH_TIP_MASS: Physical = Physical {
        wn: 20.0,
        zeta: 0.026,
        alpha: 0.5,
    };

    /// The same beam with the tip mass detached: wn becomes [`FREE_WN`], zeta is kept,
    /// alpha scales by (FREE_WN / wn)^2 (same stiffness and force gain, less mass).
    pub fn tip_mass_removed(self) -> Physical {
        let ratio = FREE_WN / self.wn;
        Physical {
            wn: FREE_WN,
            zeta: self.zeta,
            alpha: self.alpha * ratio * ratio,
        }
    }
}

/// Natural frequency of the free beam, "about 50 rad/sec" (sect. 5.1).
pub const FREE_WN: f64 = 50.0;

/// Default measurement-noise standard deviation [mm]: a good laser sensor (the notes;
/// with the paper's R = 0.001 mm^2 the DKF works at this level).
pub const DEFAULT_NOISE_SIGMA: f64 = 1e-4;

/// Default stinger kick [mm/s]: 2.5 mm tip amplitude at 20 rad/s, several times the PRBS
/// response (0.43 mm RMS) and within what +-100 V can attenuate in about 2 s (sect. 5.2).
pub const STINGER_VELOCITY: f64 = 50.0;

/// Actuator limit \[V\]; the adaptive LQR must be saturated to it (the notes).
pub const ACTUATOR_LIMIT: f64 = 100.0;

/// Clamps a commanded voltage to +-[`ACTUATOR_LIMIT`]. The plant does not clamp by itself,
/// so the caller applies this once and gives the filters the voltage actually applied.
pub fn saturate(u: f64) -> f64 {
    u.clamp(-ACTUATOR_LIMIT, ACTUATOR_LIMIT)
}

/// Euler-equivalent parameters [x3, x4, x5] of a physical mode: those whose Euler model
/// [[1, TS], [TS x3, 1 + TS x4]] has the exactly sampled poles exp(s TS), with the DC gain
/// matched (-x5/x3 = alpha/wn^2). For (20, 0.026, 0.5): [-393.93, -6.941, 0.4924].
pub fn euler_equivalent(wn: f64, zeta: f64, alpha: f64) -> [f64; 3] {
    let sigma = zeta * wn;
    // Sum and product of the exact discrete poles z = exp(s TS).
    let det = (-2.0 * sigma * TS).exp();
    let disc = zeta * zeta - 1.0;
    let trace = 2.0
        * (-sigma * TS).exp()
        * if disc < 0.0 {
            (wn * (-disc).sqrt() * TS).cos()
        } else {
            (wn * disc.sqrt() * TS).cosh()
        };
    // Euler model: trace = 2 + TS x4, det = 1 + TS x4 - TS^2 x3.
    let x4 = (trace - 2.0) / TS;
    let x3 = (trace - 1.0 - det) / (TS * TS);
    let x5 = -x3 * alpha / (wn * wn);
    [x3, x4, x5]
}

/// Exact zero-order-hold discretisation (Ad, Bd) of x1' = x2, x2' = -wn^2 x1 - 2 zeta wn x2
/// + alpha u over one sample: the exponential of [[Ac, Bc], [0, 0]] TS.
pub fn zoh_matrices(p: Physical) -> ([[f64; 2]; 2], [f64; 2]) {
    let m = [
        [0.0, TS, 0.0],
        [-p.wn * p.wn * TS, -2.0 * p.zeta * p.wn * TS, p.alpha * TS],
        [0.0, 0.0, 0.0],
    ];
    let e = expm3(m);
    ([[e[0][0], e[0][1]], [e[1][0], e[1][1]]], [e[0][2], e[1][2]])
}

fn matmul3(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut c = [[0.0; 3]; 3];
    for (i, row) in c.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|l| a[i][l] * b[l][j]).sum();
        }
    }
    c
}

/// Matrix exponential by scaling and squaring with a Taylor series (exact to rounding for
/// the small, well-conditioned matrices here; valid for any damping, unlike closed forms).
fn expm3(m: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let norm = m
        .iter()
        .map(|r| r.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    let squarings = if norm > 0.25 {
        (norm / 0.25).log2().ceil() as i32
    } else {
        0
    };
    let scale = 0.5f64.powi(squarings);
    let a = m.map(|r| r.map(|v| v * scale));
    let mut result = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut term = result;
    for n in 1..=18 {
        term = matmul3(&term, &a).map(|r| r.map(|v| v / f64::from(n)));
        for (ri, ti) in result.iter_mut().zip(&term) {
            for (r, t) in ri.iter_mut().zip(ti) {
                *r += t;
            }
        }
    }
    for _ in 0..squarings {
        result = matmul3(&result, &result);
    }
    result
}

/// How the beam is sampled.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PlantKind {
    /// The filters' forward-Euler model with Euler-equivalent parameters (default).
    #[default]
    Euler,
    /// The continuous mode sampled exactly with a zero-order hold on u.
    ExactZoh,
}

/// A change of the tip mass at `time` \[s\], after which the mode is `after`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassChange {
    /// Time of the change \[s\]; takes effect at the first sample at or after it.
    pub time: f64,
    /// Physical parameters from then on.
    pub after: Physical,
}

impl MassChange {
    /// The paper's change: the tip mass is detached at `time` (see the module doc).
    pub fn remove_tip_mass(time: f64, before: Physical) -> Self {
        Self {
            time,
            after: before.tip_mass_removed(),
        }
    }
}

/// One stinger hit: an impulse that changes the tip velocity by `velocity` \[mm/s\].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Kick {
    /// Time of the hit \[s\]; applied at the first sample at or after it.
    pub time: f64,
    /// Tip-velocity change \[mm/s\] (impulse / effective mass).
    pub velocity: f64,
}

/// Everything that defines one simulated run of the beam.
#[derive(Clone, Debug, PartialEq)]
pub struct PlantConfig {
    /// Sampling model of the beam.
    pub kind: PlantKind,
    /// Physical parameters at t = 0.
    pub params: Physical,
    /// Optional tip-mass change.
    pub mass_change: Option<MassChange>,
    /// Stinger hits, in any order.
    pub stinger: Vec<Kick>,
    /// Measurement noise added to y = x1.
    pub noise: GaussianNoise,
    /// Initial tip displacement \[mm\] and velocity \[mm/s\].
    pub x0: [f64; 2],
}

impl Default for PlantConfig {
    /// Euler plant at rest, beam with the tip mass, no events, noise sigma 1e-4 mm, seed 1.
    fn default() -> Self {
        Self {
            kind: PlantKind::Euler,
            params: Physical::WITH_TIP_MASS,
            mass_change: None,
            stinger: Vec::new(),
            noise: GaussianNoise::new(DEFAULT_NOISE_SIGMA, 1),
            x0: [0.0, 0.0],
        }
    }
}

/// First sample index k with k TS >= time (tolerant to rounding of time / TS).
fn event_sample(time: f64) -> u64 {
    (time / TS - 1e-9).ceil().max(0.0) as u64
}

/// The simulated beam. Per sample k: read [`Plant::output`] (y\[k\]), compute u\[k\], then
/// [`Plant::step`]`(u\[k\])` to advance to k + 1.
#[derive(Clone, Debug)]
pub struct Plant {
    config: PlantConfig,
    k: u64,
    x: [f64; 2],
    params: Physical,
    euler: [f64; 3],
    zoh: ([[f64; 2]; 2], [f64; 2]),
    mass_changed: bool,
    kicked: Vec<bool>,
}

impl Plant {
    /// A plant at sample 0 in state `config.x0`; events due at t = 0 are applied at once.
    pub fn new(config: PlantConfig) -> Self {
        let params = config.params;
        let mut plant = Self {
            k: 0,
            x: config.x0,
            params,
            euler: [0.0; 3],
            zoh: ([[0.0; 2]; 2], [0.0; 2]),
            mass_changed: false,
            kicked: vec![false; config.stinger.len()],
            config,
        };
        plant.set_params(params);
        plant.apply_events();
        plant
    }

    fn set_params(&mut self, p: Physical) {
        self.params = p;
        self.euler = euler_equivalent(p.wn, p.zeta, p.alpha);
        self.zoh = zoh_matrices(p);
    }

    fn apply_events(&mut self) {
        if let Some(change) = self.config.mass_change {
            // The detached mass leaves with its own momentum: x1, x2 are continuous.
            if !self.mass_changed && self.k >= event_sample(change.time) {
                self.mass_changed = true;
                self.set_params(change.after);
            }
        }
        for (kick, done) in self.config.stinger.iter().zip(self.kicked.iter_mut()) {
            if !*done && self.k >= event_sample(kick.time) {
                *done = true;
                self.x[1] += kick.velocity;
            }
        }
    }

    /// Current time k TS \[s\].
    pub fn time(&self) -> f64 {
        self.k as f64 * TS
    }

    /// True tip displacement \[mm\] and velocity \[mm/s\] at sample k.
    pub fn state(&self) -> [f64; 2] {
        self.x
    }

    /// True physical parameters in force at sample k.
    pub fn params(&self) -> Physical {
        self.params
    }

    /// Measured output y\[k\] = x1\[k\] + noise\[k\]; the noise depends only on (seed, k).
    pub fn output(&self) -> f64 {
        self.x[0] + self.config.noise.sample(self.k)
    }

    /// Applies u\[k\] \[V\] (not clamped: see [`saturate`]) over one sample and advances to k + 1;
    /// mass changes and stinger kicks due at the new sample are then applied.
    pub fn step(&mut self, u: f64) {
        self.x = match self.config.kind {
            PlantKind::Euler => {
                let [x3, x4, x5] = self.euler;
                let next = in_f64::f(&[self.x[0], self.x[1], x3, x4, x5], &[u]);
                [next[0], next[1]]
            }
            PlantKind::ExactZoh => {
                let (a, b) = self.zoh;
                [
                    a[0][0] * self.x[0] + a[0][1] * self.x[1] + b[0] * u,
                    a[1][0] * self.x[0] + a[1][1] * self.x[1] + b[1] * u,
                ]
            }
        };
        self.k += 1;
        self.apply_events();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::excitation::Prbs;

    #[test]
    fn euler_equivalent_matches_the_note() {
        let [x3, x4, x5] = euler_equivalent(20.0, 0.026, 0.5);
        assert!((x3 + 393.93).abs() < 0.01, "{x3}");
        assert!((x4 + 6.941).abs() < 0.001, "{x4}");
        assert!((x5 - 0.4924).abs() < 0.0001, "{x5}");
    }

    #[test]
    fn zoh_has_the_euler_equivalent_poles_and_dc_gain() {
        for p in [
            Physical::WITH_TIP_MASS,
            Physical::WITH_TIP_MASS.tip_mass_removed(),
        ] {
            let (a, b) = zoh_matrices(p);
            let [x3, x4, x5] = euler_equivalent(p.wn, p.zeta, p.alpha);
            let trace = a[0][0] + a[1][1];
            let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
            assert!((trace - (2.0 + TS * x4)).abs() < 1e-12);
            assert!((det - (1.0 + TS * x4 - TS * TS * x3)).abs() < 1e-12);
            // Static gain of x[k+1] = A x + B u: x1 = ((I - A)^-1 B)_1.
            let d = (1.0 - a[0][0]) * (1.0 - a[1][1]) - a[0][1] * a[1][0];
            let dc = ((1.0 - a[1][1]) * b[0] + a[0][1] * b[1]) / d;
            assert!((dc - p.alpha / (p.wn * p.wn)).abs() < 1e-9);
            assert!((dc + x5 / x3).abs() < 1e-9);
        }
    }

    #[test]
    fn mass_removal_and_kick_happen_on_time() {
        let config = PlantConfig {
            mass_change: Some(MassChange::remove_tip_mass(0.3, Physical::WITH_TIP_MASS)),
            stinger: vec![Kick {
                time: 0.15,
                velocity: STINGER_VELOCITY,
            }],
            ..PlantConfig::default()
        };
        let mut plant = Plant::new(config);
        for _ in 0..10 {
            plant.step(0.0);
        }
        assert_eq!(plant.state(), [0.0, STINGER_VELOCITY]);
        assert_eq!(plant.params(), Physical::WITH_TIP_MASS);
        for _ in 0..10 {
            plant.step(0.0);
        }
        let p = plant.params();
        assert_eq!((p.wn, p.zeta), (50.0, 0.026));
        assert!((p.alpha - 0.5 * 6.25).abs() < 1e-12);
    }

    #[test]
    fn prbs_moves_the_tip_about_0_43_mm_rms_and_runs_are_reproducible() {
        let run = |kind| {
            let mut plant = Plant::new(PlantConfig {
                kind,
                ..PlantConfig::default()
            });
            let ys: Vec<f64> = Prbs::paper()
                .take(2000)
                .map(|u| {
                    let y = plant.output();
                    plant.step(u);
                    y
                })
                .collect();
            ys
        };
        for kind in [PlantKind::Euler, PlantKind::ExactZoh] {
            let ys = run(kind);
            assert_eq!(ys, run(kind));
            let rms = (ys.iter().map(|y| y * y).sum::<f64>() / ys.len() as f64).sqrt();
            assert!((0.3..0.6).contains(&rms), "{kind:?}: {rms}");
        }
    }
}

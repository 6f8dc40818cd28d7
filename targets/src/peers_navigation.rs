//! SymForce's peer of the navigation EKF on the same target (`--features symforce`, built
//! by `cargo xtask peers`, never by the normal build): the prediction and the GNSS and
//! magnetometer fusions SymForce generates from the same model (`peers/symforce_codegen.py`,
//! C++ compiled with arm-none-eabi-g++ into `libpeers.a`, called through
//! `peers/symforce_glue.cpp`), run beside the generated `f32` filter of that model over the
//! embedded flight of `crate::navigation`.
//!
//! That model is the additive 24-state filter (a `w`-first quaternion in the covariance,
//! the IMU's delta angle and delta velocity as inputs), which the navigation model was
//! before its error-state rewrite on `Rot3`: the peer keeps its own copy of it
//! (`crate::peers_navigation_model`), of its initial estimate's layout and of its tuning
//! (`additive_tuning`), so both sides still run the same filter. The flight's IMU samples
//! (rates) are turned back into delta angles and velocities (times `DT`) before the calls.
//!
//! Before each call of ours, SymForce is handed exactly our filter's state, its covariance
//! as the packed upper triangle (from `Ekf::covariance`), the same input or measurement,
//! and the same noise (`Q`'s diagonal, or the sensor's part of `R`'s: the flight's `R` is
//! diagonal); both calls are read one at a time (`measure::Calls`), SymForce's first, and
//! their results compared: the largest difference of a state entry scaled by
//! `max(|x_i|, sqrt(P_ii))` and of a covariance entry scaled by `sqrt(P_ii P_jj)`, `x` and
//! `P` ours after the call. A measurement ours rejects as an outlier is not compared
//! (SymForce's code has no gate), only counted.
//!
//! Output, per kernel (`predict`, `update_gnss`, `update_magnetometer`):
//! `navpeer <side> <kernel> <median> <worst> <mean> <calls>` for `ours` and `symforce`
//! (instructions per call), `navstack <side> <kernel> <bytes>`, and
//! `navdiff <kernel> <compared> <skipped> <state> <covariance> <state's call>
//! <covariance's call>` (the largest differences, and the calls of the flight where they
//! were).

use crate::matrix::diag;
use crate::measure::{stack_depth, traced, Calls, Clock};
use crate::navigation::{events, flight, Event, GNSS_UPDATES, MAGNETOMETER_UPDATES, PREDICTIONS};
use crate::peers_navigation_model::navigation_additive::{Ekf, Status, DT, X_LEN};
use core::hint::black_box;
use cortex_m_semihosting::hprintln;
use generated_demo::flight::{ACCEL_NOISE, GYRO_NOISE, MAGNETOMETER_GATE};

/// States (the glue's, which `peers/symforce_codegen.py` checks against the model's), and
/// entries of the covariance's packed upper triangle.
const STATES: usize = X_LEN;
const PACKED: usize = STATES * (STATES + 1) / 2;

/// The additive filter's tuning, the diagonals of `P0` and of `Q` per IMU sample over its
/// 24 states (the navigation experiment's before the error-state rewrite): the IMU noise
/// (half the delta angle's on each quaternion entry), slow random walks for the biases
/// (per sample) and the fields.
fn additive_tuning() -> ([f32; STATES], [f32; STATES]) {
    let dt = f64::from(DT);
    let mut p0 = [0.0; STATES];
    let mut q = [0.0; STATES];
    let groups: [(core::ops::Range<usize>, f64, f64); 7] = [
        (0..4, 0.05, 0.5 * GYRO_NOISE * dt),
        (4..7, 0.5, ACCEL_NOISE * dt),
        (7..10, 1.0, 0.0),
        (10..13, 0.01 * dt, 1e-8),
        (13..16, 0.2 * dt, 3e-7),
        (16..22, 0.05, 3e-5),
        (22..24, 0.1, 1e-4),
    ];
    for (range, initial_sigma, noise_sigma) in groups {
        for i in range {
            p0[i] = (initial_sigma * initial_sigma) as f32;
            q[i] = (noise_sigma * noise_sigma) as f32;
        }
    }
    (p0, q)
}

/// The additive filter at the flight's start: the flight's initial estimate with its
/// quaternion `w` first, the additive tuning, the flight's `R` and magnetometer gate.
fn filter() -> Ekf {
    let [x, y, z, w] = [0, 1, 2, 3].map(|i| flight::X0[i]);
    let mut x0 = flight::X0;
    x0[..4].copy_from_slice(&[w, x, y, z]);
    let (p0, q) = additive_tuning();
    let mut ekf = match Ekf::new(&x0, &diag(p0), &q, &diag(flight::R)) {
        Ok(ekf) => ekf,
        Err(status) => panic!(
            "the additive navigation EKF rejected its tuning: {:?}",
            status
        ),
    };
    let status = ekf.set_magnetometer_innovation_gate(MAGNETOMETER_GATE as f32);
    assert!(status == Status::Ok, "magnetometer gate: {:?}", status);
    ekf
}

/// The additive filter's input: the IMU sample's delta angle and delta velocity.
fn delta(rates: &[f32; 6]) -> [f32; 6] {
    rates.map(|v| v * DT)
}

/// Whether the filter used the measurement (`true`) or rejected it as an outlier
/// (`false`); panics on any other status, naming the call.
fn used(status: Status, event: Event, call: usize) -> bool {
    match status {
        Status::Ok => true,
        Status::OutlierRejected => false,
        other => panic!(
            "additive navigation EKF, call {} ({:?}): {:?}",
            call, event, other
        ),
    }
}

// The kernels of ours measured: one call each, never inlined, so each is one symbol whose
// size and stack use are its own (named apart from the error-state filter's wrappers in
// `crate::navigation`, which the trace would otherwise confuse with them).

/// `Ekf::predict` of the additive filter.
#[inline(never)]
fn generated_navigation_additive_predict(filter: &mut Ekf, imu: &[f32; 6]) -> Status {
    filter.predict(imu)
}

/// `Ekf::update_gnss` of the additive filter.
#[inline(never)]
fn generated_navigation_additive_update_gnss(filter: &mut Ekf, y: &[f32; 6]) -> Status {
    filter.update_gnss(y)
}

/// `Ekf::update_magnetometer` of the additive filter.
#[inline(never)]
fn generated_navigation_additive_update_magnetometer(filter: &mut Ekf, y: &[f32; 3]) -> Status {
    filter.update_magnetometer(y)
}

/// An array as the glue takes it: 16-byte aligned, the alignment Eigen gives its
/// fixed-size vectors on this target.
#[repr(C, align(16))]
#[derive(Clone, Copy)]
struct Aligned<const N: usize>([f32; N]);

/// An estimate as SymForce's functions take and give it.
#[derive(Clone, Copy)]
struct Estimate {
    x: Aligned<STATES>,
    p: Aligned<PACKED>,
}

impl Estimate {
    /// Our filter's state and covariance, the upper triangle packed row by row.
    fn of(ekf: &Ekf) -> Estimate {
        let covariance = ekf.covariance();
        let mut p = [0.0; PACKED];
        let upper = covariance
            .iter()
            .enumerate()
            .flat_map(|(i, row)| row[i..].iter());
        for (slot, value) in p.iter_mut().zip(upper) {
            *slot = *value;
        }
        Estimate {
            x: Aligned(ekf.state()),
            p: Aligned(p),
        }
    }
}

#[allow(unsafe_code)]
mod ffi {
    use super::{Aligned, Estimate, STATES};

    /// A function of the glue: the prior's state and packed covariance, the input or
    /// measurement, the noise's diagonal; the posterior's state and packed covariance.
    type Glue =
        unsafe extern "C" fn(*const f32, *const f32, *const f32, *const f32, *mut f32, *mut f32);

    extern "C" {
        /// `peers/symforce_glue.cpp`: reads 24, 300, 6 and 24 floats.
        fn symforce_navigation_predict(
            x: *const f32,
            p: *const f32,
            u: *const f32,
            q: *const f32,
            x_new: *mut f32,
            p_new: *mut f32,
        );
        /// Reads 24, 300, 6 and 6 floats.
        fn symforce_navigation_update_gnss(
            x: *const f32,
            p: *const f32,
            y: *const f32,
            r: *const f32,
            x_new: *mut f32,
            p_new: *mut f32,
        );
        /// Reads 24, 300, 3 and 3 floats.
        fn symforce_navigation_update_magnetometer(
            x: *const f32,
            p: *const f32,
            y: *const f32,
            r: *const f32,
            x_new: *mut f32,
            p_new: *mut f32,
        );
    }

    /// `glue` on arrays of `V` and `W` entries: each public function below passes the glue
    /// function that reads exactly those.
    fn call<const V: usize, const W: usize>(
        glue: Glue,
        prior: &Estimate,
        v: &Aligned<V>,
        noise: &Aligned<W>,
        posterior: &mut Estimate,
    ) {
        // SAFETY: every pointer is to an array of the length `glue` reads or writes (24
        // states and 300 packed entries by `Estimate`'s types, V and W as its callers
        // below pair them), 16-byte aligned as Eigen's vectors are; the outputs are
        // `posterior`, a `&mut` distinct from the inputs; the glue keeps no pointer.
        unsafe {
            glue(
                prior.x.0.as_ptr(),
                prior.p.0.as_ptr(),
                v.0.as_ptr(),
                noise.0.as_ptr(),
                posterior.x.0.as_mut_ptr(),
                posterior.p.0.as_mut_ptr(),
            );
        }
    }

    /// SymForce's prediction with the IMU sample `u` and the process noise `q`.
    pub fn predict(prior: &Estimate, u: &Aligned<6>, q: &Aligned<STATES>, out: &mut Estimate) {
        call(symforce_navigation_predict, prior, u, q, out);
    }

    /// SymForce's GNSS fusion of `y` with the noise variances `r`.
    pub fn update_gnss(prior: &Estimate, y: &Aligned<6>, r: &Aligned<6>, out: &mut Estimate) {
        call(symforce_navigation_update_gnss, prior, y, r, out);
    }

    /// SymForce's magnetometer fusion of `y` with the noise variances `r`.
    pub fn update_magnetometer(
        prior: &Estimate,
        y: &Aligned<3>,
        r: &Aligned<3>,
        out: &mut Estimate,
    ) {
        call(symforce_navigation_update_magnetometer, prior, y, r, out);
    }
}

// SymForce's calls, one wrapper each, never inlined, so that the trace follows each and
// the table can give the code each reaches.

#[inline(never)]
fn peers_symforce_predict(
    prior: &Estimate,
    u: &Aligned<6>,
    q: &Aligned<STATES>,
    out: &mut Estimate,
) {
    ffi::predict(prior, u, q, out);
}

#[inline(never)]
fn peers_symforce_update_gnss(
    prior: &Estimate,
    y: &Aligned<6>,
    r: &Aligned<6>,
    out: &mut Estimate,
) {
    ffi::update_gnss(prior, y, r, out);
}

#[inline(never)]
fn peers_symforce_update_magnetometer(
    prior: &Estimate,
    y: &Aligned<3>,
    r: &Aligned<3>,
    out: &mut Estimate,
) {
    ffi::update_magnetometer(prior, y, r, out);
}

/// The largest differences of SymForce's result from ours (ours after the same call): of
/// a state entry scaled by `max(|x_i|, sqrt(P_ii))`, and of a covariance entry scaled by
/// `sqrt(P_ii P_jj)`.
fn differences(ekf: &Ekf, symforce: &Estimate) -> (f32, f32) {
    let (x, p) = (ekf.state(), ekf.covariance());
    let sigma: [f32; STATES] =
        core::array::from_fn(|i| stateforge_math::f32::sqrt(p[i][i].max(0.0)));
    let mut state = 0.0_f32;
    for (i, (ours, theirs)) in x.iter().zip(&symforce.x.0).enumerate() {
        state = state.max((ours - theirs).abs() / ours.abs().max(sigma[i]));
    }
    let mut covariance = 0.0_f32;
    let upper = (0..STATES).flat_map(|i| (i..STATES).map(move |j| (i, j)));
    for ((i, j), theirs) in upper.zip(&symforce.p.0) {
        covariance = covariance.max((p[i][j] - theirs).abs() / (sigma[i] * sigma[j]));
    }
    (state, covariance)
}

/// One kernel on both sides: the calls read, what was compared, the stacks.
struct Kernel<const N: usize> {
    name: &'static str,
    ours: Calls<N>,
    symforce: Calls<N>,
    compared: usize,
    skipped: usize,
    /// Largest differences so far (state, covariance) and the calls where they were.
    worst: (f32, f32),
    at: (usize, usize),
}

impl<const N: usize> Kernel<N> {
    fn new(name: &'static str) -> Self {
        Kernel {
            name,
            ours: Calls::new(),
            symforce: Calls::new(),
            compared: 0,
            skipped: 0,
            worst: (0.0, 0.0),
            at: (0, 0),
        }
    }

    /// Compares SymForce's `posterior` with our filter after call `call`, if ours used the
    /// measurement; else counts the call as skipped.
    fn compare(&mut self, ekf: &Ekf, posterior: &Estimate, used: bool, call: usize) {
        if !used {
            self.skipped += 1;
            return;
        }
        let (state, covariance) = differences(ekf, posterior);
        if state > self.worst.0 {
            (self.worst.0, self.at.0) = (state, call);
        }
        if covariance > self.worst.1 {
            (self.worst.1, self.at.1) = (covariance, call);
        }
        self.compared += 1;
    }

    /// Prints the kernel's lines, its stacks `(ours, SymForce's)` given.
    fn report(mut self, stacks: (usize, usize)) {
        for (side, calls, stack) in [
            ("ours", &mut self.ours, stacks.0),
            ("symforce", &mut self.symforce, stacks.1),
        ] {
            let (median, worst) = calls.median_worst();
            let mean = calls.mean();
            hprintln!(
                "navpeer {} {} {} {} {} {}",
                side,
                self.name,
                median,
                worst,
                mean,
                N
            );
            hprintln!("navstack {} {} {}", side, self.name, stack);
        }
        hprintln!(
            "navdiff {} {} {} {:e} {:e} {} {}",
            self.name,
            self.compared,
            self.skipped,
            self.worst.0,
            self.worst.1,
            self.at.0,
            self.at.1
        );
    }
}

/// The three kernels compared, and the noise SymForce is handed.
struct Comparison {
    predict: Kernel<PREDICTIONS>,
    gnss: Kernel<GNSS_UPDATES>,
    magnetometer: Kernel<MAGNETOMETER_UPDATES>,
    q: Aligned<STATES>,
    r_gnss: Aligned<6>,
    r_magnetometer: Aligned<3>,
}

impl Comparison {
    fn new() -> Comparison {
        Comparison {
            predict: Kernel::new("predict"),
            gnss: Kernel::new("update_gnss"),
            magnetometer: Kernel::new("update_magnetometer"),
            q: Aligned(additive_tuning().1),
            r_gnss: Aligned(core::array::from_fn(|i| flight::R[i])),
            r_magnetometer: Aligned(core::array::from_fn(|i| flight::R[6 + i])),
        }
    }

    /// Call `call` of the flight: SymForce's from our filter's estimate, then ours, each
    /// read; then the comparison.
    fn step(&mut self, clock: &Clock, ekf: &mut Ekf, event: Event, call: usize) {
        let prior = Estimate::of(ekf);
        let mut posterior = prior;
        let was_used = |status: Status| used(status, event, call);
        match event {
            Event::Predict(rates) => {
                let u = &delta(rates);
                let k = &mut self.predict;
                let (v, q) = (Aligned(*u), &self.q);
                k.symforce.measure(clock, || {
                    peers_symforce_predict(&prior, &v, q, &mut posterior);
                });
                let status = k
                    .ours
                    .measure(clock, || generated_navigation_additive_predict(ekf, u));
                k.compare(ekf, &posterior, was_used(status), call);
            }
            Event::Gnss(y) => {
                let k = &mut self.gnss;
                let (v, r) = (Aligned(*y), &self.r_gnss);
                k.symforce.measure(clock, || {
                    peers_symforce_update_gnss(&prior, &v, r, &mut posterior);
                });
                let status = k
                    .ours
                    .measure(clock, || generated_navigation_additive_update_gnss(ekf, y));
                k.compare(ekf, &posterior, was_used(status), call);
            }
            Event::Magnetometer(y) => {
                let k = &mut self.magnetometer;
                let (v, r) = (Aligned(*y), &self.r_magnetometer);
                k.symforce.measure(clock, || {
                    peers_symforce_update_magnetometer(&prior, &v, r, &mut posterior);
                });
                let status = k.ours.measure(clock, || {
                    generated_navigation_additive_update_magnetometer(ekf, y)
                });
                k.compare(ekf, &posterior, was_used(status), call);
            }
        }
    }

    /// Each kernel's deepest stack, ours and SymForce's, on copies of the final estimate;
    /// then every kernel's lines.
    fn report(self, ekf: &Ekf) {
        let prior = Estimate::of(ekf);
        let mut out = prior;
        let ours = |kernel: &dyn Fn(&mut Ekf)| {
            let mut copy = *ekf;
            stack_depth(|| kernel(black_box(&mut copy)))
        };
        let (imu, gnss, magnetometer) = (
            Aligned(delta(&flight::IMU[0])),
            Aligned(flight::GNSS[0].1),
            Aligned(flight::MAGNETOMETER[0].1),
        );
        let stacks = (
            ours(&|f| {
                let _ = black_box(generated_navigation_additive_predict(f, &imu.0));
            }),
            stack_depth(|| peers_symforce_predict(&prior, &imu, &self.q, &mut out)),
        );
        self.predict.report(stacks);
        let stacks = (
            ours(&|f| {
                let _ = black_box(generated_navigation_additive_update_gnss(f, &gnss.0));
            }),
            stack_depth(|| peers_symforce_update_gnss(&prior, &gnss, &self.r_gnss, &mut out)),
        );
        self.gnss.report(stacks);
        let stacks = (
            ours(&|f| {
                let _ = black_box(generated_navigation_additive_update_magnetometer(
                    f,
                    &magnetometer.0,
                ));
            }),
            stack_depth(|| {
                peers_symforce_update_magnetometer(
                    &prior,
                    &magnetometer,
                    &self.r_magnetometer,
                    &mut out,
                );
            }),
        );
        self.magnetometer.report(stacks);
    }
}

/// The flight with both, every call read, between the trace markers; then the lines.
pub fn run(clock: &Clock) {
    let mut ekf = filter();
    let mut comparison = Comparison::new();
    traced(|| {
        for (call, event) in events().enumerate() {
            comparison.step(clock, &mut ekf, event, call);
        }
    });
    comparison.report(&ekf);
}

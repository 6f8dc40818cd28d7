//! SymForce's peer of the navigation EKF on the same target (`--features symforce`, built
//! by `cargo xtask peers`, never by the normal build): the prediction and the GNSS and
//! magnetometer fusions SymForce generates from the same error-state model on its own
//! geometry (`peers/symforce_codegen.py`: the attitude an `sf.Rot3`, the covariance over
//! the 23 tangent coordinates; C++ compiled with arm-none-eabi-g++ into `libpeers.a`,
//! called through `peers/symforce_glue.cpp`), run beside the generated `f32` filter
//! (`generated_demo::navigation`, as `crate::navigation` runs it) over the embedded flight
//! of `crate::navigation`, from its initial estimate and tuning.
//!
//! Before each call of ours, SymForce is handed exactly our filter's state, its covariance
//! as the packed upper triangle (from `Ekf::covariance`), the same input or measurement,
//! and the same noise (`Q`'s diagonal over the tangent, or the sensor's part of `R`'s: the
//! flight's `R` is diagonal); both calls are read one at a time (`measure::Calls`),
//! SymForce's first, and their results compared (see [`differences`]). A measurement ours
//! rejects as an outlier is not compared (SymForce's code has no gate), only counted.
//!
//! Output, per kernel (`predict`, `update_gnss`, `update_magnetometer`):
//! `navpeer <side> <kernel> <median> <worst> <mean> <calls>` for `ours` and `symforce`
//! (instructions per call), `navstack <side> <kernel> <bytes>`, and
//! `navdiff <kernel> <compared> <skipped> <state> <covariance> <state's call>
//! <covariance's call>` (the largest differences, and the calls of the flight where they
//! were).

use crate::measure::{stack_depth, traced, Calls, Clock};
use crate::navigation::{
    events, filter, flight, generated_navigation_predict, generated_navigation_update_gnss,
    generated_navigation_update_magnetometer, used, Event, GNSS_UPDATES, MAGNETOMETER_UPDATES,
    PREDICTIONS,
};
use core::hint::black_box;
use cortex_m_semihosting::hprintln;
use generated_demo::navigation::{Ekf, TANGENT_LEN, X_LEN};

/// The state's entries and the covariance's tangent coordinates (the glue's, which
/// `peers/symforce_codegen.py` checks against the model's), and the entries of the
/// covariance's packed upper triangle.
const STATES: usize = X_LEN;
const TANGENT: usize = TANGENT_LEN;
const PACKED: usize = TANGENT * (TANGENT + 1) / 2;

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
    use super::{Aligned, Estimate, TANGENT};

    /// A function of the glue: the prior's state and packed covariance, the input or
    /// measurement, the noise's diagonal; the posterior's state and packed covariance.
    type Glue =
        unsafe extern "C" fn(*const f32, *const f32, *const f32, *const f32, *mut f32, *mut f32);

    extern "C" {
        /// `peers/symforce_glue.cpp`: reads 24, 276, 6 and 23 floats and the interval.
        fn symforce_navigation_predict(
            x: *const f32,
            p: *const f32,
            u: *const f32,
            q: *const f32,
            dt: f32,
            x_new: *mut f32,
            p_new: *mut f32,
        );
        /// Reads 24, 276, 6 and 6 floats.
        fn symforce_navigation_update_gnss(
            x: *const f32,
            p: *const f32,
            y: *const f32,
            r: *const f32,
            x_new: *mut f32,
            p_new: *mut f32,
        );
        /// Reads 24, 276, 3 and 3 floats.
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
        // states and 276 packed entries by `Estimate`'s types, V and W as its callers
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

    /// SymForce's prediction over the interval `dt` with the IMU sample `u` and the
    /// process noise density `q`.
    pub fn predict(
        prior: &Estimate,
        (dt, u): (f32, &Aligned<6>),
        q: &Aligned<TANGENT>,
        out: &mut Estimate,
    ) {
        // SAFETY: as in `call`: the arrays are of the lengths the glue reads and writes
        // (24, 276, 6 and 23; 24 and 276), 16-byte aligned, the outputs a distinct `&mut`;
        // the interval is passed by value; the glue keeps no pointer.
        unsafe {
            symforce_navigation_predict(
                prior.x.0.as_ptr(),
                prior.p.0.as_ptr(),
                u.0.as_ptr(),
                q.0.as_ptr(),
                dt,
                out.x.0.as_mut_ptr(),
                out.p.0.as_mut_ptr(),
            );
        }
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
    sample: (f32, &Aligned<6>),
    q: &Aligned<TANGENT>,
    out: &mut Estimate,
) {
    ffi::predict(prior, sample, q, out);
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
/// a state entry scaled by `max(|x_i|, sigma_k)`, `sigma_k = sqrt(P_kk)` over its tangent
/// coordinate `k`; of the attitude, the rotation that takes ours to SymForce's, as its
/// rotation vector `2 vec(q_SF ⊗ q⁻¹)` (to first order; an error in the earth frame, as
/// the covariance's), each coordinate scaled by its `sigma_k`; of a covariance entry
/// scaled by `sigma_i sigma_j`.
fn differences(ekf: &Ekf, symforce: &Estimate) -> (f32, f32) {
    let (x, p) = (ekf.state(), ekf.covariance());
    let sigma: [f32; TANGENT] =
        core::array::from_fn(|k| stateforge_math::f32::sqrt(p[k][k].max(0.0)));
    let mut state = 0.0_f32;
    let turn = rotation_between(&x, &symforce.x.0);
    for (k, angle) in turn.iter().enumerate() {
        state = state.max(angle.abs() / sigma[k]);
    }
    // The entries after the attitude's four, each with its tangent coordinate.
    for (i, (ours, theirs)) in x.iter().zip(&symforce.x.0).enumerate().skip(4) {
        state = state.max((ours - theirs).abs() / ours.abs().max(sigma[i - 1]));
    }
    let mut covariance = 0.0_f32;
    let upper = (0..TANGENT).flat_map(|i| (i..TANGENT).map(move |j| (i, j)));
    for ((i, j), theirs) in upper.zip(&symforce.p.0) {
        covariance = covariance.max((p[i][j] - theirs).abs() / (sigma[i] * sigma[j]));
    }
    (state, covariance)
}

/// `2 vec(b ⊗ a⁻¹)` of the attitudes `[x, y, z, w]` first in the states `a` and `b`: the
/// rotation vector, to first order, of the turn in the earth frame that takes `a` to `b`.
fn rotation_between(a: &[f32; STATES], b: &[f32; STATES]) -> [f32; 3] {
    let ([ax, ay, az, aw], [bx, by, bz, bw]) = ([a[0], a[1], a[2], a[3]], [b[0], b[1], b[2], b[3]]);
    // The vector part of b ⊗ conj(a): aw b_v - bw a_v - b_v × a_v.
    [
        2.0 * (aw * bx - bw * ax - (by * az - bz * ay)),
        2.0 * (aw * by - bw * ay - (bz * ax - bx * az)),
        2.0 * (aw * bz - bw * az - (bx * ay - by * ax)),
    ]
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
    q: Aligned<TANGENT>,
    r_gnss: Aligned<6>,
    r_magnetometer: Aligned<3>,
}

impl Comparison {
    fn new() -> Comparison {
        Comparison {
            predict: Kernel::new("predict"),
            gnss: Kernel::new("update_gnss"),
            magnetometer: Kernel::new("update_magnetometer"),
            q: Aligned(flight::Q),
            r_gnss: Aligned(core::array::from_fn(|i| flight::R[i])),
            r_magnetometer: Aligned(core::array::from_fn(|i| flight::R[6 + i])),
        }
    }

    /// Call `call` of the flight: SymForce's from our filter's estimate, then ours, each
    /// read; then the comparison.
    fn step(&mut self, clock: &Clock, ekf: &mut Ekf, event: Event, call: usize) {
        let prior = Estimate::of(ekf);
        let mut posterior = prior;
        let was_used = |status| used(status, event, call);
        match event {
            Event::Predict(dt, u) => {
                let k = &mut self.predict;
                let (v, q) = (Aligned(*u), &self.q);
                k.symforce.measure(clock, || {
                    peers_symforce_predict(&prior, (dt, &v), q, &mut posterior);
                });
                let status = k
                    .ours
                    .measure(clock, || generated_navigation_predict(ekf, dt, u));
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
                    .measure(clock, || generated_navigation_update_gnss(ekf, y));
                k.compare(ekf, &posterior, was_used(status), call);
            }
            Event::Magnetometer(y) => {
                let k = &mut self.magnetometer;
                let (v, r) = (Aligned(*y), &self.r_magnetometer);
                k.symforce.measure(clock, || {
                    peers_symforce_update_magnetometer(&prior, &v, r, &mut posterior);
                });
                let status = k
                    .ours
                    .measure(clock, || generated_navigation_update_magnetometer(ekf, y));
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
        let (dt, imu, gnss, magnetometer) = (
            flight::INTERVAL[0],
            Aligned(flight::IMU[0]),
            Aligned(flight::GNSS[0].1),
            Aligned(flight::MAGNETOMETER[0].1),
        );
        let stacks = (
            ours(&|f| {
                let _ = black_box(generated_navigation_predict(f, dt, &imu.0));
            }),
            stack_depth(|| peers_symforce_predict(&prior, (dt, &imu), &self.q, &mut out)),
        );
        self.predict.report(stacks);
        let stacks = (
            ours(&|f| {
                let _ = black_box(generated_navigation_update_gnss(f, &gnss.0));
            }),
            stack_depth(|| peers_symforce_update_gnss(&prior, &gnss, &self.r_gnss, &mut out)),
        );
        self.gnss.report(stacks);
        let stacks = (
            ours(&|f| {
                let _ = black_box(generated_navigation_update_magnetometer(f, &magnetometer.0));
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

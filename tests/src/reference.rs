//! Independent `f64` reference implementation of the cantilever paper's algorithms
//! (the double Kalman filter paper): the EKF (Alg. 1), the LTV window transform and the double Kalman filter
//! (Sect. 2, Alg. 2) and the adaptive finite-horizon LQR (Alg. 3, eq. 19).
//!
//! Everything here is written by hand from the paper's equations and uses `nalgebra`; nothing comes from the code
//! generator, so tests can check generated code against it.
//!
//! # Model (eqs. 3a-3f)
//! State `x = [x1, x2, x3, x4, x5]`: tip displacement, velocity, `x3 = -wn^2`,
//! `x4 = -2 zeta wn`, `x5` = input gain. Forward Euler with [`TS`]:
//!
//! ```text
//! f(x, u) = [x1 + TS x2, TS x1 x3 + (1 + TS x4) x2 + TS x5 u, x3, x4, x5],   h(x) = x1
//! ```
//!
//! # Index convention (all filters)
//! `step(u_prev, y)` at sample `k` receives `u[k-1]` and `y[k]`: it predicts `x[k|k-1]`
//! from `x[k-1|k-1]` with `u[k-1]`, then updates with `y[k]`. The initial state given to a
//! filter is therefore `x[-1|-1]`. Covariance updates use the Joseph form.

use nalgebra::{Matrix2, Matrix3, RowVector2, SMatrix, SVector, Vector2, Vector3};

/// Sample time of the cantilever experiment, in seconds (15 ms).
pub const TS: f64 = 0.015;

/// Number of states of the augmented model.
pub const NX: usize = 5;

/// An augmented state vector `[x1, x2, x3, x4, x5]`.
pub type State = SVector<f64, NX>;

/// A 5x5 matrix: covariances and state Jacobians.
pub type Mat5 = SMatrix<f64, NX, NX>;

/// The 1x5 output matrix `C = dh/dx = [1, 0, 0, 0, 0]`.
pub type OutputRow = SMatrix<f64, 1, NX>;

/// The measurement-noise covariance (1x1).
pub type Mat1 = SMatrix<f64, 1, 1>;

/// The LQR gain (1x2), acting on `[x1, x2]`.
pub type Gain = SMatrix<f64, 1, 2>;

// ---------------------------------------------------------------------------------------
// Model
// ---------------------------------------------------------------------------------------

/// Discrete model `x[k+1] = f(x[k], u[k])`, forward Euler of eq. (1). // eq. (3a)-(3e)
pub fn f(x: &State, u: f64) -> State {
    State::from([
        x[0] + TS * x[1],                                            // eq. (3a)
        TS * x[0] * x[2] + (1.0 + TS * x[3]) * x[1] + TS * x[4] * u, // eq. (3b)
        x[2],                                                        // eq. (3c)
        x[3],                                                        // eq. (3d)
        x[4],                                                        // eq. (3e)
    ])
}

/// Output `y = h(x) = x1`. // eq. (3f)
pub fn h(x: &State) -> f64 {
    x[0]
}

/// Jacobian `df/dx` at `(x, u)`, written by hand from [`f`].
pub fn jacobian_f_x(x: &State, u: f64) -> Mat5 {
    let mut a = Mat5::identity();
    // Row 1: x1 + TS x2.
    a[(0, 1)] = TS;
    // Row 2: TS x1 x3 + (1 + TS x4) x2 + TS x5 u.
    a[(1, 0)] = TS * x[2];
    a[(1, 1)] = 1.0 + TS * x[3];
    a[(1, 2)] = TS * x[0];
    a[(1, 3)] = TS * x[1];
    a[(1, 4)] = TS * u;
    // Rows 3-5: random-walk parameters, identity (already set).
    a
}

/// Jacobian `df/du` at `x` (a column): `[0, TS x5, 0, 0, 0]'`.
pub fn jacobian_f_u(x: &State) -> State {
    State::from([0.0, TS * x[4], 0.0, 0.0, 0.0])
}

/// Jacobian `dh/dx = C = [1, 0, 0, 0, 0]` (the output is linear). // eq. (13b)
pub fn jacobian_h_x() -> OutputRow {
    OutputRow::from_row_slice(&[1.0, 0.0, 0.0, 0.0, 0.0])
}

// ---------------------------------------------------------------------------------------
// Kalman filter pieces
// ---------------------------------------------------------------------------------------

/// Outcome of a filter step (or of a `predict` / `update` on its own).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepStatus {
    /// The step was applied.
    Ok,
    /// The input or the measurement was not finite; the filter is unchanged.
    Rejected,
    /// The innovation variance `S = C P C' + R` was not positive (or not finite); the
    /// filter is unchanged (as before the step, not as after its prediction).
    NonPositiveInnovation,
}

/// Measurement update with `y` and the linear output `C = [1, 0, 0, 0, 0]`, Joseph form.
/// Returns `None` if `S = C P C' + R` is not a positive finite number.
///
/// `K = P C' S^-1`, `x = x + K (y - C x)`, `P = (I - K C) P (I - K C)' + K R K'`.
/// // Alg. 1 lines 4-6; eq. (17a)-(17c)
pub fn joseph_update(x: &State, p: &Mat5, y: f64, r: &Mat1) -> Option<(State, Mat5)> {
    let c = jacobian_h_x();
    let s = (c * p * c.transpose())[(0, 0)] + r[(0, 0)];
    if !(s.is_finite() && s > 0.0) {
        return None;
    }
    let k: State = p * c.transpose() / s;
    let x_new = x + k * (y - h(x));
    let ikc = Mat5::identity() - k * c;
    let p_new = ikc * p * ikc.transpose() + k * r * k.transpose();
    Some((x_new, p_new))
}

// ---------------------------------------------------------------------------------------
// EKF (Alg. 1)
// ---------------------------------------------------------------------------------------

/// Extended Kalman filter of Alg. 1 on the model [`f`], [`h`].
#[derive(Clone, Debug, PartialEq)]
pub struct Ekf {
    /// State estimate.
    pub x: State,
    /// Estimate covariance.
    pub p: Mat5,
    /// Process-noise covariance `Q`.
    pub q: Mat5,
    /// Measurement-noise covariance `R`.
    pub r: Mat1,
}

impl Ekf {
    /// A filter starting from `x0` (taken as `x[-1|-1]`) with covariance `p0`.
    pub fn new(x0: State, p0: Mat5, q: Mat5, r: Mat1) -> Ekf {
        Ekf { x: x0, p: p0, q, r }
    }

    /// Time update with input `u`: `A = df/dx(x, u)`, `P = A P A' + Q`, `x = f(x, u)`.
    /// // Alg. 1 lines 1-3
    ///
    /// A non-finite `u` is rejected and leaves the filter unchanged.
    pub fn predict(&mut self, u: f64) -> StepStatus {
        if !u.is_finite() {
            return StepStatus::Rejected;
        }
        let a = jacobian_f_x(&self.x, u);
        self.p = a * self.p * a.transpose() + self.q;
        self.x = f(&self.x, u);
        StepStatus::Ok
    }

    /// Measurement update with `y`, Joseph form (see [`joseph_update`]). // Alg. 1 lines 4-6
    ///
    /// A non-finite `y` is rejected; a non-positive innovation variance is reported; in both
    /// cases the filter is unchanged.
    pub fn update(&mut self, y: f64) -> StepStatus {
        if !y.is_finite() {
            return StepStatus::Rejected;
        }
        match joseph_update(&self.x, &self.p, y, &self.r) {
            Some((x, p)) => {
                self.x = x;
                self.p = p;
                StepStatus::Ok
            }
            None => StepStatus::NonPositiveInnovation,
        }
    }

    /// One step at sample `k`: `predict(u[k-1])` then `update(y[k])`. All or nothing: if
    /// the status is not [`StepStatus::Ok`] the filter is as before the call.
    pub fn step(&mut self, u_prev: f64, y: f64) -> StepStatus {
        if !(u_prev.is_finite() && y.is_finite()) {
            return StepStatus::Rejected;
        }
        let mut next = self.clone();
        next.predict(u_prev);
        let status = next.update(y);
        if status == StepStatus::Ok {
            *self = next;
        }
        status
    }
}

// ---------------------------------------------------------------------------------------
// LTV window transform (Sect. 2, eqs. 4-12)
// ---------------------------------------------------------------------------------------

/// Number of outputs in a full window: `y[k-4..=k]` (with the inputs `u[k-4..=k-1]`).
pub const WINDOW_OUTPUTS: usize = 5;

/// Default threshold of the excitation measure below which a window is degenerate.
pub const DEFAULT_EXCITATION_THRESHOLD: f64 = 1e-9;

/// How the last window transform was obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WindowStatus {
    /// Fewer than [`WINDOW_OUTPUTS`] outputs so far: `phi1` = latest output (or `x0[0]` if
    /// there is none), `phi2 = x0[1]`, `phi3..phi5` = the last valid parameters.
    Filling,
    /// The full 3x3 system (eq. 8) was solved. // eq. (9)
    Solved,
    /// Case 2: the inputs `u[k-4..=k-2]` are all exactly 0, `phi5` was frozen at its last
    /// valid value and the reduced 2x2 system in `(x3, x4)` was solved. // eq. (10)
    InputFree,
    /// Case 1 (Remark 2.2): the excitation measure of the system that would have been
    /// solved is below the threshold (or its solution is not finite); `phi3..phi5` are the
    /// last valid parameters.
    Degenerate,
}

/// The outcome of the window transform: the states read from the window and the LTV model
/// `x[k+1] = F x[k] + G u[k]` of eq. (12).
#[derive(Clone, Debug, PartialEq)]
pub struct LtvModel {
    /// `[phi1, .., phi5]`: the state at the window's last sample `k` as a function of the
    /// window (`phi1 = y[k]`, `phi2` from eq. (4), `phi3..phi5` from eq. (9) or (10)).
    pub phi: [f64; NX],
    /// Determinant of the system matrix actually solved: the 3x3 matrix with rows
    /// `TS [y[j-2], dy[j-1], u[j-2]]`, `j = k, k-1, k-2` (this equals `TS^2` times the
    /// paper's `Delta_k` of eq. 9), or in case 2 the 2x2 matrix with rows
    /// `TS [y[j-2], dy[j-1]]`, `j = k, k-1`. `NaN` while the window is filling.
    pub delta: f64,
    /// `|delta| / (product of the Euclidean norms of the matrix's columns)`, in `[0, 1]`
    /// (Hadamard's inequality); 0 if a column is zero. `NaN` while the window is filling.
    pub excitation: f64,
    /// How `phi` was obtained.
    pub status: WindowStatus,
    /// `F_k` of eq. (12).
    pub f: Mat5,
    /// `G_k` of eq. (12).
    pub g: State,
}

/// `F` and `G` of eq. (12) from the window's states `phi`, the input `u` applied at the
/// window's last sample and the split weight `eta`: each product `s p` of a physical state
/// (or the input) `s` and a parameter `p` is written `(1 - eta) phi_p s + eta phi_s p`.
pub fn ltv_matrices(phi: &[f64; NX], u: f64, eta: f64) -> (Mat5, State) {
    let mut fm = Mat5::identity();
    fm[(0, 1)] = TS; // eq. (3a), linear
    fm[(1, 0)] = (1.0 - eta) * TS * phi[2]; // TS x1 x3 -> (1-eta) TS phi3 x1 + ..
    fm[(1, 1)] = 1.0 + (1.0 - eta) * TS * phi[3]; // (1 + TS x4) x2 -> x2 + (1-eta) TS phi4 x2 + ..
    fm[(1, 2)] = eta * TS * phi[0]; // .. + eta TS phi1 x3
    fm[(1, 3)] = eta * TS * phi[1]; // .. + eta TS phi2 x4
    fm[(1, 4)] = eta * TS * u; // TS x5 u -> eta TS u x5 + ..
    let g = State::from([0.0, (1.0 - eta) * TS * phi[4], 0.0, 0.0, 0.0]); // .. + (1-eta) TS phi5 u
    (fm, g)
}

/// `|det| / prod(column norms)` of a square matrix whose determinant is `det`: 0 if a
/// column is zero or anything is not finite.
fn excitation_measure<const N: usize>(m: &SMatrix<f64, N, N>, det: f64) -> f64 {
    let norms: f64 = m.column_iter().map(|c| c.norm()).product();
    let e = det.abs() / norms;
    if norms > 0.0 && e.is_finite() {
        e.min(1.0)
    } else {
        0.0
    }
}

/// The sliding window of the last outputs and inputs, and the transform of Sect. 2 that
/// reads the whole state from it (eqs. 4-11) and builds the LTV model (eq. 12).
///
/// Layout: after [`push`](Self::push) of `(u[k-1], y[k])`, `ys[i] = y[k-4+i]` and
/// `us[i] = u[k-4+i]` (`i = 0..4`); the window "ends at `k`".
#[derive(Clone, Debug, PartialEq)]
pub struct WindowTransform {
    ys: [f64; WINDOW_OUTPUTS],
    us: [f64; WINDOW_OUTPUTS - 1],
    len: usize,
    /// Excitation measure below which a window is degenerate (case 1).
    pub threshold: f64,
    last_params: [f64; 3],
    fill_state: [f64; 2],
}

impl WindowTransform {
    /// An empty window for a filter whose initial state is `x0`: `x0[2..5]` are the first
    /// "last valid" parameters and `x0[0]`, `x0[1]` are used while the window fills.
    pub fn new(x0: &State) -> WindowTransform {
        WindowTransform {
            ys: [0.0; WINDOW_OUTPUTS],
            us: [0.0; WINDOW_OUTPUTS - 1],
            len: 0,
            threshold: DEFAULT_EXCITATION_THRESHOLD,
            last_params: [x0[2], x0[3], x0[4]],
            fill_state: [x0[0], x0[1]],
        }
    }

    /// Appends the sample `k`: the input `u[k-1]` and the output `y[k]`.
    pub fn push(&mut self, u_prev: f64, y: f64) {
        self.ys.rotate_left(1);
        self.ys[WINDOW_OUTPUTS - 1] = y;
        self.us.rotate_left(1);
        self.us[WINDOW_OUTPUTS - 2] = u_prev;
        self.len = (self.len + 1).min(WINDOW_OUTPUTS);
    }

    /// Empties the window (after a lost sample); the last valid parameters are kept.
    pub fn reset(&mut self) {
        self.len = 0;
    }

    /// Number of outputs held (at most [`WINDOW_OUTPUTS`]).
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether no output is held.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Whether the window holds [`WINDOW_OUTPUTS`] outputs.
    pub fn is_full(&self) -> bool {
        self.len == WINDOW_OUTPUTS
    }

    /// The last valid `(phi3, phi4, phi5)` (initially the parameters of `x0`).
    pub fn last_params(&self) -> [f64; 3] {
        self.last_params
    }

    /// `dy` at window index `i >= 1`: `(y[j] - y[j-1]) / TS` with `j = k-4+i`. // eq. (4)
    fn dy(&self, i: usize) -> f64 {
        (self.ys[i] - self.ys[i - 1]) / TS
    }

    /// Reads the state from the window and builds `F`, `G` of eq. (12) for the step from
    /// the window's last sample `k` to `k+1`, with `u_now = u[k]` and split weight `eta`.
    /// While the window fills, `phi` is `around` (the AKF's own estimate). Records
    /// `(phi3, phi4, phi5)` as the last valid parameters unless the window is filling or
    /// degenerate.
    pub fn transform(&mut self, u_now: f64, eta: f64, around: &State) -> LtvModel {
        let (mut phi, delta, excitation, status) = self.read_state();
        if status == WindowStatus::Filling {
            phi = [around[0], around[1], around[2], around[3], around[4]];
        }
        match status {
            WindowStatus::Solved | WindowStatus::InputFree => {
                self.last_params = [phi[2], phi[3], phi[4]];
            }
            WindowStatus::Filling | WindowStatus::Degenerate => {}
        }
        let (fm, g) = ltv_matrices(&phi, u_now, eta);
        LtvModel {
            phi,
            delta,
            excitation,
            status,
            f: fm,
            g,
        }
    }

    /// `(phi, delta, excitation, status)` of the current window (no side effect).
    fn read_state(&self) -> ([f64; NX], f64, f64, WindowStatus) {
        let [p3, p4, p5] = self.last_params;
        if !self.is_full() {
            let phi1 = if self.is_empty() {
                self.fill_state[0]
            } else {
                self.ys[WINDOW_OUTPUTS - 1]
            };
            let phi = [phi1, self.fill_state[1], p3, p4, p5];
            return (phi, f64::NAN, f64::NAN, WindowStatus::Filling);
        }
        let (ys, us) = (&self.ys, &self.us);
        // Equations j = k, k-1, k-2 are window indices i = 4, 3, 2:
        // dy[j] - dy[j-1] = TS (y[j-2] x3 + dy[j-1] x4 + u[j-2] x5).   // eqs. (5)-(7)
        let (params, delta, excitation, status) = if us[..3].iter().all(|&u| u == 0.0) {
            // Case 2: x5 frozen, reduced system from j = k, k-1.   // eq. (10)
            let m = Matrix2::from_fn(|r, c| {
                let i = 4 - r;
                TS * if c == 0 { ys[i - 2] } else { self.dy(i - 1) }
            });
            let b = Vector2::from_fn(|r, _| {
                let i = 4 - r;
                self.dy(i) - self.dy(i - 1) - TS * us[i - 2] * p5
            });
            let det = m.determinant();
            let e = excitation_measure(&m, det);
            let sol = if e >= self.threshold {
                m.lu().solve(&b)
            } else {
                None
            };
            match sol.filter(|s| s.iter().all(|v| v.is_finite())) {
                Some(s) => ([s[0], s[1], p5], det, e, WindowStatus::InputFree),
                None => ([p3, p4, p5], det, e, WindowStatus::Degenerate),
            }
        } else {
            // Full system.   // eq. (8)
            let m = Matrix3::from_fn(|r, c| {
                let i = 4 - r;
                TS * match c {
                    0 => ys[i - 2],
                    1 => self.dy(i - 1),
                    _ => us[i - 2],
                }
            });
            let b = Vector3::from_fn(|r, _| {
                let i = 4 - r;
                self.dy(i) - self.dy(i - 1)
            });
            let det = m.determinant();
            let e = excitation_measure(&m, det);
            let sol = if e >= self.threshold {
                m.lu().solve(&b)
            } else {
                None
            };
            match sol.filter(|s| s.iter().all(|v| v.is_finite())) {
                Some(s) => ([s[0], s[1], s[2]], det, e, WindowStatus::Solved), // eq. (9)
                None => ([p3, p4, p5], det, e, WindowStatus::Degenerate),
            }
        };
        let [phi3, phi4, phi5] = params;
        let phi1 = ys[4]; // y[k]
                          // x2[k] = TS y[k-1] phi3 + (1 + TS phi4) dy[k] + TS phi5 u[k-1].   // eq. (4)
        let phi2 = TS * ys[3] * phi3 + (1.0 + TS * phi4) * self.dy(4) + TS * phi5 * us[3];
        ([phi1, phi2, phi3, phi4, phi5], delta, excitation, status)
    }
}

// ---------------------------------------------------------------------------------------
// DKF (Alg. 2)
// ---------------------------------------------------------------------------------------

/// Outcome of a [`Dkf::step`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DkfStatus {
    /// Whether the AKF's update was applied (see [`StepStatus`]).
    pub akf: StepStatus,
    /// Whether the LKF's update was applied; each stage commits on its own.
    pub lkf: StepStatus,
    /// How the window transform used by the step was obtained; `None` if the step was
    /// rejected before the transform.
    pub window: Option<WindowStatus>,
}

/// Double Kalman filter of Alg. 2: the auxiliary KF (AKF) on the LTV model of eq. (12),
/// then the linearised KF (LKF) on the model [`f`] linearised about the AKF estimate.
#[derive(Clone, Debug, PartialEq)]
pub struct Dkf {
    /// AKF estimate `xbar`.
    pub xbar: State,
    /// AKF covariance `Pbar`.
    pub pbar: Mat5,
    /// LKF estimate `x`: the DKF's output.
    pub x: State,
    /// LKF covariance `P`.
    pub p: Mat5,
    /// LKF process-noise covariance `Q` (the model's).
    pub q: Mat5,
    /// AKF process-noise covariance `Qbar` (of the transformed model, eq. 14a).
    pub qbar: Mat5,
    /// Measurement-noise covariance `R` (shared by both stages).
    pub r: Mat1,
    /// Split weight `eta` of eq. (12) (0.5 in the paper).
    pub eta: f64,
    /// The window of past samples and its transform.
    pub window: WindowTransform,
    /// The window transform used by the last applied (or innovation-failed) step.
    pub last: Option<LtvModel>,
    /// The LKF's last innovation `y - h(x_pred)` and its variance `C P_pred C' + R`.
    pub innovation: (f64, f64),
    /// The AKF's.
    pub akf_innovation: (f64, f64),
}

/// The innovation of `y` at the prediction `x`, `p` and its variance `C P C' + R`.
fn innovation(x: &State, p: &Mat5, y: f64, r: &Mat1) -> (f64, f64) {
    let c = jacobian_h_x();
    (y - h(x), (c * p * c.transpose())[(0, 0)] + r[(0, 0)])
}

impl Dkf {
    /// A DKF whose two stages start at `x0` (taken as `x[-1|-1]`) with covariance `p0`
    /// (Alg. 2 initialisation); the window is empty.
    pub fn new(x0: State, p0: Mat5, q: Mat5, qbar: Mat5, r: Mat1, eta: f64) -> Dkf {
        Dkf {
            xbar: x0,
            pbar: p0,
            x: x0,
            p: p0,
            q,
            qbar,
            r,
            eta,
            window: WindowTransform::new(&x0),
            last: None,
            innovation: (0.0, 1.0),
            akf_innovation: (0.0, 1.0),
        }
    }

    /// One step at sample `k` with `u_prev = u[k-1]` and `y = y[k]`:
    ///
    /// 1. `F`, `G` from the window ending at `k-1` and `u[k-1]` (eq. 12);
    /// 2. AKF: `xbar = F xbar + G u`, `Pbar = F Pbar F' + Qbar`, Joseph update with `y`;
    /// 3. LKF: `A = df/dx(xbar_prev, u)` (actual input, not 0),
    ///    `x = f(xbar_prev, u) + A (x - xbar_prev)`, `P = A P A' + Q`, Joseph update;
    /// 4. push `(u[k-1], y[k])` into the window.
    ///
    /// A non-finite `u_prev` or `y` is rejected: estimates and covariances are unchanged and
    /// the window is emptied (its samples would no longer be consecutive). A stage whose
    /// innovation variance is not positive keeps its estimate and covariance (the other
    /// stage commits on its own); the window still records the (valid) sample and its
    /// transform's last valid parameters.
    pub fn step(&mut self, u_prev: f64, y: f64) -> DkfStatus {
        if !(u_prev.is_finite() && y.is_finite()) {
            self.window.reset();
            return DkfStatus {
                akf: StepStatus::Rejected,
                lkf: StepStatus::Rejected,
                window: None,
            };
        }
        // (a) transform of the step k-1 -> k.   // eq. (12)
        let model = self.window.transform(u_prev, self.eta, &self.xbar);
        let window = Some(model.status);

        // (b) AKF.   // eq. (14), Alg. 2 lines 1-6
        let xbar_prev = self.xbar;
        let xbar_pred = model.f * self.xbar + model.g * u_prev;
        let pbar_pred = model.f * self.pbar * model.f.transpose() + self.qbar;
        let akf = joseph_update(&xbar_pred, &pbar_pred, y, &self.r);
        self.akf_innovation = innovation(&xbar_pred, &pbar_pred, y, &self.r);

        // (c) LKF about the AKF estimate at k-1.   // eqs. (18a), (18b), (17a)-(17c)
        let a = jacobian_f_x(&xbar_prev, u_prev);
        let x_pred = f(&xbar_prev, u_prev) + a * (self.x - xbar_prev);
        let p_pred = a * self.p * a.transpose() + self.q;
        let lkf = joseph_update(&x_pred, &p_pred, y, &self.r);
        self.innovation = innovation(&x_pred, &p_pred, y, &self.r);

        // (d) the window records the sample whatever the outcome.
        self.window.push(u_prev, y);
        self.last = Some(model);

        // Each stage is a filter of its own: it commits, or stays as it was.
        let status = |update: &Option<(State, Mat5)>| {
            if update.is_some() {
                StepStatus::Ok
            } else {
                StepStatus::NonPositiveInnovation
            }
        };
        let statuses = DkfStatus {
            akf: status(&akf),
            lkf: status(&lkf),
            window,
        };
        if let Some((xbar, pbar)) = akf {
            self.xbar = xbar;
            self.pbar = pbar;
        }
        if let Some((x, p)) = lkf {
            self.x = x;
            self.p = p;
        }
        statuses
    }
}

// ---------------------------------------------------------------------------------------
// Adaptive finite-horizon LQR (Alg. 3, eq. 19)
// ---------------------------------------------------------------------------------------

/// The physical sub-model of eq. (19) at the estimate `x_est`:
/// `A = [[1, TS], [TS x3, 1 + TS x4]]`, `B = [0, TS x5]'`.
pub fn lqr_model(x_est: &[f64; NX]) -> (Matrix2<f64>, Vector2<f64>) {
    let a = Matrix2::new(1.0, TS, TS * x_est[2], 1.0 + TS * x_est[3]); // eq. (19a)
    let b = Vector2::new(0.0, TS * x_est[4]);
    (a, b)
}

/// Finite-horizon LQR gain of Alg. 3 for the model of eq. (19) at `x_est`:
/// `P = Q`; `n` times { `P = A'PA - A'PB (R + B'PB)^-1 B'PA + Q` }; then
/// `K = (R + B'PB)^-1 B'PA` from the final `P`, as Alg. 3 lists it.
///
/// `None` if `n == 0` or if `R + B'PB` is not a positive finite number at some step.
pub fn lqr_gain(x_est: &[f64; NX], n: usize, q: SMatrix<f64, 2, 2>, r: f64) -> Option<Gain> {
    if n == 0 {
        return None;
    }
    let (a, b) = lqr_model(x_est);
    let gain_of = |p: &SMatrix<f64, 2, 2>| -> Option<RowVector2<f64>> {
        let s = r + (b.transpose() * p * b)[(0, 0)];
        (s.is_finite() && s > 0.0).then(|| b.transpose() * p * a / s)
    };
    let mut p = q;
    for _ in 0..n {
        let k = gain_of(&p)?;
        p = a.transpose() * p * a - a.transpose() * p * b * k + q; // eq. (19)
    }
    gain_of(&p)
}

/// Control `u = -K [x1, x2]'` saturated to `[-u_max, u_max]` (`u_max >= 0`). A `NaN`
/// control stays `NaN`.
pub fn lqr_control(k: &Gain, x_est: &[f64; NX], u_max: f64) -> f64 {
    let u = -(k[(0, 0)] * x_est[0] + k[(0, 1)] * x_est[1]);
    if u > u_max {
        u_max
    } else if u < -u_max {
        -u_max
    } else {
        u
    }
}

// ---------------------------------------------------------------------------------------
// Euler-equivalent parameters and their physical read-out
// ---------------------------------------------------------------------------------------

/// Parameters `[x3, x4, x5]` of the Euler model whose discrete poles are the exactly
/// sampled poles `exp(s TS)` of the continuous mode `s^2 + 2 zeta wn s + wn^2` and whose DC
/// gain (`-x5 / x3`) equals the continuous one (`alpha / wn^2`).
///
/// The Euler model's characteristic polynomial is
/// `z^2 - (2 + TS x4) z + (1 + TS x4 - TS^2 x3)`, so with the poles' sum `sigma` and
/// product `pi`: `x4 = (sigma - 2) / TS`, `x3 = (1 + TS x4 - pi) / TS^2`.
pub fn euler_equivalent(wn: f64, zeta: f64, alpha: f64) -> [f64; 3] {
    // Sum and product of exp(s1 TS), exp(s2 TS), valid for under- and over-damping.
    let (sum, product) = if zeta < 1.0 {
        let wd = wn * (1.0 - zeta * zeta).sqrt();
        let m = (-zeta * wn * TS).exp();
        (2.0 * m * (wd * TS).cos(), m * m)
    } else {
        let root = wn * (zeta * zeta - 1.0).sqrt();
        let z1 = ((-zeta * wn + root) * TS).exp();
        let z2 = ((-zeta * wn - root) * TS).exp();
        (z1 + z2, z1 * z2)
    };
    let x4 = (sum - 2.0) / TS;
    let x3 = (1.0 + TS * x4 - product) / (TS * TS);
    let x5 = -x3 * alpha / (wn * wn);
    [x3, x4, x5]
}

/// `(wn, zeta)` of the continuous mode whose exactly sampled poles are the Euler model's
/// discrete poles at `(x3, x4)`: `s = ln z / TS`, `wn^2 = s1 s2`, `2 zeta wn = -(s1 + s2)`
/// (for complex poles `wn = |s|`, `zeta = -Re s / |s|`).
///
/// Returns `(NaN, NaN)` when a pole is real and not positive, or when `s1 s2 <= 0`.
pub fn poles_readout(x3: f64, x4: f64) -> (f64, f64) {
    let trace = 2.0 + TS * x4;
    let det = 1.0 + TS * x4 - TS * TS * x3;
    let disc = trace * trace - 4.0 * det;
    let (s_sum, s_product) = if disc < 0.0 {
        // z = re ± i im, s = (ln |z| ± i arg z) / TS.
        let re = trace / 2.0;
        let im = (-disc).sqrt() / 2.0;
        let sr = re.hypot(im).ln() / TS;
        let si = im.atan2(re) / TS;
        (2.0 * sr, sr * sr + si * si)
    } else {
        let z1 = (trace + disc.sqrt()) / 2.0;
        let z2 = (trace - disc.sqrt()) / 2.0;
        if z1 <= 0.0 || z2 <= 0.0 {
            return (f64::NAN, f64::NAN);
        }
        let (s1, s2) = (z1.ln() / TS, z2.ln() / TS);
        (s1 + s2, s1 * s2)
    };
    if s_product.is_nan() || s_product <= 0.0 {
        return (f64::NAN, f64::NAN);
    }
    let wn = s_product.sqrt();
    (wn, -s_sum / (2.0 * wn))
}

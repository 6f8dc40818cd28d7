//! Independent `f64` references of the continuous filters, written densely with nalgebra:
//! the hybrid (continuous-discrete) EKF of the blade paper (eq. 21 between samples, the Joseph
//! update of eqs. 24-26 at the sample) and the continuous-time EKF of Kulkarni and Purwar's helicopter paper (eq. 5, with
//! the prescribed degree of stability of eq. 26). `P` is a full matrix, the gain uses a
//! matrix inverse, and each model's `dx/dt` and Jacobian are written out by hand by the
//! test that uses it (nothing comes from the code generator but the model constants).
//!
//! Both integrate state and covariance together over one sample with the model's rule
//! and number of sub-steps, the time running from the previous sample in steps of
//! `dt / substeps`: classical RK4 on `P' = A P + P A' + S`, or for forward Euler the
//! covariance of the Euler step, `(I + h A) P (I + h A)' + h S`. The continuous-time EKF
//! integrates its whole equations so while they are not stiff, else splits off its
//! measurement terms' exact flow, as the generated filter does; the equations it
//! approximates are solved to a tight tolerance by [`ContinuousEkfEquation`].

use nalgebra::{SMatrix, SVector};

/// An explicit integration rule.
#[derive(Clone, Copy, Debug)]
pub enum Rule {
    /// Forward Euler.
    Euler,
    /// Classical fourth-order Runge-Kutta.
    Rk4,
}

/// A continuous model: `dx/dt = f(t, x, u)`, `df/dx`, `y = h(t, x)`, `dh/dx`.
#[derive(Clone, Copy)]
pub struct Model<const N: usize, const M: usize, const U: usize> {
    /// `dx/dt`.
    pub rate: fn(f64, &SVector<f64, N>, &[f64; U]) -> SVector<f64, N>,
    /// `df/dx`.
    pub jacobian: fn(f64, &SVector<f64, N>, &[f64; U]) -> SMatrix<f64, N, N>,
    /// `h`.
    pub h: fn(f64, &SVector<f64, N>) -> SVector<f64, M>,
    /// `dh/dx`.
    pub jacobian_h: fn(f64, &SVector<f64, N>) -> SMatrix<f64, M, N>,
    /// Integration rule.
    pub rule: Rule,
    /// Sample period.
    pub dt: f64,
    /// Sub-steps per sample.
    pub substeps: u32,
}

/// The state and covariance of a filter.
pub type Estimate<const N: usize> = (SVector<f64, N>, SMatrix<f64, N, N>);

/// The joint rate at `(t, x, P)`: `dx/dt`, and `A`, `S` of `dP/dt = A P + P A' + S`.
type JointRate<'a, const N: usize> =
    &'a dyn Fn(
        f64,
        &SVector<f64, N>,
        &SMatrix<f64, N, N>,
    ) -> (SVector<f64, N>, SMatrix<f64, N, N>, SMatrix<f64, N, N>);

/// One sub-step of length `h` from `t`. RK4 integrates `dP/dt = A P + P A' + S`; forward
/// Euler takes the covariance of the Euler step, `(I + h A) P (I + h A)' + h S`.
fn substep<const N: usize>(
    rule: Rule,
    h: f64,
    t: f64,
    (x, p): Estimate<N>,
    rate: JointRate<'_, N>,
) -> Estimate<N> {
    let derivative = |t: f64, x: &SVector<f64, N>, p: &SMatrix<f64, N, N>| {
        let (dx, a, s) = rate(t, x, p);
        (dx, a * p + p * a.transpose() + s)
    };
    match rule {
        Rule::Euler => {
            let (dx, a, s) = rate(t, &x, &p);
            let phi = SMatrix::<f64, N, N>::identity() + a * h;
            (x + dx * h, phi * p * phi.transpose() + s * h)
        }
        Rule::Rk4 => {
            let (k1x, k1p) = derivative(t, &x, &p);
            let (k2x, k2p) =
                derivative(t + 0.5 * h, &(x + k1x * (0.5 * h)), &(p + k1p * (0.5 * h)));
            let (k3x, k3p) =
                derivative(t + 0.5 * h, &(x + k2x * (0.5 * h)), &(p + k2p * (0.5 * h)));
            let (k4x, k4p) = derivative(t + h, &(x + k3x * h), &(p + k3p * h));
            (
                x + (k1x + k4x + (k2x + k3x) * 2.0) * (h / 6.0),
                p + (k1p + k4p + (k2p + k3p) * 2.0) * (h / 6.0),
            )
        }
    }
}

/// Integrates over one sample from `t_prev`.
fn integrate<const N: usize>(
    rule: Rule,
    dt: f64,
    substeps: u32,
    t_prev: f64,
    estimate: Estimate<N>,
    rate: JointRate<'_, N>,
) -> Estimate<N> {
    let h = dt / f64::from(substeps);
    let mut t = t_prev;
    let mut estimate = estimate;
    for _ in 0..substeps {
        estimate = substep(rule, h, t, estimate, rate);
        t += h;
    }
    estimate
}

/// The hybrid EKF (the blade paper): `Q` is a spectral density.
pub struct HybridEkf<'m, const N: usize, const M: usize, const U: usize> {
    /// The model.
    pub model: &'m Model<N, M, U>,
    /// Estimate and covariance.
    pub estimate: Estimate<N>,
    /// Process noise spectral density.
    pub q: SMatrix<f64, N, N>,
    /// Measurement noise covariance.
    pub r: SMatrix<f64, M, M>,
}

impl<const N: usize, const M: usize, const U: usize> HybridEkf<'_, N, M, U> {
    /// eq. (21) over one sample from `t_prev` with `u` held.
    pub fn predict(&mut self, t_prev: f64, u: &[f64; U]) {
        let (model, q) = (self.model, self.q);
        let rate = |t: f64, x: &SVector<f64, N>, _: &SMatrix<f64, N, N>| {
            ((model.rate)(t, x, u), (model.jacobian)(t, x, u), q)
        };
        self.estimate = integrate(
            model.rule,
            model.dt,
            model.substeps,
            t_prev,
            self.estimate,
            &rate,
        );
    }

    /// eqs. (24)-(26), Joseph form, with a matrix inverse. Returns the innovation and
    /// its covariance.
    pub fn update(&mut self, t: f64, y: &SVector<f64, M>) -> Innovation<M> {
        let (x, p) = self.estimate;
        let c = (self.model.jacobian_h)(t, &x);
        let s = c * p * c.transpose() + self.r;
        let gain = p * c.transpose() * s.try_inverse().expect("S invertible");
        let innovation = y - (self.model.h)(t, &x);
        let x = x + gain * innovation;
        let i_kc = SMatrix::<f64, N, N>::identity() - gain * c;
        let p = i_kc * p * i_kc.transpose() + gain * self.r * gain.transpose();
        self.estimate = (x, p);
        (innovation, s)
    }
}

/// A measurement's innovation `y - h(x)` and its covariance `S`.
pub type Innovation<const M: usize> = (SVector<f64, M>, SMatrix<f64, M, M>);

/// The continuous-time EKF (Kulkarni and Purwar's helicopter paper, eq. 5) with a prescribed degree of stability `alpha`
/// (eq. 26; `alpha = 0` is the standard filter), integrated as the generated filter does
/// (see [`ContinuousEkf::step`]): the whole equations by RK4 while they are not stiff, else
/// split symmetrically, the measurement terms' exact flow (the Joseph-form update with
/// `2 R / T`) over half the sample on either side of the propagation without them (the
/// model's rule and sub-steps, as the hybrid EKF). `Q` and `R` are spectral densities.
pub struct ContinuousEkf<'m, const N: usize, const M: usize, const U: usize> {
    /// The model.
    pub model: &'m Model<N, M, U>,
    /// Estimate and covariance.
    pub estimate: Estimate<N>,
    /// Process noise spectral density.
    pub q: SMatrix<f64, N, N>,
    /// Measurement noise spectral density.
    pub r: SMatrix<f64, M, M>,
    /// Prescribed degree of stability.
    pub alpha: f64,
}

/// The largest `T tr(R^-1 H P H')` at which the continuous-time EKF integrates its whole
/// equations by RK4, as the generated filter does.
pub const WHOLE_STEP_STIFFNESS: f64 = 0.1;

impl<const N: usize, const M: usize, const U: usize> ContinuousEkf<'_, N, M, U> {
    /// One sample from `t_prev` with `u` and `y` held, as the generated filter integrates
    /// it: for a model of one RK4 sub-step, the whole equations by RK4 while `R` is
    /// invertible and `T tr(R^-1 H P H')` at the start is within [`WHOLE_STEP_STIFFNESS`];
    /// else split ([`ContinuousEkf::split_step`]). Returns the innovation at the start of
    /// the sample, `y - h(t_prev, x)`, and its covariance `H P H' + R / T`.
    pub fn step(&mut self, t_prev: f64, u: &[f64; U], y: &SVector<f64, M>) -> Innovation<M> {
        let (model, (x, p)) = (self.model, self.estimate);
        let c = (model.jacobian_h)(t_prev, &x);
        let innovation = (
            y - (model.h)(t_prev, &x),
            c * p * c.transpose() + self.r / model.dt,
        );
        let one_rk4_step = matches!(model.rule, Rule::Rk4) && model.substeps == 1;
        let r_inv = self.r.try_inverse().filter(|_| self.r.cholesky().is_some());
        match r_inv {
            Some(r_inv)
                if one_rk4_step
                    && model.dt * (r_inv * c * p * c.transpose()).trace()
                        <= WHOLE_STEP_STIFFNESS =>
            {
                self.whole_step(t_prev, u, y, &r_inv);
            }
            _ => self.split_step(t_prev, u, y, if one_rk4_step { 2 } else { 1 }),
        }
        innovation
    }

    /// The whole equations (Kulkarni and Purwar's helicopter paper, eq. 5, with `alpha` eq. 26) over one sample by one
    /// classical RK4 step: `x' = f + K (y - h)`, `P' = A P + P A' + Q - K H P`,
    /// `K = P H' R^-1`, `A = F + alpha I`.
    pub fn whole_step(
        &mut self,
        t_prev: f64,
        u: &[f64; U],
        y: &SVector<f64, M>,
        r_inv: &SMatrix<f64, M, M>,
    ) {
        let model = self.model;
        let (q, alpha) = (self.q, self.alpha);
        // `A P + P A' - K H P` is `A~ P + P A~'` with `A~ = A - K H / 2`.
        let rate = |t: f64, x: &SVector<f64, N>, p: &SMatrix<f64, N, N>| {
            let c = (model.jacobian_h)(t, x);
            let gain = p * c.transpose() * r_inv;
            let a = (model.jacobian)(t, x, u) + SMatrix::<f64, N, N>::identity() * alpha
                - gain * c * 0.5;
            ((model.rate)(t, x, u) + gain * (y - (model.h)(t, x)), a, q)
        };
        self.estimate = integrate(Rule::Rk4, model.dt, 1, t_prev, self.estimate, &rate);
    }

    /// One sample split symmetrically (Strang) in `parts` sub-steps of `h = T / parts`, each
    /// the measurement terms' exact flow over `h / 2` at its start, the propagation over `h`
    /// (one sub-step of the model's rule; with one part, the model's sub-steps), their flow
    /// over `h / 2` at its end; the flows of neighbouring sub-steps are one, over `h`.
    pub fn split_step(&mut self, t_prev: f64, u: &[f64; U], y: &SVector<f64, M>, parts: u32) {
        let h = self.model.dt / f64::from(parts);
        self.measure(t_prev, y, 0.5 * h);
        for part in 1..=parts {
            let t = t_prev + f64::from(part - 1) * h;
            if parts == 1 {
                self.propagate(t, u);
            } else {
                self.propagate_over(t, u, h);
            }
            let flow = if part < parts { h } else { 0.5 * h };
            self.measure(t + h, y, flow);
        }
    }

    /// The equations without the measurement terms over one sample from `t_prev` with `u`
    /// held (the model's rule and sub-steps, as the hybrid EKF).
    pub fn propagate(&mut self, t_prev: f64, u: &[f64; U]) {
        let (dt, substeps) = (self.model.dt, self.model.substeps);
        self.propagate_in(t_prev, u, (dt, substeps));
    }

    /// The equations without the measurement terms over `h` from `t` with `u` held, by one
    /// step of the model's rule.
    pub fn propagate_over(&mut self, t: f64, u: &[f64; U], h: f64) {
        self.propagate_in(t, u, (h, 1));
    }

    /// The equations without the measurement terms over `duration` from `t_prev` with `u`
    /// held, in `substeps` steps of the model's rule.
    fn propagate_in(&mut self, t_prev: f64, u: &[f64; U], (duration, substeps): (f64, u32)) {
        let model = self.model;
        let (q, alpha) = (self.q, self.alpha);
        let rate = |t: f64, x: &SVector<f64, N>, _: &SMatrix<f64, N, N>| {
            let a = (model.jacobian)(t, x, u) + SMatrix::<f64, N, N>::identity() * alpha;
            ((model.rate)(t, x, u), a, q)
        };
        self.estimate = integrate(model.rule, duration, substeps, t_prev, self.estimate, &rate);
    }

    /// The measurement terms' exact flow over `duration` at time `t` (`H` held): the
    /// Joseph-form update with the noise `R / duration`. Returns its innovation and
    /// covariance.
    pub fn measure(&mut self, t: f64, y: &SVector<f64, M>, duration: f64) -> Innovation<M> {
        let mut update = HybridEkf {
            model: self.model,
            estimate: self.estimate,
            q: self.q,
            r: self.r / duration,
        };
        let innovation = update.update(t, y);
        self.estimate = update.estimate;
        innovation
    }
}

/// The continuous-time EKF's equations themselves (Kulkarni and Purwar's helicopter paper, eq. 5, with `alpha` eq. 26),
/// `x' = f + K (y - h)`, `P' = A P + P A' + Q - K R K'`, `K = P H' R^-1`, `A = F + alpha I`,
/// over each sample with `u` and `y` held, solved to a tight tolerance by the adaptive
/// eighth-order Dormand-Prince method of the `ode_solvers` crate: what the split
/// integration of [`ContinuousEkf`] approximates.
pub struct ContinuousEkfEquation<'m, const N: usize, const M: usize, const U: usize> {
    /// The filter's model (its rule and sub-steps are not used), estimate and tuning.
    pub filter: ContinuousEkf<'m, N, M, U>,
    /// Relative and absolute tolerance of each step.
    pub tolerance: f64,
}

/// The equations over one sample, as `ode_solvers` asks: `[x, P by rows]`.
struct OverSample<'a, const N: usize, const M: usize, const U: usize> {
    filter: &'a ContinuousEkf<'a, N, M, U>,
    t_prev: f64,
    u: [f64; U],
    y: SVector<f64, M>,
    r_inv: SMatrix<f64, M, M>,
}

impl<const N: usize, const M: usize, const U: usize>
    ode_solvers::System<f64, ode_solvers::DVector<f64>> for OverSample<'_, N, M, U>
{
    fn system(&self, tau: f64, z: &ode_solvers::DVector<f64>, dz: &mut ode_solvers::DVector<f64>) {
        let model = self.filter.model;
        let t = self.t_prev + tau;
        let x = SVector::<f64, N>::from_fn(|i, _| z[i]);
        let p = SMatrix::<f64, N, N>::from_fn(|i, j| z[N + N * i + j]);
        let a =
            (model.jacobian)(t, &x, &self.u) + SMatrix::<f64, N, N>::identity() * self.filter.alpha;
        let c = (model.jacobian_h)(t, &x);
        let gain = p * c.transpose() * self.r_inv;
        let dx = (model.rate)(t, &x, &self.u) + gain * (self.y - (model.h)(t, &x));
        let dp = a * p + p * a.transpose() + self.filter.q - gain * c * p;
        for i in 0..N {
            dz[i] = dx[i];
            for j in 0..N {
                // Symmetric by construction; averaged so rounding does not make it drift.
                dz[N + N * i + j] = 0.5 * (dp[(i, j)] + dp[(j, i)]);
            }
        }
    }
}

impl<const N: usize, const M: usize, const U: usize> ContinuousEkfEquation<'_, N, M, U> {
    /// One sample from `t_prev` with `u` and `y` held; the solver's error if it fails.
    pub fn step(&mut self, t_prev: f64, u: &[f64; U], y: &SVector<f64, M>) -> Result<(), String> {
        let (x, p) = self.filter.estimate;
        let z = ode_solvers::DVector::from_iterator(
            N + N * N,
            x.iter()
                .copied()
                .chain((0..N * N).map(|k| p[(k / N, k % N)])),
        );
        let system = OverSample {
            filter: &self.filter,
            t_prev,
            u: *u,
            y: *y,
            r_inv: self.filter.r.try_inverse().ok_or("R is singular")?,
        };
        let dt = self.filter.model.dt;
        // Local time from 0: the solver's last step, to the end, is then not shortened
        // to a rounding error of `t_prev`.
        let mut solver = ode_solvers::Dop853::from_param(
            system,
            0.0,
            dt,
            dt,
            z,
            self.tolerance,
            self.tolerance,
            0.9,
            0.0,
            0.333,
            6.0,
            dt,
            1e-12,
            10_000_000,
            // No stiffness test: the tolerance bounds the steps, however small.
            u32::MAX,
            ode_solvers::dop_shared::OutputType::Sparse,
        );
        solver.integrate().map_err(|e| format!("{e:?}"))?;
        let end = solver.y_out().last().ok_or("no output")?;
        let x = SVector::<f64, N>::from_fn(|i, _| end[i]);
        let p = SMatrix::<f64, N, N>::from_fn(|i, j| end[N + N * i + j]);
        self.filter.estimate = (x, p);
        Ok(())
    }
}

/// A diagonal matrix.
pub fn diagonal<const N: usize>(d: [f64; N]) -> SMatrix<f64, N, N> {
    SMatrix::from_diagonal(&SVector::from(d))
}

/// The largest entry-wise difference of `generated` from `reference`, relative to the
/// larger of the entry and `scale`.
pub fn relative_difference(generated: &[f64], reference: &[f64], scale: f64) -> f64 {
    generated
        .iter()
        .zip(reference)
        .map(|(&g, &r)| (g - r).abs() / g.abs().max(r.abs()).max(scale).max(f64::MIN_POSITIVE))
        .fold(0.0, f64::max)
}

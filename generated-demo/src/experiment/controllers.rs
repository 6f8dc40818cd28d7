//! The four controllers of Takács et al.'s comparison (sect. 4) behind one interface: the
//! adaptive EKF-MPC (the generated `Mpc` at the median-filtered mass estimate), the
//! nominal LQ clipped at the actuator's limits, positive position feedback, open loop.
//! Each sees, once a sample, the control filter's estimate and the measured position.

use super::blade_plant::{median_of_last, M};
use super::ppf::{Ppf, PpfTuning};
use generated_demo::mass_spring_damper::in_f64::{Mpc, MpcStatus, TS};
use generated_demo::mass_spring_damper::Status;

/// The actuator's limits \[V\] (sect. 4.1: +-100 V).
pub const U_MAX: f64 = 100.0;
/// The weights shared by MPC, LQ and (as `delta`) PPF: `Q = C'C`, `R = 1e-10` (sect. 4.1).
pub const Q: [[f64; 2]; 2] = [[1.0, 0.0], [0.0, 0.0]];
pub const R: [[f64; 1]; 1] = [[1e-10]];
/// The running median's width on the weight estimate (sect. 4.1: 50 samples).
pub const MEDIAN_WIDTH: usize = 50;

/// Which controller a run uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Adaptive EKF-MPC.
    Mpc,
    /// Nominal LQ, saturated.
    Lq,
    /// Positive position feedback, saturated.
    Ppf,
    /// No control.
    OpenLoop,
}

impl Kind {
    /// All four, in the paper's order.
    pub const ALL: [Kind; 4] = [Kind::Mpc, Kind::Lq, Kind::Ppf, Kind::OpenLoop];

    /// Whether the controller acts on the control filter's estimate (PPF acts on the
    /// measurement).
    pub fn uses_estimate(self) -> bool {
        matches!(self, Kind::Mpc | Kind::Lq)
    }

    /// The label in tables and plots.
    pub fn label(self) -> &'static str {
        match self {
            Kind::Mpc => "EKF-MPC",
            Kind::Lq => "LQ",
            Kind::Ppf => "PPF",
            Kind::OpenLoop => "open loop",
        }
    }
}

/// What the MPC's solves reported over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MpcStats {
    /// Solves attempted.
    pub solves: u64,
    /// Solves whose status was not `Ok` (the controller then kept its last plan).
    pub failures: u64,
    /// The most active-set iterations of one solve.
    pub worst_iterations: usize,
    /// Active-set iterations summed over the successful solves.
    pub total_iterations: usize,
    /// Successful solves that reached the QP's optimum within the iteration bound.
    pub optimal: u64,
    /// Successful solves whose terminal weight had converged.
    pub converged: u64,
}

impl MpcStats {
    fn record(&mut self, status: &MpcStatus) {
        self.solves += 1;
        if status.status != Status::Ok {
            self.failures += 1;
            return;
        }
        self.worst_iterations = self.worst_iterations.max(status.iterations);
        self.total_iterations += status.iterations;
        self.optimal += u64::from(status.optimal);
        self.converged += u64::from(status.terminal_weight_converged);
    }

    /// Mean iterations per successful solve.
    pub fn mean_iterations(&self) -> f64 {
        self.total_iterations as f64 / (self.solves - self.failures).max(1) as f64
    }

    /// `count` as a fraction of the successful solves.
    pub fn fraction(&self, count: u64) -> f64 {
        count as f64 / (self.solves - self.failures).max(1) as f64
    }
}

/// The adaptive EKF-MPC: the filter's inverse mass replaced by the inverse of the running
/// median of its mass estimates (sect. 3.3 step 5) before each solve.
pub struct AdaptiveMpc {
    mpc: Mpc,
    masses: Vec<f64>,
    /// The solves' statistics so far.
    pub stats: MpcStats,
}

impl AdaptiveMpc {
    /// The MPC of sect. 4.1: `n = 10`, `Q = C'C`, `R = 1e-10`, +-100 V.
    pub fn new() -> Result<Self, Status> {
        Ok(Self {
            mpc: Mpc::new(&Q, &R, &[-U_MAX], &[U_MAX])?,
            masses: Vec::new(),
            stats: MpcStats::default(),
        })
    }

    /// The first move of the plan for the filter's estimate `x` (`u_prev` the input the
    /// model is linearised at); the last plan's move if the solve fails.
    pub fn input(&mut self, x: &[f64; 5], u_prev: f64) -> f64 {
        self.masses.push(1.0 / x[4]);
        let m = median_of_last(&self.masses, MEDIAN_WIDTH);
        let estimate = [x[0], x[1], x[2], x[3], 1.0 / m];
        let status = self.mpc.solve(&estimate, &[u_prev]);
        self.stats.record(&status);
        self.mpc.control()[0]
    }

    /// The median-filtered mass the last solve used \[kg\].
    pub fn mass(&self) -> f64 {
        median_of_last(&self.masses, MEDIAN_WIDTH)
    }
}

/// The nominal LQ gain (`u = -K x`): the generated MPC's terminal gain, the
/// infinite-horizon LQR of the model held over a sample, converged at the nominal mass
/// `m = 0.20 kg` with the MPC's weights (sect. 4.1).
pub fn nominal_lq_gain() -> Result<[f64; 2], String> {
    let mut mpc = Mpc::new(&Q, &R, &[-U_MAX], &[U_MAX]).map_err(|s| format!("{s:?}"))?;
    let nominal = [0.0, 0.0, 0.0, 0.0, 1.0 / M];
    for _ in 0..1000 {
        let status = mpc.solve(&nominal, &[0.0]);
        if status.status != Status::Ok {
            return Err(format!("the nominal solve failed: {:?}", status.status));
        }
        if status.terminal_weight_converged {
            return Ok(mpc.terminal_gain()[0]);
        }
    }
    Err("the nominal terminal weight did not converge in 1000 solves".to_owned())
}

/// A controller running in one of the four runs.
pub enum Controller {
    /// Adaptive EKF-MPC.
    Mpc(Box<AdaptiveMpc>),
    /// Nominal LQ gain `K`, `u = -K x` clipped.
    Lq([f64; 2]),
    /// PPF on the measurement, clipped.
    Ppf(Ppf),
    /// No input.
    OpenLoop,
}

impl Controller {
    /// The controller of `kind`; `lq_gain` and `ppf` are designed once for all runs.
    pub fn new(kind: Kind, lq_gain: [f64; 2], ppf: PpfTuning) -> Result<Self, Status> {
        Ok(match kind {
            Kind::Mpc => Controller::Mpc(Box::new(AdaptiveMpc::new()?)),
            Kind::Lq => Controller::Lq(lq_gain),
            Kind::Ppf => Controller::Ppf(Ppf::new(ppf)),
            Kind::OpenLoop => Controller::OpenLoop,
        })
    }

    /// The input for this sample from the filter's estimate `x` and the measurement `y`.
    pub fn input(&mut self, x: &[f64; 5], y: f64, u_prev: f64) -> f64 {
        match self {
            Controller::Mpc(mpc) => mpc.input(x, u_prev),
            Controller::Lq(k) => (-(k[0] * x[0] + k[1] * x[1])).clamp(-U_MAX, U_MAX),
            Controller::Ppf(ppf) => ppf.input(y, TS).clamp(-U_MAX, U_MAX),
            Controller::OpenLoop => 0.0,
        }
    }
}

//! The MPC's options, as checked.

use proc_macro2::Span;

/// How the MPC obtains its discrete prediction model at the estimate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MpcDiscretisation {
    /// The Jacobians of the model's own sample step `f` (discrete dynamics, or continuous
    /// dynamics with their integration rule unrolled).
    SampleStep,
    /// The exact zero-order hold of the continuous dynamics linearised at the estimate.
    ZeroOrderHold,
}

/// How the MPC solves its box-constrained QP.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MpcSolver {
    /// A primal active set: Newton steps on the free moves from the last plan, shifted
    /// (the default for few moves, where refactorising them is cheap).
    PrimalActiveSet,
    /// A dual active set on the Hessian's inverse, kept with it: from the unconstrained
    /// minimiser, holding the most violated bound at a time.
    DualActiveSet,
}

/// The MPC's limits besides the inputs' bounds, each hard or soft.
#[derive(Clone, Debug, Default)]
pub struct MpcLimits {
    /// Inputs whose change between moves is limited (`rate_limits`): positions in
    /// [`MpcSpec::inputs`].
    pub rates: Vec<usize>,
    /// Regulated states limited (`state_limits`): positions in [`MpcSpec::states`].
    pub states: Vec<usize>,
    /// Outputs limited (`output_limits`): indices into the model's outputs, with where
    /// each was named.
    pub outputs: Vec<(usize, Span)>,
    /// Per limited quantity, rates, then states, then outputs: whether it is soft
    /// (`soft_limits`).
    pub soft: Vec<bool>,
    /// Per limited output: its row `C` over the regulated states (`y = C x`), set by the
    /// design, which checks that the output is linear in them.
    pub output_rows: Vec<Vec<f64>>,
}

impl MpcLimits {
    /// The limit rows of one step: a row per limited quantity.
    pub fn per_step(&self) -> usize {
        self.rates.len() + self.states.len() + self.outputs.len()
    }

    /// The soft quantities' count.
    pub fn soft_count(&self) -> usize {
        self.soft.iter().filter(|&&s| s).count()
    }
}

/// The steady state of the tracked outputs' reference: `x_s = x y_ref + x_offset`,
/// `u_s = u y_ref + u_offset`, over the regulated states and the MPC's inputs.
#[derive(Clone, Debug)]
pub struct Target {
    /// Per regulated state, its coefficients on `y_ref`.
    pub x: Vec<Vec<f64>>,
    /// Per regulated state, its value at `y_ref = 0`.
    pub x_offset: Vec<f64>,
    /// Per input, its coefficients on `y_ref`.
    pub u: Vec<Vec<f64>>,
    /// Per input, its value at `y_ref = 0`.
    pub u_offset: Vec<f64>,
}

/// The most moves for which `solver` defaults to the primal active set.
pub const PRIMAL_MOVES_MAX: u32 = 16;

/// Options of the model predictive controller (dual-mode, input bounds).
#[derive(Clone, Debug)]
pub struct MpcSpec {
    /// Moves optimised over, `n`.
    pub horizon: u32,
    /// The physical states it regulates, by index into [`crate::model::Model::states`].
    pub states: Vec<usize>,
    /// The inputs it computes, by index into [`crate::model::Model::inputs`].
    pub inputs: Vec<usize>,
    /// Where the prediction model comes from.
    pub discretisation: MpcDiscretisation,
    /// How the QP is solved.
    pub solver: MpcSolver,
    /// The limits besides the inputs' bounds.
    pub limits: MpcLimits,
    /// Outputs tracked through a steady state (`tracked_outputs`): indices into the
    /// model's outputs, with where each was named.
    pub tracked: Vec<(usize, Span)>,
    /// Their steady state, set by the design.
    pub target: Option<Target>,
    /// Bound on the active-set iterations of one solve.
    pub max_iterations: u32,
    /// Riccati steps per solve towards the terminal weight (warm-started).
    pub riccati_iterations: u32,
    /// Relative change of the values the prediction model reads under which a solve
    /// keeps the last one's model, terminal weight and condensed Hessian.
    pub model_tolerance: f64,
    /// The cycle budget (`max_cycles = ..`) and where it was given: it bounds each
    /// solve's iterations at run time ([`super::work_bound`]).
    pub cycle_budget: Option<(u64, Span)>,
    /// The iterations a solve may take within the budget, by what it rebuilt (nothing,
    /// the problem, the model and the problem); set by the design when there is a budget.
    pub iterations_within_budget: Option<[u32; 3]>,
}

impl MpcSpec {
    /// The moves optimised over, horizon times inputs.
    pub fn moves(&self) -> usize {
        self.horizon as usize * self.inputs.len()
    }

    /// The limit rows over the horizon.
    pub fn limit_rows(&self) -> usize {
        self.horizon as usize * self.limits.per_step()
    }
}

/// The largest condensed problem (horizon times inputs unknowns) the MPC unrolls: the
/// primal active set's `L D L'` solve grows with the cube of the unknowns, and so does
/// the time to compile it. TinyMPC's quadrotor hover benchmark (12 states, 4 inputs, 10
/// moves) has 40: its `f64` MPC alone took 78 s of CPU to compile in the tests' profile
/// (`opt-level = 2`, debug information) with the primal active set, about 2 s with the
/// dual (whose straight-line code grows with the square), the blade's 10 moves 3 s.
pub const MPC_UNKNOWNS_MAX: u32 = 48;

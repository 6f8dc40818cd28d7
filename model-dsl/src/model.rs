//! The model IR: one resolved, checked model, independent of how it was written.

use crate::ast::Comparison;
use proc_macro2::TokenStream;

/// A checked model. Every name is resolved; every state has exactly one equation.
#[derive(Clone, Debug)]
pub struct Model {
    /// Doc comment lines of the model.
    pub docs: Vec<String>,
    /// Visibility of the generated module.
    pub vis: TokenStream,
    /// Module name.
    pub name: String,
    /// Scalar types to generate; the first is the primary one.
    pub scalars: Vec<Scalar>,
    /// Named constants with their values.
    pub constants: Vec<Constant>,
    /// Physical states `x`, in order; they come first in the state vector.
    pub states: Vec<Symbol>,
    /// Parameters: augmented random-walk states after the physical ones.
    pub params: Vec<Symbol>,
    /// Inputs `u`.
    pub inputs: Vec<Symbol>,
    /// Constants known only at run time (`known`), supplied to the model functions as
    /// `known` and stored by the filters and controller.
    pub known: Vec<Symbol>,
    /// Outputs `y = h(x, u)`.
    pub outputs: Vec<Output>,
    /// Sensors: disjoint groups of outputs measured together, each corrected with in an
    /// update of its own.
    pub sensors: Vec<Sensor>,
    /// The dynamics of the physical states.
    pub dynamics: Dynamics,
    /// Named intermediates of the dynamics block, referenced by [`Expr::Local`]: the
    /// model's own `let`s, and the entries of values its typed expressions read more than
    /// once (computed once, by name).
    pub locals: Vec<Local>,
    /// The symbols and outputs declared as vectors or rotations, in declaration order:
    /// each stands for consecutive scalar entries of its list ([`Group::first`]).
    pub groups: Vec<Group>,
}

/// The names of a vector's entries, in order (`crate::geometry::Vec3`).
pub const VEC3_ENTRIES: [&str; 3] = ["x", "y", "z"];

/// The names of a rotation's stored entries, in storage order (`crate::geometry::Quat`).
pub const QUAT_ENTRIES: [&str; 4] = ["x", "y", "z", "w"];

/// The type of a declared symbol, output or intermediate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Type {
    /// A number.
    Scalar,
    /// A 3-vector `[x, y, z]`.
    Vec3,
    /// A rotation: a unit quaternion stored `[x, y, z, w]`.
    Rot3,
}

impl Type {
    /// How many scalar entries a value of this type takes.
    pub fn entry_count(self) -> usize {
        self.entries().len()
    }

    /// The names of the entries, suffixed to the symbol's name (`v_x`); empty for a scalar,
    /// which is its own entry.
    pub fn entries(self) -> &'static [&'static str] {
        match self {
            Type::Scalar => &[""],
            Type::Vec3 => &VEC3_ENTRIES,
            Type::Rot3 => &QUAT_ENTRIES,
        }
    }

    /// The name a model writes.
    pub fn name(self) -> &'static str {
        match self {
            Type::Scalar => "a scalar",
            Type::Vec3 => "Vec3",
            Type::Rot3 => "Rot3",
        }
    }
}

/// A rotation among the estimated entries: where it is stored, and where its tangent
/// coordinates (a rotation vector) are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rotation {
    /// Its first entry in the state vector (`[x, y, z, w]`).
    pub storage: usize,
    /// Its first coordinate in the tangent space.
    pub tangent: usize,
}

/// A value of a typed expression, entry by entry: what the checks expand a model's
/// vectors and rotations into, so that everything after them sees scalars only.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// A number.
    Scalar(Expr),
    /// A 3-vector.
    Vec3([Expr; 3]),
    /// A rotation: the unit quaternion `q` (`[x, y, z, w]`), or its inverse if `inverted`
    /// (kept apart so that `q.inverse() * v` is `R' v` on the entries of `R`).
    Rot3 {
        /// The quaternion.
        q: [Expr; 4],
        /// Whether the value is the inverse of `q`.
        inverted: bool,
    },
}

impl Value {
    /// Its type.
    pub fn ty(&self) -> Type {
        match self {
            Value::Scalar(_) => Type::Scalar,
            Value::Vec3(_) => Type::Vec3,
            Value::Rot3 { .. } => Type::Rot3,
        }
    }
}

/// Which list a typed group's entries are in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GroupRole {
    /// [`Model::states`]
    State,
    /// [`Model::params`]
    Param,
    /// [`Model::inputs`]
    Input,
    /// [`Model::known`]
    Known,
    /// [`Model::outputs`]
    Output,
}

/// A vector or rotation among the model's symbols or outputs: consecutive scalar entries,
/// named `<name>_x`, `<name>_y`, ..
#[derive(Clone, Debug)]
pub struct Group {
    /// Doc comment lines.
    pub docs: Vec<String>,
    /// Name as declared.
    pub name: String,
    /// Its type.
    pub ty: Type,
    /// Which list holds its entries.
    pub role: GroupRole,
    /// The position of its first entry in that list.
    pub first: usize,
}

impl Group {
    /// The positions of its entries in its list.
    pub fn entries(&self) -> std::ops::Range<usize> {
        self.first..self.first + self.ty.entry_count()
    }
}

/// Floating-point type of generated code.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Scalar {
    /// Single precision: microcontrollers with a single-precision FPU.
    F32,
    /// Double precision: host-side checks.
    F64,
}

impl Scalar {
    /// The Rust type name.
    pub fn type_name(self) -> &'static str {
        match self {
            Scalar::F32 => "f32",
            Scalar::F64 => "f64",
        }
    }
}

/// The sample interval's parameter in generated code.
pub const INTERVAL_PARAMETER: &str = "dt";

/// A named constant.
#[derive(Clone, Debug)]
pub struct Constant {
    /// Doc comment lines.
    pub docs: Vec<String>,
    /// Name as declared.
    pub name: String,
    /// Value, evaluated in `f64` at generation time; the sample interval's nominal value.
    pub value: f64,
    /// Whether this is the sample interval (`interval DT = 0.004;`): given to each
    /// prediction at run time, its value only the nominal one.
    pub interval: bool,
}

/// A state, parameter or input.
#[derive(Clone, Debug)]
pub struct Symbol {
    /// Doc comment lines.
    pub docs: Vec<String>,
    /// Name as declared.
    pub name: String,
}

/// A measured output.
#[derive(Clone, Debug)]
pub struct Output {
    /// Doc comment lines.
    pub docs: Vec<String>,
    /// Name as declared.
    pub name: String,
    /// The measurement.
    pub expr: Expr,
}

/// The chi-square distribution's 99.9 % quantiles for 1 to 12 degrees of freedom: the gate
/// that rejects one in a thousand consistent measurements of a sensor of that many outputs
/// (what errors propose and generated documentation quotes).
pub const CHI_SQUARE_999: [f64; 12] = [
    10.83, 13.82, 16.27, 18.47, 20.52, 22.46, 24.32, 26.12, 27.88, 29.59, 31.26, 32.91,
];

/// Outputs sampled together by one sensor (a GNSS receiver's position and velocity, a
/// magnetometer's three axes).
#[derive(Clone, Debug)]
pub struct Sensor {
    /// Doc comment lines.
    pub docs: Vec<String>,
    /// Name as declared: the EKF's `update_<name>`.
    pub name: String,
    /// Indices of its outputs in [`Model::outputs`], in the order written: the order of
    /// the measurement its update takes.
    pub outputs: Vec<usize>,
    /// Its own innovation gate (`sensor gnss(gate = 22.46) = [..]`): a chi-square
    /// quantile for its outputs' number of degrees of freedom, infinite for `gate = off`
    /// (a gate generated open); `None` when it declares none (a filter's `gate`, if any,
    /// then judges its update).
    pub gate: Option<f64>,
    /// How many samples (calls of `predict`) late its measurements arrive
    /// (`sensor gnss(delay = 38) = [..]`): a measurement given now describes the state
    /// `delay` samples ago. Zero when it declares none. With a delay given at run time
    /// (`sensor flow(max_delay = 25) = [..]`), the most it may be.
    pub delay: usize,
    /// Whether each measurement comes with its own delay, from 0 to [`Sensor::delay`],
    /// given to the sensor's update at run time (`sensor flow(max_delay = 25) = [..]`).
    pub delay_at_run_time: bool,
}

/// A named intermediate of the dynamics block.
#[derive(Clone, Debug)]
pub struct Local {
    /// Name as declared.
    pub name: String,
    /// Value.
    pub expr: Expr,
}

/// How the model advances one sample.
#[derive(Clone, Debug)]
pub struct Dynamics {
    /// Discrete, or continuous with its integration rule.
    pub discretisation: Discretisation,
    /// One right-hand side per physical state, in state order: `x[k+1]` for discrete
    /// dynamics, `dx/dt` for continuous ones.
    pub rhs: Vec<Expr>,
    /// The first entries of the rotation states, whose next values `f` renormalises (one
    /// Newton step, `q (3 - q·q) / 2`) after the right-hand sides: kept apart from them so
    /// that an error-state filter's Jacobian need not differentiate it (at a unit
    /// quaternion the error's map annihilates what it changes).
    pub renormalised: Vec<usize>,
}

/// Explicit integration rules for continuous dynamics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Forward Euler, as in the papers.
    Euler,
    /// Classical fourth-order Runge-Kutta.
    Rk4,
}

/// The most integration sub-steps per sample that the discrete step `f` (and the
/// filters built on it: `ekf`, `dkf`, `lqr`) unrolls; more are integrated in a loop.
pub const UNROLLED_SUBSTEPS_MAX: u32 = 64;

/// The most integration sub-steps per sample a model may declare.
pub const SUBSTEPS_MAX: u32 = 100_000;

/// How `x[k+1]` is obtained from the equations.
#[derive(Clone, Debug)]
pub enum Discretisation {
    /// The equations give `x[k+1]` directly.
    Discrete,
    /// The equations give `dx/dt`, integrated over one sample period `dt`.
    Continuous {
        /// Integration rule.
        method: Method,
        /// The sample period: an expression of constants.
        dt: Expr,
        /// Integration steps per sample period (at least one).
        substeps: u32,
    },
}

/// Functions of one argument the language knows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Func {
    /// Sine.
    Sin,
    /// Cosine.
    Cos,
    /// Tangent.
    Tan,
    /// Exponential.
    Exp,
    /// Natural logarithm.
    Ln,
    /// Square root.
    Sqrt,
    /// Absolute value.
    Abs,
    /// Hyperbolic tangent.
    Tanh,
}

/// What the language calls a library function; generated code calls the function of the
/// same name in `stateforge_math::f32` or `stateforge_math::f64`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FuncNames {
    /// The name a model writes, in both front ends (`ln`), and the runtime crate's.
    pub name: &'static str,
}

impl FuncNames {
    const fn new(name: &'static str) -> FuncNames {
        FuncNames { name }
    }
}

/// A row of [`Func::TABLE`]: a function, its names, and its value in `f64`.
type FuncRow = (Func, FuncNames, fn(f64) -> f64);

impl Func {
    /// The function table, in declaration order (`Func as usize` indexes it): each
    /// function's names and its value in `f64`.
    const TABLE: [FuncRow; 8] = [
        (Func::Sin, FuncNames::new("sin"), f64::sin),
        (Func::Cos, FuncNames::new("cos"), f64::cos),
        (Func::Tan, FuncNames::new("tan"), f64::tan),
        (Func::Exp, FuncNames::new("exp"), f64::exp),
        (Func::Ln, FuncNames::new("ln"), f64::ln),
        (Func::Sqrt, FuncNames::new("sqrt"), f64::sqrt),
        (Func::Abs, FuncNames::new("abs"), f64::abs),
        (Func::Tanh, FuncNames::new("tanh"), f64::tanh),
    ];

    /// `atan2(y, x)`, the library function of two arguments: an [`Expr::Atan2`], not a
    /// `Func`, but named like one.
    pub const ATAN2: FuncNames = FuncNames::new("atan2");

    /// Every function, for lookups and messages.
    pub const ALL: [Func; 8] = {
        let mut all = [Func::Sin; 8];
        let mut i = 0;
        while i < all.len() {
            all[i] = Func::TABLE[i].0;
            i += 1;
        }
        all
    };

    /// The function's names, in the model and in the runtime crate.
    pub fn names(self) -> FuncNames {
        Func::TABLE[self as usize].1
    }

    /// The name a model writes.
    pub fn name(self) -> &'static str {
        self.names().name
    }

    /// Looks a function up by the name a model writes.
    pub fn from_name(name: &str) -> Option<Func> {
        Func::ALL.into_iter().find(|f| f.name() == name)
    }

    /// Evaluates the function in `f64` (constant folding and tests).
    pub fn eval(self, x: f64) -> f64 {
        (Func::TABLE[self as usize].2)(x)
    }
}

/// [`Func::TABLE`] is indexed by `Func as usize`: its rows follow the declaration.
const _: () = {
    let mut i = 0;
    while i < Func::TABLE.len() {
        assert!(
            Func::TABLE[i].0 as usize == i,
            "Func::TABLE follows the declaration"
        );
        i += 1;
    }
};

/// A resolved expression tree.
#[derive(Clone, Debug, PartialEq)]
pub enum Expr {
    /// A literal.
    Number(f64),
    /// A named constant, by index into [`Model::constants`].
    Const(usize),
    /// A physical state, by index into [`Model::states`].
    State(usize),
    /// A parameter, by index into [`Model::params`].
    Param(usize),
    /// An input, by index into [`Model::inputs`].
    Input(usize),
    /// A constant known at run time, by index into [`Model::known`].
    Known(usize),
    /// A named intermediate, by index into [`Model::locals`].
    Local(usize),
    /// The time `t` in seconds.
    Time,
    /// Negation.
    Neg(Box<Expr>),
    /// Sum.
    Add(Box<Expr>, Box<Expr>),
    /// Difference.
    Sub(Box<Expr>, Box<Expr>),
    /// Product.
    Mul(Box<Expr>, Box<Expr>),
    /// Quotient.
    Div(Box<Expr>, Box<Expr>),
    /// Integer power.
    Powi(Box<Expr>, i32),
    /// A function of one argument.
    Call(Func, Box<Expr>),
    /// `atan2(y, x)`: the angle of the point `(x, y)`, in `-pi..=pi`.
    Atan2(Box<Expr>, Box<Expr>),
    /// `if lhs cmp rhs { then } else { otherwise }`.
    Select {
        /// The comparison.
        cmp: Comparison,
        /// Left side of the condition.
        lhs: Box<Expr>,
        /// Right side of the condition.
        rhs: Box<Expr>,
        /// Value when the condition holds.
        then: Box<Expr>,
        /// Value otherwise.
        otherwise: Box<Expr>,
    },
}

impl Discretisation {
    /// Whether the equations give `dx/dt`, integrated over a sample time the model states.
    pub fn is_continuous(&self) -> bool {
        matches!(self, Discretisation::Continuous { .. })
    }

    /// Whether the sub-steps are too many to unroll: `f` is then generated as a loop.
    pub fn is_looped(&self) -> bool {
        matches!(self, Discretisation::Continuous { substeps, .. } if *substeps > UNROLLED_SUBSTEPS_MAX)
    }
}

impl Model {
    /// Length of the state vector: physical states followed by parameters.
    pub fn state_len(&self) -> usize {
        self.states.len() + self.params.len()
    }

    /// The rotations among the states and parameters, in order: each one's first entry in
    /// the state vector (4 entries, `[x, y, z, w]`) and its first coordinate in the
    /// tangent space (3, a rotation vector). A filter keeps a rotation's uncertainty in
    /// the tangent space: its covariance is over [`Model::tangent_len`] coordinates.
    pub fn rotations(&self) -> Vec<Rotation> {
        let mut estimated: Vec<(usize, &Group)> = self
            .groups
            .iter()
            .filter(|g| g.ty == Type::Rot3)
            .filter_map(|g| match g.role {
                GroupRole::State => Some((g.first, g)),
                GroupRole::Param => Some((self.states.len() + g.first, g)),
                _ => None,
            })
            .collect();
        estimated.sort_by_key(|&(first, _)| first);
        estimated
            .into_iter()
            .enumerate()
            .map(|(k, (first, _))| Rotation {
                storage: first,
                tangent: first - k,
            })
            .collect()
    }

    /// The dimension of the tangent space of the state: [`Model::state_len`], less one per
    /// rotation (four entries, three degrees of freedom).
    pub fn tangent_len(&self) -> usize {
        self.state_len() - self.rotations().len()
    }

    /// The names of the tangent space's coordinates: a rotation `q`'s are `q_theta_x`,
    /// `q_theta_y`, `q_theta_z` (its rotation vector), every other entry's its own.
    pub fn tangent_names(&self) -> Vec<String> {
        let rotations = self.rotations();
        let names: Vec<&str> = self.state_names().collect();
        let mut tangent = Vec::with_capacity(self.tangent_len());
        let mut i = 0;
        while i < names.len() {
            if rotations.iter().any(|r| r.storage == i) {
                let group = names[i].strip_suffix("_x").unwrap_or(names[i]);
                tangent.extend(["x", "y", "z"].map(|c| format!("{group}_theta_{c}")));
                i += 4;
            } else {
                tangent.push(names[i].to_owned());
                i += 1;
            }
        }
        tangent
    }

    /// The tangent coordinates of the state vector's entries `indices` (a rotation's four
    /// entries give its three coordinates), each once, in order of first appearance.
    pub fn tangent_indices(&self, indices: &[usize]) -> Vec<usize> {
        let rotations = self.rotations();
        let mut tangent = Vec::new();
        for &i in indices {
            let before = rotations.iter().filter(|r| r.storage + 4 <= i).count();
            let coordinates = match rotations
                .iter()
                .find(|r| (r.storage..r.storage + 4).contains(&i))
            {
                Some(r) => (r.tangent..r.tangent + 3).collect(),
                None => vec![i - before],
            };
            for c in coordinates {
                if !tangent.contains(&c) {
                    tangent.push(c);
                }
            }
        }
        tangent
    }

    /// Names of the physical states at `indices` (a controller's regulated states).
    pub fn states_named(&self, indices: &[usize]) -> Vec<&str> {
        indices
            .iter()
            .map(|&i| self.states[i].name.as_str())
            .collect()
    }

    /// Names of the inputs at `indices` (a controller's inputs).
    pub fn inputs_named(&self, indices: &[usize]) -> Vec<&str> {
        indices
            .iter()
            .map(|&i| self.inputs[i].name.as_str())
            .collect()
    }

    /// Names of the state vector's entries, physical states first.
    pub fn state_names(&self) -> impl Iterator<Item = &str> {
        self.states
            .iter()
            .chain(&self.params)
            .map(|s| s.name.as_str())
    }

    /// Whether `pred` holds for `expr` or any part of it, or of an intermediate it reads
    /// (an output may read those of the dynamics). Each intermediate reads only earlier
    /// ones, so one pass in order decides each once.
    pub fn reads(&self, expr: &Expr, pred: &dyn Fn(&Expr) -> bool) -> bool {
        let mut local_reads: Vec<bool> = Vec::with_capacity(self.locals.len());
        for local in &self.locals {
            let reads = local.expr.any(&|e| {
                pred(e) || matches!(e, Expr::Local(i) if local_reads.get(*i) == Some(&true))
            });
            local_reads.push(reads);
        }
        expr.any(&|e| pred(e) || matches!(e, Expr::Local(i) if local_reads.get(*i) == Some(&true)))
    }

    /// Whether the time `t` appears anywhere in the model.
    pub fn uses_time(&self) -> bool {
        let mut exprs = self
            .dynamics
            .rhs
            .iter()
            .chain(self.outputs.iter().map(|o| &o.expr))
            .chain(self.locals.iter().map(|l| &l.expr));
        exprs.any(|e| e.any(&|e| matches!(e, Expr::Time)))
    }

    /// The sample interval's index among the constants, if the model declares one
    /// (`interval DT = 0.004;`): each prediction takes it at run time.
    pub fn interval(&self) -> Option<usize> {
        self.constants.iter().position(|c| c.interval)
    }

    /// The sample interval's parameter in the functions and predictions, `dt`, if the
    /// model declares one (one name whatever the declared one, so that it never meets a
    /// name the generated code gives).
    pub fn interval_parameter(&self) -> Option<String> {
        self.interval().map(|_| INTERVAL_PARAMETER.to_owned())
    }

    /// Whether the dynamics read the sample interval (discrete ones in their equations,
    /// continuous ones as the step they are integrated over): `f` then takes it.
    pub fn dynamics_read_interval(&self) -> bool {
        self.interval().is_some_and(|i| {
            let reads = |e: &Expr| matches!(e, Expr::Const(j) if *j == i);
            let step_reads = matches!(&self.dynamics.discretisation,
                Discretisation::Continuous { dt, .. } if dt.any(&reads));
            step_reads || self.dynamics.rhs.iter().any(|e| self.reads(e, &reads))
        })
    }

    /// The samples a filter's delayed horizon lags the present by: the longest of the
    /// sensors' declared delays, zero if none declares one.
    pub fn delay(&self) -> usize {
        self.sensors.iter().map(|s| s.delay).max().unwrap_or(0)
    }
}

impl Expr {
    /// Whether the expression is a literal or a name (of a constant, a symbol, an
    /// intermediate, the time): nothing to compute, so reading it twice costs nothing.
    pub fn is_leaf(&self) -> bool {
        matches!(
            self,
            Expr::Number(_)
                | Expr::Const(_)
                | Expr::State(_)
                | Expr::Param(_)
                | Expr::Input(_)
                | Expr::Known(_)
                | Expr::Local(_)
                | Expr::Time
        )
    }

    /// Whether `pred` holds for this expression or any part of it (locals not followed).
    pub fn any(&self, pred: &dyn Fn(&Expr) -> bool) -> bool {
        if pred(self) {
            return true;
        }
        match self {
            Expr::Neg(a) | Expr::Powi(a, _) | Expr::Call(_, a) => a.any(pred),
            Expr::Add(a, b)
            | Expr::Sub(a, b)
            | Expr::Mul(a, b)
            | Expr::Div(a, b)
            | Expr::Atan2(a, b) => a.any(pred) || b.any(pred),
            Expr::Select {
                lhs,
                rhs,
                then,
                otherwise,
                ..
            } => lhs.any(pred) || rhs.any(pred) || then.any(pred) || otherwise.any(pred),
            leaf => {
                debug_assert!(leaf.is_leaf(), "every compound expression is matched above");
                false
            }
        }
    }

    /// Evaluates an expression of literals and constants; `None` if it depends on anything else.
    pub fn const_value(&self, constants: &[Constant]) -> Option<f64> {
        self.fold(&|i| constants.get(i).map(|c| c.value))
    }

    /// Evaluates an expression of literals and constants, given the value of constant `i`
    /// as `constant(i)`; `None` if it depends on anything else.
    pub fn fold(&self, constant: &dyn Fn(usize) -> Option<f64>) -> Option<f64> {
        let go = |e: &Expr| e.fold(constant);
        Some(match self {
            Expr::Number(v) => *v,
            Expr::Const(i) => constant(*i)?,
            Expr::Neg(a) => -go(a)?,
            Expr::Add(a, b) => go(a)? + go(b)?,
            Expr::Sub(a, b) => go(a)? - go(b)?,
            Expr::Mul(a, b) => go(a)? * go(b)?,
            Expr::Div(a, b) => go(a)? / go(b)?,
            Expr::Powi(a, n) => go(a)?.powi(*n),
            Expr::Call(f, a) => f.eval(go(a)?),
            Expr::Atan2(y, x) => go(y)?.atan2(go(x)?),
            Expr::Select {
                cmp,
                lhs,
                rhs,
                then,
                otherwise,
            } => {
                if cmp.holds(go(lhs)?, go(rhs)?) {
                    go(then)?
                } else {
                    go(otherwise)?
                }
            }
            Expr::State(_)
            | Expr::Param(_)
            | Expr::Input(_)
            | Expr::Known(_)
            | Expr::Local(_)
            | Expr::Time => return None,
        })
    }
}

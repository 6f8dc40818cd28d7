//! The surface form of a model: what a front end read, with names not yet resolved.
//!
//! Both front ends (the `model!` macro and TOML model files) produce a [`ModelDecl`];
//! [`crate::check`] resolves it into the one model IR, [`crate::model::Model`].

use proc_macro2::{Span, TokenStream};

/// A name as written, with where it was written.
#[derive(Clone, Debug)]
pub struct Name {
    /// The identifier text.
    pub text: String,
    /// Where it stands in the user's source (call site for model files).
    pub span: Span,
}

/// A whole model declaration.
#[derive(Clone, Debug)]
pub struct ModelDecl {
    /// Doc comment lines of the model, carried into the generated module.
    pub docs: Vec<String>,
    /// Visibility of the generated module, as tokens (`pub`, `pub(crate)` or nothing).
    pub vis: TokenStream,
    /// Name of the generated module.
    pub name: Name,
    /// Scalar types to generate, the first being the primary one; empty if not declared.
    pub scalars: Vec<Name>,
    /// Span of the whole model, for errors about something missing.
    pub span: Span,
    /// Named constants in declaration order.
    pub constants: Vec<ConstDecl>,
    /// States, parameters and inputs in declaration order.
    pub symbols: Vec<SymbolDecl>,
    /// Measured outputs in declaration order.
    pub outputs: Vec<OutputDecl>,
    /// Sensors: named groups of outputs measured together, in declaration order.
    pub sensors: Vec<SensorDecl>,
    /// Dynamics blocks; a valid model has exactly one.
    pub dynamics: Vec<DynamicsDecl>,
    /// What to generate besides the model functions: `generate ekf, dkf(eta = 0.5);`.
    pub generate: Vec<GenerateDecl>,
}

/// One item of a `generate` line: a filter or controller and its arguments.
#[derive(Clone, Debug)]
pub struct GenerateDecl {
    /// `ekf`, `dkf` or `lqr`.
    pub name: Name,
    /// `name = value` arguments in order.
    pub args: Vec<GenerateArg>,
}

/// `name = value` in a `generate` item, or among a sensor's options
/// (`sensor gnss(gate = 22.46) = [..]`).
#[derive(Clone, Debug)]
pub struct GenerateArg {
    /// The argument's name.
    pub name: Name,
    /// Its value.
    pub value: ArgValue,
}

/// Values a `generate` argument takes.
#[derive(Clone, Debug)]
pub enum ArgValue {
    /// A number, with where it was written.
    Number(f64, Span),
    /// A name.
    Name(Name),
    /// `[a, b]`, with where the list was written.
    Names(Vec<Name>, Span),
    /// `[1e-6, 1e-4]`, a list of numbers, with where it was written: no option takes one,
    /// but its error can then say what the option takes instead.
    Numbers(Vec<f64>, Span),
    /// `[predict = 250, update_gnss = 5]`, numbers by name (a TOML inline table), with
    /// where each number and the whole list were written: a budget or rate per call.
    Table(Vec<(Name, f64, Span)>, Span),
}

impl ArgValue {
    /// Where the value was written.
    pub fn span(&self) -> Span {
        match self {
            ArgValue::Number(_, span)
            | ArgValue::Names(_, span)
            | ArgValue::Numbers(_, span)
            | ArgValue::Table(_, span) => *span,
            ArgValue::Name(name) => name.span,
        }
    }
}

/// `const NAME = expr;`, or `interval NAME = expr;`: the sample interval, given to each
/// prediction at run time, `expr` its nominal value.
#[derive(Clone, Debug)]
pub struct ConstDecl {
    /// Doc comment lines.
    pub docs: Vec<String>,
    /// The constant's name.
    pub name: Name,
    /// Its value: an expression of literals and earlier constants.
    pub value: SurfaceExpr,
    /// Where `interval` was written, if this is the sample interval.
    pub interval: Option<proc_macro2::Span>,
}

/// What role a declared symbol plays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SymbolKind {
    /// A physical state with its own dynamics.
    State,
    /// An unknown constant, estimated as an augmented random-walk state.
    Param,
    /// An input known at each sample.
    Input,
    /// A constant known only at run time (a calibration value): supplied when a filter or
    /// controller is made, never estimated.
    Known,
}

/// One name in a `state`, `param` or `input` list.
#[derive(Clone, Debug)]
pub struct SymbolDecl {
    /// Doc comment lines.
    pub docs: Vec<String>,
    /// The symbol's name.
    pub name: Name,
    /// Its role.
    pub kind: SymbolKind,
    /// Its type as written after a colon (`v: Vec3`); a number if none.
    pub ty: Option<Name>,
    /// Declared `#[allow(unused)]` (in a model file, `allow_unused = true`): read by no
    /// expression on purpose, so not warned about (a state carried for a layout).
    pub allow_unused: bool,
}

/// `output y = expr`
#[derive(Clone, Debug)]
pub struct OutputDecl {
    /// Doc comment lines.
    pub docs: Vec<String>,
    /// The output's name.
    pub name: Name,
    /// What is measured.
    pub expr: SurfaceExpr,
}

/// `sensor gnss = [gnss_pn, gnss_pe];`: outputs sampled together by one sensor, which a
/// filter corrects with in one update of their own (`update_gnss`); with options,
/// `sensor gnss(gate = 13.82) = [..];`.
#[derive(Clone, Debug)]
pub struct SensorDecl {
    /// Doc comment lines.
    pub docs: Vec<String>,
    /// The sensor's name.
    pub name: Name,
    /// Its options as written (`gate = 13.82`), in order.
    pub options: Vec<GenerateArg>,
    /// The outputs it measures, as written.
    pub outputs: Vec<Name>,
}

/// How a dynamics block relates the next state to the current one.
#[derive(Clone, Debug)]
pub enum DynamicsKind {
    /// `x = expr` gives `x[k+1]`.
    Discrete,
    /// `der(x) = expr` gives `dx/dt`; the discretisation is required for a valid model.
    Continuous {
        /// `euler` or `rk4`, if written.
        method: Option<Name>,
        /// The step, if written: an expression of constants.
        dt: Option<SurfaceExpr>,
        /// Sub-steps per sample, if written, with where.
        substeps: Option<(u64, Span)>,
    },
}

/// `dynamics discrete { .. }` or `dynamics continuous(..) { .. }`
#[derive(Clone, Debug)]
pub struct DynamicsDecl {
    /// The `dynamics` keyword, for errors about the block as a whole.
    pub span: Span,
    /// Discrete or continuous, with the discretisation.
    pub kind: DynamicsKind,
    /// Statements in order.
    pub statements: Vec<Statement>,
}

/// One line of a dynamics block.
#[derive(Clone, Debug)]
pub enum Statement {
    /// `let name = expr;`: a named intermediate for later lines.
    Let {
        /// The intermediate's name.
        name: Name,
        /// Its value.
        value: SurfaceExpr,
    },
    /// `x = expr;` (discrete) or `der(x) = expr;` (continuous).
    Equation {
        /// The state assigned.
        target: Name,
        /// Whether written as `der(x)`.
        derivative: bool,
        /// Right-hand side.
        value: SurfaceExpr,
    },
}

/// An expression as written.
#[derive(Clone, Debug)]
pub struct SurfaceExpr {
    /// What kind of expression.
    pub kind: SurfaceKind,
    /// Where it stands.
    pub span: Span,
}

/// Binary arithmetic operators.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BinaryOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
}

/// Comparisons allowed in the condition of a piecewise term.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Comparison {
    /// `>`
    Gt,
    /// `>=`
    Ge,
    /// `<`
    Lt,
    /// `<=`
    Le,
}

/// The shapes of a surface expression.
#[derive(Clone, Debug)]
pub enum SurfaceKind {
    /// A numeric literal.
    Number(f64),
    /// A name: a constant, symbol, `let` intermediate or the time `t`.
    Name(String),
    /// `-e`
    Neg(Box<SurfaceExpr>),
    /// `a op b`
    Binary(BinaryOp, Box<SurfaceExpr>, Box<SurfaceExpr>),
    /// `f(args)`: the function name is checked later. A method call `a.f(b)` is `f(a, b)`.
    Call(Name, Vec<SurfaceExpr>),
    /// `v.x`: a component of a vector.
    Field(Box<SurfaceExpr>, Name),
    /// `if lhs cmp rhs { then } else { otherwise }`
    If {
        /// The comparison.
        cmp: Comparison,
        /// Left side of the condition.
        lhs: Box<SurfaceExpr>,
        /// Right side of the condition.
        rhs: Box<SurfaceExpr>,
        /// Value when the condition holds.
        then: Box<SurfaceExpr>,
        /// Value otherwise.
        otherwise: Box<SurfaceExpr>,
    },
}

impl Comparison {
    /// Whether `lhs cmp rhs` holds.
    pub fn holds(self, lhs: f64, rhs: f64) -> bool {
        match self {
            Comparison::Gt => lhs > rhs,
            Comparison::Ge => lhs >= rhs,
            Comparison::Lt => lhs < rhs,
            Comparison::Le => lhs <= rhs,
        }
    }

    /// The operator as written.
    pub fn symbol(self) -> &'static str {
        match self {
            Comparison::Gt => ">",
            Comparison::Ge => ">=",
            Comparison::Lt => "<",
            Comparison::Le => "<=",
        }
    }
}

//! The interface every generator implements, in three stages that follow the compiler's
//! one direction of flow: [`Kind`] reads a `generate` item's options (tokens -> IR),
//! [`Generator::design`] does the work that needs the model's symbolic graph once (a
//! window transform, a gain computed at generation time), and [`Lowering::lower`] turns
//! the design into code for each scalar type (IR -> tokens).
//!
//! Why trait objects rather than an enum of generators: the pipeline and the checks then
//! iterate over [`super::REGISTRY`] and never name a generator, and adding one is its
//! folder plus one line there; an enum would need a variant and a match arm in every
//! function that dispatches on it. Dynamic dispatch costs nothing measurable beside the
//! symbolic work it calls.

use super::options::{Args, Context};
use crate::ast::{DynamicsKind, GenerateDecl, ModelDecl, SymbolKind};
use crate::diagnostics::Diagnostics;
use crate::model::{Model, Scalar, UNROLLED_SUBSTEPS_MAX};
use crate::symbolic::ModelGraph;
use proc_macro2::TokenStream;
use std::any::Any;
use std::fmt::Debug;

/// What a generator is and what it asks of the model: each unit states it in one table.
#[derive(Debug)]
pub struct Description {
    /// The name written after `generate` (`ekf`).
    pub name: &'static str,
    /// How it is written with typical options, for the error that lists the generators
    /// (`` `dkf(eta = ..)` ``).
    pub usage: &'static str,
    /// What the model must give for this generator, checked before any of its code runs.
    pub requirements: &'static [Requirement],
    /// The items it defines in the generated module (types and the like), which a model
    /// constant or another generator's `name = ..` may not take.
    pub items: &'static [&'static str],
    /// `Some(default type name)` when a model may ask for several of this generator under
    /// different type names (`ekf(name = GatedEkf)`); `None` when it is asked for once.
    pub type_name_option: Option<&'static str>,
}

/// One kind of generator, what `generate <name>(..)` asks for: its [`Description`], and
/// how its options are read.
pub trait Kind: Sync {
    /// What it is and what it requires of the model.
    fn description(&self) -> &'static Description;

    /// Reads and checks the options of `item`, taking them from `args` (what is left is
    /// reported as unknown). `None` after reporting an error.
    fn options(
        &self,
        item: &GenerateDecl,
        args: &mut Args,
        cx: &Context,
        diag: &mut Diagnostics,
    ) -> Option<Box<dyn Generator>>;

    /// Whether it runs on a delayed horizon when the model's sensors declare a `delay`
    /// (else such a model is an error under its `generate` item).
    fn runs_delayed(&self) -> bool {
        false
    }

    /// Whether its predictions take the sample interval at run time when the model
    /// declares one (`interval DT = 0.004;`; else such a model is an error under its
    /// `generate` item).
    fn takes_interval(&self) -> bool {
        false
    }
}

impl dyn Kind + '_ {
    /// The name written after `generate`.
    pub fn name(&self) -> &'static str {
        self.description().name
    }

    /// What the model must give for this generator.
    pub fn requirements(&self) -> &'static [Requirement] {
        self.description().requirements
    }
}

/// A generator with its checked options.
pub trait Generator: Debug + Any {
    /// The design, made once from the model's graph: an error under the `generate` item
    /// when the model is outside what the generator supports.
    fn design(&self, model: &Model, mg: &ModelGraph) -> syn::Result<Box<dyn Lowering>>;

    /// The type names it chose with `name = ..` (see [`Description::type_name_option`]), which
    /// must not be other items of the module.
    fn type_names(&self) -> Vec<String> {
        Vec::new()
    }

    /// The options as `Any`, for tests that read a unit's options.
    fn as_any(&self) -> &dyn Any;
}

/// A design ready to lower.
pub trait Lowering {
    /// The generated items in `scalar`, and what their calls cost.
    fn lower(&self, model: &Model, mg: &ModelGraph, scalar: Scalar) -> Code;
}

/// A generator's code for one scalar type.
pub struct Code {
    /// The types and their methods.
    pub tokens: TokenStream,
    /// The arithmetic of its calls, published as `*_OPS` constants.
    pub costs: Vec<Cost>,
}

pub use super::cost::Cost;

/// What a generator may require of the model. Each is checked on the declaration, before
/// the generator's options are read, and reported under the `generate` item with what to
/// write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Requirement {
    /// It corrects its estimate with measurements: at least one `output`.
    Outputs,
    /// It computes inputs: at least one `input`.
    Inputs,
    /// It integrates `dx/dt` between samples: `dynamics continuous(..)`.
    ContinuousDynamics,
    /// It differentiates the unrolled sample step: at most
    /// [`UNROLLED_SUBSTEPS_MAX`] sub-steps.
    UnrolledStep,
    /// Its design needs every coefficient when the code is generated: no `known`.
    CoefficientsAtGeneration,
    /// Its design is for a known system: no `param` (unknowns estimated as states).
    NoParameters,
    /// It treats the estimate's entries as coordinates of a vector space: no rotation
    /// (`Rot3`) among the states and parameters, whose four entries have three degrees of
    /// freedom.
    EuclideanStates,
}

impl Requirement {
    /// Why `decl` does not meet the requirement of the generator `name`, saying what to
    /// write; `None` when it does. `alternatives` names the generators that do without
    /// it: those without run-time constants' requirement, or those that integrate
    /// continuous dynamics in a loop.
    pub fn unmet(self, name: &str, decl: &ModelDecl, alternatives: &str) -> Option<String> {
        let symbol = |kind: SymbolKind| decl.symbols.iter().find(|s| s.kind == kind);
        match self {
            Requirement::Outputs => decl.outputs.is_empty().then(|| {
                format!(
                    "`{name}` corrects its estimate with measurements: declare them with \
                     `output y = ...;`"
                )
            }),
            Requirement::Inputs => symbol(SymbolKind::Input).is_none().then(|| {
                format!("`{name}` computes the model's inputs: declare them with `input u;`")
            }),
            Requirement::ContinuousDynamics => (!continuous(decl)).then(|| {
                format!(
                    "`{name}` integrates the continuous dynamics between samples: declare \
                     them as `dynamics continuous(euler, dt = TS) {{ der(x) = ..; }}`"
                )
            }),
            Requirement::UnrolledStep => looped(decl).then(|| {
                format!(
                    "`{name}` differentiates the unrolled sample step, which allows at most \
                     {UNROLLED_SUBSTEPS_MAX} sub-steps: use fewer, or a generator that \
                     integrates them in a loop ({alternatives} among the filters, \
                     `mpc(discretisation = zoh)` among the controllers)"
                )
            }),
            Requirement::CoefficientsAtGeneration => symbol(SymbolKind::Known).map(|known| {
                format!(
                    "`{name}` needs every coefficient when the code is generated, and `{}` is \
                     known only at run time: declare it with `const` (of the generators, only \
                     {alternatives} read constants known at run time)",
                    known.name.text
                )
            }),
            Requirement::NoParameters => symbol(SymbolKind::Param).map(|param| {
                format!(
                    "`{name}` is designed for a known system, and `{}` is a parameter (an \
                     unknown estimated as a state): declare it as a constant, `const {} = \
                     ..;`, or estimate it with `ekf`",
                    param.name.text, param.name.text
                )
            }),
            Requirement::EuclideanStates => rotation_state(decl).map(|q| {
                format!(
                    "`{name}` treats the estimate's entries as a vector, and `{q}` is a \
                     rotation: its four entries have three degrees of freedom, so a filter or \
                     controller on them would leave the unit sphere. Regulate or estimate a \
                     vector of the model (an attitude error `log(q_ref.inverse() * q)` is \
                     one), or give the rotation as an `input`"
                )
            }),
        }
    }
}

/// The first rotation among the states and parameters, if any.
fn rotation_state(decl: &ModelDecl) -> Option<&str> {
    let estimated =
        |s: &&crate::ast::SymbolDecl| matches!(s.kind, SymbolKind::State | SymbolKind::Param);
    decl.symbols
        .iter()
        .filter(estimated)
        .find(|s| s.ty.as_ref().is_some_and(|t| t.text == "Rot3"))
        .map(|s| s.name.text.as_str())
}

/// Whether the model's dynamics are continuous.
fn continuous(decl: &ModelDecl) -> bool {
    decl.dynamics
        .iter()
        .any(|d| matches!(d.kind, DynamicsKind::Continuous { .. }))
}

/// Whether the model's sample step runs its sub-steps as a loop (and so has no Jacobian).
pub fn looped(decl: &ModelDecl) -> bool {
    decl.dynamics.iter().any(|d| match &d.kind {
        DynamicsKind::Continuous { substeps, .. } => substeps
            .as_ref()
            .is_some_and(|(n, _)| *n > u64::from(UNROLLED_SUBSTEPS_MAX)),
        DynamicsKind::Discrete => false,
    })
}

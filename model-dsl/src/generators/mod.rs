//! The generators: one folder per kind of filter or controller a model can ask for with
//! `generate <name>(..)`. Each is a self-contained unit: its options and their checks,
//! what it requires of the model, its design and its lowering live in its folder, behind
//! the interface of [`mod@unit`] ([`Kind`], [`Generator`], [`Lowering`]). Shared stages (the
//! filter layout, Kalman predict and Joseph update, the Riccati step, the `L D L'` solve,
//! integration sub-steps) live in [`crate::emit`] and [`crate::symbolic`]; the checks and
//! the pipeline iterate over [`REGISTRY`] and know no generator by name.
//!
//! # Adding a generator
//!
//! 1. Make its folder, `generators/<name>/`, with a `mod.rs` holding a unit struct (the
//!    [`Kind`]: its [`Description`], a table of its name, usage, [`Requirement`]s and the
//!    items it defines, and `options`, which reads its options with [`Args`] into a spec
//!    kept in `spec.rs`), the spec (the [`Generator`]:
//!    `design`, the work that needs the model's graph, once, with errors spanned at the
//!    `generate` item), and the design's [`Lowering`] (the code for one scalar type and
//!    its [`Cost`]s, published as `*_OPS` constants). Put its lowering in `lower.rs`
//!    beside it, and any design stage only it uses (`design.rs`); compose shared stages
//!    rather than restating them.
//! 2. Declare its module, `pub mod <name>;`, and add its one line to [`REGISTRY`],
//!    `&<name>::<Kind struct>,`: the registry's order is the order its items take in the
//!    generated module. (A macro could make the two one line, but `rustfmt` does not see
//!    modules a macro declares.)
//! 3. Add a compile-fail case under `tests/ui/` for each of its requirements, a snapshot
//!    of a model that uses it, and tests against an independent reference.

pub mod budget;
pub mod cost;
pub mod options;
pub mod unit;

pub use budget::Budget;
pub use options::{Args, Context};
pub use unit::{Code, Cost, Description, Generator, Kind, Lowering, Requirement};

pub mod continuous_ekf;
pub mod dkf;
pub mod ekf;
pub mod hybrid_ekf;
pub mod lqr;
pub mod mpc;
pub mod polynomial_kf;
pub mod switched_observer;

/// Every generator, in the order their code appears in the generated module.
pub static REGISTRY: &[&dyn Kind] = &[
    &ekf::Ekf,
    &dkf::Dkf,
    &polynomial_kf::PolynomialKf,
    &switched_observer::SwitchedObserver,
    &lqr::Lqr,
    &mpc::Mpc,
    &hybrid_ekf::HybridEkf,
    &continuous_ekf::ContinuousEkf,
];
